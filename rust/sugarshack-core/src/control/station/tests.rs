use super::*;
use crate::control::pid::{Action, PidConfig};
use crate::time::millis;

fn config() -> StationConfig {
    StationConfig {
        pid_loop: PidLoopConfig {
            pid: PidConfig {
                kp: 2.0,
                ti_s: 10.0,
                td_s: 1.0,
                out_min: 0.0,
                out_max: 100.0,
                action: Action::Reverse,
                fallback: Some(7.0),
                proportional_on: Default::default(),
            },
            smith: None,
        },
        ts_s: 1.0,
        stale: Some(millis(80.0)),
        setpoint: 50.0,
        mode: Mode::Auto,
        manual: None,
    }
}

fn sample(measurement: f64, sample_ms: f64) -> Sample {
    Sample {
        measurement: Some(measurement),
        sampled: millis(sample_ms),
        now: millis(sample_ms),
        track: None,
        decision: None,
    }
}

/// A sample that carries the RCC's decision for this scan.
fn decided(
    engaged: bool,
    first_cycle: bool,
    track: Option<f64>,
    measurement: f64,
    sample_ms: f64,
) -> Sample {
    Sample {
        decision: Some(Decision {
            engaged,
            first_cycle,
            track,
        }),
        ..sample(measurement, sample_ms)
    }
}

#[test]
fn dt_runs_between_sample_times_and_the_first_sample_integrates_over_ts() {
    let mut s = Station::new(config()).unwrap();
    let a = s.measure(sample(40.0, 1000.0)).unwrap().pid;
    assert_eq!(
        (a.dt_s, a.p, a.i, a.d, a.output),
        (1.0, 20.0, 2.0, 0.0, 22.0)
    );
    let b = s.measure(sample(45.0, 1500.0)).unwrap().pid;
    assert_eq!(b.dt_s, 0.5);
    assert_eq!(b.d, -2.0 * 1.0 * 5.0 / 0.5);
    let err = s.measure(sample(46.0, 1500.0)).unwrap_err();
    assert!(err.to_string().contains("same timestamp"), "{err}");
    assert_eq!(
        s.measure(sample(46.0, 2500.0)).unwrap().pid.dt_s,
        1.0,
        "the refused sample moved no clock"
    );
}

#[test]
fn manual_tracks_its_output_and_back_to_auto_is_bumpless() {
    let mut s = Station::new(config()).unwrap();
    s.measure(sample(40.0, 1000.0)).unwrap();
    s.change(Change {
        mode: Some(Mode::Manual),
        manual: Some(30.0),
        ..Change::default()
    })
    .unwrap();
    let held = s.measure(sample(43.0, 2000.0)).unwrap().pid;
    assert_eq!((held.output, held.mode), (30.0, ReportMode::Manual));
    s.change(Change {
        mode: Some(Mode::Auto),
        ..Change::default()
    })
    .unwrap();
    let first = s.measure(sample(45.0, 3000.0)).unwrap().pid;
    let expected = 30.0 + (first.p - held.p) + (first.d - held.d) + 2.0 / 10.0 * 5.0;
    assert!((first.output - expected).abs() < 1e-12, "{first:?}");
    // into manual without a value holds the last output
    s.change(Change {
        mode: Some(Mode::Manual),
        ..Change::default()
    })
    .unwrap();
    assert_eq!(s.state().manual, Some(first.output));
}

#[test]
fn manual_without_any_output_to_hold_is_refused() {
    let mut s = Station::new(config()).unwrap();
    let err = s
        .change(Change {
            mode: Some(Mode::Manual),
            ..Change::default()
        })
        .unwrap_err();
    assert_eq!(err.code(), "INVALID_INPUT");
    assert_eq!(s.state().mode, Mode::Auto);
    let err = Station::new(StationConfig {
        mode: Mode::Manual,
        ..config()
    })
    .unwrap_err();
    assert_eq!(err.code(), "INVALID_CONFIG");
}

#[test]
fn a_change_applies_whole_or_not_at_all() {
    // New tunings with limits the fallback falls outside: the tunings must not stay either
    // (the node used to roll them back by hand).
    let mut s = Station::new(config()).unwrap();
    s.measure(sample(40.0, 1000.0)).unwrap();
    let change = Change {
        setpoint: Some(60.0),
        tunings: Some(Tunings {
            kp: Some(5.0),
            ..Tunings::default()
        }),
        limits: Some(Limits {
            min: Some(10.0),
            max: Some(60.0),
        }),
        ..Change::default()
    };
    assert_eq!(s.change(change).unwrap_err().code(), "INVALID_CONFIG");
    assert_eq!(s.pid_loop().pid().config().kp, 2.0);
    assert_eq!(s.pid_loop().pid().config().out_min, 0.0);
    assert_eq!(s.state().setpoint, 50.0);
    let empty = Change {
        tunings: Some(Tunings::default()),
        ..Change::default()
    };
    assert_eq!(
        s.change(empty).unwrap_err().code(),
        "INVALID_INPUT",
        "a misspelt key is not 'no change'"
    );
    let nan = Change {
        setpoint: Some(f64::NAN),
        ..Change::default()
    };
    assert_eq!(s.change(nan).unwrap_err().code(), "INVALID_INPUT");
    s.change(Change {
        limits: Some(Limits {
            max: Some(60.0),
            ..Limits::default()
        }),
        ..Change::default()
    })
    .unwrap();
    assert_eq!(s.pid_loop().pid().config().out_max, 60.0);
}

