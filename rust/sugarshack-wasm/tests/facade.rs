#![cfg(target_arch = "wasm32")]

//! The JS boundary of the interlock, run under Node: handles, errors as JS
//! `Error`s with a `code`, and the snapshot round trip through plain JSON.

use js_sys::{Array, JSON};
use sugarshack_wasm::{Interlock, RESOURCE_SETS_KEPT};
use wasm_bindgen::{JsCast, JsValue};
use wasm_bindgen_test::wasm_bindgen_test;

mod support;
use support::{get, json, message_of};

fn plant_config() -> JsValue {
    json(
        r#"{
            "resources": [
                { "name": "YEL", "lockout": { "valves": { "V12": 0, "V13": 0 }, "pumps": { "P1": false } } },
                { "name": "RED", "lockout": { "valves": { "V40": 0 } } }
            ],
            "policy": "greedy",
            "queueBound": 8
        }"#,
    )
}

fn plant() -> Interlock {
    Interlock::new(plant_config()).expect("valid config")
}

/// The operations granted by the last release, cancel or clear.
fn granted(lock: &Interlock, count: u32) -> Vec<f64> {
    assert_eq!(
        lock.granted(count),
        None,
        "no more than `count` grants are kept"
    );
    (0..count).map(|i| lock.granted(i).unwrap()).collect()
}

fn code_of(error: JsValue) -> String {
    assert!(
        error.is_instance_of::<js_sys::Error>(),
        "errors are JS Error objects"
    );
    get(&error, "code").as_string().expect("error has a code")
}

#[wasm_bindgen_test]
fn handles_are_stable_and_drive_acquire_and_release() {
    let mut lock = plant();
    let load = lock.operation("10").unwrap();
    let flit = lock.operation("18").unwrap();
    assert_eq!(
        lock.operation("10").unwrap(),
        load,
        "same name, same handle"
    );
    assert_eq!(lock.find_operation("18").unwrap(), flit);
    assert_eq!(lock.operation_name(flit).as_deref(), Some("18"));
    let yel = lock.resource_set(vec!["YEL".into()]).unwrap();
    let both = lock
        .resource_set(vec!["RED".into(), "YEL".into(), "RED".into()])
        .unwrap();
    assert_eq!(
        lock.resource_set(vec!["YEL".into(), "RED".into()]).unwrap(),
        both,
        "sets are interned by content"
    );
    assert_ne!(yel, both);

    assert!(
        lock.acquire(load, 20, yel, 1000.0).unwrap(),
        "granted at once"
    );
    assert!(
        !lock.acquire(flit, 92, both, 1001.0).unwrap(),
        "queued behind load"
    );
    assert_eq!(lock.queued_operations(), vec![flit]);
    let count = lock.release(load, 1500.0).unwrap();
    assert_eq!(granted(&lock, count), vec![flit]);
    assert!(lock.is_holding(flit));

    let events: Array = lock.drain_events().unwrap().unchecked_into();
    let kinds: Vec<String> = events
        .iter()
        .map(|e| get(&e, "kind").as_string().unwrap())
        .collect();
    assert_eq!(kinds, ["granted", "queued", "released", "granted"]);
    let last = events.get(3);
    assert_eq!(get(&last, "operation").as_string().as_deref(), Some("18"));
    assert_eq!(get(&last, "waitedMs").as_f64(), Some(499.0));
    assert_eq!(get(&last, "atMs").as_f64(), Some(1500.0));
}

