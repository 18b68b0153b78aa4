use super::*;
use serde_json::json;

use crate::time::ms;

/// V1, V2 (valves, tolerance 2) and P1 (pump) on ctrl-1; V9 on ctrl-2.
fn plant(escalation: &str) -> PlantModel {
    serde_json::from_value(json!({
        "actuatorTypes": {
            "valve": { "signal": "analog", "tolerance": 2, "noMotionMs": 1000, "completionMs": 3000,
                       "staleMs": 5000, "retries": 1, "escalation": escalation },
            "pump": { "signal": "binary", "noMotionMs": 1000, "completionMs": 2000, "staleMs": 5000 }
        },
        "devices": [{ "id": "ctrl-1", "kind": "actuator-panel" }, { "id": "ctrl-2", "kind": "actuator-panel" }],
        "actuators": [
            { "id": "V1", "type": "valve", "device": "ctrl-1", "io": 1, "idle": 0, "lockout": 0 },
            { "id": "V2", "type": "valve", "device": "ctrl-1", "io": 2, "idle": 0, "lockout": 0 },
            { "id": "P1", "type": "pump", "device": "ctrl-1", "io": 1, "idle": false, "lockout": false },
            { "id": "V9", "type": "valve", "device": "ctrl-2", "io": 9, "idle": 0, "lockout": 0 }
        ]
    }))
    .unwrap()
}

fn tracker() -> (Tracker, ActuatorId, ActuatorId, ActuatorId) {
    let mut t = Tracker::new(plant("fail-fast"), ms(0)).unwrap();
    let [v1, v2, p1] = ["V1", "V2", "P1"].map(|n| t.actuator(n).unwrap());
    for id in [v1, v2, p1] {
        t.feedback(id, 0.0, None, ms(0)).unwrap();
    }
    (t, v1, v2, p1)
}

/// A command after a retained lockout: the lockout cleared (empty, retained), then the command.
fn cleared_then(topic: &str, payload: &str) -> Vec<(String, String, bool)> {
    vec![
        (topic.into(), String::new(), true),
        (topic.into(), payload.into(), false),
    ]
}

fn publishes(effects: &[Effect]) -> Vec<(String, String, bool)> {
    effects
        .iter()
        .filter_map(|e| match e {
            Effect::Publish {
                topic,
                payload,
                retain,
                ..
            } => Some((topic.clone(), payload.clone(), *retain)),
            _ => None,
        })
        .collect()
}

fn has(effects: &[Effect], wanted: impl Fn(&Effect) -> bool) -> bool {
    effects.iter().any(wanted)
}

/// Whether the effects answer `caller`'s group command as completed at `at_ms`.
fn completes_group(effects: &[Effect], caller: Caller, at_ms: u64) -> bool {
    has(effects, |e| {
        matches!(
            e,
            Effect::GroupCompleted {
                caller: c,
                completion_ms,
                ..
            } if *c == caller && *completion_ms == ms(at_ms)
        )
    })
}

#[test]
fn a_command_goes_from_pending_to_moving_to_stopped() {
    let (mut t, v1, _, _) = tracker();
    let sent = t.command(&[(v1, 100.0)], 1, false, ms(100)).unwrap();
    assert_eq!(
        publishes(&sent),
        vec![("ctrl-1/valve/1/command".into(), "100".into(), false)]
    );
    assert_eq!(t.phase(v1), Some(Phase::Pending));
    let noise = t.feedback(v1, 1.5, None, ms(600)).unwrap();
    assert!(
        !has(&noise, |e| matches!(e, Effect::Moving { .. })),
        "within tolerance of the start is not motion"
    );
    let moving = t.feedback(v1, 30.0, None, ms(2100)).unwrap();
    assert!(has(&moving, |e| matches!(
        e,
        Effect::Moving {
            issue_to_motion_ms,
            caller: 1,
            ..
        } if *issue_to_motion_ms == ms(2000)
    )));
    assert_eq!(t.phase(v1), Some(Phase::Moving));
    let done = t.feedback(v1, 98.5, None, ms(3100)).unwrap();
    assert!(has(&done, |e| matches!(
        e,
        Effect::Completed {
            issue_to_motion_ms,
            completion_ms,
            retries: 0,
            ..
        } if *issue_to_motion_ms == ms(2000) && *completion_ms == ms(3000)
    )));
    assert!(completes_group(&done, 1, 3000));
    assert_eq!(t.phase(v1), Some(Phase::Stopped));
}

#[test]
fn a_group_returns_once_every_actuator_is_done() {
    let (mut t, v1, v2, p1) = tracker();
    let sent = t
        .command(&[(v1, 50.0), (v2, 100.0), (p1, 1.0)], 9, false, ms(0))
        .unwrap();
    assert_eq!(publishes(&sent).len(), 3);
    assert_eq!(
        publishes(&sent)[2],
        ("ctrl-1/pump/1/command".into(), "ON".into(), false)
    );
    let pump = t.feedback(p1, 1.0, None, ms(500)).unwrap();
    assert!(
        has(&pump, |e| matches!(e, Effect::Moving { .. }))
            && has(&pump, |e| matches!(e, Effect::Completed { .. }))
    );
    t.feedback(v1, 50.0, None, ms(900)).unwrap();
    let before = t.feedback(v2, 60.0, None, ms(900)).unwrap();
    assert!(!has(&before, |e| matches!(
        e,
        Effect::GroupCompleted { .. }
    )));
    let last = t.feedback(v2, 100.0, None, ms(1500)).unwrap();
    assert!(completes_group(&last, 9, 1500));
}

#[test]
fn a_command_to_where_it_already_is_completes_at_once() {
    let (mut t, v1, _, _) = tracker();
    let effects = t.command(&[(v1, 1.0)], 3, false, ms(50)).unwrap();
    assert_eq!(
        publishes(&effects).len(),
        1,
        "still sent, so the device holds the commanded state"
    );
    assert!(completes_group(&effects, 3, 0));
    assert_eq!(t.counts().moving, 0);
}

#[test]
fn bad_commands_send_nothing_and_change_nothing() {
    let (mut t, v1, v2, p1) = tracker();
    t.command(&[(v1, 100.0)], 1, false, ms(0)).unwrap();
    let refused = |t: &mut Tracker, targets: &[(ActuatorId, f64)]| {
        t.command(targets, 2, false, ms(10)).unwrap_err().code()
    };
    assert_eq!(refused(&mut t, &[(v2, 100.0), (v1, 0.0)]), "STILL_MOVING");
    assert_eq!(refused(&mut t, &[(v2, 101.0)]), "INVALID_TARGET");
    assert_eq!(refused(&mut t, &[(p1, 0.5)]), "INVALID_TARGET");
    assert_eq!(
        refused(&mut t, &[(v2, 10.0), (v2, 20.0)]),
        "DUPLICATE_ACTUATOR"
    );
    assert_eq!(refused(&mut t, &[]), "EMPTY_COMMAND");
    assert_eq!(
        refused(&mut t, &[(ActuatorId(99), 1.0)]),
        "UNKNOWN_ACTUATOR"
    );
    assert_eq!(
        t.command(&[(v2, 10.0)], 1, false, ms(10))
            .unwrap_err()
            .code(),
        "CALLER_BUSY"
    );
    assert_eq!(
        t.phase(v2),
        Some(Phase::Idle),
        "V2 untouched by the refused groups"
    );
    assert_eq!(
        t.actuator("V77").unwrap_err().to_string(),
        "unknown actuator 'V77': it is not in the plant document"
    );
    let err = t.target_from_json(p1, &json!(1)).unwrap_err();
    assert!(err.to_string().contains("true or false"), "{err}");
}

