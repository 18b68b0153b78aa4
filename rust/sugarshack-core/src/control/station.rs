//! A PID station: the loop as an operator and a flow see it. It owns the set
//! point, auto/manual mode and the manual output, decides each step's elapsed
//! time, and sends the fallback when the measurement goes stale, a rule run by
//! `tick(now)` so the caller only keeps a timer. Time is always an argument.
//!
//! - dt is the time between two samples' own timestamps, except the first
//!   sample, and the first after a stale period, which integrate over Ts;
//! - in manual the integrator tracks the manual output, so going back to auto
//!   is bumpless; into manual without a value holds the last output;
//! - a change (set point, mode, manual output, tunings, limits) is checked as a
//!   whole before any of it applies: a refused one changes nothing;
//! - stale: no valid measurement for `stale_ms` sends one fallback step, then
//!   one every `stale_ms`; behind an RCC decision it steps nothing (the rcc
//!   node skips scans without I/O state, Fig. 7 line 11: writing blind would
//!   keep the backup out) and reports "no I/O" once.

use serde::{Deserialize, Deserializer, Serialize};

use super::error::{computed, finite, ControlError};
use super::pid::{PidInput, PidStep, StepMode};
use super::pid_loop::{PidLoop, PidLoopConfig};
use super::rcc::{self, Decision};
use super::smith;
use crate::sealed::{self, Kind, Refusal};
use crate::text::quote;
use crate::text::seconds;
use crate::time::Millis;

/// Who sets the output.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// The PID.
    #[default]
    Auto,
    /// A person, through the manual output.
    Manual,
}

/// What a pid node runs: its loop, timing and start values.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct StationConfig {
    /// The PID and its Smith predictor.
    #[serde(rename = "loop")]
    pub pid_loop: PidLoopConfig,
    /// Sample period in seconds: the dt of a first sample.
    pub ts_s: f64,
    /// No valid measurement for this long sends the fallback; 0 turns it off;
    /// absent (or null): [`DEFAULT_STALE_SAMPLES`] × Ts.
    #[serde(rename = "staleMs", default, deserialize_with = "stale_after")]
    pub stale: Option<Millis>,
    /// The set point at start.
    pub setpoint: f64,
    /// The mode at start.
    #[serde(default)]
    pub mode: Mode,
    /// The manual output at start, if any.
    #[serde(default)]
    pub manual: Option<f64>,
}

/// Stale after this many sample periods when the configuration does not say.
pub const DEFAULT_STALE_SAMPLES: f64 = 3.0;

/// What a pid node's configuration left blank becomes: shown by the editor and help.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct PidDefaults {
    /// The adaptive dead time's estimator weight.
    pub alpha: f64,
    /// The adaptive dead time's standard deviations above the mean.
    pub h: f64,
    /// The longest dead time the Smith predictor's delay line holds, in samples.
    pub max_samples: usize,
    /// Stale after this many sample periods.
    pub stale_samples: f64,
}

/// The defaults every pid node's configuration falls back on.
pub const PID_DEFAULTS: PidDefaults = PidDefaults {
    alpha: smith::DEFAULT_ALPHA,
    h: smith::DEFAULT_H,
    max_samples: smith::DEFAULT_MAX_SAMPLES,
    stale_samples: DEFAULT_STALE_SAMPLES,
};

impl StationConfig {
    /// The stale time in force: as set, else [`DEFAULT_STALE_SAMPLES`] × Ts.
    pub fn stale_after(&self) -> Result<Millis, ControlError> {
        match self.stale {
            Some(stale) => Ok(stale),
            None => Millis::from_secs_f64(DEFAULT_STALE_SAMPLES * self.ts_s).ok_or_else(|| {
                ControlError::config(format!(
                    "stale after defaults to {DEFAULT_STALE_SAMPLES} × Ts, and Ts {} is too long for it: set stale after",
                    quote(self.ts_s)
                ))
            }),
        }
    }
}

/// The stale time as written, in ms: refused unless a number >= 0; null is "not set".
fn stale_after<'de, D: Deserializer<'de>>(deserializer: D) -> Result<Option<Millis>, D::Error> {
    let Some(ms) = Option::<f64>::deserialize(deserializer)? else {
        return Ok(None);
    };
    Millis::new(ms).map(Some).ok_or_else(|| {
        serde::de::Error::custom(format!(
            "stale after must be a number of seconds >= 0 (0 turns the watchdog off), got {}",
            seconds(ms)
        ))
    })
}

/// One sample as it arrived.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// `None` or not finite: a bad measurement, stepped as the fallback.
    pub measurement: Option<f64>,
    /// When it was measured: the elapsed time runs between these.
    pub sampled: Millis,
    /// When it arrived, by the clock `tick` is given: staleness counts from here.
    pub now: Millis,
    /// An action someone else applied, for the integrator to track.
    pub track: Option<f64>,
    /// An RCC controller's decision for this scan.
    pub decision: Option<Decision>,
}

