//! The paper's §7.3 (Table 3, Fig. 12): a unit step on a flow loop whose round
//! trips are drawn from DS²'s shape stretched 10 to 40 times, with the PI alone
//! (uncompensated), with a Smith predictor set to floor((μ + 3σ)/Ts), and with
//! the adaptive predictor fed the round trips it measures.

use crate::sim::{
    DelayDist, FirstOrderParams, FirstOrderProcess, Link, DS2_MAX_MS, DS2_MEAN_MS, DS2_SD_MS,
};
use sugarshack_core::control::delay::DelayEstimator;
use sugarshack_core::control::pid::{Action, PidConfig, PidInput};
use sugarshack_core::control::pid_loop::{PidLoop, PidLoopConfig};
use sugarshack_core::control::smith::{DeadTime, FopdtModel, SmithConfig};
use sugarshack_core::control::ControlError;

use crate::metrics::{oscillates, step_metrics, Step, StepMetrics, Trace};
use crate::tuning::{apparent_dead_time_s, gain_for_crossover, ziegler_nichols_pi, PiTuning};

/// Table 3: Ts = 300 ms.
pub const TS_MS: i64 = 300;
pub const TICK_MS: i64 = 10;
/// Table 3 gives τ = 3 s only; gain 1 as in Table 2, and no dead time of its own.
pub const FLOW_PROCESS: FirstOrderParams = FirstOrderParams {
    gain: 1.0,
    tau_s: 3.0,
    dead_time_s: 0.0,
};
/// Table 3's delay distributions: DS² stretched by these factors.
pub const DS2_SCALES: [f64; 4] = [10.0, 20.0, 30.0, 40.0];
/// The dead times Table 3 lists for them (z^-10 .. z^-40).
pub const PAPER_DEAD_TIME_SAMPLES: [usize; 4] = [10, 20, 30, 40];
/// Table 3's unit step at t = 0.
pub const UNIT_STEP: Step = Step {
    at_s: 0.0,
    initial: 0.0,
    setpoint: 1.0,
};
/// The loop runs at rest this long before the step, as a plant loop would have:
/// the adaptive estimator starts the step with round trips already measured.
pub const WARM_UP_S: f64 = 60.0;
/// Long enough for the largest compensated dead time (12 s) plus several
/// closed-loop time constants, and for an unstable loop to show it.
pub const DURATION_S: f64 = 180.0;
/// Final value: the mean of the run's last 20 s.
pub const TAIL_S: f64 = 20.0;
/// A valve sized for about twice the nominal flow, as in Table 2.
pub const ACTION_LIMITS: (f64, f64) = (0.0, 2.0);
/// Estimator weight: about the last 10 round trips count, so D_c follows a
/// change of delay within a few seconds but one late packet moves it little.
pub const ADAPTIVE_ALPHA: f64 = 0.1;
/// Three standard deviations above the mean, as the fixed setting uses.
pub const ADAPTIVE_H: f64 = 3.0;
/// Runs per delay distribution (the paper repeated each "several times").
pub const SEEDS: u64 = 20;

/// The controller is designed as if there were no delay (§4): what it sees
/// then is the sampling alone, half a sample of hold.
pub fn apparent_dead_time() -> f64 {
    apparent_dead_time_s(0.0, TS_MS as f64 / 1000.0, FLOW_PROCESS.dead_time_s)
}

pub fn ziegler_nichols() -> PiTuning {
    ziegler_nichols_pi(FLOW_PROCESS.gain, FLOW_PROCESS.tau_s, apparent_dead_time())
}

/// The most the fixed predictor under-estimates a round trip: the largest
/// distribution's maximum minus its setting μ + 3σ (20 - 12.4 = 7.6 s).
pub fn largest_under_estimate_s() -> f64 {
    let scale = DS2_SCALES[DS2_SCALES.len() - 1];
    scale * (DS2_MAX_MS - DS2_MEAN_MS - 3.0 * DS2_SD_MS) / 1000.0
}