#[test]
fn no_motion_is_retried_at_the_threshold_then_fails_fast() {
    let (mut t, v1, _, _) = tracker();
    t.command(&[(v1, 100.0)], 1, false, ms(0)).unwrap();
    assert!(t.tick(ms(999)).is_empty(), "just before T");
    let retry = t.tick(ms(1000));
    assert!(
        has(&retry, |e| matches!(
            e,
            Effect::Retry {
                attempt: 1,
                fault: FaultKind::NoMotion,
                ..
            }
        )),
        "exactly at T"
    );
    assert_eq!(
        publishes(&retry),
        vec![("ctrl-1/valve/1/command".into(), "100".into(), false)]
    );
    assert!(t.tick(ms(1999)).is_empty(), "a fresh window for the retry");
    let failed = t.tick(ms(2000));
    assert!(has(&failed, |e| matches!(
        e,
        Effect::Fault {
            fault: FaultKind::NoMotion,
            ..
        }
    )));
    assert!(has(&failed, |e| matches!(
        e,
        Effect::GroupFailed {
            caller: 1,
            fault: FaultKind::NoMotion,
            ..
        }
    )));
    assert_eq!(t.phase(v1), Some(Phase::Faulted));
    assert!(t.tick(ms(2001)).is_empty(), "escalates once");
    // A faulted actuator can still be commanded (a lockout must always go through).
    assert!(t.command(&[(v1, 0.0)], 2, false, ms(2100)).is_ok());
}

#[test]
fn target_not_reached_counts_from_the_attempt() {
    let (mut t, v1, _, _) = tracker();
    t.command(&[(v1, 100.0)], 1, false, ms(0)).unwrap();
    t.feedback(v1, 20.0, None, ms(500)).unwrap();
    assert!(t.tick(ms(2999)).is_empty());
    assert!(has(&t.tick(ms(3000)), |e| matches!(
        e,
        Effect::Retry {
            fault: FaultKind::NotReached,
            ..
        }
    )));
    t.feedback(v1, 40.0, None, ms(3500)).unwrap();
    let failed = t.tick(ms(6000));
    assert!(has(&failed, |e| matches!(
        e,
        Effect::GroupFailed {
            fault: FaultKind::NotReached,
            ..
        }
    )));
}

#[test]
fn hang_escalation_reports_the_fault_and_leaves_the_command_to_the_callers_timeout() {
    let mut t = Tracker::new(plant("hang"), ms(0)).unwrap();
    let v1 = t.actuator("V1").unwrap();
    t.feedback(v1, 0.0, None, ms(0)).unwrap();
    t.command(&[(v1, 100.0)], 1, false, ms(0)).unwrap();
    t.tick(ms(1000));
    let escalated = t.tick(ms(2000));
    assert!(has(&escalated, |e| matches!(
        e,
        Effect::Fault {
            fault: FaultKind::NoMotion,
            ..
        }
    )));
    assert!(!has(&escalated, |e| matches!(
        e,
        Effect::GroupFailed { .. }
    )));
    let late = t.feedback(v1, 100.0, None, ms(9000)).unwrap();
    assert!(completes_group(&late, 1, 9000));
    assert!(!t.withdraw(1), "already answered");
}

#[test]
fn uncommanded_movement_while_idle_is_a_fault_once_per_excursion() {
    let (mut t, v1, _, _) = tracker();
    assert!(t
        .feedback(v1, 1.9, None, ms(10))
        .unwrap()
        .iter()
        .all(|e| !matches!(e, Effect::Fault { .. })));
    let moved = t.feedback(v1, 2.1, None, ms(20)).unwrap();
    assert!(has(&moved, |e| matches!(
        e,
        Effect::Fault {
            fault: FaultKind::Uncommanded,
            ..
        }
    )));
    assert!(!has(
        &t.feedback(v1, 40.0, None, ms(30)).unwrap(),
        |e| matches!(e, Effect::Fault { .. })
    ));
    let back = t.feedback(v1, 0.5, None, ms(40)).unwrap();
    assert!(has(&back, |e| matches!(
        e,
        Effect::Recovered {
            fault: FaultKind::Uncommanded,
            ..
        }
    )));
}

#[test]
fn feedback_goes_stale_at_the_threshold_and_fails_a_running_command() {
    let (mut t, v1, v2, _) = tracker();
    t.command(&[(v1, 100.0)], 1, false, ms(4000)).unwrap();
    t.feedback(v1, 10.0, None, ms(4500)).unwrap();
    // V2 last reported at 0: stale at exactly 5000.
    let at_4999 = t.tick(ms(4999));
    assert!(!has(
        &at_4999,
        |e| matches!(e, Effect::Fault { actuator, .. } if *actuator == v2)
    ));
    let at_5000 = t.tick(ms(5000));
    assert!(has(
        &at_5000,
        |e| matches!(e, Effect::Fault { actuator, fault: FaultKind::Stale } if *actuator == v2)
    ));
    assert!(
        !has(&at_5000, |e| matches!(e, Effect::GroupFailed { .. })),
        "V1 reported at 4500"
    );
    let recovered = t.feedback(v2, 0.0, None, ms(6000)).unwrap();
    assert!(has(&recovered, |e| matches!(
        e,
        Effect::Recovered {
            fault: FaultKind::Stale,
            ..
        }
    )));
    assert_eq!(
        t.phase(v2),
        Some(Phase::Idle),
        "no command ever: idle again"
    );
    let stale_v1 = t.tick(ms(9500));
    assert!(has(&stale_v1, |e| matches!(
        e,
        Effect::GroupFailed {
            caller: 1,
            fault: FaultKind::Stale,
            ..
        }
    )));
}

#[test]
fn a_device_going_offline_fails_its_commands_and_refuses_new_ones() {
    let (mut t, v1, v2, _) = tracker();
    let ctrl1 = t.device("ctrl-1").unwrap();
    t.command(&[(v1, 100.0)], 1, false, ms(0)).unwrap();
    let offline = t.device_status(ctrl1, false, ms(100)).unwrap();
    assert!(has(&offline, |e| matches!(
        e,
        Effect::DeviceStatus { online: false, .. }
    )));
    assert!(has(&offline, |e| matches!(
        e,
        Effect::GroupFailed {
            caller: 1,
            fault: FaultKind::DeviceOffline,
            ..
        }
    )));
    assert_eq!(
        t.command(&[(v2, 50.0)], 2, false, ms(200))
            .unwrap_err()
            .code(),
        "DEVICE_OFFLINE"
    );
    let later = t.tick(ms(60_000));
    let on_ctrl1 = |id: &ActuatorId| [v1, v2].contains(id) || t.actuator_name(*id) == Some("P1");
    assert!(
        !has(
            &later,
            |e| matches!(e, Effect::Fault { actuator, .. } if on_ctrl1(actuator))
        ),
        "no stale faults while known offline"
    );
    assert!(
        has(&later, |e| matches!(
            e,
            Effect::Fault {
                fault: FaultKind::Stale,
                ..
            }
        )),
        "ctrl-2 is online and silent: stale"
    );
    let online = t.device_status(ctrl1, true, ms(300)).unwrap();
    assert_eq!(
        publishes(&online),
        vec![("ctrl-1/valve/1/command".into(), "100".into(), false)],
        "commanded state re-sent"
    );
    assert!(
        t.device_status(ctrl1, true, ms(301)).unwrap().is_empty(),
        "no change, no effect"
    );
}

#[test]
fn lockouts_are_retained_take_over_and_are_cleared_by_the_next_command() {
    let (mut t, v1, _, p1) = tracker();
    t.command(&[(v1, 100.0), (p1, 1.0)], 1, false, ms(0))
        .unwrap();
    let lockout = t
        .command(&[(v1, 0.0), (p1, 0.0)], 2, true, ms(100))
        .unwrap();
    assert!(has(&lockout, |e| matches!(
        e,
        Effect::GroupFailed {
            caller: 1,
            fault: FaultKind::LockedOut,
            ..
        }
    )));
    assert_eq!(
        publishes(&lockout),
        vec![
            ("ctrl-1/valve/1/command".into(), "0".into(), true),
            ("ctrl-1/pump/1/command".into(), "OFF".into(), true)
        ]
    );
    assert!(
        has(&lockout, |e| matches!(
            e,
            Effect::GroupCompleted { caller: 2, .. }
        )),
        "both already there"
    );
    assert!(
        has(&lockout, |e| matches!(
            e,
            Effect::LockoutConfirmed { actuator, after_ms, sends: 1 } if *actuator == p1 && *after_ms == ms(0))),
        "the last sample already shows it there"
    );
    assert!(t.pending_lockouts().is_empty());
    let ctrl1 = t.device("ctrl-1").unwrap();
    t.device_status(ctrl1, false, ms(200)).unwrap();
    let back = t.device_status(ctrl1, true, ms(300)).unwrap();
    assert!(
        publishes(&back).iter().all(|(_, _, retain)| *retain),
        "lockouts re-sent retained"
    );
    let next = t.command(&[(p1, 1.0)], 3, false, ms(400)).unwrap();
    assert_eq!(
        publishes(&next),
        cleared_then("ctrl-1/pump/1/command", "ON"),
        "the retained lockout is cleared before a normal command"
    );
}