/// A change to the loop; each field absent means "as it is".
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Change {
    /// A new set point.
    #[serde(default, deserialize_with = "number")]
    pub setpoint: Option<f64>,
    /// A new mode.
    #[serde(default)]
    pub mode: Option<Mode>,
    /// A new manual output.
    #[serde(default, deserialize_with = "number")]
    pub manual: Option<f64>,
    /// New tunings.
    #[serde(default)]
    pub tunings: Option<Tunings>,
    /// New output limits.
    #[serde(default)]
    pub limits: Option<Limits>,
}

/// Tunings to change; the others stay.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Tunings {
    /// Proportional gain.
    #[serde(default, deserialize_with = "number")]
    pub kp: Option<f64>,
    /// Integral time, in seconds.
    #[serde(default, deserialize_with = "number")]
    pub ti_s: Option<f64>,
    /// Derivative time, in seconds.
    #[serde(default, deserialize_with = "number")]
    pub td_s: Option<f64>,
}

/// Output limits to change; the other stays.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Limits {
    /// The lowest output.
    #[serde(default, deserialize_with = "number")]
    pub min: Option<f64>,
    /// The highest output.
    #[serde(default, deserialize_with = "number")]
    pub max: Option<f64>,
}

/// A field that is there must be a number: null is refused, not taken for "absent".
fn number<'de, D: Deserializer<'de>>(deserializer: D) -> Result<Option<f64>, D::Error> {
    f64::deserialize(deserializer).map(Some)
}

/// What a restart brings back.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Saved {
    /// The integral term.
    #[serde(default)]
    pub integral: Option<f64>,
    /// The set point.
    #[serde(default)]
    pub setpoint: Option<f64>,
    /// The mode.
    #[serde(default)]
    pub mode: Option<Mode>,
    /// The manual output.
    #[serde(default)]
    pub manual: Option<f64>,
}

impl Saved {
    /// This state of pid node `owner`, sealed for `config` at `now` (see
    /// [`crate::sealed`]): the document a restart opens with [`Saved::open`].
    pub fn seal(&self, owner: &str, config: &StationConfig, now: Millis) -> String {
        // Plain data always serializes.
        sealed::seal(Kind::Pid, owner, &sealed::digest(config), now, self).unwrap_or_default()
    }

    /// The state pid node `owner` sealed in `text`, or why it is not usable
    /// (another node's, damaged, of an unknown version): then the node starts
    /// from its configuration. A changed configuration does not refuse it: the
    /// set point, mode and integral carry over, bumpless, as after a msg.
    pub fn open(text: &str, owner: &str) -> Result<Saved, Refusal> {
        sealed::open::<Saved>(text, Kind::Pid, owner).map(|document| document.state)
    }
}

/// How the reported output was computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ReportMode {
    /// By the PID.
    Auto,
    /// Following an action applied by someone else.
    Tracking,
    /// The fallback: no usable measurement.
    Fallback,
    /// Set by a person.
    Manual,
}

/// Every term of a step and what it was computed from, for telemetry (msg.pid).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Report {
    /// The proportional term.
    pub p: f64,
    /// The integral term.
    pub i: f64,
    /// The derivative term.
    pub d: f64,
    /// The output sent.
    pub output: f64,
    /// How it was computed.
    pub mode: ReportMode,
    /// Whether the output is at a limit.
    pub saturated: bool,
    /// The set point used.
    pub setpoint: f64,
    /// The measurement used, if any.
    pub measurement: Option<f64>,
    /// What the PID saw: the measurement, or the Smith predictor's estimate.
    pub seen: Option<f64>,
    /// The Smith predictor's dead time, in samples, if it has one.
    pub dead_time_samples: Option<usize>,
    /// The time since the last step, in seconds.
    pub dt_s: f64,
}

/// One measurement's result.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Outcome {
    /// False behind an RCC decision in standby: the output is not to be sent.
    pub engaged: bool,
    /// What the PID did.
    pub pid: Report,
}

/// What a due `tick` did.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "camelCase")]
pub enum Stale {
    /// A fallback step, to be sent.
    Fallback {
        /// What the PID did.
        pid: Report,
    },
    /// Behind RCC: nothing stepped; the watch ends until the next measurement.
    NoIo,
}

/// The loop's own state, for a status and for persisting.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct StationState {
    /// The set point.
    pub setpoint: f64,
    /// The mode.
    pub mode: Mode,
    /// The manual output, if any.
    pub manual: Option<f64>,
    /// The last output, if any.
    pub last_output: Option<f64>,
    /// The integral term.
    pub integral: f64,
}