#[wasm_bindgen_test]
fn core_errors_become_js_errors_with_codes_and_clear_messages() {
    let mut lock = plant();
    let op = lock.operation("12").unwrap();
    let err = lock.resource_set(vec!["YLW".into()]).unwrap_err();
    assert!(message_of(&err).contains("'YLW'"), "{}", message_of(&err));
    assert_eq!(code_of(err), "UNKNOWN_RESOURCE");
    assert_eq!(
        code_of(lock.resource_set(vec![]).unwrap_err()),
        "EMPTY_RESOURCE_SET"
    );
    assert_eq!(
        code_of(lock.find_operation("ghost").unwrap_err()),
        "UNKNOWN_OPERATION"
    );
    assert_eq!(
        code_of(lock.operation("").unwrap_err()),
        "MISSING_OPERATION"
    );
    assert_eq!(code_of(lock.release(op, 0.0).unwrap_err()), "NOT_HOLDING");
    assert_eq!(
        code_of(lock.acquire(op, 1, 77.0, 0.0).unwrap_err()),
        "UNKNOWN_RESOURCE_SET"
    );
    assert_eq!(
        code_of(lock.acquire(999.0, 1, 0.0, 0.0).unwrap_err()),
        "UNKNOWN_OPERATION"
    );
    let yel = lock.resource_set(vec!["YEL".into()]).unwrap();
    assert_eq!(
        code_of(lock.acquire(op, 1, yel, f64::NAN).unwrap_err()),
        "INVALID_TIME"
    );
    assert_eq!(
        code_of(lock.clear(yel, None, None, false, 0.0).unwrap_err()),
        "NOT_FAULTED"
    );
    lock.acquire(op, 1, yel, 0.0).unwrap();
    let err = lock.acquire(op, 1, yel, 0.0).unwrap_err();
    assert!(message_of(&err).contains("C1"));
    assert_eq!(code_of(err), "ALREADY_HOLDING");
    assert!(lock.is_holding(op), "a refused call changes nothing");

    let bad = Interlock::new(json(
        r#"{ "resources": [{ "name": "A" }, { "name": "A" }] }"#,
    ))
    .err()
    .unwrap();
    assert!(message_of(&bad).contains("'A' is configured twice"));
    assert_eq!(code_of(bad), "INVALID_CONFIG");
    let typo = Interlock::new(json(
        r#"{ "resources": [{ "name": "A" }], "polcy": "greedy" }"#,
    ))
    .err()
    .unwrap();
    assert!(message_of(&typo).contains("polcy"), "{}", message_of(&typo));
    let wrong_type = Interlock::new(json(r#"{ "resources": "YEL" }"#))
        .err()
        .unwrap();
    assert_eq!(code_of(wrong_type), "INVALID_CONFIG");
}

#[wasm_bindgen_test]
fn fault_returns_lockout_commands_as_plain_objects() {
    let mut lock = plant();
    let op = lock.operation("12").unwrap();
    let waiter = lock.operation("10").unwrap();
    let yel = lock.resource_set(vec!["YEL".into()]).unwrap();
    lock.acquire(op, 22, yel, 0.0).unwrap();
    lock.acquire(waiter, 20, yel, 0.0).unwrap();
    let outcome = lock.fault(op, Some("no flow".into()), 10.0).unwrap();
    let lockouts: Array = get(&outcome, "lockouts").unchecked_into();
    assert_eq!(lockouts.length(), 1);
    let first = lockouts.get(0);
    assert_eq!(get(&first, "resource").as_string().as_deref(), Some("YEL"));
    let command = stringify(&get(&first, "command"));
    assert_eq!(
        command,
        r#"{"valves":{"V12":0,"V13":0},"pumps":{"P1":false}}"#
    );
    assert_eq!(get(&outcome, "dropped").as_bool(), Some(false));
    assert_eq!(lock.faulted_resources(), vec!["YEL".to_string()]);
    assert!(
        lock.release(op, 11.0).is_err(),
        "a faulted operation holds nothing"
    );
    let count = lock.clear(yel, None, None, false, 20.0).unwrap();
    assert_eq!(
        granted(&lock, count),
        vec![waiter],
        "the waiter goes once the line is cleared"
    );
    assert_eq!(lock.release(waiter, 30.0).unwrap(), 0);
    assert_eq!(
        granted(&lock, 0),
        Vec::<f64>::new(),
        "a release that grants nothing clears the last grants"
    );
}

#[wasm_bindgen_test]
fn snapshot_survives_json_and_restores_held_lines_as_faulted() {
    let lock = holder_and_waiter(0.0);
    // What a context store keeps: a JSON string.
    let stored = stringify(&lock.snapshot(10.0).unwrap());
    let config = json(r#"{ "resources": [{ "name": "YEL" }, { "name": "RED" }] }"#);

    let kept = Interlock::restore(config.clone(), json(&stored), true, false, 20.0).unwrap();
    assert_eq!(
        kept.faulted_resources(),
        vec!["YEL".to_string()],
        "held when saved: interrupted"
    );
    let kept_waiter = kept.find_operation("18").unwrap();
    assert!(kept.is_queued(kept_waiter));
    let resaved: JsValue = kept.snapshot(10.0).unwrap();
    let yel_state = get(&Array::from(&get(&resaved, "resources")).get(0), "state");
    assert_eq!(
        get(&yel_state, "state").as_string().as_deref(),
        Some("faulted")
    );
    assert_eq!(
        get(&yel_state, "cause").as_string().as_deref(),
        Some("interrupted")
    );
    assert_eq!(
        get(&yel_state, "operation").as_string().as_deref(),
        Some("12")
    );

    let dropped = Interlock::restore(config.clone(), json(&stored), false, false, 20.0).unwrap();
    assert!(
        dropped.queued_operations().is_empty(),
        "waiters without callers are dropped"
    );

    let err = Interlock::restore(config, json(r#"{ "version": 1 }"#), true, false, 0.0)
        .err()
        .unwrap();
    assert_eq!(code_of(err), "INVALID_SNAPSHOT");
}

#[wasm_bindgen_test]
fn counts_and_warnings_cross_as_plain_objects() {
    let mut lock = Interlock::new(json(
        r#"{ "resources": [{ "name": "YEL" }], "warnQueuedMs": 1000 }"#,
    ))
    .unwrap();
    let a = lock.operation("a").unwrap();
    let b = lock.operation("b").unwrap();
    let yel = lock.resource_set(vec!["YEL".into()]).unwrap();
    lock.acquire(a, 1, yel, 0.0).unwrap();
    lock.acquire(b, 1, yel, 0.0).unwrap();
    let counts = lock.counts().unwrap();
    assert_eq!(get(&counts, "holding").as_f64(), Some(1.0));
    assert_eq!(get(&counts, "queued").as_f64(), Some(1.0));
    assert_eq!(get(&counts, "faulted").as_f64(), Some(0.0));
    assert_eq!(Array::from(&lock.tick(999.0).unwrap()).length(), 0);
    let warnings = Array::from(&lock.tick(1000.0).unwrap());
    assert_eq!(warnings.length(), 1);
    assert_eq!(
        get(&warnings.get(0), "kind").as_string().as_deref(),
        Some("warn-queued")
    );
    assert_eq!(
        Array::from(&lock.tick(5000.0).unwrap()).length(),
        0,
        "once per crossing"
    );
}

fn stringify(value: &JsValue) -> String {
    JSON::stringify(value).unwrap().as_string().unwrap()
}

/// The plant with '12' holding YEL from `at` ms and '18' waiting on YEL and RED 5 ms later.
fn holder_and_waiter(at: f64) -> Interlock {
    let mut lock = plant();
    let op = lock.operation("12").unwrap();
    let waiter = lock.operation("18").unwrap();
    let yel = lock.resource_set(vec!["YEL".into()]).unwrap();
    let both = lock.resource_set(vec!["YEL".into(), "RED".into()]).unwrap();
    lock.acquire(op, 22, yel, at).unwrap();
    lock.acquire(waiter, 92, both, at + 5.0).unwrap();
    lock
}

/// That plant from 100 ms, saved as JSON at 110 ms.
fn saved_plant() -> (Interlock, String) {
    let lock = holder_and_waiter(100.0);
    let stored = stringify(&lock.snapshot(110.0).unwrap());
    (lock, stored)
}

fn two_lines() -> JsValue {
    json(r#"{ "resources": [{ "name": "YEL" }, { "name": "RED" }] }"#)
}

#[wasm_bindgen_test]
fn snapshot_v2_lists_configured_lines_and_a_hand_over_keeps_holds() {
    let (_, stored) = saved_plant();
    let saved = json(&stored);
    assert_eq!(get(&saved, "version").as_f64(), Some(2.0));
    assert_eq!(stringify(&get(&saved, "configured")), r#"["YEL","RED"]"#);

    let mut kept = Interlock::restore(two_lines(), json(&stored), true, true, 120.0).unwrap();
    let op = kept.find_operation("12").unwrap();
    assert!(kept.is_holding(op), "a hand-over keeps the hold");
    assert!(kept.faulted_resources().is_empty());
    assert!(kept.is_queued(kept.find_operation("18").unwrap()));
    let hold = Array::from(&get(&kept.snapshot(120.0).unwrap(), "holds")).get(0);
    assert_eq!(
        get(&hold, "sinceMs").as_f64(),
        Some(100.0),
        "with its start"
    );
    assert_eq!(kept.release(op, 130.0).unwrap(), 1);
    assert_eq!(
        kept.granted(0),
        Some(kept.find_operation("18").unwrap()),
        "the kept waiter goes on release"
    );

    let restarted = Interlock::restore(two_lines(), json(&stored), false, false, 120.0).unwrap();
    assert_eq!(restarted.faulted_resources(), vec!["YEL".to_string()]);
    assert!(!restarted.is_holding(restarted.find_operation("12").unwrap()));
    assert!(restarted.queued_operations().is_empty());
}

#[wasm_bindgen_test]
fn operations_a_restore_lets_through_are_read_with_granted() {
    let mut lock = Interlock::new(json(
        r#"{ "resources": [{ "name": "YEL" }, { "name": "RED" }], "policy": "no-overtaking" }"#,
    ))
    .unwrap();
    let [holder, wide, narrow] = ["holder", "wide", "narrow"].map(|n| lock.operation(n).unwrap());
    let red = lock.resource_set(vec!["RED".into()]).unwrap();
    let yel = lock.resource_set(vec!["YEL".into()]).unwrap();
    let both = lock.resource_set(vec!["YEL".into(), "RED".into()]).unwrap();
    lock.acquire(holder, 1, red, 0.0).unwrap();
    lock.acquire(wide, 9, both, 1.0).unwrap();
    lock.acquire(narrow, 1, yel, 2.0).unwrap();
    let stored = stringify(&lock.snapshot(3.0).unwrap());
    // RED is gone: the wide request is dropped and the narrow one may go.
    let restored = Interlock::restore(
        json(r#"{ "resources": [{ "name": "YEL" }], "policy": "no-overtaking" }"#),
        json(&stored),
        true,
        true,
        4.0,
    )
    .unwrap();
    assert_eq!(
        granted(&restored, 1),
        vec![restored.find_operation("narrow").unwrap()]
    );
}

#[wasm_bindgen_test]
fn a_refused_snapshot_leaves_the_caller_free_to_start_unknown() {
    let (_, stored) = saved_plant();
    let mut tampered: serde_json::Value = serde_json::from_str(&stored).unwrap();
    tampered["resources"].as_array_mut().unwrap().pop();
    let err = Interlock::restore(two_lines(), json(&tampered.to_string()), true, true, 120.0)
        .err()
        .unwrap();
    let message = message_of(&err);
    assert!(message.contains("'RED'"), "{message}");
    assert_eq!(code_of(err), "INVALID_SNAPSHOT");

    let note = format!("state unknown after restart: {message}");
    let mut lock = Interlock::unknown_state(two_lines(), Some(note.clone()), 130.0).unwrap();
    assert_eq!(
        lock.faulted_resources(),
        vec!["YEL".to_string(), "RED".to_string()]
    );
    let saved = lock.snapshot(131.0).unwrap();
    let red = get(&Array::from(&get(&saved, "resources")).get(1), "state");
    assert_eq!(get(&red, "state").as_string().as_deref(), Some("faulted"));
    assert_eq!(get(&red, "cause").as_string().as_deref(), Some("unknown"));
    assert_eq!(get(&red, "note").as_string(), Some(note.clone()));
    let events = Array::from(&lock.drain_events().unwrap());
    assert_eq!(events.length(), 1);
    assert_eq!(
        get(&events.get(0), "kind").as_string().as_deref(),
        Some("state-unknown")
    );
    assert_eq!(
        stringify(&get(&events.get(0), "resources")),
        r#"["YEL","RED"]"#
    );

    // A person clears the lines, and work goes on.
    let op = lock.operation("12").unwrap();
    let yel = lock.resource_set(vec!["YEL".into()]).unwrap();
    assert!(
        !lock.acquire(op, 1, yel, 140.0).unwrap(),
        "an unknown line is not granted"
    );
    let both = lock.resource_set(vec!["YEL".into(), "RED".into()]).unwrap();
    let count = lock.clear(both, None, None, false, 150.0).unwrap();
    assert_eq!(granted(&lock, count), vec![op]);
    assert!(lock.faulted_resources().is_empty());

    // The unknown state, saved, survives a restart as it is.
    let again = Interlock::restore(two_lines(), saved, false, false, 160.0).unwrap();
    assert_eq!(again.faulted_resources().len(), 2);
    let quiet = Interlock::unknown_state(two_lines(), None, 0.0).unwrap();
    assert_eq!(quiet.faulted_resources().len(), 2);
    assert_eq!(
        code_of(
            Interlock::unknown_state(two_lines(), None, -1.0)
                .err()
                .unwrap()
        ),
        "INVALID_TIME"
    );
    assert_eq!(
        code_of(
            Interlock::unknown_state(json(r#"{ "resources": [] }"#), None, 0.0)
                .err()
                .unwrap()
        ),
        "INVALID_CONFIG"
    );
}

#[wasm_bindgen_test]
fn a_long_fault_note_is_cut_to_500_characters() {
    let mut lock = plant();
    let op = lock.operation("12").unwrap();
    let yel = lock.resource_set(vec!["YEL".into()]).unwrap();
    lock.acquire(op, 1, yel, 0.0).unwrap();
    lock.fault(op, Some("x".repeat(10_000)), 1.0).unwrap();
    let saved = lock.snapshot(2.0).unwrap();
    let yel_state = get(&Array::from(&get(&saved, "resources")).get(0), "state");
    let note = get(&yel_state, "note").as_string().unwrap();
    assert_eq!(note.chars().count(), 500);
    assert!(note.ends_with('\u{2026}'));
}

#[wasm_bindgen_test]
fn release_and_cancel_by_name() {
    let mut lock = plant();
    let err = lock.release_named("ghost", 0.0).unwrap_err();
    assert!(message_of(&err).contains("'ghost'"), "{}", message_of(&err));
    assert_eq!(code_of(err), "NOT_HOLDING");
    assert_eq!(
        code_of(lock.cancel_named("ghost", 0.0).unwrap_err()),
        "NOT_QUEUED"
    );
    assert_eq!(
        code_of(lock.find_operation("ghost").unwrap_err()),
        "UNKNOWN_OPERATION",
        "an unknown name is not registered"
    );
    assert_eq!(
        code_of(lock.release_named("", 0.0).unwrap_err()),
        "MISSING_OPERATION"
    );
    assert_eq!(
        code_of(lock.cancel_named("", 0.0).unwrap_err()),
        "MISSING_OPERATION"
    );

    let op = lock.operation("12").unwrap();
    let waiter = lock.operation("18").unwrap();
    let late = lock.operation("20").unwrap();
    let yel = lock.resource_set(vec!["YEL".into()]).unwrap();
    lock.acquire(op, 1, yel, 0.0).unwrap();
    lock.acquire(waiter, 5, yel, 1.0).unwrap();
    lock.acquire(late, 1, yel, 2.0).unwrap();
    assert_eq!(
        code_of(lock.release_named("12", f64::NAN).unwrap_err()),
        "INVALID_TIME"
    );
    assert_eq!(
        code_of(lock.release_named("18", 3.0).unwrap_err()),
        "NOT_HOLDING"
    );
    assert_eq!(lock.cancel_named("20", 3.0).unwrap(), 0);
    assert!(!lock.is_queued(late));
    let count = lock.release_named("12", 4.0).unwrap();
    assert_eq!(granted(&lock, count), vec![waiter]);
}

#[wasm_bindgen_test]
fn numeric_calls_answer_as_acquire_and_release_and_keep_the_refusal() {
    let mut lock = plant();
    let load = lock.operation("10").unwrap();
    let flit = lock.operation("18").unwrap();
    let yel = lock.resource_set(vec!["YEL".into()]).unwrap();
    assert_eq!(lock.acquire_code(load, 20, yel, 0.0), 1, "granted");
    assert_eq!(lock.acquire_code(flit, 92, yel, 1.0), 0, "queued");
    assert!(lock.take_error().is_undefined(), "no refusal kept");

    assert_eq!(lock.acquire_code(load, 20, yel, 2.0), -1, "already holding");
    assert_eq!(code_of(lock.take_error()), "ALREADY_HOLDING");
    assert!(lock.take_error().is_undefined(), "taken once");
    assert_eq!(lock.acquire_code(999.0, 1, yel, 2.0), -1);
    assert_eq!(code_of(lock.take_error()), "UNKNOWN_OPERATION");
    assert_eq!(lock.acquire_code(load, 1, 999.0, 2.0), -1);
    assert_eq!(code_of(lock.take_error()), "UNKNOWN_RESOURCE_SET");
    assert_eq!(
        lock.acquire_code(load, 1, yel, f64::NAN),
        -1,
        "a time that is not finite"
    );
    lock.take_error();

    assert_eq!(lock.release_code(load, 3.0), 1.0, "the waiter is granted");
    assert_eq!(granted(&lock, 1), vec![flit]);
    assert_eq!(lock.release_code(load, 4.0), -1.0);
    assert_eq!(code_of(lock.take_error()), "NOT_HOLDING");
    assert_eq!(lock.release_code(flit, 5.0), 0.0);
}

#[wasm_bindgen_test]
fn abnormal_events_are_kept_and_normal_work_is_dropped_unread() {
    let mut lock = plant();
    let load = lock.operation("10").unwrap();
    let flit = lock.operation("18").unwrap();
    let yel = lock.resource_set(vec!["YEL".into()]).unwrap();
    let red = lock.resource_set(vec!["RED".into()]).unwrap();
    assert!(lock.acquire(load, 20, yel, 1000.0).unwrap());
    assert!(!lock.acquire(flit, 92, yel, 1001.0).unwrap());
    lock.release(load, 1500.0).unwrap();
    assert_eq!(
        Array::from(&lock.drain_abnormal_events().unwrap()).length(),
        0
    );
    lock.fault_resources(red, None, Some("ana".into()), Some("leak".into()), 1600.0)
        .unwrap();
    let events = Array::from(&lock.drain_abnormal_events().unwrap());
    let kinds: Vec<String> = events
        .iter()
        .map(|e| get(&e, "kind").as_string().unwrap())
        .collect();
    assert_eq!(kinds, ["resource-faulted"]);
    assert_eq!(
        get(&events.get(0), "by").as_string().as_deref(),
        Some("ana")
    );
    assert_eq!(
        Array::from(&lock.drain_events().unwrap()).length(),
        0,
        "drained, the others too"
    );
}

#[wasm_bindgen_test]
fn a_new_operation_name_per_msg_is_forgotten_once_idle_and_old_handles_are_refused() {
    let mut lock = plant();
    let yel = lock.resource_set(vec!["YEL".into()]).unwrap();
    let first = lock.operation("batch-0").unwrap();
    let epoch = lock.handle_epoch();
    for i in 0..5000 {
        let op = lock.operation(&format!("batch-{i}")).unwrap();
        assert!(lock.acquire(op, 1, yel, i as f64).unwrap());
        lock.release(op, i as f64).unwrap();
        lock.drain_abnormal_events().unwrap();
    }
    assert_ne!(lock.handle_epoch(), epoch, "forgetting is announced");
    assert_eq!(lock.operation_name(first), None);
    assert_eq!(
        code_of(lock.acquire(first, 1, yel, 5000.0).unwrap_err()),
        "UNKNOWN_OPERATION"
    );
    assert_eq!(lock.acquire_code(first, 1, yel, 5000.0), -1);
    assert_eq!(code_of(lock.take_error()), "UNKNOWN_OPERATION");
    for bad in [f64::NAN, -1.0, 0.5, 1e300] {
        assert_eq!(lock.acquire_code(bad, 1, yel, 5000.0), -1, "{bad}");
        lock.take_error();
    }
    // The name registers anew and works.
    let again = lock.operation("batch-0").unwrap();
    assert_ne!(again, first);
    assert!(lock.acquire(again, 1, yel, 5001.0).unwrap());
}

#[wasm_bindgen_test]
fn resource_set_handles_are_dropped_past_the_bound_and_old_ones_refused() {
    let names: Vec<String> = (0..17).map(|i| format!("L{i}")).collect();
    let resources: Vec<String> = names
        .iter()
        .map(|n| format!(r#"{{ "name": "{n}" }}"#))
        .collect();
    let mut lock = Interlock::new(json(&format!(
        r#"{{ "resources": [{}] }}"#,
        resources.join(",")
    )))
    .unwrap();
    let first = lock.resource_set(vec!["L0".into()]).unwrap();
    let epoch = lock.handle_epoch();
    for mask in 1..=RESOURCE_SETS_KEPT as u32 + 1 {
        let set: Vec<String> = (0..17)
            .filter(|b| mask & (1 << b) != 0)
            .map(|b| names[b].clone())
            .collect();
        lock.resource_set(set).unwrap();
    }
    assert_ne!(lock.handle_epoch(), epoch);
    let op = lock.operation("a").unwrap();
    assert_eq!(
        code_of(lock.acquire(op, 1, first, 0.0).unwrap_err()),
        "UNKNOWN_RESOURCE_SET"
    );
    let again = lock.resource_set(vec!["L0".into()]).unwrap();
    assert!(lock.acquire(op, 1, again, 0.0).unwrap());
}

#[wasm_bindgen_test]
fn a_sealed_state_opens_for_its_interlock_and_any_other_text_opens_lost() {
    let lock = holder_and_waiter(100.0);
    let beside = json(
        r#"{ "routines": { "r": { "routine": "r", "state": "idle", "pending": null, "halted": false } } }"#,
    );
    let text = lock.seal("il", Some("pl".into()), beside, 110.0).unwrap();
    let open = |text: &str| {
        Interlock::open(plant_config(), "il", Some("pl".into()), "file", text, 120.0).unwrap()
    };
    let opened = open(&text);
    assert!(get(&opened, "lost").is_null());
    assert_eq!(stringify(&get(&opened, "added")), "[]");
    assert_eq!(
        stringify(&get(&get(&opened, "routines"), "r")),
        r#"{"routine":"r","state":"idle","pending":null,"halted":false}"#
    );
    // The interlock comes back inside the plain object: its held line faulted "interrupted".
    let restored = get(&opened, "interlock");
    let counts = get(&restored, "counts")
        .dyn_into::<js_sys::Function>()
        .unwrap();
    assert_eq!(
        stringify(&counts.call0(&restored).unwrap()),
        r#"{"holding":0,"queued":0,"faulted":1}"#
    );
    for (text, why) in [
        (
            text.replace("\"owner\":\"il\"", "\"owner\":\"il2\""),
            "does not match its checksum",
        ),
        ("{".to_owned(), "not valid JSON"),
        (String::new(), "not valid JSON"),
    ] {
        let lost = open(&text);
        let reason = get(&lost, "lost").as_string().unwrap();
        assert!(
            reason.starts_with("file: ") && reason.contains(why),
            "{reason}"
        );
    }
    let other = Interlock::open(
        plant_config(),
        "il2",
        Some("pl".into()),
        "file",
        &text,
        120.0,
    )
    .unwrap();
    assert!(get(&other, "lost")
        .as_string()
        .unwrap()
        .contains("the state of node 'il'"));
    assert_eq!(
        code_of(Interlock::open(json("{}"), "il", None, "file", &text, 120.0).unwrap_err()),
        "INVALID_CONFIG"
    );
}
