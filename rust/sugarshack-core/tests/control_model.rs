//! The control core against simple reference models: the PID against a
//! textbook sum while nothing saturates, its limits and bumpless transfer for
//! any input sequence, the delay estimator's convergence, and RCC groups whose
//! controllers fail and recover at random against "the lowest live id acts".

use proptest::prelude::*;
use sugarshack_core::control::delay::DelayEstimator;
use sugarshack_core::control::error::positive_duration;
use sugarshack_core::control::pid::{Action, Pid, PidConfig, PidInput, ProportionalOn, StepMode};
use sugarshack_core::control::pid_loop::PidLoopConfig;
use sugarshack_core::control::rcc::{thresholds_from_ms, IoModule, RccConfig, RccController};
use sugarshack_core::control::rcc::{Decision, IoState};
use sugarshack_core::control::smith::{DeadTime, FopdtModel, SmithConfig, SmithPredictor};
use sugarshack_core::control::station::{
    Change, Limits, Mode, Sample, Saved, Stale, Station, StationConfig, Tunings,
};
use sugarshack_core::time::Millis;

/// A test's time in ms, known valid.
fn millis(value: f64) -> Millis {
    Millis::new(value).expect("a valid time")
}

fn pid_config(
    kp: f64,
    ti_s: f64,
    td_s: f64,
    out_min: f64,
    out_max: f64,
    direct: bool,
) -> PidConfig {
    let action = if direct {
        Action::Direct
    } else {
        Action::Reverse
    };
    PidConfig {
        kp,
        ti_s,
        td_s,
        out_min,
        out_max,
        action,
        fallback: None,
        proportional_on: Default::default(),
    }
}

#[derive(Clone, Debug)]
enum Op {
    Step {
        setpoint: f64,
        measurement: Option<f64>,
        dt_s: f64,
        track: Option<f64>,
    },
    Tunings {
        kp: f64,
        ti_s: f64,
        td_s: f64,
    },
    Limits {
        low: f64,
        span: f64,
    },
    Integral(f64),
}