/// A pid node's loop with its set point, mode and stale watch.
#[derive(Clone, Debug)]
pub struct Station {
    pid_loop: PidLoop,
    ts_s: f64,
    stale: Millis,
    setpoint: f64,
    mode: Mode,
    manual: Option<f64>,
    previous_sample: Option<Millis>,
    /// The next step integrates over Ts: the first sample, or the first after going stale.
    over_ts: bool,
    via_rcc: bool,
    stale_at: Option<Millis>,
}

fn manual_needed() -> ControlError {
    ControlError::input("manual mode needs a manual output: the loop has no output yet to hold")
}

impl Station {
    /// A station for `config`, refused if it cannot run.
    pub fn new(config: StationConfig) -> Result<Self, ControlError> {
        let config_number = |value: f64, what: &str| {
            finite(value, what).map_err(|e| ControlError::config(e.to_string()))
        };
        if !(config.ts_s.is_finite() && config.ts_s > 0.0) {
            return Err(ControlError::config(format!(
                "sample period Ts must be a number of seconds greater than 0, got {}",
                quote(config.ts_s)
            )));
        }
        let setpoint = config_number(config.setpoint, "set point")?;
        let manual = config
            .manual
            .map(|m| config_number(m, "manual output"))
            .transpose()?;
        if config.mode == Mode::Manual && manual.is_none() {
            return Err(ControlError::config(
                "starting in manual mode needs a manual output",
            ));
        }
        let stale = config.stale_after()?;
        Ok(Self {
            pid_loop: PidLoop::new(config.pid_loop)?,
            ts_s: config.ts_s,
            stale,
            setpoint,
            mode: config.mode,
            manual,
            previous_sample: None,
            over_ts: true,
            via_rcc: false,
            stale_at: None,
        })
    }

    /// Its loop.
    pub fn pid_loop(&self) -> &PidLoop {
        &self.pid_loop
    }

    /// What survives a restart, and what a dashboard shows.
    pub fn state(&self) -> StationState {
        StationState {
            setpoint: self.setpoint,
            mode: self.mode,
            manual: self.manual,
            last_output: self.pid_loop.pid().last_output(),
            integral: self.pid_loop.pid().integral(),
        }
    }

    /// A measured round trip, for the adaptive dead time.
    pub fn observe_round_trip(&mut self, round_trip: Millis) -> Result<(), ControlError> {
        self.pid_loop.observe_round_trip(round_trip)
    }

    /// What a restart brings back, checked as a whole: a refused one changes nothing.
    pub fn restore(&mut self, saved: Saved) -> Result<(), ControlError> {
        let integral = saved
            .integral
            .map(|i| finite(i, "saved integral"))
            .transpose()?;
        let setpoint = saved
            .setpoint
            .map(|s| finite(s, "saved set point"))
            .transpose()?;
        let manual = saved
            .manual
            .map(|m| finite(m, "saved manual output"))
            .transpose()?
            .or(self.manual);
        let mode = match saved.mode.unwrap_or(self.mode) {
            // a manual mode saved without its output resumes in auto
            Mode::Manual if manual.is_none() => Mode::Auto,
            mode => mode,
        };
        if let Some(integral) = integral {
            self.pid_loop.pid_mut().set_integral(integral)?;
        }
        self.setpoint = setpoint.unwrap_or(self.setpoint);
        (self.mode, self.manual) = (mode, manual);
        Ok(())
    }

    /// Applies `change` whole, or refuses it and changes nothing.
    pub fn change(&mut self, change: Change) -> Result<(), ControlError> {
        let setpoint = change
            .setpoint
            .map(|s| finite(s, "set point"))
            .transpose()?;
        let given_manual = change
            .manual
            .map(|m| finite(m, "manual output"))
            .transpose()?;
        let mut next = self.pid_loop.pid().config().clone();
        if let Some(t) = change.tunings {
            if t.kp.is_none() && t.ti_s.is_none() && t.td_s.is_none() {
                return Err(ControlError::input(
                    "a tunings change names none of kp, ti, td",
                ));
            }
            next.kp = t.kp.unwrap_or(next.kp);
            next.ti_s = t.ti_s.unwrap_or(next.ti_s);
            next.td_s = t.td_s.unwrap_or(next.td_s);
        }
        if let Some(l) = change.limits {
            if l.min.is_none() && l.max.is_none() {
                return Err(ControlError::input(
                    "a limits change names none of min, max",
                ));
            }
            next.out_min = l.min.unwrap_or(next.out_min);
            next.out_max = l.max.unwrap_or(next.out_max);
        }
        next.validate()?;
        let mode = change.mode.unwrap_or(self.mode);
        // Into manual without a value: hold the loop's last output (bumpless), else the configured one.
        let entering = mode == Mode::Manual && self.mode != Mode::Manual;
        let manual = given_manual.or(if entering {
            self.pid_loop.pid().last_output().or(self.manual)
        } else {
            self.manual
        });
        if mode == Mode::Manual && manual.is_none() {
            return Err(manual_needed());
        }
        // Checked above: neither can refuse now.
        let pid = self.pid_loop.pid_mut();
        if change.tunings.is_some() {
            pid.set_tunings(next.kp, next.ti_s, next.td_s)?;
        }
        if change.limits.is_some() {
            pid.set_limits(next.out_min, next.out_max)?;
        }
        self.setpoint = setpoint.unwrap_or(self.setpoint);
        (self.mode, self.manual) = (mode, manual);
        Ok(())
    }

