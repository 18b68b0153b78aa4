//! A PID step in standard (ISA) form with the elapsed time passed in.
//!
//! - derivative on the measurement, so a set point change gives no kick;
//! - anti-windup by clamped integration: each step integrates only as far as
//!   keeps P + I + D within the limits, and never moves the integrator against
//!   the error (so a one-sample spike in P or D cannot drag it, and with
//!   integral action off nothing moves it at all);
//! - proportional on error (default) or on measurement (Arduino PID's P_ON_M):
//!   on measurement the proportional action moves with the measurement and is
//!   kept in the integrator, so a set point change gives no proportional kick;
//! - tracking (the paper's §5.3 bumpless transfer): while another controller or
//!   an operator drives the actuator, the integrator is set to `a - P - D`, so
//!   the first step in control starts from the action `a` already applied;
//! - new tunings take effect without a bump: the next step re-seeds the
//!   integrator from the last output;
//! - a missing or non-numeric measurement holds the integrator and outputs the
//!   configured fallback (or holds the last output): never a NaN;
//! - every term is checked finite before it becomes state: inputs too large to
//!   compute with are refused with INVALID_INPUT and leave the PID as it was.
//!
//! Parallel gains (simple-pid's and Arduino PID's Kp, Ki, Kd, all >= 0) map
//! onto this form as kp = Kp, ti = Kp / Ki (0 when Ki = 0), td = Kd / Kp.
//! Ki or Kd with Kp = 0 has no standard form. Arduino's DIRECT is `Reverse`
//! here (output rises as the measurement falls below the set point).

use serde::{Deserialize, Serialize};

use super::error::{computed, finite, ControlError};
use crate::text::quote;

/// Direction of the controller (ISA terms).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Action {
    /// Output rises when the measurement falls below the set point (heating, filling).
    #[default]
    Reverse,
    /// Output rises when the measurement rises above the set point (cooling, draining).
    Direct,
}

/// A PID's tuning, limits and behaviour.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct PidConfig {
    /// Proportional gain Kc (output units per measurement unit).
    pub kp: f64,
    /// Integral time in seconds; 0 turns integral action off.
    #[serde(default)]
    pub ti_s: f64,
    /// Derivative time in seconds; 0 turns derivative action off.
    #[serde(default)]
    pub td_s: f64,
    /// The lowest output.
    pub out_min: f64,
    /// The highest output.
    pub out_max: f64,
    /// Direct or reverse action.
    #[serde(default)]
    pub action: Action,
    /// Output while the measurement is missing or not a number; `None` holds the last output.
    #[serde(default)]
    pub fallback: Option<f64>,
    /// Whether P acts on the error or on the measurement (no kick on set point changes).
    #[serde(default)]
    pub proportional_on: ProportionalOn,
}

/// What the proportional term acts on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ProportionalOn {
    /// P = Kc·e: the textbook form.
    #[default]
    Error,
    /// P moves by -Kc·Δpv each step, kept in the integrator (Arduino PID's P_ON_M):
    /// no kick on a set point change, and a gentler approach without overshoot.
    Measurement,
}

impl PidConfig {
    /// Refuses a tuning or limits that cannot run.
    pub fn validate(&self) -> Result<(), ControlError> {
        check_tunings(self.kp, self.ti_s, self.td_s)?;
        check_limits(self.out_min, self.out_max)?;
        if let Some(fallback) = self.fallback {
            if !fallback.is_finite() || fallback < self.out_min || fallback > self.out_max {
                return Err(ControlError::config(format!(
                    "fallback output {fallback} must be a number within the output limits [{}, {}]",
                    quote(self.out_min),
                    quote(self.out_max),
                    fallback = quote(fallback)
                )));
            }
        }
        Ok(())
    }

    fn integral_gain(&self) -> f64 {
        if self.ti_s > 0.0 {
            self.kp / self.ti_s
        } else {
            0.0
        }
    }

