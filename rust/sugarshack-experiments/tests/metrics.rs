//! The metrics on signals whose answers are known in closed form.

use sugarshack_experiments::metrics::{
    max_difference, oscillates, overshoot_pct, settling_time_s, step_metrics, swing_growth, Step,
    Trace, SETTLING_BAND,
};

const DT: f64 = 0.01;

fn sampled(duration_s: f64, f: impl Fn(f64) -> f64) -> Trace {
    let mut trace = Trace::default();
    for k in 0..=(duration_s / DT).round() as usize {
        let t = k as f64 * DT;
        trace.push(t, f(t));
    }
    trace
}

const UNIT: Step = Step {
    at_s: 0.0,
    initial: 0.0,
    setpoint: 1.0,
};

#[test]
fn first_order_step_settles_at_tau_ln_20_without_overshoot() {
    let tau = 3.0;
    let trace = sampled(60.0, |t| 1.0 - (-t / tau).exp());
    let m = step_metrics(&trace, UNIT, 5.0);
    // The final value is the mean of a tail still rising by e^-15: no overshoot beyond that.
    assert!(m.overshoot_pct < 1e-4, "{}", m.overshoot_pct);
    assert!(m.steady_state_error.abs() < 1e-6);
    // |y - 1| = e^(-t/τ) <= 0.05 from t = τ ln 20 on; one sample of resolution.
    let expected = tau * (1.0 / SETTLING_BAND).ln();
    let t_s = m.settling_time_s.expect("settles");
    assert!((t_s - expected).abs() <= DT + 1e-9, "{t_s} vs {expected}");
    assert!((m.pure_settling_time_s(2.0).unwrap() - (t_s - 2.0)).abs() < 1e-12);
}

#[test]
fn underdamped_second_order_overshoot_matches_its_damping() {
    let (zeta, wn) = (0.3f64, 1.0f64);
    let wd = wn * (1.0 - zeta * zeta).sqrt();
    let phi = (1.0 - zeta * zeta).sqrt().atan2(zeta);
    let y =
        |t: f64| 1.0 - (-zeta * wn * t).exp() / (1.0 - zeta * zeta).sqrt() * (wd * t + phi).sin();
    let trace = sampled(80.0, y);
    let expected = 100.0 * (-zeta * std::f64::consts::PI / (1.0 - zeta * zeta).sqrt()).exp();
    let mp = overshoot_pct(&trace, UNIT, 1.0);
    assert!((mp - expected).abs() < 0.05, "{mp} vs {expected}");
    // The envelope e^(-ζωt)/sqrt(1-ζ²) bounds the settling time from above.
    let envelope_bound = -(SETTLING_BAND * (1.0 - zeta * zeta).sqrt()).ln() / (zeta * wn);
    let t_s = settling_time_s(&trace, UNIT, 1.0, UNIT.band(), 5.0).unwrap();
    assert!(
        t_s <= envelope_bound + DT && t_s > 0.5 * envelope_bound,
        "{t_s} vs {envelope_bound}"
    );
}

#[test]
fn a_step_down_and_an_offset_start_are_measured_on_the_step_size() {
    // From 1.04 down to 0.69, overshooting by 0.035 (10 % of the 0.35 step).
    let step = Step {
        at_s: 5.0,
        initial: 1.04,
        setpoint: 0.69,
    };
    let trace = sampled(60.0, |t| {
        if t < 5.0 {
            1.04
        } else if t < 10.0 {
            0.655
        } else {
            0.69
        }
    });
    let m = step_metrics(&trace, step, 10.0);
    assert!((m.overshoot_pct - 10.0).abs() < 1e-9, "{}", m.overshoot_pct);
    assert!((step.band() - 0.05 * 0.35).abs() < 1e-12);
    assert!(
        (m.settling_time_s.unwrap() - 5.0).abs() < 1e-9,
        "enters the band at 10 s, 5 s after the step"
    );
}

#[test]
fn an_output_still_outside_the_band_at_the_end_has_not_settled() {
    let ramp = sampled(60.0, |t| t / 60.0);
    let m = step_metrics(&ramp, UNIT, 20.0);
    assert_eq!(m.settling_time_s, None);
    let sine = sampled(200.0, |t| 1.0 + 0.3 * (0.5 * t).sin());
    let m = step_metrics(&sine, UNIT, 20.0);
    assert_eq!(m.settling_time_s, None);
    assert!(oscillates(&sine, UNIT, &m));
    assert!(
        !oscillates(&ramp, UNIT, &step_metrics(&ramp, UNIT, 20.0)),
        "a creep is not a swing"
    );
}

#[test]
fn swing_growth_tells_growing_from_dying_oscillations() {
    let growing = sampled(200.0, |t| 1.0 + 0.01 * (0.02 * t).exp() * t.sin());
    let dying = sampled(200.0, |t| 1.0 + (-0.02 * t).exp() * t.sin());
    assert!(swing_growth(&growing, UNIT) > 1.0);
    assert!(swing_growth(&dying, UNIT) < 1.0);
}

#[test]
fn max_difference_compares_at_each_sample_over_the_window() {
    let a = sampled(10.0, |t| t);
    let b = sampled(10.0, |t| if (4.0..6.0).contains(&t) { t + 0.5 } else { t });
    assert!((max_difference(&a, &b, 0.0, 10.0) - 0.5).abs() < 1e-12);
    assert_eq!(
        max_difference(&a, &b, 7.0, 10.0),
        0.0,
        "outside the window the traces agree"
    );
    // Held values: b sampled 10 times more coarsely still compares at a's times.
    let coarse = sampled(10.0, |t| t).points().into_iter().step_by(10).fold(
        Trace::default(),
        |mut tr, (t, v)| {
            tr.push(t, v);
            tr
        },
    );
    assert!(max_difference(&a, &coarse, 0.0, 10.0) < 0.1 + 1e-9);
}
