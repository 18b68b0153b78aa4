use super::*;

fn config() -> PidConfig {
    PidConfig {
        kp: 2.0,
        ti_s: 4.0,
        td_s: 0.5,
        out_min: 0.0,
        out_max: 100.0,
        action: Action::Reverse,
        fallback: None,
        proportional_on: Default::default(),
    }
}

fn auto(setpoint: f64, measurement: f64) -> PidInput {
    PidInput {
        setpoint,
        measurement: Some(measurement),
        dt_s: 1.0,
        track: None,
    }
}

/// A PID with this fallback output, after one step at 40 for a set point of 50.
fn stepped_once_with_fallback(fallback: f64) -> Pid {
    let mut pid = Pid::new(PidConfig {
        fallback: Some(fallback),
        ..config()
    })
    .unwrap();
    pid.step(auto(50.0, 40.0)).unwrap();
    pid
}

#[test]
fn terms_follow_the_standard_form() {
    let mut pid = Pid::new(config()).unwrap();
    let first = pid.step(auto(50.0, 40.0)).unwrap();
    assert_eq!(
        (first.p, first.d),
        (20.0, 0.0),
        "P = Kc·e; no derivative on the first sample"
    );
    assert_eq!(first.i, 5.0, "I = Kc/Ti·e·dt = 2/4·10·1");
    assert_eq!(first.output, 25.0);
    let second = pid.step(auto(50.0, 44.0)).unwrap();
    assert_eq!(second.p, 12.0);
    assert_eq!(second.d, -4.0, "D = -Kc·Td·dpv/dt = -2·0.5·4/1");
    assert_eq!(second.i, 8.0);
    assert_eq!(second.output, 16.0);
    assert_eq!(second.mode, StepMode::Auto);
}

#[test]
fn a_set_point_change_gives_no_derivative_kick() {
    let mut pid = Pid::new(config()).unwrap();
    pid.step(auto(50.0, 40.0)).unwrap();
    let step = pid.step(auto(80.0, 40.0)).unwrap();
    assert_eq!(step.d, 0.0);
}

#[test]
fn direct_action_reverses_every_term() {
    let mut pid = Pid::new(PidConfig {
        action: Action::Direct,
        out_min: -100.0,
        ..config()
    })
    .unwrap();
    pid.step(auto(50.0, 40.0)).unwrap();
    let step = pid.step(auto(50.0, 44.0)).unwrap();
    assert_eq!((step.p, step.d), (-12.0, 4.0));
    assert!(step.i < 0.0);
}

#[test]
fn output_stays_in_limits_and_the_integrator_does_not_wind_up() {
    let mut pid = Pid::new(PidConfig {
        out_max: 30.0,
        ..config()
    })
    .unwrap();
    for _ in 0..100 {
        let step = pid.step(auto(100.0, 0.0)).unwrap();
        assert_eq!(step.output, 30.0);
        assert!(step.saturated);
    }
    assert_eq!(
        pid.integral(),
        0.0,
        "P alone holds the limit: nothing was integrated for 100 s"
    );
    // once the measurement passes the set point the output leaves the limit at once
    let step = pid.step(auto(100.0, 101.0)).unwrap();
    assert!(step.output < 30.0, "{step:?}");
}

#[test]
fn tracking_sets_the_integrator_to_the_action_minus_p_and_d() {
    let mut pid = Pid::new(config()).unwrap();
    pid.step(auto(50.0, 40.0)).unwrap();
    let step = pid
        .step(PidInput {
            track: Some(33.0),
            ..auto(50.0, 42.0)
        })
        .unwrap();
    assert_eq!(step.mode, StepMode::Tracking);
    assert_eq!(step.i, 33.0 - step.p - step.d);
    assert_eq!(step.output, 33.0);
    // the first step in control continues from 33 plus only the P, D and one integration change
    let next = pid.step(auto(50.0, 42.0)).unwrap();
    let expected = 33.0 + (next.p - step.p) + (next.d - step.d) + 2.0 / 4.0 * 8.0;
    assert!((next.output - expected).abs() < 1e-12);
}