fn op() -> impl Strategy<Value = Op> {
    let measurement = prop_oneof![
        8 => (-1e3..1e3f64).prop_map(Some),
        1 => Just(None),
        1 => Just(Some(f64::NAN)),
    ];
    prop_oneof![
        8 => (-1e3..1e3f64, measurement, 0.001..10.0f64, prop::option::weighted(0.2, -1e3..1e3f64))
            .prop_map(|(setpoint, measurement, dt_s, track)| Op::Step { setpoint, measurement, dt_s, track }),
        1 => (0.0..20.0f64, 0.0..50.0f64, 0.0..5.0f64).prop_map(|(kp, ti_s, td_s)| Op::Tunings { kp, ti_s, td_s }),
        1 => (-500.0..500.0f64, 1.0..1e3f64).prop_map(|(low, span)| Op::Limits { low, span }),
        1 => (-1e4..1e4f64).prop_map(Op::Integral),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// Whatever arrives, the output is a number within the limits in force.
    #[test]
    fn output_is_always_finite_and_within_limits(
        (kp, ti_s, td_s) in (0.0..20.0f64, 0.0..50.0f64, 0.0..5.0f64),
        direct in any::<bool>(),
        ops in prop::collection::vec(op(), 1..60),
    ) {
        let mut pid = Pid::new(pid_config(kp, ti_s, td_s, -100.0, 100.0, direct)).unwrap();
        for op in ops {
            match op {
                Op::Step { setpoint, measurement, dt_s, track } => {
                    let step = pid.step(PidInput { setpoint, measurement, dt_s, track }).unwrap();
                    let c = pid.config();
                    prop_assert!(step.output.is_finite());
                    prop_assert!(step.output >= c.out_min && step.output <= c.out_max, "{step:?} {c:?}");
                    prop_assert!([step.p, step.i, step.d].iter().all(|t| t.is_finite()));
                }
                Op::Tunings { kp, ti_s, td_s } => pid.set_tunings(kp, ti_s, td_s).unwrap(),
                Op::Limits { low, span } => pid.set_limits(low, low + span).unwrap(),
                Op::Integral(i) => pid.set_integral(i).unwrap(),
            }
        }
    }

    /// Away from the limits, the output is the textbook sum of the three terms.
    #[test]
    fn matches_the_textbook_pid_while_unsaturated(
        (kp, ti_s, td_s) in (0.1..5.0f64, 0.5..20.0f64, 0.0..2.0f64),
        direct in any::<bool>(),
        samples in prop::collection::vec((-10.0..10.0f64, -10.0..10.0f64, 0.01..2.0f64), 1..40),
    ) {
        let mut pid = Pid::new(pid_config(kp, ti_s, td_s, -1e12, 1e12, direct)).unwrap();
        let sign = if direct { -1.0 } else { 1.0 };
        let (mut integral, mut previous) = (0.0f64, None::<f64>);
        for (setpoint, measurement, dt_s) in samples {
            let step = pid.step(PidInput { setpoint, measurement: Some(measurement), dt_s, track: None }).unwrap();
            let error = sign * (setpoint - measurement);
            integral += kp / ti_s * error * dt_s;
            let derivative = previous.map_or(0.0, |p| -sign * kp * td_s * (measurement - p) / dt_s);
            previous = Some(measurement);
            let expected = kp * error + integral + derivative;
            prop_assert!((step.output - expected).abs() <= 1e-9 * (1.0 + expected.abs()), "{} vs {expected}", step.output);
        }
    }

    /// The paper's §5.3: after tracking action a, the first output in control
    /// differs from a only by the change of P and D plus one integration.
    #[test]
    fn bumpless_transfer_moves_the_first_output_by_no_more_than_the_p_and_d_change(
        (kp, ti_s, td_s) in (0.1..10.0f64, 0.5..20.0f64, 0.0..2.0f64),
        history in prop::collection::vec((-50.0..50.0f64, 0.05..1.0f64), 0..10),
        action in -80.0..80.0f64,
        (setpoint, m0, m1, dt_s) in (-50.0..50.0f64, -50.0..50.0f64, -50.0..50.0f64, 0.05..1.0f64),
    ) {
        let mut pid = Pid::new(pid_config(kp, ti_s, td_s, -100.0, 100.0, false)).unwrap();
        for (measurement, dt_s) in history {
            pid.step(PidInput { setpoint, measurement: Some(measurement), dt_s, track: None }).unwrap();
        }
        let tracked = pid.step(PidInput { setpoint, measurement: Some(m0), dt_s, track: Some(action) }).unwrap();
        prop_assert_eq!(tracked.mode, StepMode::Tracking);
        prop_assert_eq!(tracked.output, action);
        let first = pid.step(PidInput { setpoint, measurement: Some(m1), dt_s, track: None }).unwrap();
        let bound = ((first.p - tracked.p) + (first.d - tracked.d)).abs() + (kp / ti_s * (setpoint - m1) * dt_s).abs();
        prop_assert!((first.output - action).abs() <= bound + 1e-9, "{} from {action}, bound {bound}", first.output);
    }

    /// From any earlier estimate, a constant round trip pulls the mean in
    /// geometrically and the dead time settles on floor(d / Ts). The variance
    /// decays as (1 - alpha)^n too: 2,000 samples bring even alpha = 0.05 from a
    /// 5 s gap to well under a microsecond.
    #[test]
    fn the_estimator_converges_on_a_constant_delay(
        alpha in 0.05..1.0f64,
        h in 0.0..4.0f64,
        before in prop::collection::vec(0.0..5000.0f64, 1..20),
        delay in 0.0..5000.0f64,
        ts_ms in 50.0..1000.0f64,
    ) {
        let mut e = DelayEstimator::new(alpha, h).unwrap();
        for d in &before {
            e.observe(millis(*d)).unwrap();
        }
        let gap = (e.mean().unwrap().as_f64() - delay).abs();
        for n in 1..=2000 {
            e.observe(millis(delay)).unwrap();
            let bound = (1.0 - alpha).powi(n) * gap + 1e-6;
            prop_assert!((e.mean().unwrap().as_f64() - delay).abs() <= bound);
        }
        prop_assert!(e.std().unwrap().as_f64() < 1e-3 * (1.0 + delay));
        let settled = e.dead_time_samples(millis(ts_ms)).unwrap() as f64;
        let exact = delay / ts_ms;
        prop_assert!(settled == exact.floor() || (settled - exact).abs() < 1e-3, "{settled} vs {exact}");
    }
}

/// A controller's fail-stop outages: (down at, up at) in ms.
type Outages = Vec<(u64, u64)>;

const TS_MS: u64 = 200;
const THRESHOLDS: [f64; 3] = [200.0, 500.0, 800.0];
const JITTER_MS: u64 = 40;
const KP: f64 = 0.8;
const TI_S: f64 = 1.5;

fn outages() -> impl Strategy<Value = Outages> {
    prop::collection::vec((1_000u64..40_000, 300u64..8_000), 0..3).prop_map(|mut spans| {
        spans.sort();
        let mut out: Outages = Vec::new();
        for (start, length) in spans {
            let start = out.last().map_or(start, |&(_, up)| start.max(up + 1_000));
            out.push((start, start + length));
        }
        out
    })
}

fn alive(outages: &Outages, t: u64) -> bool {
    !outages.iter().any(|&(down, up)| t >= down && t < up)
}

/// Time since `id`'s liveness last changed, or since the start.
fn stable_for(outages: &Outages, t: u64) -> u64 {
    outages
        .iter()
        .flat_map(|&(d, u)| [d, u])
        .filter(|&e| e <= t)
        .map(|e| t - e)
        .min()
        .unwrap_or(t)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// Three controllers with their own phases and jitter fail and recover at
    /// random over 50 s of a first-order plant. Against the reference "the
    /// lowest live id acts": once liveness has been still for D_3 + 2·Ts only
    /// that controller writes; while anyone lives the actuator is never left
    /// longer than D_3 + 2·Ts; and each change of writer is bumpless.
    #[test]
    fn rcc_group_keeps_one_writer_and_hands_over_without_a_bump(
        schedule in (outages(), outages(), outages()),
        phases in (0..TS_MS, 0..TS_MS, 0..TS_MS),
        seed in any::<u64>(),
    ) {
        let schedule = [schedule.0, schedule.1, schedule.2];
        let phases = [phases.0, phases.1, phases.2];
        let mut rng = seed | 1;
        let mut jitter = move || { rng ^= rng << 13; rng ^= rng >> 7; rng ^= rng << 17; rng % JITTER_MS };
        let mut io = IoModule::new(3, 0.0).unwrap();
        let mut controllers: Vec<_> = (1..=3)
            .map(|id| RccController::new(RccConfig { id, thresholds: THRESHOLDS.iter().map(|&t| millis(t)).collect(), ts: millis(TS_MS as f64), smooth_handover: true, poll_timeout: None }).unwrap())
            .collect();
        let mut pids: Vec<_> = (0..3).map(|_| Pid::new(pid_config(KP, TI_S, 0.0, 0.0, 2.0, false)).unwrap()).collect();
        let mut next_poll: Vec<u64> = phases.to_vec();
        let mut last_poll: Vec<Option<(u64, f64)>> = vec![None; 3];
        let mut was_alive = [true; 3];
        let (mut y, mut last_writer, mut last_write_at) = (0.0f64, None::<usize>, 0u64);
        let decay = (-0.01f64 / 2.0).exp();
        let horizon = 50_000u64;
        let quiet = THRESHOLDS[2] as u64 + 2 * TS_MS + JITTER_MS;
        for t in (0..horizon).step_by(10) {
            y = decay * y + (1.0 - decay) * io.last_action();
            for index in 0..3 {
                let live = alive(&schedule[index], t);
                if live && !was_alive[index] {
                    controllers[index].poll_timed_out();
                }
                was_alive[index] = live;
                if !live || t < next_poll[index] {
                    continue;
                }
                next_poll[index] = t + TS_MS + jitter();
                let dt_s = last_poll[index].map_or(TS_MS as f64 / 1000.0, |(at, _)| (t - at) as f64 / 1000.0);
                let state = io.state(millis(t as f64));
                let scan = controllers[index].scan(&mut pids[index], &state, 1.0, Some(y), dt_s).unwrap();
                if let Some(action) = scan.write {
                    let expected_writer = (0..3).find(|&i| alive(&schedule[i], t)).unwrap();
                    let settled = (0..3).all(|i| stable_for(&schedule[i], t) >= quiet);
                    prop_assert!(!settled || index == expected_writer, "t={t}: C{} wrote while C{} lives", index + 1, expected_writer + 1);
                    let new_writer = last_writer != Some(index);
                    let previous_gone = last_writer.is_none_or(|w| !alive(&schedule[w], t));
                    if new_writer && previous_gone && !scan.first_cycle {
                        if let Some((_, y_before)) = last_poll[index] {
                            let bound = KP * (y - y_before).abs() + KP / TI_S * (1.0 - y).abs() * dt_s + 1e-9;
                            prop_assert!((action - state.last_action).abs() <= bound,
                                "t={t}: C{} took over with {action} after {}", index + 1, state.last_action);
                        }
                    }
                    io.write(index + 1, action, millis(t as f64)).unwrap();
                    (last_writer, last_write_at) = (Some(index), t);
                }
                last_poll[index] = Some((t, y));
            }
            let anyone_alive_long = (0..3).any(|i| alive(&schedule[i], t) && stable_for(&schedule[i], t) >= quiet);
            if anyone_alive_long && t > quiet {
                prop_assert!(t - last_write_at <= quiet, "t={t}: nobody wrote for {} ms", t - last_write_at);
            }
        }
    }
}

/// Any f64 at all, the edges often: subnormals, ±MAX, NaN, ±∞, ±0.
fn any_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => any::<f64>(),
        4 => prop::sample::select(vec![
            0.0, -0.0, 5e-324, -5e-324, 1e-320, f64::MIN_POSITIVE, f64::MAX, f64::MIN, 1e308, -1e308, 1e307,
            f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1.0, -1.0, 100.0,
        ]),
        2 => -1e3..1e3f64,
    ]
}

