//! The adaptive Smith predictor of the paper's Fig. 5 (Eq. 2): the PID designed
//! for the process without delay sees `y + ŷ(k) - ŷ(k - D_c)`, where ŷ is a
//! first-order model driven by the actions sent, and D_c either is fixed or
//! follows the round-trip estimator. The delay line is sized at run time up to
//! `max_samples`, so memory stays bounded whatever delays the network shows.
//!
//! The line is indexed by time, not by sample count: ŷ(k - D_c) is the model's
//! output D_c·Ts seconds ago, interpolated between the samples around it. With
//! regular sampling at Ts that is exactly the paper's sample; with irregular
//! sampling (steps at each measurement's own timestamp) the delay the PID sees
//! stays the one the model advanced through.

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

use super::delay::DelayEstimator;
use super::error::{computed, finite, positive, ControlError};
use crate::text::quote;
use crate::time::Millis;

/// Upper bound on `max_samples`: 100 000 samples of f64 is 800 kB per loop.
pub const MAX_DELAY_LINE: usize = 100_000;

/// `max_samples` when not set: 400 samples of Ts covers the paper's delays at its Ts.
pub const DEFAULT_MAX_SAMPLES: usize = 400;

/// The estimator's weight of a new round trip when not set.
pub const DEFAULT_ALPHA: f64 = 0.1;

/// How many standard deviations above the mean round trip the dead time covers, when not set.
pub const DEFAULT_H: f64 = 3.0;

/// First-order process model without its dead time: gain and time constant.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct FopdtModel {
    /// The process gain.
    pub gain: f64,
    /// The process time constant, in seconds.
    pub tau_s: f64,
}

/// How the predictor knows the dead time.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "mode", rename_all = "lowercase", deny_unknown_fields)]
pub enum DeadTime {
    /// A dead time set at design time, e.g. floor((μ + 3σ) / Ts) as in the paper's Table 3.
    Fixed {
        /// The dead time, in samples.
        samples: usize,
    },
    /// D_c from the estimator fed with measured round trips.
    Adaptive {
        /// The weight of each new round trip in the estimate.
        #[serde(default = "default_alpha")]
        alpha: f64,
        /// How many standard deviations above the mean the dead time is taken.
        #[serde(default = "default_h")]
        h: f64,
    },
}

/// A Smith predictor's process model and dead time.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct SmithConfig {
    /// The first-order process model.
    pub model: FopdtModel,
    /// Sampling period in seconds: the unit of the dead time.
    pub ts_s: f64,
    /// The dead time: fixed, or following the measured round trip.
    pub dead_time: DeadTime,
    /// Longest dead time the delay line holds, in samples.
    #[serde(default = "default_max_samples")]
    pub max_samples: usize,
}

fn default_max_samples() -> usize {
    DEFAULT_MAX_SAMPLES
}

fn default_alpha() -> f64 {
    DEFAULT_ALPHA
}

fn default_h() -> f64 {
    DEFAULT_H
}

impl SmithConfig {
    /// Refuses a model or dead time that cannot run.
    pub fn validate(&self) -> Result<(), ControlError> {
        if !(self.model.gain.is_finite() && self.model.gain != 0.0) {
            return Err(ControlError::config(format!(
                "model gain must be a non-zero number, got {}",
                quote(self.model.gain)
            )));
        }
        positive(self.model.tau_s, "model time constant (s)")?;
        positive(self.ts_s, "sampling period Ts (s)")?;
        if self.max_samples == 0 || self.max_samples > MAX_DELAY_LINE {
            return Err(ControlError::config(format!(
                "maxSamples must be between 1 and {MAX_DELAY_LINE}, got {}",
                self.max_samples
            )));
        }
        match self.dead_time {
            DeadTime::Fixed { samples } if samples > self.max_samples => {
                Err(ControlError::config(format!(
                    "fixed dead time of {samples} samples exceeds maxSamples {}",
                    self.max_samples
                )))
            }
            DeadTime::Fixed { .. } => Ok(()),
            DeadTime::Adaptive { alpha, h } => DelayEstimator::new(alpha, h).map(|_| ()),
        }
    }
}

/// Corrects the measurement for a dead time, so the PID acts on the process it would see without it.
#[derive(Clone, Debug)]
pub struct SmithPredictor {
    config: SmithConfig,
    estimator: Option<DelayEstimator>,
    /// ŷ(k), ŷ(k-1), ... newest first; at most max_samples + 1 values.
    model_outputs: VecDeque<ModelSample>,
}

#[derive(Clone, Copy, Debug)]
struct ModelSample {
    y: f64,
    /// Seconds from the sample before this one.
    dt_s: f64,
}

impl SmithPredictor {
    /// A predictor for `config`, refused if it cannot run.
    pub fn new(config: SmithConfig) -> Result<Self, ControlError> {
        config.validate()?;
        let estimator = match config.dead_time {
            DeadTime::Fixed { .. } => None,
            DeadTime::Adaptive { alpha, h } => Some(DelayEstimator::new(alpha, h)?),
        };
        Ok(Self {
            config,
            estimator,
            model_outputs: VecDeque::from([ModelSample { y: 0.0, dt_s: 0.0 }]),
        })
    }