#[test]
fn new_tunings_do_not_bump_the_output() {
    let mut pid = Pid::new(PidConfig {
        out_max: 1000.0,
        ..config()
    })
    .unwrap();
    let before = pid.step(auto(50.0, 40.0)).unwrap();
    pid.set_tunings(8.0, 1.0, 0.0).unwrap();
    let after = pid.step(auto(50.0, 40.0)).unwrap();
    assert_eq!(after.output, before.output);
    assert_eq!(after.p, 80.0, "the new gain is in force");
    let later = pid.step(auto(50.0, 40.0)).unwrap();
    assert_eq!(
        later.output - after.output,
        8.0 * 10.0,
        "and so is the new integral time"
    );
}

#[test]
fn a_missing_or_nan_measurement_holds_the_integrator_and_outputs_the_fallback() {
    let mut pid = stepped_once_with_fallback(10.0);
    let integral = pid.integral();
    for measurement in [None, Some(f64::NAN), Some(f64::INFINITY)] {
        let step = pid
            .step(PidInput {
                measurement,
                ..auto(50.0, 0.0)
            })
            .unwrap();
        assert_eq!((step.output, step.mode), (10.0, StepMode::Fallback));
        assert_eq!(pid.integral(), integral);
    }
    // with no fallback configured the last output is held
    let mut holding = Pid::new(config()).unwrap();
    let last = holding.step(auto(50.0, 40.0)).unwrap().output;
    assert_eq!(
        holding
            .step(PidInput {
                measurement: None,
                ..auto(50.0, 0.0)
            })
            .unwrap()
            .output,
        last
    );
    // after a gap the derivative does not differentiate across it
    let resumed = holding.step(auto(50.0, 10.0)).unwrap();
    assert_eq!(resumed.d, 0.0);
}

#[test]
fn refuses_inputs_that_cannot_be_stepped() {
    let mut pid = Pid::new(config()).unwrap();
    for dt_s in [0.0, -1.0, f64::NAN] {
        assert_eq!(
            pid.step(PidInput {
                dt_s,
                ..auto(50.0, 40.0)
            })
            .unwrap_err()
            .code(),
            "INVALID_INPUT"
        );
    }
    assert_eq!(
        pid.step(auto(f64::NAN, 40.0)).unwrap_err().code(),
        "INVALID_INPUT"
    );
    assert_eq!(
        pid.step(PidInput {
            track: Some(f64::NAN),
            ..auto(50.0, 40.0)
        })
        .unwrap_err()
        .code(),
        "INVALID_INPUT"
    );
    assert_eq!(pid.last_output(), None, "a refused step changes nothing");
}

#[test]
fn refuses_configs_that_break_the_loop() {
    let broken = [
        PidConfig {
            out_min: 10.0,
            out_max: 0.0,
            ..config()
        },
        PidConfig {
            out_min: 5.0,
            out_max: 5.0,
            ..config()
        },
        PidConfig {
            kp: -1.0,
            ..config()
        },
        PidConfig {
            ti_s: f64::NAN,
            ..config()
        },
        PidConfig {
            fallback: Some(200.0),
            ..config()
        },
    ];
    for c in broken {
        let err = Pid::new(c.clone()).unwrap_err();
        assert_eq!(err.code(), "INVALID_CONFIG", "{c:?}");
    }
    let mut pid = Pid::new(config()).unwrap();
    assert!(pid.set_limits(100.0, 0.0).is_err());
    assert_eq!(
        pid.config().out_max,
        100.0,
        "a refused change leaves the old limits"
    );
}

#[test]
fn a_restored_integral_resumes_the_output() {
    let mut pid = Pid::new(config()).unwrap();
    pid.set_integral(42.0).unwrap();
    let step = pid.step(auto(50.0, 50.0)).unwrap();
    assert_eq!(step.output, 42.0);
    assert!(pid.set_integral(f64::NAN).is_err());
}