    /// Limits are validated finite with min < max, so this never panics.
    fn clamp(&self, value: f64) -> f64 {
        value.clamp(self.out_min, self.out_max)
    }
}

/// The integration increment trimmed so `before + increment` stays within the
/// limits, but never reversed: clamping must not move the integrator against the error.
fn trim(increment: f64, before: f64, out_min: f64, out_max: f64) -> f64 {
    if increment > 0.0 {
        increment.min((out_max - before).max(0.0))
    } else if increment < 0.0 {
        increment.max((out_min - before).min(0.0))
    } else {
        0.0
    }
}

fn check_tunings(kp: f64, ti_s: f64, td_s: f64) -> Result<(), ControlError> {
    for (value, what) in [
        (kp, "kp"),
        (ti_s, "ti (integral time, s)"),
        (td_s, "td (derivative time, s)"),
    ] {
        if !value.is_finite() || value < 0.0 {
            return Err(ControlError::config(format!(
                "{what} must be a number >= 0, got {value} (use the action setting to reverse the loop's direction)",
                value = quote(value)
            )));
        }
    }
    // The gains the step multiplies by must be numbers too: kp/ti and kp·td.
    if ti_s > 0.0 && !(kp / ti_s).is_finite() {
        return Err(ControlError::config(format!(
            "ti {ti} s is too small for kp {kp}: the integral gain kp/ti is not a number",
            ti = quote(ti_s),
            kp = quote(kp)
        )));
    }
    if !(kp * td_s).is_finite() {
        return Err(ControlError::config(format!(
            "kp {kp} times td {td} s is not a number: the derivative gain overflows",
            td = quote(td_s),
            kp = quote(kp)
        )));
    }
    Ok(())
}

fn check_limits(out_min: f64, out_max: f64) -> Result<(), ControlError> {
    if !out_min.is_finite() || !out_max.is_finite() || out_min >= out_max {
        return Err(ControlError::config(format!(
            "output limits must be numbers with min < max, got min {out_min} and max {out_max}",
            out_min = quote(out_min),
            out_max = quote(out_max)
        )));
    }
    Ok(())
}

/// One sample for [`Pid::step`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PidInput {
    /// The set point.
    pub setpoint: f64,
    /// `None` or a non-finite value: the step outputs the fallback.
    pub measurement: Option<f64>,
    /// Seconds since the previous step; must be > 0.
    pub dt_s: f64,
    /// `Some(a)`: the actuator is driven by someone else with action `a`; the
    /// integrator tracks it so taking control later is bumpless.
    pub track: Option<f64>,
}

/// How a step computed its output.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum StepMode {
    /// The PID computed it from the measurement.
    Auto,
    /// It followed an output applied by someone else.
    Tracking,
    /// No usable measurement: the fallback output was sent.
    Fallback,
}

/// Every term of one step, for telemetry.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PidStep {
    /// The proportional term.
    pub p: f64,
    /// The integral term.
    pub i: f64,
    /// The derivative term.
    pub d: f64,
    /// The output sent, within the limits.
    pub output: f64,
    /// How it was computed.
    pub mode: StepMode,
    /// The unclamped P + I + D was outside the limits.
    pub saturated: bool,
}

