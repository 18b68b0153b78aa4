use super::*;
use serde_json::json;

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
    let mut t = Tracker::new(plant("fail-fast"), 0).unwrap();
    let [v1, v2, p1] = ["V1", "V2", "P1"].map(|n| t.actuator(n).unwrap());
    for id in [v1, v2, p1] {
        t.feedback(id, 0.0, None, 0).unwrap();
    }
    (t, v1, v2, p1)
}

fn publishes(effects: &[Effect]) -> Vec<(String, String, bool)> {
    effects
        .iter()
        .filter_map(|e| match e {
            Effect::Publish {
                topic,
                payload,
                retain,
            } => Some((topic.clone(), payload.clone(), *retain)),
            _ => None,
        })
        .collect()
}

fn has(effects: &[Effect], wanted: impl Fn(&Effect) -> bool) -> bool {
    effects.iter().any(wanted)
}

#[test]
fn a_command_goes_from_pending_to_moving_to_stopped() {
    let (mut t, v1, _, _) = tracker();
    let sent = t.command(&[(v1, 100.0)], 1, false, 100).unwrap();
    assert_eq!(
        publishes(&sent),
        vec![("ctrl-1/valve/1/command".into(), "100".into(), false)]
    );
    assert_eq!(t.phase(v1), Some(Phase::Pending));
    let noise = t.feedback(v1, 1.5, None, 600).unwrap();
    assert!(
        !has(&noise, |e| matches!(e, Effect::Moving { .. })),
        "within tolerance of the start is not motion"
    );
    let moving = t.feedback(v1, 30.0, None, 2100).unwrap();
    assert!(has(&moving, |e| matches!(
        e,
        Effect::Moving {
            issue_to_motion_ms: 2000,
            caller: 1,
            ..
        }
    )));
    assert_eq!(t.phase(v1), Some(Phase::Moving));
    let done = t.feedback(v1, 98.5, None, 3100).unwrap();
    assert!(has(&done, |e| matches!(
        e,
        Effect::Completed {
            issue_to_motion_ms: 2000,
            completion_ms: 3000,
            retries: 0,
            ..
        }
    )));
    assert!(has(&done, |e| matches!(
        e,
        Effect::GroupCompleted {
            caller: 1,
            completion_ms: 3000
        }
    )));
    assert_eq!(t.phase(v1), Some(Phase::Stopped));
}

#[test]
fn a_group_returns_once_every_actuator_is_done() {
    let (mut t, v1, v2, p1) = tracker();
    let sent = t
        .command(&[(v1, 50.0), (v2, 100.0), (p1, 1.0)], 9, false, 0)
        .unwrap();
    assert_eq!(publishes(&sent).len(), 3);
    assert_eq!(
        publishes(&sent)[2],
        ("ctrl-1/pump/1/command".into(), "ON".into(), false)
    );
    let pump = t.feedback(p1, 1.0, None, 500).unwrap();
    assert!(
        has(&pump, |e| matches!(e, Effect::Moving { .. }))
            && has(&pump, |e| matches!(e, Effect::Completed { .. }))
    );
    t.feedback(v1, 50.0, None, 900).unwrap();
    let before = t.feedback(v2, 60.0, None, 900).unwrap();
    assert!(!has(&before, |e| matches!(
        e,
        Effect::GroupCompleted { .. }
    )));
    let last = t.feedback(v2, 100.0, None, 1500).unwrap();
    assert!(has(&last, |e| matches!(
        e,
        Effect::GroupCompleted {
            caller: 9,
            completion_ms: 1500
        }
    )));
}

#[test]
fn a_command_to_where_it_already_is_completes_at_once() {
    let (mut t, v1, _, _) = tracker();
    let effects = t.command(&[(v1, 1.0)], 3, false, 50).unwrap();
    assert_eq!(
        publishes(&effects).len(),
        1,
        "still sent, so the device holds the commanded state"
    );
    assert!(has(&effects, |e| matches!(
        e,
        Effect::GroupCompleted {
            caller: 3,
            completion_ms: 0
        }
    )));
    assert_eq!(t.counts().moving, 0);
}