    /// Its configuration.
    pub fn config(&self) -> &SmithConfig {
        &self.config
    }

    /// Its round-trip estimator, when the dead time is adaptive.
    pub fn estimator(&self) -> Option<&DelayEstimator> {
        self.estimator.as_ref()
    }

    /// Feeds a measured round trip to the estimator; a fixed dead time ignores it.
    pub fn observe_round_trip(&mut self, round_trip: Millis) -> Result<(), ControlError> {
        match &mut self.estimator {
            Some(estimator) => estimator.observe(round_trip),
            None => Ok(()),
        }
    }

    /// D_c in samples, capped at `max_samples`.
    pub fn dead_time_samples(&self) -> usize {
        let samples = match (&self.estimator, self.config.dead_time) {
            (Some(estimator), _) => Millis::from_secs_f64(self.config.ts_s)
                .and_then(|ts| estimator.dead_time_samples(ts).ok())
                .unwrap_or(0),
            (None, DeadTime::Fixed { samples }) => samples,
            (None, DeadTime::Adaptive { .. }) => 0,
        };
        samples.min(self.config.max_samples)
    }

    /// What the PID should see: the measurement plus the model's prediction of
    /// what the delay still hides.
    pub fn feedback(&self, measurement: f64) -> Result<f64, ControlError> {
        let now = self.model_output();
        computed(
            measurement + (now - self.delayed_output()),
            "Smith predictor's corrected measurement",
        )
    }

    /// ŷ D_c·Ts seconds ago, or the oldest the line holds.
    fn delayed_output(&self) -> f64 {
        let line = &self.model_outputs;
        let mut remaining = self.dead_time_samples() as f64 * self.config.ts_s;
        for k in 0..line.len() - 1 {
            if remaining <= 0.0 {
                return line[k].y;
            }
            let span = line[k].dt_s;
            // Sums of Ts carry rounding: within a billionth of a sample it is that sample.
            if (remaining - span).abs() <= 1e-9 * span {
                return line[k + 1].y;
            }
            if remaining < span {
                return line[k].y + (line[k + 1].y - line[k].y) * (remaining / span);
            }
            remaining -= span;
        }
        line[line.len() - 1].y
    }

