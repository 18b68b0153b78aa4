//! Reliable Cloud Control (the paper's §5, Fig. 7): redundant controllers with
//! ids 1..n decide on their own, with no shared clock, which one acts. The I/O
//! side keeps the state tuple (a, u_1..u_n): the last action applied and, per
//! controller, the time since it last acted, counted by the I/O side's own
//! clock. Controller i acts when every lower id's age is at least its
//! engagement threshold D_i, and D_i > D_j >= Ts for i > j keeps one in charge.

use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serialize};

use super::error::{finite, out_of_range, positive_duration, ControlError};
use super::pid::{Pid, PidInput, PidStep};
use crate::text::{quote, seconds};
use crate::time::Millis;

/// D_1..D_n must rise strictly with the id and start at Ts or above.
pub fn validate_thresholds(thresholds: &[Millis], ts: Millis) -> Result<(), ControlError> {
    let raw: Vec<f64> = thresholds.iter().map(|t| t.as_f64()).collect();
    check_thresholds(&raw, ts.as_f64()).map(drop)
}

/// D_1..D_n and Ts as given in ms, refused unless D_i > D_j >= Ts > 0: where
/// numbers from outside become [`Millis`].
pub fn thresholds_from_ms(
    thresholds_ms: &[f64],
    ts_ms: f64,
) -> Result<(Vec<Millis>, Millis), ControlError> {
    let ts = check_thresholds(thresholds_ms, ts_ms)?;
    // Checked: every threshold is finite and at least Ts > 0.
    let thresholds = thresholds_ms
        .iter()
        .filter_map(|&t| Millis::new(t))
        .collect();
    Ok((thresholds, ts))
}

fn check_thresholds(thresholds_ms: &[f64], ts_ms: f64) -> Result<Millis, ControlError> {
    let ts = positive_duration(ts_ms, "sampling period Ts")?;
    if thresholds_ms.is_empty() {
        return Err(ControlError::config(
            "engagement thresholds: give one per controller, D_1..D_n",
        ));
    }
    for (index, &threshold) in thresholds_ms.iter().enumerate() {
        let id = index + 1;
        if !threshold.is_finite() || threshold < ts_ms {
            return Err(ControlError::config(format!(
                "engagement threshold D_{id} = {threshold} must be at least the sampling period Ts = {ts}",
                threshold = seconds(threshold),
                ts = seconds(ts_ms)
            )));
        }
        if index > 0 && threshold <= thresholds_ms[index - 1] {
            return Err(ControlError::config(format!(
                "engagement threshold D_{id} = {threshold} must be greater than D_{} = {}: a backup must wait longer than every controller above it",
                index,
                seconds(thresholds_ms[index - 1]),
                threshold = seconds(threshold)
            )));
        }
    }
    Ok(ts)
}

/// What a controller reads from the I/O side in its Polling step.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct IoState {
    /// The last action written.
    pub last_action: f64,
    /// Per controller id 1..n: the time since it last acted; `None` if it never has (∞).
    #[serde(rename = "agesMs", deserialize_with = "ages")]
    pub ages: Vec<Option<Millis>>,
}

/// The I/O side's memory of the state tuple.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct IoModule {
    last_action: f64,
    last_write_ms: Vec<Option<Millis>>,
}

impl IoModule {
    /// `initial_action` is what the actuator holds before any controller acts.
    pub fn new(controllers: usize, initial_action: f64) -> Result<Self, ControlError> {
        if controllers == 0 {
            return Err(ControlError::config(
                "an I/O module serves at least one controller",
            ));
        }
        let last_action = finite(initial_action, "initial action")
            .map_err(|e| ControlError::config(e.to_string()))?;
        Ok(Self {
            last_action,
            last_write_ms: vec![None; controllers],
        })
    }

    /// How many controllers it serves.
    pub fn controllers(&self) -> usize {
        self.last_write_ms.len()
    }

    /// The last action written.
    pub fn last_action(&self) -> f64 {
        self.last_action
    }

    /// Conditional Acting's write: the action and a zeroed age for `id` (1-based).
    pub fn write(&mut self, id: usize, action: f64, now: Millis) -> Result<(), ControlError> {
        let controllers = self.controllers();
        let slot = id
            .checked_sub(1)
            .and_then(|index| self.last_write_ms.get_mut(index))
            .ok_or(ControlError::UnknownController { id, controllers })?;
        let action = finite(action, "action")?;
        *slot = Some(now);
        self.last_action = action;
        Ok(())
    }