#[test]
fn tracking_without_a_measurement_follows_the_action_and_reseeds_from_it() {
    let mut pid = stepped_once_with_fallback(0.0);
    let blind = pid
        .step(PidInput {
            measurement: None,
            track: Some(70.0),
            ..auto(50.0, 0.0)
        })
        .unwrap();
    assert_eq!(
        (blind.mode, blind.output),
        (StepMode::Tracking, 70.0),
        "not the fallback: someone else drives the actuator"
    );
    // the first good sample in control continues from 70, as after any tracking
    let next = pid.step(auto(50.0, 45.0)).unwrap();
    assert_eq!(next.output, 70.0);
}

// Bug reproductions from the hardening review: each failed before its fix.

fn p_only() -> PidConfig {
    PidConfig {
        kp: 1.0,
        ti_s: 0.0,
        td_s: 0.0,
        out_min: 0.0,
        out_max: 100.0,
        ..config()
    }
}

#[test]
fn without_integral_action_a_saturation_leaves_no_offset() {
    let mut pid = Pid::new(p_only()).unwrap();
    assert_eq!(pid.step(auto(10.0, 5.0)).unwrap().output, 5.0);
    assert_eq!(pid.step(auto(10.0, -200.0)).unwrap().output, 100.0);
    assert_eq!(
        pid.step(auto(10.0, 5.0)).unwrap().output,
        5.0,
        "P only: back to kp·e"
    );
    assert_eq!(
        pid.integral(),
        0.0,
        "nothing integrates, so nothing may move the integrator"
    );
}

#[test]
fn a_p_only_loop_settles_where_the_loop_gain_puts_it_after_saturating() {
    // y' = (2u - y) / 1 s, kp 1, set point 1: y settles at 2/(1 + 2) whatever saturated on the way.
    let mut pid = Pid::new(PidConfig {
        out_max: 1.0,
        ..p_only()
    })
    .unwrap();
    let mut y = -5.0f64;
    for _ in 0..2000 {
        let u = pid
            .step(PidInput {
                dt_s: 0.01,
                ..auto(1.0, y)
            })
            .unwrap()
            .output;
        y += (2.0 * u - y) * 0.01;
    }
    assert!((y - 2.0 / 3.0).abs() < 1e-6, "{y}");
}

#[test]
fn a_measurement_too_large_to_compute_with_is_refused_and_changes_nothing() {
    let mut pid = Pid::new(PidConfig {
        kp: 2.0,
        td_s: 0.0,
        ..config()
    })
    .unwrap();
    pid.step(auto(50.0, 40.0)).unwrap();
    let (integral, last) = (pid.integral(), pid.last_output());
    let err = pid.step(auto(50.0, 1e308)).unwrap_err();
    assert_eq!(err.code(), "INVALID_INPUT");
    assert!(err.to_string().contains("nothing was changed"), "{err}");
    assert_eq!((pid.integral(), pid.last_output()), (integral, last));
    // the fallback and a re-seed after new tunings still work from the finite state
    assert_eq!(
        pid.step(PidInput {
            measurement: None,
            ..auto(50.0, 0.0)
        })
        .unwrap()
        .output,
        last.unwrap()
    );
    pid.set_tunings(1.0, 4.0, 0.0).unwrap();
    assert!(pid.step(auto(50.0, 45.0)).unwrap().output.is_finite());
}

#[test]
fn no_panic_where_derivative_and_error_overflow_together() {
    // kp 100, td 1: 1e308 then 1e307 made the clamp bounds NaN, and f64::clamp panics on those.
    let mut pid = Pid::new(PidConfig {
        kp: 100.0,
        ti_s: 4.0,
        td_s: 1.0,
        ..config()
    })
    .unwrap();
    let _ = pid.step(auto(0.0, 1e308));
    assert_eq!(
        pid.step(auto(0.0, 1e307)).unwrap_err().code(),
        "INVALID_INPUT"
    );
    assert!(
        pid.step(auto(0.0, 1.0)).unwrap().output.is_finite(),
        "the loop keeps working"
    );
}