/// A PID with exact bumpless transfer between tunings, limits and modes.
///
/// ```
/// use sugarshack_core::control::pid::{Pid, PidConfig, PidInput, StepMode};
///
/// let config: PidConfig =
///     serde_json::from_str(r#"{ "kp": 2, "tiS": 10, "outMin": 0, "outMax": 100, "fallback": 5 }"#).unwrap();
/// let mut pid = Pid::new(config).unwrap();
/// // Reverse action: 10 below the set point, P = kp·e = 20 and the output rises.
/// let step = pid.step(PidInput { setpoint: 50.0, measurement: Some(40.0), dt_s: 1.0, track: None }).unwrap();
/// assert_eq!((step.p, step.mode), (20.0, StepMode::Auto));
/// assert!((step.output - (step.p + step.i + step.d)).abs() < 1e-9);
/// // No measurement: the fallback goes out and the integrator holds.
/// let integral = pid.integral();
/// let blind = pid.step(PidInput { setpoint: 50.0, measurement: None, dt_s: 1.0, track: None }).unwrap();
/// assert_eq!((blind.output, blind.mode), (5.0, StepMode::Fallback));
/// assert_eq!(pid.integral(), integral);
/// // A configuration that cannot run is refused with its code.
/// let inverted: PidConfig = serde_json::from_str(r#"{ "kp": 1, "outMin": 10, "outMax": 0 }"#).unwrap();
/// assert_eq!(Pid::new(inverted).unwrap_err().code(), "INVALID_CONFIG");
/// ```
#[derive(Clone, Debug)]
pub struct Pid {
    config: PidConfig,
    integral: f64,
    last_measurement: Option<f64>,
    last_output: Option<f64>,
    /// Set by a tuning or limit change: the next auto step re-seeds the integrator.
    reseed: bool,
}

impl Pid {
    /// A PID for `config`, refused if the configuration cannot run.
    pub fn new(config: PidConfig) -> Result<Self, ControlError> {
        config.validate()?;
        Ok(Self {
            config,
            integral: 0.0,
            last_measurement: None,
            last_output: None,
            reseed: false,
        })
    }

    /// Its configuration now.
    pub fn config(&self) -> &PidConfig {
        &self.config
    }

    /// Its integral term now.
    pub fn integral(&self) -> f64 {
        self.integral
    }

    /// Restores a persisted integrator (output units).
    pub fn set_integral(&mut self, integral: f64) -> Result<(), ControlError> {
        self.integral = finite(integral, "integral")?;
        // An integrator set on purpose wins over a re-seed still pending from new tunings.
        self.reseed = false;
        Ok(())
    }

    /// The last output it computed, if any.
    pub fn last_output(&self) -> Option<f64> {
        self.last_output
    }

    /// Forgets the previous measurement, so the next step has no derivative kick.
    pub fn restart(&mut self) {
        self.last_measurement = None;
    }

    /// New tunings, bumpless: the next output continues from the last.
    pub fn set_tunings(&mut self, kp: f64, ti_s: f64, td_s: f64) -> Result<(), ControlError> {
        check_tunings(kp, ti_s, td_s)?;
        (self.config.kp, self.config.ti_s, self.config.td_s) = (kp, ti_s, td_s);
        self.reseed = self.last_output.is_some();
        Ok(())
    }

    /// New output limits; refused if min > max.
    pub fn set_limits(&mut self, out_min: f64, out_max: f64) -> Result<(), ControlError> {
        check_limits(out_min, out_max)?;
        if let Some(fallback) = self.config.fallback {
            if fallback < out_min || fallback > out_max {
                return Err(ControlError::config(format!(
                    "fallback output {fallback} would fall outside the new limits [{out_min}, {out_max}]",
                    fallback = quote(fallback),
                    out_min = quote(out_min),
                    out_max = quote(out_max)
                )));
            }
        }
        (self.config.out_min, self.config.out_max) = (out_min, out_max);
        self.last_output = self.last_output.map(|o| self.config.clamp(o));
        self.reseed = self.last_output.is_some();
        Ok(())
    }