fn maybe_f64() -> impl Strategy<Value = Option<f64>> {
    prop::option::weighted(0.8, any_f64())
}

#[derive(Clone, Debug)]
enum AnyOp {
    Measure {
        measurement: Option<f64>,
        sample_ms: f64,
        now_ms: f64,
        track: Option<f64>,
        rcc: Option<(bool, bool, Option<f64>)>,
    },
    Tick(f64),
    Change {
        setpoint: Option<f64>,
        manual: Option<Option<f64>>,
        kp: Option<f64>,
        ti_s: Option<f64>,
        td_s: Option<f64>,
        min: Option<f64>,
        max: Option<f64>,
    },
    Restore {
        integral: Option<f64>,
        setpoint: Option<f64>,
        manual: Option<f64>,
    },
    RoundTrip(f64),
}

fn any_op() -> impl Strategy<Value = AnyOp> {
    prop_oneof![
        6 => (maybe_f64(), any_f64(), any_f64(), maybe_f64(), prop::option::weighted(0.3, (any::<bool>(), any::<bool>(), maybe_f64())))
            .prop_map(|(measurement, sample_ms, now_ms, track, rcc)| AnyOp::Measure { measurement, sample_ms, now_ms, track, rcc }),
        2 => any_f64().prop_map(AnyOp::Tick),
        2 => (maybe_f64(), prop::option::weighted(0.3, maybe_f64()), maybe_f64(), maybe_f64(), maybe_f64(), maybe_f64(), maybe_f64())
            .prop_map(|(setpoint, manual, kp, ti_s, td_s, min, max)| AnyOp::Change { setpoint, manual, kp, ti_s, td_s, min, max }),
        1 => (maybe_f64(), maybe_f64(), maybe_f64()).prop_map(|(integral, setpoint, manual)| AnyOp::Restore { integral, setpoint, manual }),
        1 => any_f64().prop_map(AnyOp::RoundTrip),
    ]
}

