use super::*;
use crate::control::pid::{Action, PidConfig, StepMode};
use crate::time::millis;

fn controller(id: usize) -> RccController {
    RccController::new(RccConfig {
        id,
        thresholds: vec![millis(200.0), millis(400.0), millis(600.0)],
        ts: millis(200.0),
        smooth_handover: true,
        poll_timeout: None,
    })
    .unwrap()
}

fn pid() -> Pid {
    Pid::new(PidConfig {
        kp: 1.0,
        ti_s: 2.0,
        td_s: 0.0,
        out_min: 0.0,
        out_max: 10.0,
        action: Action::Reverse,
        fallback: None,
        proportional_on: Default::default(),
    })
    .unwrap()
}

fn state(last_action: f64, ages: [Option<f64>; 3]) -> IoState {
    IoState {
        last_action,
        ages: ages.iter().map(|a| a.map(millis)).collect(),
    }
}

/// One scan of the loop these tests drive: setpoint 5, measurement 4, every 0.2 s.
fn run_scan(rcc: &mut RccController, pid: &mut Pid, io: IoState) -> Scan {
    rcc.scan(pid, &io, 5.0, Some(4.0), 0.2).unwrap()
}

#[test]
fn thresholds_must_rise_with_the_id_from_ts() {
    let valid = [millis(200.0), millis(400.0), millis(600.0)];
    assert!(validate_thresholds(&valid, millis(200.0)).is_ok());
    assert!(validate_thresholds(&valid, millis(300.0)).is_err());
    assert_eq!(
        thresholds_from_ms(&[200.0, 400.0, 600.0], 200.0).unwrap(),
        (valid.to_vec(), millis(200.0))
    );
    for (thresholds, ts) in [
        (vec![100.0, 400.0], 200.0),
        (vec![400.0, 400.0], 200.0),
        (vec![400.0, 300.0], 200.0),
        (vec![], 200.0),
        (vec![200.0, f64::NAN], 200.0),
        (vec![200.0, 400.0], 0.0),
    ] {
        assert_eq!(
            thresholds_from_ms(&thresholds, ts).unwrap_err().code(),
            "INVALID_CONFIG",
            "{thresholds:?} {ts}"
        );
    }
    // Worded in seconds, the unit of the node settings.
    assert_eq!(
        thresholds_from_ms(&[1500.0, 1000.0], 500.0)
            .unwrap_err()
            .to_string(),
        "engagement threshold D_2 = 1 s must be greater than D_1 = 1.5 s: a backup must wait longer than every controller above it"
    );
    assert_eq!(
        thresholds_from_ms(&[400.0], 500.0).unwrap_err().to_string(),
        "engagement threshold D_1 = 0.4 s must be at least the sampling period Ts = 0.5 s"
    );
    let outside = RccConfig {
        id: 4,
        ..controller(1).config().clone()
    };
    assert_eq!(
        RccController::new(outside).unwrap_err().code(),
        "INVALID_CONFIG"
    );
}

#[test]
fn the_primary_is_always_engaged() {
    let primary = controller(1);
    assert!(primary
        .engaged(&state(0.0, [Some(0.0), Some(0.0), Some(0.0)]))
        .unwrap());
}

#[test]
fn a_backup_engages_only_when_every_lower_id_is_older_than_its_threshold() {
    let secondary = controller(2);
    let tertiary = controller(3);
    let fresh = state(0.0, [Some(100.0), None, None]);
    assert!(!secondary.engaged(&fresh).unwrap());
    let primary_gone = state(0.0, [Some(450.0), None, None]);
    assert!(secondary.engaged(&primary_gone).unwrap());
    assert!(
        !tertiary.engaged(&primary_gone).unwrap(),
        "450 ms < D_3 = 600 ms"
    );
    // the secondary acted meanwhile: the tertiary stays out even past its threshold for the primary
    assert!(!tertiary
        .engaged(&state(0.0, [Some(900.0), Some(150.0), None]))
        .unwrap());
    assert!(tertiary
        .engaged(&state(0.0, [Some(900.0), Some(700.0), None]))
        .unwrap());
    assert!(
        tertiary.engaged(&state(0.0, [None, None, None])).unwrap(),
        "never acted counts as infinitely old"
    );
}

#[test]
fn standby_and_first_cycle_track_the_last_action() {
    let mut secondary = controller(2);
    let mut pid = pid();
    let scan = run_scan(
        &mut secondary,
        &mut pid,
        state(6.0, [Some(50.0), None, None]),
    );
    assert_eq!(
        (scan.engaged, scan.first_cycle, scan.write),
        (false, true, None)
    );
    assert_eq!(
        (scan.step.mode, scan.step.output),
        (StepMode::Tracking, 6.0)
    );
    // engaged after the primary's age passes D_2: first write continues from 6.0
    let scan = run_scan(
        &mut secondary,
        &mut pid,
        state(6.0, [Some(420.0), None, None]),
    );
    assert!(scan.engaged && !scan.first_cycle);
    let written = scan.write.unwrap();
    assert!(
        (written - (6.0 + 1.0 / 2.0 * 1.0 * 0.2)).abs() < 1e-12,
        "one integration step away: {written}"
    );
}

