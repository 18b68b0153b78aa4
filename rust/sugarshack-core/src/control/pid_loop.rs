//! A PID with an optional Smith predictor in front of its measurement: the
//! loop a remote controller runs (the paper's Fig. 5).

use serde::{Deserialize, Serialize};

use super::error::ControlError;
use super::pid::{Pid, PidConfig, PidInput, PidStep};
use super::rcc::Controller;
use super::smith::{SmithConfig, SmithPredictor};
use crate::time::Millis;

/// A PID and, optionally, the Smith predictor in front of it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct PidLoopConfig {
    /// The PID.
    pub pid: PidConfig,
    /// The Smith predictor, when the loop has a dead time to compensate.
    #[serde(default)]
    pub smith: Option<SmithConfig>,
}

/// A PID with an optional Smith predictor: what a pid node runs.
#[derive(Clone, Debug)]
pub struct PidLoop {
    pid: Pid,
    smith: Option<SmithPredictor>,
    /// The measurement the PID last saw: predicted when a Smith predictor is on.
    seen: Option<f64>,
}

impl PidLoop {
    /// A loop for `config`, refused if it cannot run.
    pub fn new(config: PidLoopConfig) -> Result<Self, ControlError> {
        let smith = config.smith.map(SmithPredictor::new).transpose()?;
        Ok(Self {
            pid: Pid::new(config.pid)?,
            smith,
            seen: None,
        })
    }

    /// Its PID.
    pub fn pid(&self) -> &Pid {
        &self.pid
    }

    /// Its PID, to change tunings or limits.
    pub fn pid_mut(&mut self) -> &mut Pid {
        &mut self.pid
    }

    /// Its Smith predictor, if any.
    pub fn smith(&self) -> Option<&SmithPredictor> {
        self.smith.as_ref()
    }

    /// The measurement the PID saw last (after the predictor's correction).
    pub fn seen(&self) -> Option<f64> {
        self.seen
    }

    /// A measured round trip, for the adaptive dead time.
    pub fn observe_round_trip(&mut self, round_trip: Millis) -> Result<(), ControlError> {
        match &mut self.smith {
            Some(smith) => smith.observe_round_trip(round_trip),
            None => Ok(()),
        }
    }

    /// One step of the PID and the model together: if either refuses, neither changes.
    pub fn step(&mut self, input: PidInput) -> Result<PidStep, ControlError> {
        let measurement = input.measurement.filter(|m| m.is_finite());
        let seen = match (&self.smith, measurement) {
            (Some(smith), Some(m)) => Some(smith.feedback(m)?),
            (_, m) => m,
        };
        let before = self.smith.is_some().then(|| self.pid.clone());
        let step = self.pid.step(PidInput {
            measurement: seen,
            ..input
        })?;
        if let (Some(smith), Some(before)) = (&mut self.smith, before) {
            if let Err(err) = smith.advance(step.output, input.dt_s) {
                self.pid = before;
                return Err(err);
            }
        }
        self.seen = seen;
        Ok(step)
    }
}

impl Controller for PidLoop {
    fn step(&mut self, input: PidInput) -> Result<PidStep, ControlError> {
        PidLoop::step(self, input)
    }

    fn restart(&mut self) {
        self.pid.restart();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::pid::Action;
    use crate::control::smith::{DeadTime, FopdtModel};

    fn config(smith: Option<SmithConfig>) -> PidLoopConfig {
        PidLoopConfig {
            pid: PidConfig {
                kp: 1.0,
                ti_s: 3.0,
                td_s: 0.0,
                out_min: -10.0,
                out_max: 10.0,
                action: Action::Reverse,
                fallback: None,
                proportional_on: Default::default(),
            },
            smith,
        }
    }

    /// A predictor sampled every 0.3 s with `samples` of fixed dead time.
    fn smith(gain: f64, tau_s: f64, samples: usize, max_samples: usize) -> SmithConfig {
        SmithConfig {
            model: FopdtModel { gain, tau_s },
            ts_s: 0.3,
            dead_time: DeadTime::Fixed { samples },
            max_samples,
        }
    }

    /// One untracked step, 0.3 s after the last.
    fn untracked_step(
        pid: &mut PidLoop,
        setpoint: f64,
        measurement: Option<f64>,
    ) -> Result<PidStep, ControlError> {
        pid.step(PidInput {
            setpoint,
            measurement,
            dt_s: 0.3,
            track: None,
        })
    }

    /// Closed loop on a first-order process with `dead` samples of dead time.
    fn overshoot(smith: bool, dead: usize) -> f64 {
        let smith = smith.then(|| self::smith(1.0, 3.0, dead, 100));
        let mut pid = PidLoop::new(config(smith)).unwrap();
        let a = (-0.3f64 / 3.0).exp();
        let (mut y, mut actions, mut peak) = (0.0f64, vec![0.0; dead + 1], 0.0f64);
        for _ in 0..400 {
            let step = untracked_step(&mut pid, 1.0, Some(y)).unwrap();
            actions.push(step.output);
            let applied = actions[actions.len() - 1 - dead];
            y = a * y + (1.0 - a) * applied;
            peak = peak.max(y);
        }
        assert!((y - 1.0).abs() < 0.01, "settles on the set point");
        peak - 1.0
    }

    #[test]
    fn the_predictor_removes_the_overshoot_dead_time_causes() {
        let without = overshoot(false, 10);
        let with = overshoot(true, 10);
        assert!(
            without > 0.2,
            "3 s of dead time makes this PI overshoot: {without}"
        );
        assert!(
            with < 0.01,
            "the predictor's loop behaves as with no delay: {with}"
        );
        assert!((with - overshoot(false, 0)).abs() < 1e-9);
    }

    #[test]
    fn a_missing_measurement_leaves_the_model_running_on_the_fallback() {
        let mut pid = PidLoop::new(config(Some(smith(1.0, 3.0, 2, 10)))).unwrap();
        untracked_step(&mut pid, 1.0, Some(0.0)).unwrap();
        let step = untracked_step(&mut pid, 1.0, None).unwrap();
        assert!(step.output.is_finite());
        assert_eq!(pid.seen(), None);
    }

    #[test]
    fn a_refused_model_step_leaves_the_pid_as_it_was() {
        // gain·(1 - e^(-dt/τ))·action overflows once the action is 10
        let mut pid = PidLoop::new(config(Some(smith(1e308, 0.01, 2, 10)))).unwrap();
        untracked_step(&mut pid, 0.0, Some(0.0)).unwrap();
        let (integral, last) = (pid.pid().integral(), pid.pid().last_output());
        let err = untracked_step(&mut pid, 50.0, Some(0.0)).unwrap_err();
        assert_eq!(err.code(), "INVALID_INPUT");
        assert_eq!(
            (pid.pid().integral(), pid.pid().last_output()),
            (integral, last)
        );
    }
}