    /// The state the controllers poll at `now`.
    pub fn state(&self, now: Millis) -> IoState {
        IoState {
            last_action: self.last_action,
            ages: self
                .last_write_ms
                .iter()
                .map(|w| w.map(|at| now.saturating_sub(at)))
                .collect(),
        }
    }
}

/// Ages as the I/O side wrote them, each refused unless a number of ms >= 0.
fn ages<'de, D: Deserializer<'de>>(deserializer: D) -> Result<Vec<Option<Millis>>, D::Error> {
    let raw = Vec::<Option<f64>>::deserialize(deserializer)?;
    raw.into_iter()
        .map(|age| {
            age.map(|age| {
                Millis::new(age).ok_or_else(|| {
                    D::Error::custom(format!(
                        "a controller age must be a number of ms >= 0, got {age}",
                        age = quote(age)
                    ))
                })
            })
            .transpose()
        })
        .collect()
}

/// One controller's place in the redundancy scheme.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", try_from = "RccSettings")]
pub struct RccConfig {
    /// 1 for the primary, 2 for the secondary, ...
    pub id: usize,
    /// D_1..D_n, one per controller of the group.
    #[serde(rename = "thresholdsMs")]
    pub thresholds: Vec<Millis>,
    /// The sampling period.
    #[serde(rename = "tsMs")]
    pub ts: Millis,
    /// Bumpless handover (§5.3); off only to show what it prevents.
    pub smooth_handover: bool,
    /// No state polled for this long is a polling timeout (Fig. 7 line 11); 3·Ts when absent.
    #[serde(rename = "pollTimeoutMs")]
    pub poll_timeout: Option<Millis>,
}

/// An [`RccConfig`] as written, in ms: its numbers are checked as they become [`Millis`].
#[derive(Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
struct RccSettings {
    id: usize,
    thresholds_ms: Vec<f64>,
    ts_ms: f64,
    #[serde(default = "yes")]
    smooth_handover: bool,
    #[serde(default)]
    poll_timeout_ms: Option<f64>,
}

impl TryFrom<RccSettings> for RccConfig {
    type Error = ControlError;

    fn try_from(s: RccSettings) -> Result<Self, ControlError> {
        let (thresholds, ts) = thresholds_from_ms(&s.thresholds_ms, s.ts_ms)?;
        let poll_timeout = s
            .poll_timeout_ms
            .map(|t| positive_duration(t, "poll timeout"))
            .transpose()?;
        Ok(Self {
            id: s.id,
            thresholds,
            ts,
            smooth_handover: s.smooth_handover,
            poll_timeout,
        })
    }
}

fn yes() -> bool {
    true
}

/// The Computing step's verdict for one polled state.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Decision {
    /// Whether this controller writes this scan.
    pub engaged: bool,
    /// The first cycle after it engaged: its integrator starts from the action in place.
    pub first_cycle: bool,
    /// The action the controller's integrator must track this scan (§5.3).
    pub track: Option<f64>,
}

/// One scan's outcome.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Scan {
    /// Whether this controller writes this scan.
    pub engaged: bool,
    /// The first cycle after it engaged.
    pub first_cycle: bool,
    /// The action to write to the I/O side: present only when engaged.
    pub write: Option<f64>,
    /// The PID's step for this scan.
    pub step: PidStep,
}

/// One controller of an RCC group: decides from the polled state whether it is the one that writes.
#[derive(Clone, Debug)]
pub struct RccController {
    config: RccConfig,
    poll_timeout: Millis,
    first_cycle: bool,
    /// When the polling timeout falls due, while one is being watched for.
    poll_due: Option<Millis>,
}

impl RccController {
    /// A controller for `config`, refused if its thresholds break D_i > D_j >= Ts.
    pub fn new(config: RccConfig) -> Result<Self, ControlError> {
        validate_thresholds(&config.thresholds, config.ts)?;
        let controllers = config.thresholds.len();
        if config.id == 0 || config.id > controllers {
            return Err(ControlError::config(format!(
                "controller id {} is outside 1..{controllers} (one engagement threshold per controller)",
                config.id
            )));
        }
        let poll_timeout_ms = config
            .poll_timeout
            .map_or(3.0 * config.ts.as_f64(), Millis::as_f64);
        let poll_timeout = positive_duration(poll_timeout_ms, "poll timeout")?;
        Ok(Self {
            config,
            poll_timeout,
            first_cycle: true,
            poll_due: None,
        })
    }

