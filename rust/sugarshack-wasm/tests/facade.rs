#![cfg(target_arch = "wasm32")]

//! The JS boundary of the interlock, run under Node: handles, errors as JS
//! `Error`s with a `code`, and the snapshot round trip through plain JSON.

use js_sys::{Array, Reflect, JSON};
use sugarshack_wasm::Interlock;
use wasm_bindgen::{JsCast, JsValue};
use wasm_bindgen_test::wasm_bindgen_test;

fn json(text: &str) -> JsValue {
    JSON::parse(text).expect("test JSON parses")
}

fn plant() -> Interlock {
    Interlock::new(json(
        r#"{
            "resources": [
                { "name": "YEL", "lockout": { "valves": { "V12": 0, "V13": 0 }, "pumps": { "P1": false } } },
                { "name": "RED", "lockout": { "valves": { "V40": 0 } } }
            ],
            "policy": "greedy",
            "queueBound": 8
        }"#,
    ))
    .expect("valid config")
}

/// The operations granted by the last release, cancel or clear.
fn granted(lock: &Interlock, count: u32) -> Vec<u32> {
    assert_eq!(
        lock.granted(count),
        None,
        "no more than `count` grants are kept"
    );
    (0..count).map(|i| lock.granted(i).unwrap()).collect()
}

fn get(value: &JsValue, key: &str) -> JsValue {
    Reflect::get(value, &key.into()).unwrap()
}

fn code_of(error: JsValue) -> String {
    assert!(
        error.is_instance_of::<js_sys::Error>(),
        "errors are JS Error objects"
    );
    get(&error, "code").as_string().expect("error has a code")
}

fn message_of(error: &JsValue) -> String {
    error.dyn_ref::<js_sys::Error>().unwrap().message().into()
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
        code_of(lock.acquire(op, 1, 77, 0.0).unwrap_err()),
        "UNKNOWN_RESOURCE_SET"
    );
    assert_eq!(
        code_of(lock.acquire(999, 1, 0, 0.0).unwrap_err()),
        "UNKNOWN_OPERATION"
    );
    let yel = lock.resource_set(vec!["YEL".into()]).unwrap();
    assert_eq!(
        code_of(lock.acquire(op, 1, yel, f64::NAN).unwrap_err()),
        "INVALID_TIME"
    );
    assert_eq!(code_of(lock.clear(yel, 0.0).unwrap_err()), "NOT_FAULTED");
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
    let command = JSON::stringify(&get(&first, "command"))
        .unwrap()
        .as_string()
        .unwrap();
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
    let count = lock.clear(yel, 20.0).unwrap();
    assert_eq!(
        granted(&lock, count),
        vec![waiter],
        "the waiter goes once the line is cleared"
    );
    assert_eq!(lock.release(waiter, 30.0).unwrap(), 0);
    assert_eq!(
        granted(&lock, 0),
        Vec::<u32>::new(),
        "a release that grants nothing clears the last grants"
    );
}

#[wasm_bindgen_test]
fn snapshot_survives_json_and_restores_held_lines_as_faulted() {
    let mut lock = plant();
    let op = lock.operation("12").unwrap();
    let waiter = lock.operation("18").unwrap();
    let yel = lock.resource_set(vec!["YEL".into()]).unwrap();
    let both = lock.resource_set(vec!["YEL".into(), "RED".into()]).unwrap();
    lock.acquire(op, 22, yel, 0.0).unwrap();
    lock.acquire(waiter, 92, both, 5.0).unwrap();
    // What a context store keeps: a JSON string.
    let stored = JSON::stringify(&lock.snapshot(10.0).unwrap())
        .unwrap()
        .as_string()
        .unwrap();
    let config = json(r#"{ "resources": [{ "name": "YEL" }, { "name": "RED" }] }"#);

    let mut kept = Interlock::restore(config.clone(), json(&stored), true, 20.0).unwrap();
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

    let dropped = Interlock::restore(config.clone(), json(&stored), false, 20.0).unwrap();
    assert!(
        dropped.queued_operations().is_empty(),
        "waiters without callers are dropped"
    );

    let err = Interlock::restore(config, json(r#"{ "version": 1 }"#), true, 0.0)
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