    /// Moves the model one sample on with the action sent in it.
    pub fn advance(&mut self, action: f64, dt_s: f64) -> Result<(), ControlError> {
        let action = finite(action, "action")?;
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return Err(ControlError::input(format!(
                "elapsed time must be > 0 s, got {dt_s}",
                dt_s = quote(dt_s)
            )));
        }
        let FopdtModel { gain, tau_s } = self.config.model;
        let a = (-dt_s / tau_s).exp();
        let next = computed(
            a * self.model_output() + gain * (1.0 - a) * action,
            "Smith predictor's model output",
        )?;
        self.model_outputs.push_front(ModelSample { y: next, dt_s });
        self.model_outputs.truncate(self.config.max_samples + 1);
        Ok(())
    }

    /// ŷ(k): the model's undelayed output.
    pub fn model_output(&self) -> f64 {
        self.model_outputs[0].y
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::time::millis;

    fn predictor(dead_time: DeadTime) -> SmithPredictor {
        SmithPredictor::new(SmithConfig {
            model: FopdtModel {
                gain: 2.0,
                tau_s: 3.0,
            },
            ts_s: 0.3,
            dead_time,
            max_samples: 50,
        })
        .unwrap()
    }

    #[test]
    fn model_is_the_exact_first_order_step_response() {
        let mut s = predictor(DeadTime::Fixed { samples: 0 });
        for _ in 0..10 {
            s.advance(1.0, 0.3).unwrap();
        }
        // after τ = 3 s the model is at K·(1 - e^-1)
        assert!((s.model_output() - 2.0 * (1.0 - (-1f64).exp())).abs() < 1e-12);
    }

    #[test]
    fn with_a_matching_process_the_pid_sees_the_undelayed_model() {
        let dead = 4;
        let mut s = predictor(DeadTime::Fixed { samples: dead });
        let mut outputs = vec![0.0];
        for k in 0..20 {
            let action = if k < 10 { 1.0 } else { -0.5 };
            s.advance(action, 0.3).unwrap();
            outputs.push(s.model_output());
            // a real process matching the model shows ŷ delayed by `dead` samples
            let measured = if outputs.len() > dead {
                outputs[outputs.len() - 1 - dead]
            } else {
                0.0
            };
            assert!((s.feedback(measured).unwrap() - s.model_output()).abs() < 1e-12);
        }
    }

    #[test]
    fn adaptive_dead_time_follows_the_estimator_and_is_capped() {
        let mut s = predictor(DeadTime::Adaptive { alpha: 0.2, h: 3.0 });
        assert_eq!(s.dead_time_samples(), 0, "no round trip seen yet");
        for _ in 0..200 {
            s.observe_round_trip(millis(1500.0)).unwrap();
        }
        assert_eq!(s.dead_time_samples(), 5, "1.5 s / 0.3 s");
        s.observe_round_trip(millis(1e7)).unwrap();
        assert_eq!(s.dead_time_samples(), 50, "capped at maxSamples");
    }

    #[test]
    fn delay_line_memory_is_bounded() {
        let mut s = predictor(DeadTime::Fixed { samples: 50 });
        for _ in 0..1000 {
            s.advance(1.0, 0.3).unwrap();
        }
        assert_eq!(s.model_outputs.len(), 51);
    }

    #[test]
    fn an_adaptive_dead_time_left_blank_takes_alpha_h_and_max_samples_from_here() {
        let given = r#"{ "model": { "gain": 1, "tauS": 3 }, "tsS": 0.3, "deadTime": { "mode": "adaptive" } }"#;
        let config: SmithConfig = serde_json::from_str(given).unwrap();
        assert_eq!(
            config.dead_time,
            DeadTime::Adaptive {
                alpha: DEFAULT_ALPHA,
                h: DEFAULT_H
            }
        );
        assert_eq!(config.max_samples, DEFAULT_MAX_SAMPLES);
        assert_eq!(
            (DEFAULT_ALPHA, DEFAULT_H, DEFAULT_MAX_SAMPLES),
            (0.1, 3.0, 400)
        );
        SmithPredictor::new(config).unwrap();
    }

    #[test]
    fn what_is_set_wins_over_the_defaults() {
        let given = r#"{ "model": { "gain": 1, "tauS": 3 }, "tsS": 0.3, "maxSamples": 20,
                         "deadTime": { "mode": "adaptive", "alpha": 0.5, "h": 0 } }"#;
        let config: SmithConfig = serde_json::from_str(given).unwrap();
        assert_eq!(config.dead_time, DeadTime::Adaptive { alpha: 0.5, h: 0.0 });
        assert_eq!(config.max_samples, 20);
    }

    #[test]
    fn refuses_configs_that_cannot_run() {
        let base = SmithConfig {
            model: FopdtModel {
                gain: 1.0,
                tau_s: 3.0,
            },
            ts_s: 0.3,
            dead_time: DeadTime::Fixed { samples: 10 },
            max_samples: 400,
        };
        let broken = [
            SmithConfig { ts_s: 0.0, ..base },
            SmithConfig { ts_s: -0.3, ..base },
            SmithConfig {
                model: FopdtModel {
                    gain: 0.0,
                    tau_s: 3.0,
                },
                ..base
            },
            SmithConfig {
                model: FopdtModel {
                    gain: 1.0,
                    tau_s: f64::NAN,
                },
                ..base
            },
            SmithConfig {
                dead_time: DeadTime::Fixed { samples: 401 },
                ..base
            },
            SmithConfig {
                dead_time: DeadTime::Adaptive { alpha: 0.0, h: 3.0 },
                ..base
            },
            SmithConfig {
                max_samples: 0,
                ..base
            },
        ];
        for config in broken {
            assert_eq!(
                SmithPredictor::new(config).unwrap_err().code(),
                "INVALID_CONFIG",
                "{config:?}"
            );
        }
        let mut s = SmithPredictor::new(base).unwrap();
        assert_eq!(
            s.advance(f64::NAN, 0.3).unwrap_err().code(),
            "INVALID_INPUT"
        );
        assert_eq!(s.advance(1.0, 0.0).unwrap_err().code(), "INVALID_INPUT");
    }

    #[test]
    fn irregular_sampling_keeps_the_delay_line_in_step_with_the_model() {
        // A process that matches the model shows ŷ delayed by D_c·Ts seconds, whatever
        // the spacing of the samples; counting samples instead of seconds misses that.
        let dead = 4;
        let mut s = predictor(DeadTime::Fixed { samples: dead });
        let dead_s = dead as f64 * 0.3;
        let mut t = 0.0;
        for k in 0..40 {
            let dt = if k % 2 == 0 { 0.1 } else { 0.5 };
            s.advance(1.0, dt).unwrap();
            t += dt;
            // ŷ at t - dead_s, by the exact first-order step response (unit action from 0)
            let at = t - dead_s;
            let measured = if at <= 0.0 {
                0.0
            } else {
                2.0 * (1.0 - (-at / 3.0).exp())
            };
            if at > 0.6 {
                let error = (s.feedback(measured).unwrap() - s.model_output()).abs();
                // linear interpolation between samples at most 0.5 s apart
                assert!(error < 0.02, "k={k} t={t}: {error}");
            }
        }
    }

    #[test]
    fn a_model_output_too_large_to_compute_is_refused_and_changes_nothing() {
        let mut s = SmithPredictor::new(SmithConfig {
            model: FopdtModel {
                gain: 1e308,
                tau_s: 3.0,
            },
            ts_s: 0.3,
            dead_time: DeadTime::Fixed { samples: 2 },
            max_samples: 10,
        })
        .unwrap();
        s.advance(1.0, 0.3).unwrap();
        let before = s.model_output();
        assert_eq!(s.advance(100.0, 0.3).unwrap_err().code(), "INVALID_INPUT");
        assert_eq!(s.model_output(), before);
        assert_eq!(s.feedback(f64::MAX).unwrap_err().code(), "INVALID_INPUT");
    }
}