/// ZN's gain for a loop with no delay is far too high once the predictor's
/// model is off by Δ seconds of delay: the model error e^(-jωΔ) - 1 reaches
/// magnitude 1 at ωΔ = π/3, and below crossover the loop passes it at full
/// gain. So we keep ZN's integral time and set the gain for a crossover of
/// π/(3Δ) with Δ the largest under-estimate (small-gain robustness).
pub fn target_crossover_rad_s() -> f64 {
    std::f64::consts::PI / (3.0 * largest_under_estimate_s())
}

pub fn tuning() -> PiTuning {
    let zn = ziegler_nichols();
    PiTuning {
        kp: gain_for_crossover(
            FLOW_PROCESS.gain,
            FLOW_PROCESS.tau_s,
            zn.ti_s,
            target_crossover_rad_s(),
        ),
        ti_s: zn.ti_s,
    }
}

/// Table 3's formula D_c = floor((μ + 3σ) / Ts) for DS² stretched by `scale`.
pub fn fixed_dead_time_samples(scale: f64) -> Result<usize, ControlError> {
    let dist = DelayDist::ds2_scaled(scale)?;
    Ok(((dist.mean_ms() + 3.0 * dist.sd_ms()) / TS_MS as f64).floor() as usize)
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Compensation {
    /// The PI alone.
    None,
    /// Smith predictor with Table 3's fixed dead time.
    Fixed,
    /// Smith predictor whose dead time follows the measured round trips.
    Adaptive,
}

impl Compensation {
    pub fn label(self) -> &'static str {
        match self {
            Self::None => "uncompensated",
            Self::Fixed => "Smith, fixed D_c",
            Self::Adaptive => "Smith, adaptive",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DelayCase {
    /// DS² stretch factor; `None`: no network delay at all (the baseline).
    pub scale: Option<f64>,
    pub compensation: Compensation,
    pub seed: u64,
    pub tuning: PiTuning,
}

impl DelayCase {
    pub fn new(scale: Option<f64>, compensation: Compensation, seed: u64) -> Self {
        Self {
            scale,
            compensation,
            seed,
            tuning: tuning(),
        }
    }
}

#[derive(Clone, Debug, Default)]
pub struct DelayRun {
    pub output: Trace,
    pub action: Trace,
    /// D_c in samples at each sample (constant unless adaptive).
    pub dead_time_samples: Trace,
    /// D_c in force when the step is applied.
    pub dead_time_at_step: usize,
    /// Round trips the controller measured (ms).
    pub round_trips_ms: Vec<f64>,
}

impl DelayRun {
    pub fn metrics(&self) -> StepMetrics {
        step_metrics(&self.output, UNIT_STEP, TAIL_S)
    }

    /// Neither settled nor creeping: still swinging at the end.
    pub fn unstable(&self) -> bool {
        oscillates(&self.output, UNIT_STEP, &self.metrics())
    }

    pub fn dead_time_at_step_s(&self) -> f64 {
        self.dead_time_at_step as f64 * TS_MS as f64 / 1000.0
    }
}

/// An action on its way to the actuator, tagged with when it was sent.
struct ActionPacket {
    action: f64,
    sent_ms: i64,
}

/// A sample from the I/O side, echoing the tag of the action it last applied,
/// from which the controller measures the round trip.
struct Measurement {
    value: f64,
    applied_sent_ms: Option<i64>,
}

pub fn simulate(case: &DelayCase) -> Result<DelayRun, ControlError> {
    let forward = match case.scale {
        Some(scale) => DelayDist::ds2_scaled(scale)?,
        None => DelayDist::constant(0.0)?,
    };
    // The drawn delay is the whole round trip, put on the action's way out; the
    // sample comes back at once, so each action's round trip is one draw.
    let mut to_io: Link<ActionPacket> = Link::new(forward, case.seed);
    let mut to_controller: Link<Measurement> =
        Link::new(DelayDist::constant(0.0)?, case.seed ^ 0x5EED);
    let smith = match (case.compensation, case.scale) {
        (Compensation::None, _) => None,
        (Compensation::Fixed, scale) => Some(DeadTime::Fixed {
            samples: scale.map(fixed_dead_time_samples).transpose()?.unwrap_or(0),
        }),
        (Compensation::Adaptive, _) => Some(DeadTime::Adaptive {
            alpha: ADAPTIVE_ALPHA,
            h: ADAPTIVE_H,
        }),
    }
    .map(|dead_time| SmithConfig {
        model: FopdtModel {
            gain: FLOW_PROCESS.gain,
            tau_s: FLOW_PROCESS.tau_s,
        },
        ts_s: TS_MS as f64 / 1000.0,
        dead_time,
        max_samples: 400,
    });
    let (out_min, out_max) = ACTION_LIMITS;
    let mut controller = PidLoop::new(PidLoopConfig {
        pid: PidConfig {
            kp: case.tuning.kp,
            ti_s: case.tuning.ti_s,
            td_s: 0.0,
            out_min,
            out_max,
            action: Action::Reverse,
            fallback: None,
            proportional_on: Default::default(),
        },
        smith,
    })?;
    let mut process = FirstOrderProcess::new(FLOW_PROCESS, UNIT_STEP.initial)?;

    let mut run = DelayRun::default();
    let mut actuator = UNIT_STEP.initial / FLOW_PROCESS.gain;
    let mut applied_sent_ms: Option<i64> = None;
    let mut measured: Option<f64> = None;
    let mut last_echo: Option<i64> = None;
    let start = -(WARM_UP_S * 1000.0).round() as i64;
    let end = (DURATION_S * 1000.0).round() as i64;
    let ts_s = TS_MS as f64 / 1000.0;
    for now in (start..=end).step_by(TICK_MS as usize) {
        let now_f = now as f64;
        let t_s = now_f / 1000.0;
        let sampling = now.rem_euclid(TS_MS) == 0;

        // I/O side: of the actions delivered together, the last one is written.
        if let Some(packet) = to_io.receive_latest(now_f) {
            actuator = packet.action;
            applied_sent_ms = Some(packet.sent_ms);
        }
        if sampling {
            to_controller.send(
                Measurement {
                    value: process.output(),
                    applied_sent_ms,
                },
                now_f,
            );
        }

        // Controller, every Ts.
        if sampling {
            if let Some(sample) = to_controller.receive_latest(now_f) {
                measured = Some(sample.value);
                if let Some(sent) = sample.applied_sent_ms.filter(|&s| Some(s) != last_echo) {
                    let round_trip = DelayEstimator::round_trip((now - sent) as f64)?;
                    controller.observe_round_trip(round_trip)?;
                    run.round_trips_ms.push(round_trip.as_f64());
                    last_echo = Some(sent);
                }
            }
            let setpoint = if t_s >= UNIT_STEP.at_s {
                UNIT_STEP.setpoint
            } else {
                UNIT_STEP.initial
            };
            let dead_time = controller.smith().map_or(0, |s| s.dead_time_samples());
            if now == 0 {
                run.dead_time_at_step = dead_time;
            }
            let step = controller.step(PidInput {
                setpoint,
                measurement: measured,
                dt_s: ts_s,
                track: None,
            })?;
            to_io.send(
                ActionPacket {
                    action: step.output,
                    sent_ms: now,
                },
                now_f,
            );
            if t_s >= UNIT_STEP.at_s {
                run.dead_time_samples.push(t_s, dead_time as f64);
            }
        }

        if t_s >= UNIT_STEP.at_s {
            run.output.push(t_s, process.output());
            run.action.push(t_s, actuator);
        }
        process.step(actuator, 0.0, TICK_MS as f64 / 1000.0)?;
    }
    Ok(run)
}

/// Every seed's run of one delay and compensation.
#[derive(Clone, Debug)]
pub struct CaseResults {
    pub scale: Option<f64>,
    pub compensation: Compensation,
    pub runs: Vec<(u64, DelayRun, StepMetrics)>,
}

impl CaseResults {
    pub fn run(
        scale: Option<f64>,
        compensation: Compensation,
        seeds: u64,
    ) -> Result<Self, ControlError> {
        let runs = (1..=seeds)
            .map(|seed| {
                let run = simulate(&DelayCase::new(scale, compensation, seed))?;
                let metrics = run.metrics();
                Ok((seed, run, metrics))
            })
            .collect::<Result<Vec<_>, ControlError>>()?;
        Ok(Self {
            scale,
            compensation,
            runs,
        })
    }

    /// The worst run: unsettled before settled, then largest overshoot, then latest settling.
    pub fn worst(&self) -> &(u64, DelayRun, StepMetrics) {
        self.runs
            .iter()
            .max_by(|a, b| {
                rank(&a.2)
                    .partial_cmp(&rank(&b.2))
                    .unwrap_or(std::cmp::Ordering::Equal)
            })
            .expect("at least one seed")
    }

    /// The best run, by the same order.
    pub fn best(&self) -> &(u64, DelayRun, StepMetrics) {
        self.runs
            .iter()
            .min_by(|a, b| {
                rank(&a.2)
                    .partial_cmp(&rank(&b.2))
                    .unwrap_or(std::cmp::Ordering::Equal)
            })
            .expect("at least one seed")
    }

    pub fn unstable_runs(&self) -> usize {
        self.runs
            .iter()
            .filter(|(_, run, _)| run.unstable())
            .count()
    }

    pub fn unsettled_runs(&self) -> usize {
        self.runs
            .iter()
            .filter(|(_, _, m)| m.settling_time_s.is_none())
            .count()
    }

    /// Median overshoot over the seeds.
    pub fn median_overshoot_pct(&self) -> f64 {
        let mut values: Vec<f64> = self.runs.iter().map(|(_, _, m)| m.overshoot_pct).collect();
        values.sort_by(f64::total_cmp);
        let n = values.len();
        if n % 2 == 1 {
            values[n / 2]
        } else {
            (values[n / 2 - 1] + values[n / 2]) / 2.0
        }
    }

    /// Smallest and largest D_c (samples) in force at the step.
    pub fn dead_time_range(&self) -> (usize, usize) {
        self.runs
            .iter()
            .fold((usize::MAX, 0), |(lo, hi), (_, run, _)| {
                (lo.min(run.dead_time_at_step), hi.max(run.dead_time_at_step))
            })
    }
}

/// Unsettled runs rank after settled ones; then by overshoot, then by settling time.
fn rank(m: &StepMetrics) -> (bool, f64, f64) {
    (
        m.settling_time_s.is_none(),
        m.overshoot_pct,
        m.settling_time_s.unwrap_or(f64::INFINITY),
    )
}

/// Whether run `a` performed better than run `b`, by the order `best` and `worst` use.
pub fn performed_better(a: &StepMetrics, b: &StepMetrics) -> bool {
    rank(a) < rank(b)
}

/// Table 3 reproduced: the zero-delay baseline, then each delay with each compensation.
#[derive(Clone, Debug)]
pub struct Table3 {
    pub zero_delay: CaseResults,
    /// Per entry of `DS2_SCALES`: uncompensated, fixed, adaptive.
    pub rows: Vec<[CaseResults; 3]>,
}

impl Table3 {
    pub fn run(seeds: u64) -> Result<Self, ControlError> {
        let zero_delay = CaseResults::run(None, Compensation::None, 1)?;
        let rows = DS2_SCALES
            .iter()
            .map(|&scale| {
                Ok([
                    CaseResults::run(Some(scale), Compensation::None, seeds)?,
                    CaseResults::run(Some(scale), Compensation::Fixed, seeds)?,
                    CaseResults::run(Some(scale), Compensation::Adaptive, seeds)?,
                ])
            })
            .collect::<Result<Vec<_>, ControlError>>()?;
        Ok(Self { zero_delay, rows })
    }
}