    /// One step for a sample that arrived.
    pub fn measure(&mut self, sample: Sample) -> Result<Outcome, ControlError> {
        let measurement = sample.measurement.filter(|m| m.is_finite());
        let dt_s = match self.previous_sample {
            // Signed: a sample older than the last one is refused by the PID (dt <= 0).
            Some(previous) if !self.over_ts => computed(
                (sample.sampled.as_f64() - previous.as_f64()) / 1000.0,
                "elapsed time",
            )?,
            _ => self.ts_s,
        };
        let (step, engaged) = self.step(measurement, dt_s, sample.track, sample.decision)?;
        self.previous_sample = Some(sample.sampled);
        self.over_ts = false;
        self.via_rcc = sample.decision.is_some();
        if measurement.is_some() && self.stale > Millis::ZERO {
            self.stale_at = Some(later(sample.now, self.stale));
        }
        Ok(Outcome {
            engaged,
            pid: self.report(step, measurement, dt_s),
        })
    }

    /// When `tick` next has something to do, if ever.
    pub fn next_tick(&self) -> Option<Millis> {
        self.stale_at
    }

    /// The stale-measurement rule, due at `next_tick`: `None` when nothing is due.
    pub fn tick(&mut self, now: Millis) -> Result<Option<Stale>, ControlError> {
        match self.stale_at {
            Some(due) if now >= due => {}
            _ => return Ok(None),
        }
        if self.via_rcc {
            self.stale_at = None;
            return Ok(Some(Stale::NoIo));
        }
        // Re-armed first: a refused step must not leave a tick due at once, again and again.
        self.stale_at = Some(later(now, self.stale));
        let dt_s = self.stale.as_secs_f64();
        let (step, _) = self.step(None, dt_s, None, None)?;
        self.over_ts = true;
        Ok(Some(Stale::Fallback {
            pid: self.report(step, None, dt_s),
        }))
    }

    fn step(
        &mut self,
        measurement: Option<f64>,
        dt_s: f64,
        track: Option<f64>,
        decision: Option<Decision>,
    ) -> Result<(PidStep, bool), ControlError> {
        let manual = match self.mode {
            Mode::Manual => Some(self.manual.ok_or_else(manual_needed)?),
            Mode::Auto => None,
        };
        match decision {
            Some(decision) => {
                let follow = Decision {
                    track: manual.or(decision.track).or(track),
                    ..decision
                };
                let scan = rcc::act(
                    &follow,
                    &mut self.pid_loop,
                    self.setpoint,
                    measurement,
                    dt_s,
                )?;
                Ok((scan.step, scan.engaged))
            }
            None => {
                let input = PidInput {
                    setpoint: self.setpoint,
                    measurement,
                    dt_s,
                    track: manual.or(track),
                };
                Ok((self.pid_loop.step(input)?, true))
            }
        }
    }

    fn report(&self, step: PidStep, measurement: Option<f64>, dt_s: f64) -> Report {
        let mode = match (self.mode, step.mode) {
            (Mode::Manual, _) => ReportMode::Manual,
            (Mode::Auto, StepMode::Auto) => ReportMode::Auto,
            (Mode::Auto, StepMode::Tracking) => ReportMode::Tracking,
            (Mode::Auto, StepMode::Fallback) => ReportMode::Fallback,
        };
        Report {
            p: step.p,
            i: step.i,
            d: step.d,
            output: step.output,
            mode,
            saturated: step.saturated,
            setpoint: self.setpoint,
            measurement,
            seen: self.pid_loop.seen(),
            dead_time_samples: self.pid_loop.smith().map(|s| s.dead_time_samples()),
            dt_s,
        }
    }
}

/// `period` after `now`, always later: at a time so large that adding the
/// period changes nothing, the next float up (a tick is never due at once
/// again), up to the largest time there is.
fn later(now: Millis, period: Millis) -> Millis {
    let next = now.saturating_add(period);
    if next > now {
        next
    } else {
        // Times are >= 0, so the next bit pattern up is the next float up.
        Millis::new(f64::from_bits(now.as_f64().to_bits() + 1)).unwrap_or(Millis::MAX)
    }
}

#[cfg(test)]
mod tests;