#[test]
fn an_engaged_controller_after_a_timeout_tracks_once_then_runs_free() {
    let mut primary = controller(1);
    let mut pid = pid();
    run_scan(&mut primary, &mut pid, state(0.0, [None, None, None]));
    let free = run_scan(&mut primary, &mut pid, state(3.0, [Some(0.0), None, None]));
    assert_eq!(free.step.mode, StepMode::Auto);
    primary.poll_timed_out();
    let back = run_scan(
        &mut primary,
        &mut pid,
        state(7.5, [Some(900.0), Some(10.0), None]),
    );
    assert!(back.first_cycle && back.engaged);
    assert_eq!(
        (back.step.mode, back.write),
        (StepMode::Tracking, Some(7.5)),
        "takes over from the backup's action"
    );
}

#[test]
fn without_smooth_handover_the_standby_integrator_runs_free() {
    let mut secondary = RccController::new(RccConfig {
        smooth_handover: false,
        ..controller(2).config().clone()
    })
    .unwrap();
    let mut pid = pid();
    let scan = run_scan(
        &mut secondary,
        &mut pid,
        state(6.0, [Some(50.0), None, None]),
    );
    assert_eq!(scan.step.mode, StepMode::Auto);
    assert!(scan.write.is_none());
}

#[test]
fn the_io_module_ages_writes_by_its_own_clock() {
    let mut io = IoModule::new(3, 1.5).unwrap();
    assert_eq!(io.state(millis(1000.0)), state(1.5, [None, None, None]));
    io.write(2, 4.0, millis(1000.0)).unwrap();
    io.write(1, 5.0, millis(1100.0)).unwrap();
    assert_eq!(
        io.state(millis(1300.0)),
        state(5.0, [Some(200.0), Some(300.0), None])
    );
    assert_eq!(
        io.write(4, 1.0, millis(1400.0)).unwrap_err(),
        ControlError::UnknownController {
            id: 4,
            controllers: 3
        }
    );
    assert_eq!(
        io.write(0, 1.0, millis(1400.0)).unwrap_err().code(),
        "UNKNOWN_CONTROLLER"
    );
    assert_eq!(
        io.write(1, f64::NAN, millis(1400.0)).unwrap_err().code(),
        "INVALID_INPUT"
    );
    assert_eq!(io.last_action(), 5.0, "refused writes change nothing");
}

#[test]
fn a_malformed_state_is_refused() {
    let secondary = controller(2);
    let short = IoState {
        last_action: 0.0,
        ages: vec![Some(millis(1.0))],
    };
    assert_eq!(
        secondary.engaged(&short).unwrap_err().code(),
        "INVALID_INPUT"
    );
    // An age that is not one is refused as the state is read.
    let negative = r#"{ "lastAction": 0, "agesMs": [-1, null, null] }"#;
    let refused = serde_json::from_str::<IoState>(negative).unwrap_err();
    assert!(
        refused
            .to_string()
            .starts_with("a controller age must be a number of ms >= 0, got -1"),
        "{refused}"
    );
    let read: IoState =
        serde_json::from_str(r#"{ "lastAction": 0, "agesMs": [150, null, 0.5] }"#).unwrap();
    assert_eq!(read, state(0.0, [Some(150.0), None, Some(0.5)]));
    assert_eq!(
        serde_json::to_string(&read).unwrap(),
        r#"{"lastAction":0.0,"agesMs":[150,null,0.5]}"#
    );
    let mut secondary = controller(2);
    assert!(secondary
        .decide(&state(f64::NAN, [None, None, None]))
        .is_err());
}

#[test]
fn the_polling_timeout_is_a_tick_rule_counted_from_the_last_state() {
    let mut rcc = controller(1);
    assert_eq!(rcc.next_tick(), None);
    rcc.watch_from(millis(0.0)).unwrap();
    assert_eq!(rcc.next_tick(), Some(millis(600.0)), "3·Ts by default");
    rcc.decide_at(&state(1.0, [None, None, None]), millis(100.0))
        .unwrap();
    assert!(!rcc.first_cycle());
    assert!(!rcc.tick(millis(699.0)).unwrap());
    assert!(
        rcc.tick(millis(700.0)).unwrap(),
        "600 ms after the last state"
    );
    assert!(rcc.first_cycle(), "the next scan re-seeds");
    assert!(!rcc.tick(millis(2000.0)).unwrap(), "once per silence");
    assert_eq!(rcc.next_tick(), None);
    assert!(
        rcc.decide_at(&state(1.0, [None, None, None]), millis(2000.0))
            .unwrap()
            .first_cycle
    );
    for bad in [f64::NAN, -1.0] {
        let refused = crate::control::error::time(bad, "time (ms)").unwrap_err();
        assert_eq!(refused.code(), "INVALID_INPUT");
    }
    let custom = RccConfig {
        poll_timeout: Some(millis(150.0)),
        ..rcc.config().clone()
    };
    let mut rcc = RccController::new(custom.clone()).unwrap();
    rcc.watch_from(millis(0.0)).unwrap();
    assert_eq!(rcc.next_tick(), Some(millis(150.0)));
    assert_eq!(
        RccController::new(RccConfig {
            poll_timeout: Some(millis(0.0)),
            ..custom
        })
        .unwrap_err()
        .code(),
        "INVALID_CONFIG"
    );
}