#[test]
fn changes_are_reported_by_exception_with_time_of_flight() {
    let (mut t, v1, _, _) = tracker();
    let first = t.feedback(v1, 10.0, Some(ms(900)), ms(1000)).unwrap();
    assert!(has(
        &first,
        |e| matches!(e, Effect::Changed { value, time_of_flight_ms: Some(100), .. } if *value == 10.0)
    ));
    assert!(!has(
        &t.feedback(v1, 11.9, Some(ms(1900)), ms(2000)).unwrap(),
        |e| matches!(e, Effect::Changed { .. })
    ));
    assert!(has(
        &t.feedback(v1, 12.1, None, ms(3000)).unwrap(),
        |e| matches!(
            e,
            Effect::Changed {
                time_of_flight_ms: None,
                ..
            }
        )
    ));
}

#[test]
fn a_bad_sample_in_a_batch_is_reported_and_the_rest_still_counts() {
    let (mut t, v1, v2, p1) = tracker();
    let mut effects = Vec::new();
    let rejected = t
        .feedback_batch(
            &[(v1, 50.0), (p1, 0.3), (v2, f64::NAN)],
            Some(ms(10)),
            ms(20),
            &mut effects,
        )
        .unwrap();
    let codes: Vec<(ActuatorId, &str)> = rejected
        .iter()
        .map(|(id, err)| (*id, err.code().name()))
        .collect();
    assert_eq!(
        codes,
        vec![(p1, "INVALID_FEEDBACK"), (v2, "INVALID_FEEDBACK")]
    );
    assert_eq!(t.position(v1), Some(50.0));
    assert_eq!(t.position(v2), Some(0.0));
    let ctrl1 = t.device("ctrl-1").unwrap();
    assert_eq!(t.slot(ctrl1, "valve", 2), Some(v2));
    assert_eq!(
        t.slot(ctrl1, "valve", 16),
        None,
        "a slot the plant does not name"
    );
}

#[test]
fn withdrawing_a_group_leaves_its_actuators_idle() {
    let (mut t, v1, v2, _) = tracker();
    t.command(&[(v1, 100.0), (v2, 100.0)], 5, false, ms(0))
        .unwrap();
    assert!(t.withdraw(5));
    assert_eq!(
        t.counts(),
        Counts {
            moving: 0,
            stopped: 0,
            faulted: 0,
            lockouts_pending: 0,
            offline_devices: 0
        }
    );
    assert!(t.tick(ms(1500)).is_empty(), "nothing left to time out");
}

#[test]
fn timed_completions_confirmed_lockouts_and_fault_lockouts_are_timing_figures() {
    let series = |effects: &[Effect]| -> Vec<(&str, u64)> {
        effects
            .iter()
            .flat_map(Effect::timings)
            .flatten()
            .map(|(name, ms)| (name, ms.as_u64()))
            .collect()
    };
    let (mut t, v1, v2, _) = tracker();
    // Already there: completed at once, no figure of motion.
    assert_eq!(
        series(&t.command(&[(v2, 0.0)], 1, false, ms(0)).unwrap()),
        []
    );
    t.command(&[(v1, 100.0)], 2, false, ms(0)).unwrap();
    t.feedback(v1, 50.0, None, ms(400)).unwrap();
    let done = t.feedback(v1, 100.0, None, ms(900)).unwrap();
    assert_eq!(
        series(&done),
        [("command/issueToMotion", 400), ("command/completion", 900)]
    );
    // A lockout after a fault at 1000: confirmed and completed, fault to completion.
    let issued = t
        .issue(
            &[(v1, 0.0)],
            3,
            Terms {
                lockout: true,
                fault_at: Some(ms(1000)),
                timeout: None,
            },
            ms(1200),
        )
        .unwrap();
    assert_eq!(series(&issued), []);
    t.feedback(v1, 50.0, None, ms(1500)).unwrap();
    let done = t.feedback(v1, 0.0, None, ms(2000)).unwrap();
    assert_eq!(
        series(&done),
        [
            ("lockout/confirm", 800),
            ("command/issueToMotion", 300),
            ("command/completion", 800),
            ("fault/lockout", 1000)
        ]
    );
}

#[test]
fn callers_count_up_wrap_within_u32_and_skip_a_group_still_waiting() {
    let (mut t, v1, v2, _) = tracker();
    assert_eq!([t.new_caller(), t.new_caller()], [1, 2]);
    // 3 waits on V1; 4 completes at once (V2 is already at 0) and waits on nothing.
    t.command(&[(v1, 100.0)], 3, false, ms(0)).unwrap();
    t.command(&[(v2, 0.0)], 4, false, ms(0)).unwrap();
    assert_eq!(t.new_caller(), 4);
    t.last_caller = MAX_CALLER - 1;
    assert_eq!(t.new_caller(), MAX_CALLER);
    assert_eq!([t.new_caller(), t.new_caller()], [1, 2]);
    // Past 2 comes 3, still waiting: skipped.
    assert_eq!(t.new_caller(), 4);
    assert!(t.withdraw(3));
    t.last_caller = 2;
    assert_eq!(t.new_caller(), 3, "free again once withdrawn");
}

#[test]
fn group_commands_read_by_type_and_refuse_mismatches() {
    let (t, v1, v2, p1) = tracker();
    let targets = t
        .parse_group(&json!({ "valves": { "V1": 100, "V2": 0 }, "pump": { "P1": true } }))
        .unwrap();
    assert_eq!(targets, vec![(v1, 100.0), (v2, 0.0), (p1, 1.0)]);
    let code = |payload| t.parse_group(&payload).unwrap_err();
    assert_eq!(
        code(json!({ "valves": { "P1": 0 } })).to_string(),
        "invalid group command: 'P1' is a pump, not a valve"
    );
    assert_eq!(
        code(json!({ "motors": { "M1": 1 } })).to_string(),
        "invalid group command: unknown actuator type 'motors' (known: pump, valve)"
    );
    assert_eq!(
        code(json!({ "valves": { "V77": 1 } })).code(),
        "UNKNOWN_ACTUATOR"
    );
    assert_eq!(
        code(json!({ "valves": { "V1": "open" } })).code(),
        "INVALID_TARGET"
    );
    assert_eq!(code(json!({ "valves": {} })).code(), "EMPTY_COMMAND");
    assert_eq!(code(json!([1, 2])).code(), "INVALID_GROUP");
}

#[test]
fn c2_refuses_a_command_outside_the_held_resources() {
    let mut doc = serde_json::to_value(plant("fail-fast")).unwrap();
    doc["resources"] = json!([{ "id": "YEL" }, { "id": "RED" }]);
    for (i, line) in ["YEL", "YEL", "YEL", "RED"].iter().enumerate() {
        doc["actuators"][i]["resource"] = json!(line);
    }
    doc["actuators"][1]["resource"] = serde_json::Value::Null;
    let t = Tracker::new(serde_json::from_value(doc).unwrap(), ms(0)).unwrap();
    let yel = ["YEL".to_string()];
    let targets = t
        .parse_group(&json!({ "valves": { "V1": 100 }, "pumps": { "P1": true } }))
        .unwrap();
    assert_eq!(t.check_within(&targets, &yel), Ok(()));
    let red = t
        .parse_group(&json!({ "valves": { "V1": 100, "V9": 100 } }))
        .unwrap();
    let err = t.check_within(&red, &yel).unwrap_err();
    assert_eq!(err.code(), "OUTSIDE_RESOURCES");
    assert_eq!(err.to_string(), "C2: actuator 'V9' is on resource 'RED', outside the resources held (YEL); nothing was sent");
    let loose = t.parse_group(&json!({ "valves": { "V2": 100 } })).unwrap();
    assert!(t
        .check_within(&loose, &yel)
        .unwrap_err()
        .to_string()
        .contains("'V2' belongs to no resource"));
}