    /// Starts counting the polling timeout from `now` (at deploy: no state yet).
    pub fn watch_from(&mut self, now: Millis) -> Result<(), ControlError> {
        self.poll_due = Some(self.deadline(now)?);
        Ok(())
    }

    /// The Computing step for a state polled at `now`; the polling timeout counts from it.
    pub fn decide_at(&mut self, state: &IoState, now: Millis) -> Result<Decision, ControlError> {
        let due = self.deadline(now)?;
        let decision = self.decide(state)?;
        self.poll_due = Some(due);
        Ok(decision)
    }

    fn deadline(&self, now: Millis) -> Result<Millis, ControlError> {
        now.checked_add(self.poll_timeout).ok_or_else(|| {
            out_of_range(
                now.as_f64() + self.poll_timeout.as_f64(),
                "polling deadline",
            )
        })
    }

    /// When `tick` next has something to do, if ever.
    pub fn next_tick(&self) -> Option<Millis> {
        self.poll_due
    }

    /// True once when no state came within the polling timeout: the next scan re-seeds.
    pub fn tick(&mut self, now: Millis) -> Result<bool, ControlError> {
        match self.poll_due {
            Some(due) if now >= due => {
                self.poll_due = None;
                self.poll_timed_out();
                Ok(true)
            }
            _ => Ok(false),
        }
    }

    /// Its configuration.
    pub fn config(&self) -> &RccConfig {
        &self.config
    }

    /// Whether its next engaged scan is a first cycle.
    pub fn first_cycle(&self) -> bool {
        self.first_cycle
    }

    /// The Polling step timed out (Fig. 7 line 11): the next scan re-seeds.
    pub fn poll_timed_out(&mut self) {
        self.first_cycle = true;
    }

    /// Engaged unless a lower id acted within my threshold.
    pub fn engaged(&self, state: &IoState) -> Result<bool, ControlError> {
        let controllers = self.config.thresholds.len();
        if state.ages.len() != controllers {
            return Err(ControlError::input(format!(
                "the I/O state lists {} controller ages, this group has {controllers}",
                state.ages.len()
            )));
        }
        let threshold = self.config.thresholds[self.config.id - 1];
        Ok(state.ages[..self.config.id - 1]
            .iter()
            .all(|age| age.is_none_or(|age| age >= threshold)))
    }

    /// Computing step: engagement, and what the integrator tracks. Clears firstCycle.
    pub fn decide(&mut self, state: &IoState) -> Result<Decision, ControlError> {
        let engaged = self.engaged(state)?;
        let last_action = finite(state.last_action, "the I/O side's last action")?;
        let first_cycle = std::mem::replace(&mut self.first_cycle, false);
        let track =
            (self.config.smooth_handover && (!engaged || first_cycle)).then_some(last_action);
        Ok(Decision {
            engaged,
            first_cycle,
            track,
        })
    }

    /// Computing and Conditional Acting for one polled state.
    pub fn scan<C: Controller>(
        &mut self,
        controller: &mut C,
        state: &IoState,
        setpoint: f64,
        measurement: Option<f64>,
        dt_s: f64,
    ) -> Result<Scan, ControlError> {
        let decision = self.decide(state)?;
        act(&decision, controller, setpoint, measurement, dt_s)
    }
}

/// A controller RCC can drive: one step, optionally tracking an action.
pub trait Controller {
    /// One control step for `input`.
    fn step(&mut self, input: PidInput) -> Result<PidStep, ControlError>;
    /// Forget the previous measurement (after a gap in polling).
    fn restart(&mut self);
}

impl Controller for Pid {
    fn step(&mut self, input: PidInput) -> Result<PidStep, ControlError> {
        Pid::step(self, input)
    }

    fn restart(&mut self) {
        Pid::restart(self);
    }
}

/// Steps `controller` as `decision` says; the action is to be written only when engaged.
pub fn act<C: Controller>(
    decision: &Decision,
    controller: &mut C,
    setpoint: f64,
    measurement: Option<f64>,
    dt_s: f64,
) -> Result<Scan, ControlError> {
    if decision.first_cycle {
        controller.restart();
    }
    let step = controller.step(PidInput {
        setpoint,
        measurement,
        dt_s,
        track: decision.track,
    })?;
    Ok(Scan {
        engaged: decision.engaged,
        first_cycle: decision.first_cycle,
        write: decision.engaged.then_some(step.output),
        step,
    })
}

#[cfg(test)]
mod tests;