#[test]
fn tunings_whose_gains_overflow_are_refused() {
    for (kp, ti_s, td_s) in [(1e300, 0.0, 1e300), (5.0, 5e-324, 0.0)] {
        assert_eq!(
            Pid::new(PidConfig {
                kp,
                ti_s,
                td_s,
                ..config()
            })
            .unwrap_err()
            .code(),
            "INVALID_CONFIG",
            "{kp} {ti_s} {td_s}"
        );
        let mut pid = Pid::new(config()).unwrap();
        assert_eq!(
            pid.set_tunings(kp, ti_s, td_s).unwrap_err().code(),
            "INVALID_CONFIG"
        );
        assert_eq!(pid.config().kp, 2.0);
    }
}

#[test]
fn a_tiny_dt_that_makes_the_derivative_infinite_is_refused() {
    let mut pid = Pid::new(config()).unwrap();
    pid.step(auto(50.0, 40.0)).unwrap();
    let before = pid.integral();
    assert_eq!(
        pid.step(PidInput {
            dt_s: 1e-320,
            ..auto(50.0, 41.0)
        })
        .unwrap_err()
        .code(),
        "INVALID_INPUT"
    );
    assert_eq!(pid.integral(), before);
    assert!(pid.step(auto(50.0, 41.0)).unwrap().output.is_finite());
}

#[test]
fn an_integral_set_after_new_tunings_is_the_one_used() {
    let mut pid = Pid::new(config()).unwrap();
    pid.step(auto(50.0, 40.0)).unwrap();
    pid.set_tunings(1.0, 0.0, 0.0).unwrap();
    pid.set_integral(7.0).unwrap();
    let step = pid.step(auto(50.0, 50.0)).unwrap();
    assert_eq!(
        (step.i, step.output),
        (7.0, 7.0),
        "not re-seeded from the last output over it"
    );
}

#[test]
fn a_one_sample_spike_does_not_drag_the_integrator() {
    // Steady at 50 with I = 50; one sample reading 0 kicks P and D to the top limit.
    // The old clamp pulled I to 100 - P - D = 0 against the (positive) error: the
    // output then sat at 0 instead of 50 once the spike had passed.
    let mut pid = Pid::new(PidConfig {
        kp: 1.0,
        ti_s: 10.0,
        td_s: 1.0,
        ..config()
    })
    .unwrap();
    pid.set_integral(50.0).unwrap();
    assert_eq!(pid.step(auto(50.0, 50.0)).unwrap().output, 50.0);
    let spike = pid.step(auto(50.0, 0.0)).unwrap();
    assert!(spike.saturated);
    assert_eq!(
        pid.integral(),
        50.0,
        "integration stopped at the limit, the integrator not moved"
    );
    pid.step(auto(50.0, 50.0)).unwrap(); // D kicks back down this once
    assert_eq!(pid.step(auto(50.0, 50.0)).unwrap().output, 50.0);
}

#[test]
fn proportional_on_measurement_gives_no_kick_on_a_set_point_change() {
    let on_m = PidConfig {
        proportional_on: ProportionalOn::Measurement,
        td_s: 0.0,
        ..config()
    };
    let mut pid = Pid::new(on_m).unwrap();
    let first = pid.step(auto(50.0, 40.0)).unwrap();
    assert_eq!(
        (first.p, first.output),
        (0.0, 5.0),
        "only the integration: 2/4·10·1"
    );
    let raised = pid.step(auto(80.0, 40.0)).unwrap();
    assert_eq!(
        raised.output,
        5.0 + 2.0 / 4.0 * 40.0,
        "the set point acts through I alone"
    );
    // the measurement rising by 4 takes kp·4 off at once
    let next = pid.step(auto(80.0, 44.0)).unwrap();
    assert_eq!(next.output, raised.output - 2.0 * 4.0 + 2.0 / 4.0 * 36.0);
}