// ---- standing lockout orders ------------------------------------------------

/// V1 at 99 (a normal command completed), then locked out at `at`: not there yet.
fn locked_out_at_99(at: u64) -> (Tracker, ActuatorId) {
    let (mut t, v1, _, _) = tracker();
    t.command(&[(v1, 100.0)], 1, false, ms(0)).unwrap();
    t.feedback(v1, 99.0, None, ms(500)).unwrap();
    let sent = t.command(&[(v1, 0.0)], 2, true, ms(at)).unwrap();
    assert_eq!(
        publishes(&sent),
        vec![("ctrl-1/valve/1/command".into(), "0".into(), true)]
    );
    assert_eq!(
        t.pending_lockouts(),
        vec![PendingLockout {
            actuator: v1,
            target: 0.0,
            since_ms: ms(at),
            sends: 1
        }]
    );
    (t, v1)
}

fn resent(effects: &[Effect]) -> Vec<u32> {
    effects
        .iter()
        .filter_map(|e| match e {
            Effect::LockoutResent { attempt, .. } => Some(*attempt),
            _ => None,
        })
        .collect()
}

const LOCKOUT_V1: (&str, &str, bool) = ("ctrl-1/valve/1/command", "0", true);

fn lockout_v1() -> Vec<(String, String, bool)> {
    vec![(LOCKOUT_V1.0.into(), LOCKOUT_V1.1.into(), LOCKOUT_V1.2)]
}

#[test]
fn an_unconfirmed_lockout_is_resent_every_completion_window_without_limit() {
    let (mut t, v1) = locked_out_at_99(1000);
    let retry = t.tick(ms(2000));
    assert!(has(&retry, |e| matches!(
        e,
        Effect::Retry { caller: 2, .. }
    )));
    assert_eq!(publishes(&retry), lockout_v1(), "the group's own retry");
    let failed = t.tick(ms(3000));
    assert!(
        has(&failed, |e| matches!(
            e,
            Effect::GroupFailed {
                caller: 2,
                fault: FaultKind::NoMotion,
                ..
            }
        )),
        "the group command gives up"
    );
    assert!(publishes(&failed).is_empty());
    assert_eq!(t.counts().lockouts_pending, 1, "the order does not");
    let mut last = 2000;
    for window in 1..=50u32 {
        let due = last + 3000;
        t.feedback(v1, 99.0, None, ms(due - 1)).unwrap();
        assert!(
            publishes(&t.tick(ms(due - 1))).is_empty(),
            "window {window}: not before completionMs"
        );
        let sent = t.tick(ms(due));
        assert_eq!(
            resent(&sent),
            vec![window + 1],
            "window {window}: the retry was re-send 1"
        );
        assert_eq!(publishes(&sent), lockout_v1(), "window {window}");
        last = due;
    }
    assert_eq!(t.pending_lockouts()[0].sends, 52);
}

#[test]
fn a_lockout_is_not_resent_while_offline_and_at_once_when_back_or_the_path_is_restored() {
    let (mut t, _) = locked_out_at_99(1000);
    let ctrl1 = t.device("ctrl-1").unwrap();
    let offline = t.device_status(ctrl1, false, ms(1500)).unwrap();
    assert!(has(&offline, |e| matches!(
        e,
        Effect::GroupFailed {
            caller: 2,
            fault: FaultKind::DeviceOffline,
            ..
        }
    )));
    for now in (2000..40_000).step_by(500) {
        let ticked = t.tick(ms(now));
        assert!(
            publishes(&ticked).is_empty() && resent(&ticked).is_empty(),
            "offline at {now}"
        );
    }
    let back = t.device_status(ctrl1, true, ms(40_000)).unwrap();
    assert_eq!(resent(&back), vec![1]);
    assert_eq!(publishes(&back), lockout_v1(), "at once, retained");
    assert!(publishes(&t.tick(ms(42_999))).is_empty());
    assert_eq!(publishes(&t.tick(ms(43_000))), lockout_v1());
    let restored = t.path_restored(ms(44_000));
    assert_eq!(resent(&restored), vec![3]);
    assert_eq!(
        publishes(&restored),
        lockout_v1(),
        "V2 and P1 were never commanded"
    );
    assert!(
        publishes(&t.tick(ms(46_999))).is_empty(),
        "the window starts again at the restore"
    );
    assert_eq!(resent(&t.tick(ms(47_000))), vec![4]);
}

#[test]
fn a_sample_at_the_target_from_an_online_device_confirms_the_lockout() {
    let (mut t, v1) = locked_out_at_99(1000);
    let ctrl1 = t.device("ctrl-1").unwrap();
    t.device_status(ctrl1, false, ms(1200)).unwrap();
    let unheard = t.feedback(v1, 0.0, None, ms(1300)).unwrap();
    assert!(
        !has(&unheard, |e| matches!(e, Effect::LockoutConfirmed { .. })),
        "its device is offline"
    );
    t.device_status(ctrl1, true, ms(1400)).unwrap();
    assert_eq!(
        t.feedback(v1, 1.0, Some(ms(9000)), ms(1450))
            .unwrap_err()
            .code(),
        "FUTURE_TIMESTAMP"
    );
    assert_eq!(
        t.counts().lockouts_pending,
        1,
        "a refused sample confirms nothing"
    );
    let moving = t.feedback(v1, 40.0, None, ms(1500)).unwrap();
    assert!(!has(&moving, |e| matches!(
        e,
        Effect::LockoutConfirmed { .. }
    )));
    let there = t.feedback(v1, 2.0, None, ms(1600)).unwrap();
    assert!(has(&there, |e| matches!(
        e,
        Effect::LockoutConfirmed { actuator, after_ms, sends: 2 } if *actuator == v1 && *after_ms == ms(600))));
    assert!(t.pending_lockouts().is_empty());
    assert_eq!(t.counts().lockouts_pending, 0);
    for now in (2000..20_000).step_by(500) {
        t.feedback(v1, 0.0, None, ms(now)).unwrap();
        assert!(
            publishes(&t.tick(ms(now))).is_empty(),
            "confirmed: no re-send at {now}"
        );
    }
}

#[test]
fn a_normal_command_waits_for_the_lockout_to_be_confirmed() {
    let (mut t, v1) = locked_out_at_99(1000);
    let v2 = t.actuator("V2").unwrap();
    let err = t
        .command(&[(v2, 50.0), (v1, 50.0)], 3, false, ms(1100))
        .unwrap_err();
    assert_eq!(err.code(), "LOCKOUT_PENDING");
    assert_eq!(
        err.to_string(),
        "actuator 'V1' has not yet confirmed its lockout state; it is re-sent until feedback shows it there, check the device if that takes long (nothing was sent)"
    );
    assert_eq!(
        t.phase(v2),
        Some(Phase::Idle),
        "V2 untouched by the refused group"
    );
    let renewed = t.command(&[(v1, 0.0)], 4, true, ms(1200)).unwrap();
    assert!(
        has(&renewed, |e| matches!(
            e,
            Effect::GroupFailed {
                caller: 2,
                fault: FaultKind::LockedOut,
                ..
            }
        )),
        "the second lockout takes over the first one's group"
    );
    assert_eq!(
        t.pending_lockouts(),
        vec![PendingLockout {
            actuator: v1,
            target: 0.0,
            since_ms: ms(1000),
            sends: 2
        }],
        "renewed: pending since the first"
    );
    assert!(
        publishes(&t.tick(ms(4199))).len() <= 1,
        "the window restarts at the renewal (only the group's retry at 2200)"
    );
    let confirmed = t.feedback(v1, 0.0, None, ms(4300)).unwrap();
    assert!(has(&confirmed, |e| matches!(
        e,
        Effect::LockoutConfirmed {
            sends: 3,
            after_ms,
            ..
        } if *after_ms == ms(3300)
    )));
    let next = t.command(&[(v1, 50.0)], 5, false, ms(4400)).unwrap();
    assert_eq!(
        publishes(&next),
        cleared_then("ctrl-1/valve/1/command", "50"),
        "accepted once confirmed, clearing the retained lockout first"
    );
}