#[test]
fn bad_commands_send_nothing_and_change_nothing() {
    let (mut t, v1, v2, p1) = tracker();
    t.command(&[(v1, 100.0)], 1, false, 0).unwrap();
    let refused = |t: &mut Tracker, targets: &[(ActuatorId, f64)]| {
        t.command(targets, 2, false, 10).unwrap_err().code()
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
        t.command(&[(v2, 10.0)], 1, false, 10).unwrap_err().code(),
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
    t.command(&[(v1, 100.0)], 1, false, 0).unwrap();
    assert!(t.tick(999).is_empty(), "just before T");
    let retry = t.tick(1000);
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
    assert!(t.tick(1999).is_empty(), "a fresh window for the retry");
    let failed = t.tick(2000);
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
    assert!(t.tick(2001).is_empty(), "escalates once");
    // A faulted actuator can still be commanded (a lockout must always go through).
    assert!(t.command(&[(v1, 0.0)], 2, false, 2100).is_ok());
}

#[test]
fn target_not_reached_counts_from_the_attempt() {
    let (mut t, v1, _, _) = tracker();
    t.command(&[(v1, 100.0)], 1, false, 0).unwrap();
    t.feedback(v1, 20.0, None, 500).unwrap();
    assert!(t.tick(2999).is_empty());
    assert!(has(&t.tick(3000), |e| matches!(
        e,
        Effect::Retry {
            fault: FaultKind::NotReached,
            ..
        }
    )));
    t.feedback(v1, 40.0, None, 3500).unwrap();
    let failed = t.tick(6000);
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
    let mut t = Tracker::new(plant("hang"), 0).unwrap();
    let v1 = t.actuator("V1").unwrap();
    t.feedback(v1, 0.0, None, 0).unwrap();
    t.command(&[(v1, 100.0)], 1, false, 0).unwrap();
    t.tick(1000);
    let escalated = t.tick(2000);
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
    let late = t.feedback(v1, 100.0, None, 9000).unwrap();
    assert!(has(&late, |e| matches!(
        e,
        Effect::GroupCompleted {
            caller: 1,
            completion_ms: 9000
        }
    )));
    assert!(!t.withdraw(1), "already answered");
}

#[test]
fn uncommanded_movement_while_idle_is_a_fault_once_per_excursion() {
    let (mut t, v1, _, _) = tracker();
    assert!(t
        .feedback(v1, 1.9, None, 10)
        .unwrap()
        .iter()
        .all(|e| !matches!(e, Effect::Fault { .. })));
    let moved = t.feedback(v1, 2.1, None, 20).unwrap();
    assert!(has(&moved, |e| matches!(
        e,
        Effect::Fault {
            fault: FaultKind::Uncommanded,
            ..
        }
    )));
    assert!(!has(
        &t.feedback(v1, 40.0, None, 30).unwrap(),
        |e| matches!(e, Effect::Fault { .. })
    ));
    let back = t.feedback(v1, 0.5, None, 40).unwrap();
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
    t.command(&[(v1, 100.0)], 1, false, 4000).unwrap();
    t.feedback(v1, 10.0, None, 4500).unwrap();
    // V2 last reported at 0: stale at exactly 5000.
    let at_4999 = t.tick(4999);
    assert!(!has(
        &at_4999,
        |e| matches!(e, Effect::Fault { actuator, .. } if *actuator == v2)
    ));
    let at_5000 = t.tick(5000);
    assert!(has(
        &at_5000,
        |e| matches!(e, Effect::Fault { actuator, fault: FaultKind::Stale } if *actuator == v2)
    ));
    assert!(
        !has(&at_5000, |e| matches!(e, Effect::GroupFailed { .. })),
        "V1 reported at 4500"
    );
    let recovered = t.feedback(v2, 0.0, None, 6000).unwrap();
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
    let stale_v1 = t.tick(9500);
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
    t.command(&[(v1, 100.0)], 1, false, 0).unwrap();
    let offline = t.device_status(ctrl1, false, 100).unwrap();
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
        t.command(&[(v2, 50.0)], 2, false, 200).unwrap_err().code(),
        "DEVICE_OFFLINE"
    );
    let later = t.tick(60_000);
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
    let online = t.device_status(ctrl1, true, 300).unwrap();
    assert_eq!(
        publishes(&online),
        vec![("ctrl-1/valve/1/command".into(), "100".into(), false)],
        "commanded state re-sent"
    );
    assert!(
        t.device_status(ctrl1, true, 301).unwrap().is_empty(),
        "no change, no effect"
    );
}

#[test]
fn lockouts_are_retained_take_over_and_are_cleared_by_the_next_command() {
    let (mut t, v1, _, p1) = tracker();
    t.command(&[(v1, 100.0), (p1, 1.0)], 1, false, 0).unwrap();
    let lockout = t.command(&[(v1, 0.0), (p1, 0.0)], 2, true, 100).unwrap();
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
    let ctrl1 = t.device("ctrl-1").unwrap();
    t.device_status(ctrl1, false, 200).unwrap();
    let back = t.device_status(ctrl1, true, 300).unwrap();
    assert!(
        publishes(&back).iter().all(|(_, _, retain)| *retain),
        "lockouts re-sent retained"
    );
    let next = t.command(&[(p1, 1.0)], 3, false, 400).unwrap();
    assert_eq!(
        publishes(&next),
        vec![
            ("ctrl-1/pump/1/command".into(), String::new(), true),
            ("ctrl-1/pump/1/command".into(), "ON".into(), false)
        ],
        "the retained lockout is cleared before a normal command"
    );
}

#[test]
fn changes_are_reported_by_exception_with_time_of_flight() {
    let (mut t, v1, _, _) = tracker();
    let first = t.feedback(v1, 10.0, Some(900), 1000).unwrap();
    assert!(has(
        &first,
        |e| matches!(e, Effect::Changed { value, time_of_flight_ms: Some(100), .. } if *value == 10.0)
    ));
    assert!(!has(
        &t.feedback(v1, 11.9, Some(1900), 2000).unwrap(),
        |e| matches!(e, Effect::Changed { .. })
    ));
    assert!(has(
        &t.feedback(v1, 12.1, None, 3000).unwrap(),
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
    let rejected = t.feedback_batch(
        &[(v1, 50.0), (p1, 0.3), (v2, f64::NAN)],
        Some(10),
        20,
        &mut effects,
    );
    let codes: Vec<(ActuatorId, &str)> =
        rejected.iter().map(|(id, err)| (*id, err.code())).collect();
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
    t.command(&[(v1, 100.0), (v2, 100.0)], 5, false, 0).unwrap();
    assert!(t.withdraw(5));
    assert_eq!(
        t.counts(),
        Counts {
            moving: 0,
            stopped: 0,
            faulted: 0
        }
    );
    assert!(t.tick(1500).is_empty(), "nothing left to time out");
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
    let t = Tracker::new(serde_json::from_value(doc).unwrap(), 0).unwrap();
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
