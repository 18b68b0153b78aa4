#![cfg(target_arch = "wasm32")]

//! The tracker's JS boundary, run under Node: plant errors, group commands as
//! plain objects, typed-array batches, effects and rejections.

use js_sys::Array;
use sugarshack_wasm::Tracker;
use wasm_bindgen::{JsCast, JsValue};
use wasm_bindgen_test::wasm_bindgen_test;

mod support;
use support::{code_of, get, json, message_of};

const PLANT: &str = r#"{
    "actuatorTypes": {
        "valve": { "signal": "analog", "tolerance": 2, "noMotionMs": 1000, "completionMs": 5000, "staleMs": 5000, "retries": 0 },
        "pump": { "signal": "binary", "noMotionMs": 1000, "completionMs": 3000, "staleMs": 5000 }
    },
    "devices": [{ "id": "ctrl-1", "kind": "actuator-panel" }],
    "actuators": [
        { "id": "V12", "type": "valve", "device": "ctrl-1", "io": 12, "idle": 0, "lockout": 0 },
        { "id": "P1", "type": "pump", "device": "ctrl-1", "io": 1, "idle": false, "lockout": false }
    ]
}"#;

fn kinds(effects: &JsValue) -> Vec<String> {
    Array::from(effects)
        .iter()
        .map(|e| get(&e, "kind").as_string().unwrap())
        .collect()
}