#[test]
fn a_lockout_to_another_state_replaces_the_order() {
    let (mut t, v1) = locked_out_at_99(1000);
    t.command(&[(v1, 10.0)], 3, true, ms(1500)).unwrap();
    assert_eq!(
        t.pending_lockouts(),
        vec![PendingLockout {
            actuator: v1,
            target: 10.0,
            since_ms: ms(1500),
            sends: 1
        }]
    );
    assert!(!has(
        &t.feedback(v1, 0.0, None, ms(1600)).unwrap(),
        |e| matches!(e, Effect::LockoutConfirmed { .. })
    ));
}

#[test]
fn withdrawing_the_lockouts_caller_does_not_end_the_order() {
    let (mut t, v1) = locked_out_at_99(1000);
    assert!(t.withdraw(2));
    assert_eq!(t.phase(v1), Some(Phase::Idle));
    assert_eq!(t.counts().lockouts_pending, 1);
    assert!(
        publishes(&t.tick(ms(3999))).is_empty(),
        "no group retry: it is gone"
    );
    let sent = t.tick(ms(4000));
    assert_eq!(resent(&sent), vec![1]);
    assert_eq!(publishes(&sent), lockout_v1());
}

#[test]
fn a_lockout_is_resent_while_feedback_is_stale() {
    let (mut t, _) = locked_out_at_99(1000);
    t.tick(ms(2000));
    t.tick(ms(3000));
    let stale = t.tick(ms(5000));
    assert!(has(&stale, |e| matches!(
        e,
        Effect::Fault {
            fault: FaultKind::Stale,
            ..
        }
    )));
    assert_eq!(
        publishes(&stale),
        lockout_v1(),
        "silence is no confirmation"
    );
}

#[test]
fn a_restored_path_republishes_every_commanded_state_and_restarts_the_windows() {
    let (mut t, v1, v2, p1) = tracker();
    t.command(&[(v1, 100.0)], 1, false, ms(0)).unwrap();
    t.command(&[(p1, 1.0)], 2, true, ms(0)).unwrap();
    t.feedback(v1, 30.0, None, ms(500)).unwrap();
    t.feedback(v2, 0.0, None, ms(500)).unwrap();
    let restored = t.path_restored(ms(2500));
    assert_eq!(
        publishes(&restored),
        vec![
            ("ctrl-1/valve/1/command".into(), "100".into(), false),
            ("ctrl-1/pump/1/command".into(), "ON".into(), true)
        ]
    );
    assert!(
        !has(&t.tick(ms(5499)), |e| matches!(
            e,
            Effect::Retry { caller: 1, .. }
                | Effect::Fault {
                    fault: FaultKind::Stale,
                    ..
                }
        )),
        "fresh windows: no retry of V1, and no staleness counted over the outage"
    );
    assert!(has(&t.tick(ms(5500)), |e| matches!(
        e,
        Effect::Retry {
            caller: 1,
            fault: FaultKind::NotReached,
            ..
        }
    )));
}

/// Every publish of `effects` handed to the tracker's outbox at `outlet`, within `bound`.
fn wait_all(
    t: &mut Tracker,
    outlet: outbox::Outlet,
    effects: Vec<Effect>,
    bound: usize,
) -> Vec<outbox::Kept> {
    effects
        .into_iter()
        .filter_map(|e| match e {
            Effect::Publish {
                device,
                topic,
                payload,
                retain,
            } => Some(t.keep_publish(outlet, device, topic, payload, retain, bound)),
            _ => None,
        })
        .collect()
}

#[test]
fn waiting_publishes_past_the_bound_never_lose_a_lockout_and_a_drop_republishes_every_state() {
    use outbox::{Kept, Outlet};
    let (mut t, v1, v2, p1) = tracker();
    let commands = t
        .command(&[(v1, 100.0), (v2, 50.0)], 1, false, ms(0))
        .unwrap();
    assert_eq!(
        wait_all(&mut t, Outlet::Held, commands, 2),
        vec![Kept::Kept, Kept::Kept]
    );
    // The pump's lockout comes past the bound: the oldest command is dropped for it.
    let lockout = t.command(&[(p1, 0.0)], 2, true, ms(10)).unwrap();
    assert_eq!(
        wait_all(&mut t, Outlet::Held, lockout.clone(), 2),
        vec![Kept::Dropped { first: true }]
    );
    assert_eq!(t.kept_publishes(Outlet::Held), 2);
    // The same lockout again (a resend) is not kept twice; a command past the bound is dropped.
    assert_eq!(wait_all(&mut t, Outlet::Held, lockout, 2), vec![Kept::Kept]);
    t.withdraw(1);
    let more = t.command(&[(v1, 20.0)], 3, false, ms(20)).unwrap();
    assert_eq!(
        wait_all(&mut t, Outlet::Held, more, 2),
        vec![Kept::Dropped { first: false }]
    );
    assert_eq!(
        t.kept_publishes(Outlet::Unsent),
        0,
        "the outlets wait apart"
    );
    let sent = t.send_kept(Outlet::Held, ms(100));
    assert_eq!(
        publishes(&sent),
        vec![
            ("ctrl-1/valve/2/command".into(), "50".into(), false),
            ("ctrl-1/pump/1/command".into(), "OFF".into(), true),
            // Some were dropped: every commanded state and standing lockout again.
            ("ctrl-1/valve/1/command".into(), "20".into(), false),
            ("ctrl-1/valve/2/command".into(), "50".into(), false),
            ("ctrl-1/pump/1/command".into(), "OFF".into(), true),
        ]
    );
    assert_eq!(t.kept_publishes(Outlet::Held), 0);
    assert!(
        t.send_kept(Outlet::Held, ms(200)).is_empty(),
        "nothing dropped since"
    );
}

#[test]
fn only_a_standing_lockout_msg_is_kept_past_the_bound_and_a_forgotten_outlet_sends_nothing() {
    use outbox::{Kept, Outlet};
    let (mut t, v1, _, p1) = tracker();
    let command = t.command(&[(v1, 100.0)], 1, false, ms(0)).unwrap();
    wait_all(&mut t, Outlet::Unsent, command, 1);
    let lockout = t.command(&[(p1, 0.0)], 2, true, ms(0)).unwrap();
    let (device, topic) = (t.actuators[p1.index()].device, "ctrl-1/pump/1/command");
    // Retained but not the lockout's payload, or the lockout's payload not retained: no lockout.
    let forged = t.keep_publish(Outlet::Unsent, device, topic.into(), "ON".into(), true, 1);
    assert_eq!(forged, Kept::Dropped { first: true });
    let unretained = t.keep_publish(Outlet::Unsent, device, topic.into(), "OFF".into(), false, 1);
    assert_eq!(unretained, Kept::Dropped { first: false });
    assert_eq!(
        wait_all(&mut t, Outlet::Unsent, lockout, 1),
        vec![Kept::Dropped { first: false }]
    );
    assert_eq!(
        t.kept_publishes(Outlet::Unsent),
        1,
        "the lockout took the command's place"
    );
    t.drop_kept(Outlet::Unsent);
    assert!(t.send_kept(Outlet::Unsent, ms(10)).is_empty());
}