#[test]
fn a_null_in_a_change_is_refused_not_taken_for_absent() {
    let parsed: Result<Change, _> = serde_json::from_str(r#"{ "setpoint": null }"#);
    assert!(parsed.is_err());
    let parsed: Change = serde_json::from_str(r#"{ "tunings": { "kp": 3 } }"#).unwrap();
    assert_eq!(parsed.tunings.unwrap().kp, Some(3.0));
}

#[test]
fn stale_sends_the_fallback_every_stale_ms_from_the_last_good_measurement() {
    let mut s = Station::new(config()).unwrap();
    assert_eq!(
        s.next_tick(),
        None,
        "the watch starts with the first measurement"
    );
    s.measure(sample(40.0, 1000.0)).unwrap();
    assert_eq!(s.next_tick(), Some(millis(1080.0)));
    assert_eq!(s.tick(millis(1079.0)).unwrap(), None);
    let Some(Stale::Fallback { pid }) = s.tick(millis(1080.0)).unwrap() else {
        panic!("stale at 1080")
    };
    assert_eq!(
        (pid.output, pid.mode, pid.dt_s, pid.measurement),
        (7.0, ReportMode::Fallback, 0.08, None)
    );
    assert_eq!(s.next_tick(), Some(millis(1160.0)));
    // a bad measurement does not restart the watch
    s.measure(Sample {
        measurement: None,
        ..sample(0.0, 1100.0)
    })
    .unwrap();
    assert_eq!(s.next_tick(), Some(millis(1160.0)));
    assert!(matches!(
        s.tick(millis(1160.0)).unwrap(),
        Some(Stale::Fallback { .. })
    ));
    let back = s.measure(sample(41.0, 1200.0)).unwrap().pid;
    assert_eq!(
        (back.mode, back.dt_s),
        (ReportMode::Auto, 1.0),
        "the first sample after going stale integrates over Ts"
    );
    assert_eq!(
        Station::new(StationConfig {
            stale: Some(Millis::ZERO),
            ..config()
        })
        .unwrap()
        .next_tick(),
        None
    );
}

#[test]
fn stale_behind_rcc_steps_nothing_and_says_so_once() {
    let mut s = Station::new(config()).unwrap();
    let first = s
        .measure(decided(true, true, Some(10.0), 40.0, 1000.0))
        .unwrap();
    assert_eq!((first.engaged, first.pid.output), (true, 10.0));
    let out = s
        .measure(decided(false, false, Some(12.0), 40.0, 1050.0))
        .unwrap();
    assert!(!out.engaged);
    assert_eq!(s.tick(millis(1130.0)).unwrap(), Some(Stale::NoIo));
    assert_eq!(s.next_tick(), None);
    assert_eq!(s.state().last_output, Some(12.0), "nothing stepped");
}

#[test]
fn manual_overrides_what_an_rcc_decision_tracks() {
    let mut s = Station::new(StationConfig {
        mode: Mode::Manual,
        manual: Some(33.0),
        ..config()
    })
    .unwrap();
    let out = s
        .measure(decided(true, false, Some(10.0), 40.0, 1000.0))
        .unwrap();
    assert_eq!((out.pid.output, out.pid.mode), (33.0, ReportMode::Manual));
}

#[test]
fn a_restart_restores_what_was_saved_or_refuses_it_whole() {
    let mut s = Station::new(config()).unwrap();
    s.restore(Saved {
        integral: Some(12.0),
        setpoint: Some(55.0),
        mode: Some(Mode::Manual),
        manual: Some(33.0),
    })
    .unwrap();
    assert_eq!(
        s.state(),
        StationState {
            setpoint: 55.0,
            mode: Mode::Manual,
            manual: Some(33.0),
            last_output: None,
            integral: 12.0
        }
    );
    let mut s = Station::new(config()).unwrap();
    s.restore(Saved {
        mode: Some(Mode::Manual),
        ..Saved::default()
    })
    .unwrap();
    assert_eq!(
        s.state().mode,
        Mode::Auto,
        "manual saved without its output resumes in auto"
    );
    let bad = Saved {
        integral: Some(1.0),
        setpoint: Some(f64::INFINITY),
        ..Saved::default()
    };
    assert!(s.restore(bad).is_err());
    assert_eq!((s.state().integral, s.state().setpoint), (0.0, 50.0));
}

#[test]
fn stale_after_left_out_is_three_sample_periods() {
    let mut written = serde_json::to_value(config()).unwrap();
    written["tsS"] = serde_json::json!(0.1);
    for absent in [None, Some(serde_json::Value::Null)] {
        match &absent {
            None => written.as_object_mut().unwrap().remove("staleMs"),
            Some(null) => written
                .as_object_mut()
                .unwrap()
                .insert("staleMs".into(), null.clone()),
        };
        let read: StationConfig = serde_json::from_value(written.clone()).unwrap();
        assert_eq!(read.stale, None, "{absent:?} is not set");
        // 3 × 0.1 s as the node computed it before the rule moved here: 300.00000000000006 ms
        assert_eq!(read.stale_after().unwrap(), millis(3.0 * 0.1 * 1000.0));
        let mut s = Station::new(read).unwrap();
        s.measure(sample(40.0, 1000.0)).unwrap();
        assert_eq!(
            s.next_tick(),
            Some(millis(1000.0 + DEFAULT_STALE_SAMPLES * 0.1 * 1000.0))
        );
    }
    assert_eq!(DEFAULT_STALE_SAMPLES, 3.0);
}

#[test]
fn a_stale_time_that_is_set_wins_and_zero_turns_the_watch_off() {
    let set = StationConfig {
        stale: Some(millis(80.0)),
        ..config()
    };
    assert_eq!(set.stale_after().unwrap(), millis(80.0));
    let mut off = Station::new(StationConfig {
        stale: Some(Millis::ZERO),
        ..config()
    })
    .unwrap();
    off.measure(sample(40.0, 1000.0)).unwrap();
    assert_eq!(off.next_tick(), None);
}

#[test]
fn a_ts_too_long_for_the_default_stale_time_is_refused() {
    let refused = Station::new(StationConfig {
        ts_s: f64::MAX / 2.0,
        stale: None,
        ..config()
    })
    .unwrap_err();
    assert_eq!(refused.code(), "INVALID_CONFIG");
    assert!(refused.to_string().contains("set stale after"), "{refused}");
}

#[test]
fn the_defaults_shown_are_the_ones_applied() {
    assert_eq!(
        PID_DEFAULTS,
        PidDefaults {
            alpha: smith::DEFAULT_ALPHA,
            h: smith::DEFAULT_H,
            max_samples: smith::DEFAULT_MAX_SAMPLES,
            stale_samples: DEFAULT_STALE_SAMPLES,
        }
    );
    let shown = serde_json::to_value(PID_DEFAULTS).unwrap();
    assert_eq!(
        shown,
        serde_json::json!({ "alpha": 0.1, "h": 3.0, "maxSamples": 400, "staleSamples": 3.0 })
    );
}

#[test]
fn a_stale_time_that_is_not_one_is_refused_as_it_is_read() {
    for bad in [serde_json::json!(-1000.0), serde_json::json!(-1)] {
        let mut written = serde_json::to_value(config()).unwrap();
        assert_eq!(written["staleMs"], serde_json::json!(80));
        written["staleMs"] = bad;
        let refused = serde_json::from_value::<StationConfig>(written).unwrap_err();
        assert!(
            refused.to_string().contains("stale after must be"),
            "{refused}"
        );
    }
}

#[test]
fn refuses_configurations_that_cannot_run() {
    for broken in [
        StationConfig {
            ts_s: 0.0,
            ..config()
        },
        StationConfig {
            setpoint: f64::INFINITY,
            ..config()
        },
    ] {
        assert_eq!(
            Station::new(broken.clone()).unwrap_err().code(),
            "INVALID_CONFIG",
            "{broken:?}"
        );
    }
}

#[test]
fn a_sealed_state_opens_for_its_own_node_only_and_unchanged() {
    let saved = Saved {
        integral: Some(7.5),
        setpoint: Some(55.0),
        mode: Some(Mode::Manual),
        manual: Some(33.0),
    };
    let text = saved.seal("pid-1", &config(), millis(9.0));
    assert_eq!(Saved::open(&text, "pid-1"), Ok(saved));
    let mut edited = config();
    edited.setpoint = 80.0;
    assert_ne!(
        text,
        saved.seal("pid-1", &edited, millis(9.0)),
        "saved for its configuration"
    );
    assert!(matches!(
        Saved::open(&text, "pid-2"),
        Err(Refusal::NotOurs { .. })
    ));
    assert_eq!(
        Saved::open(&text.replace("55", "56"), "pid-1"),
        Err(Refusal::ChecksumMismatch)
    );
    let interlock = text.replace("sugarshack-pid-state", "sugarshack-interlock-state");
    assert_eq!(
        Saved::open(&interlock, "pid-1").unwrap_err().to_string(),
        "it is the state of an interlock"
    );
}