#[wasm_bindgen_test]
fn a_broken_plant_lists_every_problem() {
    let err = Tracker::new(json(r#"{ "actuatorTypes": {}, "devices": [],
        "actuators": [{ "id": "V1", "type": "valve", "device": "ctrl-9", "io": 1, "idle": 0, "lockout": 0 }] }"#), 0.0)
    .err()
    .unwrap();
    let message: String = err.dyn_ref::<js_sys::Error>().unwrap().message().into();
    assert!(
        message.contains("actuators[0] (V1): unknown device 'ctrl-9'"),
        "{message}"
    );
    assert!(
        message.contains("actuators[0] (V1): unknown type 'valve'"),
        "{message}"
    );
    assert_eq!(code_of(err), "INVALID_PLANT");
}

#[wasm_bindgen_test]
fn a_group_command_runs_from_plain_objects_to_completion() {
    let mut t = Tracker::new(json(PLANT), 0.0).unwrap();
    let actuators = Array::from(&t.actuators().unwrap());
    assert_eq!(actuators.length(), 2);
    assert_eq!(get(&actuators.get(1), "binary").as_bool(), Some(true));
    let ctrl1 = t.device("ctrl-1").unwrap();
    let v12 = t.slot(ctrl1, "valve", 12).unwrap();
    let p1 = t.slot(ctrl1, "pump", 1).unwrap();
    assert_eq!(t.slot(ctrl1, "valve", 3), None);
    t.feedback_batch(&[v12, p1], &[0.0, 0.0], Some(0.0), 10.0)
        .unwrap();
    t.take_effects().unwrap();

    let queued = t
        .command(
            json(r#"{ "valves": { "V12": 100 }, "pumps": { "P1": true } }"#),
            7,
            false,
            100.0,
            None,
            None,
            None,
        )
        .unwrap();
    assert_eq!(queued, 2);
    let sent = t.take_effects().unwrap();
    let first = Array::from(&sent).get(0);
    assert_eq!(
        get(&first, "topic").as_string().as_deref(),
        Some("ctrl-1/valve/12/command")
    );
    assert_eq!(get(&first, "payload").as_string().as_deref(), Some("100"));
    assert_eq!(get(&first, "retain").as_bool(), Some(false));
    assert_eq!(
        get(&Array::from(&sent).get(1), "payload")
            .as_string()
            .as_deref(),
        Some("ON")
    );

    t.feedback_batch(&[v12, p1], &[50.0, 1.0], Some(1900.0), 2000.0)
        .unwrap();
    t.feedback_batch(&[v12, p1], &[99.0, 1.0], Some(2900.0), 3000.0)
        .unwrap();
    let effects = t.take_effects().unwrap();
    let seen = kinds(&effects);
    assert!(
        seen.contains(&"moving".to_string()) && seen.contains(&"completed".to_string()),
        "{seen:?}"
    );
    let done = Array::from(&effects)
        .iter()
        .find(|e| get(e, "kind").as_string().as_deref() == Some("groupCompleted"))
        .unwrap();
    assert_eq!(get(&done, "caller").as_f64(), Some(7.0));
    assert_eq!(get(&done, "completionMs").as_f64(), Some(2900.0));
    let changed = Array::from(&effects)
        .iter()
        .find(|e| get(e, "kind").as_string().as_deref() == Some("changed"))
        .unwrap();
    assert_eq!(get(&changed, "timeOfFlightMs").as_f64(), Some(100.0));
    assert_eq!(t.phase(v12).unwrap(), "stopped");
}

#[wasm_bindgen_test]
fn refusals_throw_coded_errors_and_send_nothing() {
    let mut t = Tracker::new(json(PLANT), 0.0).unwrap();
    t.command(
        json(r#"{ "valves": { "V12": 100 } }"#),
        1,
        false,
        0.0,
        None,
        None,
        None,
    )
    .unwrap();
    t.take_effects().unwrap();
    let code = |t: &mut Tracker, payload: &str| {
        code_of(
            t.command(json(payload), 2, false, 10.0, None, None, None)
                .unwrap_err(),
        )
    };
    for (payload, expected) in [
        (r#"{ "valves": { "V12": 0 } }"#, "STILL_MOVING"),
        (r#"{ "valves": { "V99": 0 } }"#, "UNKNOWN_ACTUATOR"),
        (r#"{ "pumps": { "P1": 5 } }"#, "INVALID_TARGET"),
        (r#"{ "valves": { "P1": 0 } }"#, "INVALID_GROUP"),
        (r#""open everything""#, "INVALID_GROUP"),
    ] {
        assert_eq!(code(&mut t, payload), expected, "{payload}");
    }
    assert_eq!(
        Array::from(&t.take_effects().unwrap()).length(),
        0,
        "nothing queued by refusals"
    );
}

#[wasm_bindgen_test]
fn bad_samples_in_a_batch_come_back_as_rejections() {
    let mut t = Tracker::new(json(PLANT), 0.0).unwrap();
    let v12 = t.actuator("V12").unwrap();
    let p1 = t.actuator("P1").unwrap();
    t.feedback_batch(&[v12, p1], &[f64::NAN, 0.5], None, 10.0)
        .unwrap();
    let effects = Array::from(&t.take_effects().unwrap());
    let rejected: Vec<JsValue> = effects
        .iter()
        .filter(|e| get(e, "kind").as_string().as_deref() == Some("rejected"))
        .collect();
    assert_eq!(rejected.len(), 2);
    assert_eq!(get(&rejected[1], "actuator").as_f64(), Some(f64::from(p1)));
    assert_eq!(
        get(&rejected[1], "code").as_string().as_deref(),
        Some("INVALID_FEEDBACK")
    );
    assert_eq!(
        code_of(
            t.feedback_batch(&[v12], &[1.0, 2.0], None, 20.0)
                .unwrap_err()
        ),
        "INVALID_FEEDBACK"
    );
    let counts = t.counts().unwrap();
    assert_eq!(get(&counts, "faulted").as_f64(), Some(0.0));
}

#[wasm_bindgen_test]
fn counts_on_a_device_list_count_only_its_actuators() {
    let mut t = Tracker::new(
        json(
            r#"{
        "actuatorTypes": { "valve": { "signal": "analog", "tolerance": 2, "noMotionMs": 1000, "completionMs": 5000, "staleMs": 5000 } },
        "devices": [{ "id": "ctrl-1", "kind": "actuator-panel" }, { "id": "ctrl-2", "kind": "actuator-panel" }],
        "actuators": [
            { "id": "V1", "type": "valve", "device": "ctrl-1", "io": 1, "idle": 0, "lockout": 0 },
            { "id": "V2", "type": "valve", "device": "ctrl-2", "io": 1, "idle": 0, "lockout": 0 },
            { "id": "V3", "type": "valve", "device": "ctrl-2", "io": 2, "idle": 0, "lockout": 0 }
        ]
    }"#,
        ),
        0.0,
    )
    .unwrap();
    t.command(
        json(r#"{ "valves": { "V2": 100, "V3": 100 } }"#),
        1,
        false,
        0.0,
        None,
        None,
        None,
    )
    .unwrap();
    t.command(
        json(r#"{ "valves": { "V1": 0 } }"#),
        2,
        true,
        0.0,
        None,
        None,
        None,
    )
    .unwrap();
    let moving = |c: &JsValue| get(c, "moving").as_f64().unwrap();
    let on_two = t.counts_on(&[1]).unwrap();
    assert_eq!(moving(&on_two), 2.0);
    assert_eq!(get(&on_two, "lockoutsPending").as_f64(), Some(0.0));
    let on_one = t.counts_on(&[0]).unwrap();
    assert_eq!(moving(&on_one), 1.0);
    assert_eq!(get(&on_one, "lockoutsPending").as_f64(), Some(1.0));
    assert_eq!(
        moving(&t.counts_on(&[0, 1]).unwrap()),
        moving(&t.counts().unwrap())
    );
    assert_eq!(
        moving(&t.counts_on(&[7, 1_000_000]).unwrap()),
        0.0,
        "unknown devices count nothing"
    );
}

/// The effect of `kind` among `effects`.
fn effect(effects: &JsValue, kind: &str) -> JsValue {
    Array::from(effects)
        .iter()
        .find(|e| get(e, "kind").as_string().as_deref() == Some(kind))
        .unwrap_or_else(|| panic!("no {kind} in {:?}", kinds(effects)))
}

#[wasm_bindgen_test]
fn the_core_answers_a_group_command_worded_timed_and_on_its_deadline() {
    let mut t = Tracker::new(json(PLANT), 0.0).unwrap();
    let v12 = t.actuator("V12").unwrap();
    t.feedback_batch(&[v12], &[0.0], None, 10.0).unwrap();
    t.take_effects().unwrap();
    let valve = || json(r#"{ "valves": { "V12": 100 } }"#);
    t.command(valve(), 1, false, 100.0, None, None, Some(1500.0))
        .unwrap();
    assert_eq!(t.next_deadline(), Some(1600.0));
    t.take_effects().unwrap();
    t.expire(1599.0).unwrap();
    assert!(kinds(&t.take_effects().unwrap()).is_empty());
    t.expire(1600.0).unwrap();
    let timed_out = effect(&t.take_effects().unwrap(), "groupTimedOut");
    assert_eq!(get(&timed_out, "timeoutMs").as_f64(), Some(1500.0));
    assert_eq!(
        Array::from(&get(&timed_out, "waiting")).to_vec(),
        vec![JsValue::from(v12)]
    );
    assert_eq!(t.next_deadline(), None);

    // No retries in this plant: the first no-motion check fails the group, worded by the core.
    t.command(valve(), 2, false, 2000.0, None, None, None)
        .unwrap();
    t.tick(3000.0).unwrap();
    let failed = effect(&t.take_effects().unwrap(), "groupFailed");
    assert_eq!(
        get(&failed, "code").as_string().as_deref(),
        Some("COMMAND_FAILED")
    );
    assert_eq!(get(&failed, "retries").as_f64(), Some(0.0));
    assert_eq!(
        get(&failed, "message").as_string().as_deref(),
        Some("valve V12 did not move within 1 s of its command")
    );

    // A lockout after a fault: the fault lockout time; in place at once, so not timed.
    t.command(
        json(r#"{ "valves": { "V12": 0 } }"#),
        3,
        true,
        3500.0,
        None,
        Some(3250.0),
        None,
    )
    .unwrap();
    let effects = t.take_effects().unwrap();
    assert_eq!(
        get(&effect(&effects, "completed"), "timed").as_bool(),
        Some(false)
    );
    assert_eq!(
        get(&effect(&effects, "groupCompleted"), "faultLockoutMs").as_f64(),
        Some(250.0)
    );
}

#[wasm_bindgen_test]
fn a_wait_is_a_deadline_of_the_tracker_and_times_out_with_its_last_reason() {
    let mut t = Tracker::new(json(PLANT), 0.0).unwrap();
    assert_eq!(t.next_deadline(), None);
    let a = t.wait_start(5_000.0, 1_000.0, "`LT-3` > 10").unwrap();
    let b = t.wait_start(9_000.0, 1_000.0, "`LT-3` > 10").unwrap();
    assert_eq!(
        t.next_deadline(),
        Some(6_000.0),
        "the tracker's one deadline"
    );
    let waiting = t
        .wait_checked(a, Some("LT-3 is stale".into()), 2_000.0)
        .unwrap();
    assert_eq!(
        get(&waiting, "state").as_string().as_deref(),
        Some("waiting")
    );
    let out = Array::from(&t.expire_waits(6_000.0).unwrap());
    assert_eq!(out.length(), 1);
    assert_eq!(get(&out.get(0), "wait").as_f64(), Some(f64::from(a)));
    assert_eq!(
        get(&out.get(0), "reason").as_string().as_deref(),
        Some("LT-3 is stale")
    );
    assert_eq!(
        get(&out.get(0), "code").as_string().as_deref(),
        Some("CONDITION_TIMEOUT")
    );
    assert_eq!(
        get(&out.get(0), "message").as_string().as_deref(),
        Some("condition `LT-3` > 10 did not hold within 5 s (last check: LT-3 is stale)")
    );
    let met = t.wait_checked(b, None, 7_000.0).unwrap();
    assert_eq!(get(&met, "state").as_string().as_deref(), Some("met"));
    assert_eq!((t.waiting(), t.next_deadline()), (0, None));
    assert_eq!(
        code_of(t.wait_start(f64::NAN, 0.0, "`LT-3` > 10").unwrap_err()),
        "INVALID_INPUT"
    );
}

#[wasm_bindgen_test]
fn a_wait_past_the_most_one_plant_keeps_is_queue_full_started_or_carried_over() {
    let mut t = Tracker::new(json(PLANT), 0.0).unwrap();
    let mut started = 0;
    while t.wait_start(1_000.0, 0.0, "`LT-3` > 10").is_ok() {
        started += 1;
    }
    assert_eq!(started, 100_000);
    let full = t.wait_until(500.0, 1_000.0, "`LT-3` > 10").unwrap_err();
    assert_eq!(
        message_of(&full),
        "more than 100000 msgs wait on conditions of one plant; refused"
    );
    assert_eq!(code_of(full), "QUEUE_FULL");
    assert_eq!(t.waiting(), 100_000);
}

#[wasm_bindgen_test]
fn an_answer_says_whether_the_status_and_the_devices_health_may_have_moved() {
    let mut t = Tracker::new(json(PLANT), 0.0).unwrap();
    let ctrl1 = t.device("ctrl-1").unwrap();
    let v12 = t.slot(ctrl1, "valve", 12).unwrap();
    let answer = |t: &mut Tracker| {
        serde_json::from_str::<serde_json::Value>(&t.take_answer().unwrap()).unwrap()
    };
    assert_eq!(answer(&mut t), serde_json::json!({}), "nothing queued");
    // Each answer flags what its effects may move: the status for anything but
    // a new value, the devices' health for a device status, a fault or a recovery.
    let flagged = |a: &serde_json::Value| {
        let kinds: Vec<String> = a["effects"]
            .as_array()
            .unwrap()
            .iter()
            .map(|e| e["kind"].as_str().unwrap().to_owned())
            .collect();
        assert_eq!(
            a.get("status").is_some(),
            kinds.iter().any(|k| k != "changed"),
            "{a}"
        );
        let health = kinds
            .iter()
            .any(|k| ["deviceStatus", "fault", "recovered"].contains(&k.as_str()));
        assert_eq!(a.get("health").is_some(), health, "{a}");
        kinds
    };
    t.feedback(v12, 0.0, None, 10.0).unwrap();
    t.take_effects().unwrap();
    t.command(
        json(r#"{ "valves": { "V12": 100 } }"#),
        5,
        false,
        100.0,
        None,
        None,
        None,
    )
    .unwrap();
    assert_eq!(flagged(&answer(&mut t)), ["publish"]);
    t.feedback(v12, 40.0, None, 200.0).unwrap();
    assert!(flagged(&answer(&mut t)).contains(&"moving".to_owned()));
    t.feedback(v12, 60.0, None, 300.0).unwrap();
    assert_eq!(flagged(&answer(&mut t)), ["changed"]);
    t.device_status(ctrl1, false, 400.0).unwrap();
    assert!(flagged(&answer(&mut t)).contains(&"deviceStatus".to_owned()));

    let unserved = |t: &mut Tracker| {
        t.not_sent(
            "unserved",
            ctrl1,
            "ctrl-1/valve/12/command".into(),
            "60".into(),
            false,
            0.0,
        )
        .unwrap()
    };
    assert_eq!(unserved(&mut t), -1.0, "reported the first time");
    assert_eq!(unserved(&mut t), 0.0);
    t.serving_changed();
    assert_eq!(unserved(&mut t), -1.0);
}

#[wasm_bindgen_test]
fn health_lists_unconfirmed_lockouts_by_actuator_id() {
    let mut t = Tracker::new(json(PLANT), 0.0).unwrap();
    t.command(
        json(r#"{ "valves": { "V12": 0 } }"#),
        3,
        true,
        100.0,
        None,
        None,
        None,
    )
    .unwrap();
    let health = t.health(200.0).unwrap();
    let pending = Array::from(&get(&health, "lockoutsPending"));
    assert_eq!(pending.length(), 1);
    assert_eq!(
        get(&pending.get(0), "actuator").as_string().as_deref(),
        Some("V12")
    );
    assert_eq!(get(&pending.get(0), "sends").as_f64(), Some(1.0));
    assert_eq!(Array::from(&get(&health, "operations")).length(), 0);
}

#[wasm_bindgen_test]
fn a_group_that_timed_out_or_failed_carries_the_error_its_caller_fails_with() {
    let mut t = Tracker::new(json(PLANT), 0.0).unwrap();
    let v12 = t.actuator("V12").unwrap();
    t.feedback_batch(&[v12], &[0.0], None, 10.0).unwrap();
    let valve = || json(r#"{ "valves": { "V12": 100 } }"#);
    t.command(valve(), 1, false, 100.0, None, None, Some(1500.0))
        .unwrap();
    let sent = t.take_effects().unwrap();
    assert!(get(&effect(&sent, "publish"), "error").is_undefined());
    t.expire(1600.0).unwrap();
    let error = get(
        &effect(&t.take_effects().unwrap(), "groupTimedOut"),
        "error",
    );
    assert_eq!(
        get(&error, "code").as_string().as_deref(),
        Some("COMMAND_TIMEOUT")
    );
    assert_eq!(
        get(&error, "message").as_string().as_deref(),
        Some("group command did not complete within 1.5 s: V12 had not completed; the command was withdrawn (its actuators keep their last command)")
    );
    t.command(valve(), 2, false, 2000.0, None, None, None)
        .unwrap();
    t.tick(3000.0).unwrap();
    let failed = effect(&t.take_effects().unwrap(), "groupFailed");
    let error = get(&failed, "error");
    assert_eq!(
        get(&error, "code").as_string(),
        get(&failed, "code").as_string()
    );
    assert_eq!(
        get(&error, "message").as_string(),
        get(&failed, "message").as_string()
    );
}