#[test]
fn a_publish_not_sent_waits_or_is_dropped_as_why_it_could_not_go_out_says() {
    use outbox::{Blocked, Outlet, Told};
    let (mut t, v1, _, _) = tracker();
    let device = t.actuators[v1.index()].device;
    let not_sent = |t: &mut Tracker, blocked, bound| {
        t.not_sent(
            blocked,
            device,
            "ctrl-1/valve/1/command".into(),
            "100".into(),
            false,
            bound,
        )
    };
    assert_eq!(not_sent(&mut t, Blocked::Suspended, 1), Told::Nothing);
    assert_eq!(
        not_sent(&mut t, Blocked::Suspended, 1),
        Told::Dropped { bound: 1 }
    );
    assert_eq!(
        not_sent(&mut t, Blocked::Suspended, 1),
        Told::Nothing,
        "warned once"
    );
    assert_eq!(not_sent(&mut t, Blocked::Deploying, 0), Told::Nothing);
    assert_eq!(not_sent(&mut t, Blocked::Standby, 0), Told::Nothing);
    assert_eq!(
        (
            t.kept_publishes(Outlet::Held),
            t.kept_publishes(Outlet::Unsent)
        ),
        (1, 1),
        "a standby's is dropped"
    );
    assert_eq!(not_sent(&mut t, Blocked::Unserved, 0), Told::Unserved);
    assert_eq!(
        not_sent(&mut t, Blocked::Unserved, 0),
        Told::Nothing,
        "reported once"
    );
    t.serving_changed();
    assert_eq!(not_sent(&mut t, Blocked::Unserved, 0), Told::Unserved);
    assert_eq!(t.kept_publishes(Outlet::Unsent), 1);
}

#[test]
fn a_caller_whose_group_timed_out_or_failed_gets_the_code_and_words_of_it() {
    let mut t = Tracker::new(plant("fail-fast"), ms(0)).unwrap();
    let [v1, v2] = ["V1", "V2"].map(|n| t.actuator(n).unwrap());
    t.feedback(v1, 0.0, None, ms(0)).unwrap();
    t.feedback(v2, 0.0, None, ms(0)).unwrap();
    let terms = Terms {
        timeout: Some(ms(500)),
        ..Terms::default()
    };
    t.issue(&[(v2, 100.0), (v1, 10.0)], 1, terms, ms(0))
        .unwrap();
    let timed_out = t.tick(ms(500));
    let error = timed_out.iter().find_map(|e| t.outcome_error(e));
    assert_eq!(
        error,
        Some((
            Code::CommandTimeout,
            "group command did not complete within 0.5 s: V2, V1 had not completed; \
             the command was withdrawn (its actuators keep their last command)"
                .into()
        ))
    );
    t.command(&[(v1, 100.0)], 2, false, ms(600)).unwrap();
    t.tick(ms(1600));
    let failed = t.tick(ms(2600));
    let (code, message) = failed.iter().find_map(|e| t.outcome_error(e)).unwrap();
    assert_eq!(code, Code::CommandFailed);
    assert!(message.contains("V1"), "{message}");
    let done = t.command(&[(v2, 0.0)], 3, false, ms(3700)).unwrap();
    assert!(
        done.iter().all(|e| t.outcome_error(e).is_none()),
        "a publish is no failure"
    );
}

// ---- device timestamps ---------------------------------------------------------

#[test]
fn a_sample_stamped_beyond_the_clock_skew_is_refused_and_applies_nothing() {
    let (mut t, v1, _, _) = tracker();
    assert_eq!(t.plant().clock_skew_ms, ms(5000));
    let err = t.feedback(v1, 50.0, Some(ms(9001)), ms(4000)).unwrap_err();
    assert_eq!(
        err,
        TrackError::FutureTimestamp {
            actuator: "V1".into(),
            ahead_ms: ms(5001),
            skew_ms: ms(5000)
        }
    );
    assert_eq!(err.code(), "FUTURE_TIMESTAMP");
    assert_eq!(
        err.to_string(),
        "feedback for 'V1' is stamped 5001 ms ahead of its reception, more than clockSkewMs (5000 ms): set the device's clock (nothing of it was applied)"
    );
    assert_eq!(t.position(v1), Some(0.0), "no position");
    assert!(
        has(&t.tick(ms(5000)), |e| matches!(
            e,
            Effect::Fault { actuator, fault: FaultKind::Stale } if *actuator == v1
        )),
        "no freshness"
    );
    let at_limit = t.feedback(v1, 50.0, Some(ms(11_000)), ms(6000)).unwrap();
    assert!(has(&at_limit, |e| matches!(
        e,
        Effect::Changed {
            time_of_flight_ms: Some(-5000),
            ..
        }
    )));
    let later = t.feedback(v1, 60.0, Some(ms(6900)), ms(7000)).unwrap();
    assert!(has(&later, |e| matches!(
        e,
        Effect::Changed {
            time_of_flight_ms: Some(100),
            ..
        }
    )));
    assert!(
        t.feedback(v1, 0.0, Some(ms(u64::MAX)), ms(8000)).is_err(),
        "no overflow"
    );
}

#[test]
fn a_device_clock_that_jumps_back_is_still_heard_in_arrival_order() {
    let (mut t, v1, _, _) = tracker();
    t.feedback(v1, 10.0, Some(ms(9900)), ms(10_000)).unwrap();
    let jumped = t.feedback(v1, 20.0, Some(ms(2000)), ms(10_100)).unwrap();
    assert!(has(&jumped, |e| matches!(
        e,
        Effect::Changed { value, time_of_flight_ms: Some(8100), .. } if *value == 20.0
    )));
    assert_eq!(t.position(v1), Some(20.0));
}

#[test]
fn a_batch_stamped_beyond_the_clock_skew_is_refused_whole() {
    let (mut t, v1, v2, p1) = tracker();
    let mut effects = Vec::new();
    let err = t
        .feedback_batch(
            &[(v1, 50.0), (p1, 0.3), (v2, 40.0)],
            Some(ms(20_000)),
            ms(10_000),
            &mut effects,
        )
        .unwrap_err();
    assert_eq!(err.code(), "FUTURE_TIMESTAMP");
    assert!(err.to_string().contains("10000 ms ahead"), "{err}");
    assert!(effects.is_empty(), "no per-sample rejection, no effect");
    assert_eq!((t.position(v1), t.position(v2)), (Some(0.0), Some(0.0)));
    let rejected = t
        .feedback_batch(
            &[(v1, 50.0), (v2, 40.0)],
            Some(ms(9000)),
            ms(10_000),
            &mut effects,
        )
        .unwrap();
    assert!(rejected.is_empty());
    assert_eq!((t.position(v1), t.position(v2)), (Some(50.0), Some(40.0)));
    assert_eq!(
        t.feedback_batch(&[], Some(ms(u64::MAX)), ms(10_000), &mut effects),
        Ok(Vec::new()),
        "an empty batch has nothing to refuse"
    );
}

/// P1 (an ESPHome switch) and V1 (an ESPHome valve), both on change only.
fn esphome_tracker() -> (Tracker, ActuatorId, ActuatorId) {
    let plant: PlantModel = serde_json::from_value(json!({
        "actuatorTypes": {
            "valve": { "signal": "analog", "tolerance": 2, "noMotionMs": 1000, "completionMs": 3000, "staleMs": 5000 },
            "pump": { "signal": "binary", "noMotionMs": 1000, "completionMs": 2000, "staleMs": 5000 }
        },
        "devices": [{ "id": "ctrl-1", "kind": "actuator-panel", "profile": "esphome" }],
        "actuators": [
            { "id": "V1", "type": "valve", "device": "ctrl-1", "idle": 0, "lockout": 0 },
            { "id": "P1", "type": "pump", "device": "ctrl-1", "idle": false, "lockout": false }
        ]
    }))
    .unwrap();
    let mut t = Tracker::new(plant, ms(0)).unwrap();
    let [v1, p1] = ["V1", "P1"].map(|n| t.actuator(n).unwrap());
    t.feedback(v1, 0.0, None, ms(0)).unwrap();
    t.feedback(p1, 1.0, None, ms(0)).unwrap();
    (t, v1, p1)
}