    /// One control step: the output for `input`.
    pub fn step(&mut self, input: PidInput) -> Result<PidStep, ControlError> {
        let setpoint = finite(input.setpoint, "set point")?;
        if !(input.dt_s.is_finite() && input.dt_s > 0.0) {
            return Err(ControlError::input(format!(
                "elapsed time must be a number of seconds greater than 0, got {} (are two samples carrying the same timestamp?)",
                quote(input.dt_s)
            )));
        }
        let track = input
            .track
            .map(|a| finite(a, "tracked action"))
            .transpose()?;
        let Some(measurement) = input.measurement.filter(|m| m.is_finite()) else {
            return Ok(match track {
                // P and D are unknown: follow the action, and re-seed from it on the next good sample.
                Some(action) => self.blind_tracking_step(action),
                None => self.fallback_step(),
            });
        };

        let c = &self.config;
        let sign = match c.action {
            Action::Reverse => 1.0,
            Action::Direct => -1.0,
        };
        // `+ 0.0` turns a -0 into 0, so telemetry never shows "-0".
        let error = computed(
            sign * (setpoint - measurement) + 0.0,
            "control error (set point - measurement)",
        )?;
        let change = match self.last_measurement {
            Some(previous) => Some(computed(
                measurement - previous,
                "change of the measurement",
            )?),
            None => None,
        };
        let on_error = c.proportional_on == ProportionalOn::Error;
        let p = if on_error && c.kp != 0.0 {
            computed(c.kp * error + 0.0, "proportional term")?
        } else {
            0.0
        };
        let kd = c.kp * c.td_s;
        let d = match change {
            Some(dm) if kd != 0.0 => {
                computed(-sign * kd * (dm / input.dt_s) + 0.0, "derivative term")?
            }
            _ => 0.0,
        };
        // Proportional on measurement: its change this step, carried by the integrator.
        let p_moved = match change {
            Some(dm) if !on_error && c.kp != 0.0 => {
                computed(-sign * c.kp * dm, "proportional change")?
            }
            _ => 0.0,
        };

        if let Some(action) = track {
            // The clamped action: the integrator must not hold more than the limits allow.
            let output = c.clamp(action);
            self.integral = computed(output - p - d, "tracking integrator")?;
            self.last_measurement = Some(measurement);
            self.reseed = false;
            self.last_output = Some(output);
            return Ok(PidStep {
                p,
                i: self.integral,
                d,
                output,
                mode: StepMode::Tracking,
                saturated: output != action,
            });
        }
        if self.reseed {
            if let Some(last) = self.last_output {
                let integral = computed(last - p - d, "re-seeded integrator")?;
                let step = self.finish(p, integral, d, StepMode::Auto)?;
                self.last_measurement = Some(measurement);
                self.reseed = false;
                return Ok(step);
            }
        }

        let increment = computed(
            c.integral_gain() * error * input.dt_s + p_moved,
            "integration",
        )?;
        let before = computed(p + self.integral + d, "output")?;
        let trimmed = trim(increment, before, c.out_min, c.out_max);
        let integral = computed(self.integral + trimmed, "integrator")?;
        let mut step = self.finish(p, integral, d, StepMode::Auto)?;
        self.last_measurement = Some(measurement);
        step.saturated |= trimmed != increment;
        Ok(step)
    }

    /// Commits `integral` and the output, once P + I + D is known to be a number.
    fn finish(
        &mut self,
        p: f64,
        integral: f64,
        d: f64,
        mode: StepMode,
    ) -> Result<PidStep, ControlError> {
        let unclamped = computed(p + integral + d, "output")?;
        let output = self.config.clamp(unclamped);
        self.integral = integral;
        self.last_output = Some(output);
        Ok(PidStep {
            p,
            i: integral,
            d,
            output,
            mode,
            saturated: output != unclamped,
        })
    }

    fn blind_tracking_step(&mut self, action: f64) -> PidStep {
        let output = self.config.clamp(action);
        self.last_measurement = None;
        self.last_output = Some(output);
        self.reseed = true;
        PidStep {
            p: 0.0,
            i: self.integral,
            d: 0.0,
            output,
            mode: StepMode::Tracking,
            saturated: output != action,
        }
    }

    fn fallback_step(&mut self) -> PidStep {
        let output = self
            .config
            .fallback
            .or(self.last_output)
            .unwrap_or_else(|| self.config.clamp(self.integral));
        // The next good sample must not differentiate across the gap.
        self.last_measurement = None;
        self.last_output = Some(output);
        PidStep {
            p: 0.0,
            i: self.integral,
            d: 0.0,
            output,
            mode: StepMode::Fallback,
            saturated: false,
        }
    }
}

#[cfg(test)]
mod tests;