fn station_config(values: [f64; 10], smith: Option<u8>, on_measurement: bool) -> StationConfig {
    let [kp, ti_s, td_s, out_min, out_max, fallback, ts_s, gain, tau_s, setpoint] = values;
    let dead_time = match smith {
        Some(0) => Some(DeadTime::Fixed { samples: 3 }),
        Some(_) => Some(DeadTime::Adaptive { alpha: 0.5, h: 3.0 }),
        None => None,
    };
    StationConfig {
        pid_loop: PidLoopConfig {
            pid: PidConfig {
                kp,
                ti_s,
                td_s,
                out_min,
                out_max,
                action: Action::Reverse,
                fallback: fallback.is_finite().then_some(fallback),
                proportional_on: if on_measurement {
                    ProportionalOn::Measurement
                } else {
                    ProportionalOn::Error
                },
            },
            smith: dead_time.map(|dead_time| SmithConfig {
                model: FopdtModel { gain, tau_s },
                ts_s,
                dead_time,
                max_samples: 20,
            }),
        },
        ts_s,
        stale: Some(millis(50.0)),
        setpoint,
        mode: Mode::Auto,
        manual: None,
    }
}

/// The loop's state is only ever numbers the loop can use.
fn assert_sound(station: &Station) -> Result<(), TestCaseError> {
    let state = station.state();
    let config = station.pid_loop().pid().config();
    prop_assert!(state.integral.is_finite() && state.setpoint.is_finite());
    prop_assert!(state.manual.is_none_or(f64::is_finite));
    if let Some(output) = state.last_output {
        prop_assert!(
            output.is_finite() && output >= config.out_min && output <= config.out_max,
            "{output} {config:?}"
        );
    }
    if let Some(smith) = station.pid_loop().smith() {
        prop_assert!(smith.model_output().is_finite());
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1024))]

    /// Over the whole f64 range, every public call of the loop either works or
    /// returns a coded error: none panics (in wasm, a trap), and no state becomes
    /// a number the loop cannot use. Every output is within the limits.
    #[test]
    fn no_input_panics_the_loop_or_corrupts_its_state(
        values in prop::array::uniform10(prop_oneof![3 => any_f64(), 7 => 0.01..50.0f64]),
        smith in prop::option::of(0u8..2),
        on_measurement in any::<bool>(),
        ops in prop::collection::vec(any_op(), 1..40),
    ) {
        let Ok(mut station) = Station::new(station_config(values, smith, on_measurement)) else { return Ok(()) };
        for op in ops {
            match op {
                AnyOp::Measure { measurement, sample_ms, now_ms, track, rcc } => {
                    let decision = rcc.map(|(engaged, first_cycle, track)| Decision { engaged, first_cycle, track });
                    // Times that are not times are refused before they reach the station.
                    let (Some(sampled), Some(now)) = (Millis::new(sample_ms), Millis::new(now_ms)) else { continue };
                    if let Ok(outcome) = station.measure(Sample { measurement, sampled, now, track, decision }) {
                        let c = station.pid_loop().pid().config();
                        prop_assert!(outcome.pid.output >= c.out_min && outcome.pid.output <= c.out_max);
                        prop_assert!([outcome.pid.p, outcome.pid.i, outcome.pid.d, outcome.pid.dt_s].iter().all(|v| v.is_finite()));
                    }
                }
                AnyOp::Tick(now) => {
                    let Some(now) = Millis::new(now) else { continue };
                    if let Ok(Some(Stale::Fallback { pid })) = station.tick(now) {
                        prop_assert!(pid.output.is_finite());
                    }
                    // a tick at the due time never leaves one due at once again
                    if let Some(due) = station.next_tick() {
                        prop_assert!(due > now || station.tick(now).is_ok());
                    }
                }
                AnyOp::Change { setpoint, manual, kp, ti_s, td_s, min, max } => {
                    let tunings = (kp.is_some() || ti_s.is_some() || td_s.is_some()).then_some(Tunings { kp, ti_s, td_s });
                    let limits = (min.is_some() || max.is_some()).then_some(Limits { min, max });
                    let mode = manual.map(|_| Mode::Manual);
                    let _ = station.change(Change { setpoint, mode, manual: manual.flatten(), tunings, limits });
                }
                AnyOp::Restore { integral, setpoint, manual } => {
                    let _ = station.restore(Saved { integral, setpoint, mode: None, manual });
                }
                AnyOp::RoundTrip(ms) => {
                    if let Ok(round_trip) = DelayEstimator::round_trip(ms) {
                        let _ = station.observe_round_trip(round_trip);
                    }
                }
            }
            assert_sound(&station)?;
        }
    }

    /// The PID, the Smith predictor and the estimator on their own, every call with any f64.
    #[test]
    fn no_input_panics_the_pid_predictor_or_estimator(
        values in prop::array::uniform8(any_f64()),
        calls in prop::collection::vec((0u8..8, prop::array::uniform4(any_f64())), 1..40),
    ) {
        let [kp, ti_s, td_s, out_min, out_max, gain, tau_s, ts_s] = values;
        let mut pid = Pid::new(pid_config(kp, ti_s, td_s, out_min, out_max, false))
            .unwrap_or_else(|_| Pid::new(pid_config(1.0, 1.0, 1.0, -10.0, 10.0, false)).unwrap());
        let smith = SmithPredictor::new(SmithConfig { model: FopdtModel { gain, tau_s }, ts_s, dead_time: DeadTime::Adaptive { alpha: 0.5, h: 3.0 }, max_samples: 8 });
        let mut smith = smith.unwrap_or_else(|_| SmithPredictor::new(SmithConfig {
            model: FopdtModel { gain: 1.0, tau_s: 1.0 }, ts_s: 0.1, dead_time: DeadTime::Adaptive { alpha: 0.5, h: 3.0 }, max_samples: 8,
        }).unwrap());
        let mut estimator = DelayEstimator::new(0.3, 3.0).unwrap();
        for (call, [a, b, c, d]) in calls {
            match call {
                0 => { let _ = pid.step(PidInput { setpoint: a, measurement: Some(b), dt_s: c, track: d.is_sign_negative().then_some(d) }); }
                1 => { let _ = pid.set_tunings(a, b, c); }
                2 => { let _ = pid.set_limits(a, b); }
                3 => { let _ = pid.set_integral(a); }
                4 => { let _ = smith.advance(a, b); let _ = smith.feedback(c); }
                5 => {
                    if let Some(round_trip) = Millis::new(a) { let _ = smith.observe_round_trip(round_trip); }
                    let _ = smith.dead_time_samples();
                }
                6 => {
                    if let Some(round_trip) = Millis::new(a) { let _ = estimator.observe(round_trip); }
                    if let Some(ts) = Millis::new(b) { let _ = estimator.dead_time_samples(ts); }
                }
                _ => { let _ = DelayEstimator::new(a, b); pid.restart(); }
            }
            let c = pid.config();
            prop_assert!(pid.integral().is_finite());
            prop_assert!(pid.last_output().is_none_or(|o| o.is_finite() && o >= c.out_min && o <= c.out_max));
            prop_assert!(smith.model_output().is_finite());
            prop_assert!(estimator.mean().is_some() == estimator.std().is_some());
        }
    }

    /// RCC and the I/O module with any f64 for every number they take.
    #[test]
    fn no_input_panics_rcc_or_the_io_module(
        thresholds in prop::collection::vec(any_f64(), 0..4),
        (ts_ms, timeout) in (any_f64(), maybe_f64()),
        id in 0usize..5,
        calls in prop::collection::vec((0u8..4, any_f64(), prop::collection::vec(prop::option::of(any_f64()), 0..4)), 1..30),
    ) {
        // Numbers become Millis where the facade turns them into a config.
        let rcc = thresholds_from_ms(&thresholds, ts_ms).and_then(|(thresholds, ts)| {
            let poll_timeout = timeout.map(|t| positive_duration(t, "poll timeout")).transpose()?;
            RccController::new(RccConfig { id, thresholds, ts, smooth_handover: true, poll_timeout })
        });
        let mut io = IoModule::new(3, 0.0).unwrap();
        let mut pid = Pid::new(pid_config(1.0, 2.0, 0.5, 0.0, 10.0, false)).unwrap();
        if let Ok(mut rcc) = rcc {
            for (call, x, ages) in calls {
                let state = IoState { last_action: x, ages: ages.into_iter().map(|a| a.and_then(Millis::new)).collect() };
                // A time that is not one is refused before it reaches RCC.
                let now = Millis::new(x);
                match (call, now) {
                    (0, Some(now)) => { let _ = rcc.decide_at(&state, now); }
                    (1, Some(now)) => { let _ = rcc.tick(now); let _ = rcc.watch_from(now); }
                    (2, _) => { let _ = rcc.scan(&mut pid, &state, x, Some(x), x); }
                    (_, Some(now)) => { let _ = io.write(id, x, now); let _ = io.state(now); }
                    (_, None) => prop_assert!(sugarshack_core::control::error::time(x, "time (ms)").is_err()),
                }
                prop_assert!(io.last_action().is_finite());
                prop_assert!(pid.integral().is_finite());
            }
        }
    }
}