#[test]
fn an_on_change_device_is_not_stale_while_idle_and_a_command_to_its_state_completes_at_once() {
    let (mut t, v1, p1) = esphome_tracker();
    // An hour of silence: nothing moved, nothing to say.
    assert!(t.tick(ms(3_600_000)).is_empty());
    assert_eq!(t.phase(p1), Some(Phase::Idle));
    // The switch deduplicates: ON again publishes nothing back; the command is done at once.
    let effects = t.command(&[(p1, 1.0)], 7, false, ms(3_600_000)).unwrap();
    assert!(completes_group(&effects, 7, 0));
    assert_eq!(
        publishes(&effects),
        vec![(
            "ctrl-1/switch/p1/command".to_owned(),
            "ON".to_owned(),
            false
        )]
    );
    // A real move still has its no-motion threshold.
    let effects = t.command(&[(v1, 100.0)], 8, false, ms(3_600_000)).unwrap();
    assert_eq!(
        publishes(&effects),
        vec![(
            "ctrl-1/valve/v1/position/command".to_owned(),
            "100".to_owned(),
            false
        )]
    );
    let faults = t.tick(ms(3_601_000));
    assert!(
        faults.iter().any(|e| matches!(
            e,
            Effect::Retry {
                fault: FaultKind::NoMotion,
                ..
            }
        ) || matches!(
            e,
            Effect::GroupFailed {
                fault: FaultKind::NoMotion,
                ..
            }
        )),
        "{faults:?}"
    );
}

#[test]
fn an_on_change_device_going_offline_fails_its_commands_at_once() {
    let (mut t, v1, _) = esphome_tracker();
    t.command(&[(v1, 100.0)], 9, false, ms(10)).unwrap();
    let device = t.device("ctrl-1").unwrap();
    let effects = t.device_status(device, false, ms(20)).unwrap();
    assert!(effects.iter().any(|e| matches!(
        e,
        Effect::GroupFailed {
            caller: 9,
            fault: FaultKind::DeviceOffline,
            ..
        }
    )));
}

#[test]
fn what_was_heard_goes_from_nothing_to_the_device_to_the_actuator() {
    let mut t = Tracker::new(plant("fail-fast"), ms(0)).unwrap();
    let [v1, v2, v9] = ["V1", "V2", "V9"].map(|n| t.actuator(n).unwrap());
    assert_eq!(
        t.heard(v1),
        Some(Heard::Nothing),
        "a new plant has heard nothing"
    );
    let ctrl1 = t.device("ctrl-1").unwrap();
    // Its status alone (a device speaking another profile is still seen online).
    t.device_status(ctrl1, true, ms(10)).unwrap();
    assert_eq!(t.heard(v1), Some(Heard::DeviceOnly));
    t.feedback(v2, 0.0, None, ms(20)).unwrap();
    assert_eq!(
        t.heard(v1),
        Some(Heard::DeviceOnly),
        "another actuator's feedback is not V1's"
    );
    assert_eq!(t.heard(v2), Some(Heard::Feedback));
    assert_eq!(
        t.heard(v9),
        Some(Heard::Nothing),
        "ctrl-2 is another device"
    );
    t.feedback(v9, 0.0, None, ms(30)).unwrap();
    assert_eq!(
        t.heard(v9),
        Some(Heard::Feedback),
        "a sample is heard without a status"
    );
    assert_eq!(t.heard(ActuatorId(99)), None);
}

#[test]
fn a_failed_group_carries_its_commands_retries_code_and_words() {
    let (mut t, v1, _, p1) = tracker();
    t.command(&[(v1, 100.0)], 1, false, ms(0)).unwrap();
    t.feedback(v1, 20.0, None, ms(500)).unwrap();
    t.tick(ms(3000));
    t.feedback(v1, 40.0, None, ms(3500)).unwrap();
    let failed = t.tick(ms(6000));
    let Some(Effect::GroupFailed {
        retries,
        code,
        message,
        ..
    }) = failed
        .iter()
        .find(|e| matches!(e, Effect::GroupFailed { .. }))
    else {
        panic!("{failed:?}");
    };
    assert_eq!((*retries, *code), (1, Code::CommandFailed));
    assert_eq!(
        message,
        "valve V1 did not reach 100 within 3 s of its command (after 1 retry)"
    );
    // Taken over by a lockout before any retry: its own code, no retries.
    t.feedback(p1, 0.0, None, ms(6000)).unwrap();
    t.command(&[(p1, 1.0)], 2, false, ms(6000)).unwrap();
    let lockout = t.command(&[(p1, 0.0)], 3, true, ms(6100)).unwrap();
    assert!(has(&lockout, |e| matches!(
        e,
        Effect::GroupFailed { caller: 2, retries: 0, code: Code::LockedOut, message, .. }
            if message == "pump P1 was taken over by a lockout command before it completed"
    )));
}

#[test]
fn only_commands_that_had_to_move_are_timed() {
    let (mut t, v1, v2, _) = tracker();
    let in_place = t.command(&[(v1, 1.0)], 1, false, ms(10)).unwrap();
    assert!(has(&in_place, |e| matches!(
        e,
        Effect::Completed { timed: false, completion_ms, .. } if *completion_ms == Millis::ZERO
    )));
    t.command(&[(v2, 50.0)], 2, false, ms(20)).unwrap();
    let moved = t.feedback(v2, 50.0, None, ms(20)).unwrap();
    assert!(
        has(&moved, |e| matches!(
            e,
            Effect::Completed { timed: true, .. }
        )),
        "arrived in the same ms: still a figure of motion"
    );
}

#[test]
fn a_lockout_after_a_fault_reports_the_time_from_the_fault_to_isolation() {
    let (mut t, v1, v2, _) = tracker();
    let after_fault = |at: u64| Terms {
        lockout: true,
        fault_at: Some(ms(at)),
        timeout: None,
    };
    t.issue(&[(v1, 0.0), (v2, 50.0)], 1, after_fault(750), ms(1000))
        .unwrap();
    let done = t.feedback(v2, 49.0, None, ms(1040)).unwrap();
    assert!(has(&done, |e| matches!(
        e,
        Effect::GroupCompleted { caller: 1, completion_ms, fault_lockout_ms: Some(f), .. }
            if *completion_ms == ms(40) && *f == ms(290)
    )));
    // All in place at once; a fault time after the command counts as none elapsed.
    let at_once = t
        .issue(&[(v1, 0.0)], 2, after_fault(5000), ms(1100))
        .unwrap();
    assert!(has(&at_once, |e| matches!(
        e,
        Effect::GroupCompleted { caller: 2, fault_lockout_ms: Some(f), .. } if *f == Millis::ZERO
    )));
    let plain = t.command(&[(v1, 10.0)], 3, false, ms(1200)).unwrap();
    assert!(!has(&plain, |e| matches!(e, Effect::GroupCompleted { .. })));
    let done = t.feedback(v1, 10.0, None, ms(1300)).unwrap();
    assert!(has(&done, |e| matches!(
        e,
        Effect::GroupCompleted {
            caller: 3,
            fault_lockout_ms: None,
            ..
        }
    )));
}

#[test]
fn a_device_reads_offline_above_stale_above_online() {
    let (mut t, v1, _, _) = tracker();
    let state = |t: &Tracker, d: &str| t.device_health_of(t.device(d).unwrap()).unwrap().state();
    assert_eq!(state(&t, "ctrl-1"), Availability::Online);
    // V9 never reported: after staleMs it is stale, so ctrl-2 is.
    t.tick(ms(5000));
    assert_eq!(state(&t, "ctrl-2"), Availability::Stale);
    assert_eq!(state(&t, "ctrl-1"), Availability::Stale);
    t.feedback(v1, 0.0, None, ms(5100)).unwrap();
    let ctrl1 = t.device("ctrl-1").unwrap();
    t.device_status(ctrl1, false, ms(5200)).unwrap();
    assert_eq!(state(&t, "ctrl-1"), Availability::Offline);
    assert_eq!(t.devices_offline(), vec!["ctrl-1".to_owned()]);
    let json = serde_json::to_value(t.device_health()).unwrap();
    assert_eq!(json[0]["state"], "offline");
    assert_eq!(json[1]["state"], "stale");
    assert_eq!(json[1]["stale"], json!(["V9"]));
}

#[test]
fn a_group_past_its_timeout_is_withdrawn_at_the_first_tick_naming_what_it_waited_for() {
    let mut t = Tracker::new(plant("hang"), ms(0)).unwrap();
    let [v1, v2, p1] = ["V1", "V2", "P1"].map(|n| t.actuator(n).unwrap());
    t.feedback(v1, 0.0, None, ms(0)).unwrap();
    t.feedback(v2, 0.0, None, ms(0)).unwrap();
    let waits = |timeout: u64| Terms {
        timeout: Some(ms(timeout)),
        ..Terms::default()
    };
    t.issue(&[(v2, 100.0), (v1, 10.0)], 1, waits(1500), ms(100))
        .unwrap();
    t.issue(&[(p1, 1.0)], 2, waits(0), ms(100)).unwrap();
    assert_eq!(
        t.next_deadline(),
        Some(ms(1600)),
        "no limit for a 0 timeout"
    );
    t.feedback(v1, 10.0, None, ms(500)).unwrap();
    assert!(!has(&t.tick(ms(1599)), |e| matches!(
        e,
        Effect::GroupTimedOut { .. }
    )));
    let timed_out = t.tick(ms(1600));
    assert_eq!(
        timed_out.first(),
        Some(&Effect::GroupTimedOut {
            caller: 1,
            timeout_ms: ms(1500),
            waiting: vec![v2],
            actuators: vec![Reached {
                actuator: v1,
                target: 10.0,
                issue_to_motion_ms: ms(400),
                completion_ms: ms(400),
                retries: 0,
            }],
        })
    );
    assert_eq!(t.phase(v2), Some(Phase::Idle), "withdrawn");
    assert_eq!(t.next_deadline(), None);
    assert!(!t.withdraw(1), "already answered");
}

#[test]
fn a_group_outcome_lists_the_actuators_that_reached_their_targets_in_that_order() {
    let (mut t, v1, v2, p1) = tracker();
    let at = |actuator, target, motion, completion| Reached {
        actuator,
        target,
        issue_to_motion_ms: ms(motion),
        completion_ms: ms(completion),
        retries: 0,
    };
    // V1 is at 0 already; P1 then V2 get there.
    t.command(&[(v2, 100.0), (v1, 0.0), (p1, 1.0)], 1, false, ms(100))
        .unwrap();
    t.feedback(p1, 1.0, None, ms(600)).unwrap();
    t.feedback(v2, 40.0, None, ms(700)).unwrap();
    let done = t.feedback(v2, 100.0, None, ms(1100)).unwrap();
    let outcome = done
        .iter()
        .find(|e| matches!(e, Effect::GroupCompleted { .. }));
    let Some(Effect::GroupCompleted { actuators, .. }) = outcome else {
        panic!("completed: {done:?}");
    };
    assert_eq!(
        actuators,
        &vec![
            at(v1, 0.0, 0, 0),
            at(p1, 1.0, 500, 500),
            at(v2, 100.0, 600, 1000)
        ]
    );

    // A failed group lists those that got there before it failed.
    t.command(&[(p1, 0.0), (v1, 50.0)], 2, false, ms(2000))
        .unwrap();
    t.feedback(p1, 0.0, None, ms(2300)).unwrap();
    let ctrl1 = t.device("ctrl-1").unwrap();
    let failed = t.device_status(ctrl1, false, ms(2400)).unwrap();
    let outcome = failed
        .iter()
        .find(|e| matches!(e, Effect::GroupFailed { .. }));
    let Some(Effect::GroupFailed {
        actuators,
        actuator,
        ..
    }) = outcome
    else {
        panic!("failed: {failed:?}");
    };
    assert_eq!(*actuator, v1);
    assert_eq!(actuators, &vec![at(p1, 0.0, 300, 300)]);
}

#[test]
fn only_device_status_fault_and_recovery_move_health_and_a_new_value_leaves_the_status() {
    let (mut t, v1, _, _) = tracker();
    let moved = t.feedback(v1, 40.0, None, ms(100)).unwrap();
    let value = moved
        .iter()
        .find(|e| matches!(e, Effect::Changed { .. }))
        .expect("a new value");
    assert!(!value.moves_status() && !value.moves_health());
    for e in &moved {
        assert_eq!(
            e.moves_status(),
            !matches!(e, Effect::Changed { .. }),
            "{e:?}"
        );
    }
    let issued = t.command(&[(v1, 80.0)], 7, false, ms(150)).unwrap();
    assert!(!issued.is_empty());
    for e in &issued {
        assert!(e.moves_status(), "{e:?}");
        assert_eq!(
            e.moves_health(),
            matches!(
                e,
                Effect::DeviceStatus { .. } | Effect::Fault { .. } | Effect::Recovered { .. }
            )
        );
    }
    let ctrl1 = t.device("ctrl-1").unwrap();
    let offline = t.device_status(ctrl1, false, ms(200)).unwrap();
    assert!(offline
        .iter()
        .any(|e| matches!(e, Effect::DeviceStatus { .. }) && e.moves_health()));
}

#[test]
fn a_device_served_by_no_node_is_reported_once_until_the_serving_nodes_change() {
    let (mut t, _, _, _) = tracker();
    let [ctrl1, ctrl2] = ["ctrl-1", "ctrl-2"].map(|n| t.device(n).unwrap());
    assert!(t.unserved(ctrl1));
    assert!(!t.unserved(ctrl1));
    assert!(t.unserved(ctrl2), "each device is reported on its own");
    t.serving_changed();
    assert!(t.unserved(ctrl1));
    assert!(!t.unserved(ctrl1));
    assert!(!t.unserved(DeviceId::from_index(99)), "no such device");
}

#[test]
fn a_group_outcome_is_told_to_its_caller_by_actuator_and_device_ids() {
    let (mut t, v1, v2, p1) = tracker();
    let reached = |id: &str, target, motion, completion| ReachedBy {
        actuator: id.into(),
        target,
        issue_to_motion_ms: ms(motion),
        completion_ms: ms(completion),
        retries: 0,
    };
    t.command(&[(v1, 0.0), (p1, 1.0)], 1, false, ms(100))
        .unwrap();
    let done = t.feedback(p1, 1.0, None, ms(600)).unwrap();
    let completed = done.iter().find_map(|e| t.outcome(e)).unwrap();
    assert_eq!(
        completed,
        Outcome {
            completion_ms: Some(ms(500)),
            fault_lockout_ms: None,
            waiting: None,
            failed: None,
            actuators: vec![reached("V1", 0.0, 0, 0), reached("P1", 1.0, 500, 500)],
        }
    );
    t.command(&[(p1, 0.0), (v2, 50.0)], 2, false, ms(2000))
        .unwrap();
    t.feedback(p1, 0.0, None, ms(2300)).unwrap();
    let ctrl1 = t.device("ctrl-1").unwrap();
    let failed = t.device_status(ctrl1, false, ms(2400)).unwrap();
    let outcome = failed.iter().find_map(|e| t.outcome(e)).unwrap();
    assert_eq!(
        outcome.failed,
        Some(Failed {
            actuator: "V2".into(),
            device: "ctrl-1".into(),
            fault: FaultKind::DeviceOffline,
            retries: 0,
        })
    );
    assert_eq!(outcome.actuators, vec![reached("P1", 0.0, 300, 300)]);
    assert!(failed
        .iter()
        .filter(|e| !matches!(e, Effect::GroupFailed { .. }))
        .all(|e| t.outcome(e).is_none()));
    let timed_out = Effect::GroupTimedOut {
        caller: 3,
        timeout_ms: ms(1500),
        waiting: vec![v2, v1],
        actuators: Vec::new(),
    };
    let told = t.outcome(&timed_out).unwrap();
    assert_eq!(told.waiting, Some(vec!["V2".to_string(), "V1".to_string()]));
    assert_eq!(
        serde_json::to_value(&told).unwrap(),
        json!({ "waiting": ["V2", "V1"], "actuators": [] })
    );
}
