#![cfg(target_arch = "wasm32")]

//! What JS hands the facade is bounded before it is read, run under Node:
//! values nested absurdly deep, circular, too large or not data at all are
//! refused with a coded error, and the same objects keep working after.

use js_sys::{Array, Function, Reflect, JSON};
use sugarshack_wasm::{Interlock, PidLoop, Rcc, Tracker};
use wasm_bindgen::{JsCast, JsValue};
use wasm_bindgen_test::wasm_bindgen_test;

mod support;
use support::{fresh_value, get, json, message_of, valve_plant};

/// The value a JS function body returns.
fn js(body: &str) -> JsValue {
    Function::new_no_args(body)
        .call0(&JsValue::NULL)
        .expect("test JS runs")
}

fn code_of(error: &JsValue) -> String {
    assert!(
        error.is_instance_of::<js_sys::Error>(),
        "errors are JS Errors"
    );
    get(error, "code").as_string().expect("error has a code")
}

/// Asserts the error's code, naming the case and showing the message when it differs.
#[track_caller]
fn assert_code(err: &JsValue, code: &str, case: &str) {
    let message = message_of(err);
    assert_eq!(code_of(err), code, "{case}: {message}");
}

/// Asserts the error's message holds `part`, showing the message when it does not.
#[track_caller]
fn assert_message_contains(err: &JsValue, part: &str) {
    let message = message_of(err);
    assert!(message.contains(part), "{message}");
}

#[track_caller]
fn assert_message_starts_with(err: &JsValue, prefix: &str) {
    let message = message_of(err);
    assert!(message.starts_with(prefix), "{message}");
}

/// Asserts a message quotes what it refused short, whatever its size.
#[track_caller]
fn assert_message_short(err: &JsValue) {
    let message = message_of(err);
    assert!(message.chars().count() < 300, "{message:.400}");
}

const LEVELS: usize = 10_000;

fn deep_array() -> JsValue {
    js(&format!(
        "let v = []; for (let i = 0; i < {LEVELS}; i++) v = [v]; return v;"
    ))
}

fn deep_object() -> JsValue {
    js(&format!(
        "let v = {{}}; for (let i = 0; i < {LEVELS}; i++) v = {{ valves: v }}; return v;"
    ))
}

/// Nested JSON text: a JS string is read as JSON, so it must be bounded too.
fn deep_text() -> JsValue {
    JsValue::from_str(&("[".repeat(LEVELS) + &"]".repeat(LEVELS)))
}

fn deep_values() -> Vec<(&'static str, JsValue)> {
    vec![
        ("array", deep_array()),
        ("object", deep_object()),
        ("text", deep_text()),
    ]
}

fn circular() -> JsValue {
    js("const o = { valves: {} }; o.valves.back = o; return o;")
}

fn big_int() -> JsValue {
    js("return { valves: { V12: 10n } };")
}

fn throwing_getter() -> JsValue {
    js("return { get valves() { throw new Error('the sensor bus is down'); } };")
}

fn plant() -> String {
    valve_plant(
        r#"
    "actuators": [
        { "id": "V12", "type": "valve", "device": "ctrl-1", "io": 12, "idle": 0, "lockout": 0 },
        { "id": "V13", "type": "valve", "device": "ctrl-1", "io": 13, "idle": 0, "lockout": 0 }
    ]
"#,
    )
}

/// A valid command for a fresh caller still goes through: the instance is healthy.
fn still_commands(t: &mut Tracker, caller: u32) {
    let queued = t
        .command(
            json(r#"{ "valves": { "V13": 50 } }"#),
            caller,
            false,
            10.0,
            None,
            None,
            None,
        )
        .expect("a valid command after a refusal");
    assert!(queued > 0);
    t.withdraw(caller);
    t.take_effects().unwrap();
}

#[wasm_bindgen_test]
fn deep_group_commands_are_refused_and_the_tracker_carries_on() {
    let mut t = Tracker::new(json(&plant()), 0.0).unwrap();
    for (caller, (kind, deep)) in deep_values().into_iter().enumerate() {
        let err = t
            .command(deep, 1, false, 10.0, None, None, None)
            .unwrap_err();
        assert_code(&err, "INPUT_TOO_DEEP", kind);
        assert_message_starts_with(&err, "invalid group command: nested deeper than");
        still_commands(&mut t, 100 + caller as u32);
    }
}

#[wasm_bindgen_test]
fn values_that_are_not_data_are_refused_and_the_tracker_carries_on() {
    let mut t = Tracker::new(json(&plant()), 0.0).unwrap();
    let cases = [
        (circular(), "INPUT_CIRCULAR", "circular"),
        (
            big_int(),
            "INVALID_INPUT",
            "invalid group command: valves.V12 is a BigInt (10n), which JSON cannot carry: send it as a plain number",
        ),
        (
            js("return { valves: { V12: 1 }, pumps: [{ P1: 0 }, { P2: 7n }] };"),
            "INVALID_INPUT",
            "pumps[1].P2 is a BigInt (7n)",
        ),
        (js("return 5n;"), "INVALID_INPUT", "the value is a BigInt (5n)"),
        (throwing_getter(), "INVALID_INPUT", "the sensor bus is down"),
        (
            js("return { get valves() { throw 42; } };"),
            "INVALID_INPUT",
            "not an Error was thrown",
        ),
        (
            js("return { toJSON() { throw 'no'; } };"),
            "INVALID_INPUT",
            "(no)",
        ),
        (JsValue::UNDEFINED, "INVALID_INPUT", "nothing to read"),
        (js("return () => 1;"), "INVALID_INPUT", "nothing to read"),
    ];
    for (caller, (value, code, words)) in cases.into_iter().enumerate() {
        let err = t
            .command(value, 1, false, 10.0, None, None, None)
            .unwrap_err();
        let message = message_of(&err);
        assert_eq!(code_of(&err), code, "{message}");
        assert!(message.contains(words), "{message}");
        still_commands(&mut t, 200 + caller as u32);
    }
}

#[wasm_bindgen_test]
fn a_megabyte_group_command_is_refused_as_too_large() {
    let mut t = Tracker::new(json(&plant()), 0.0).unwrap();
    let big = js("return { valves: { V12: 'x'.repeat(1 << 20) } };");
    let err = t
        .command(big, 1, false, 10.0, None, None, None)
        .unwrap_err();
    assert_eq!(code_of(&err), "INPUT_TOO_LARGE");
    let message = message_of(&err);
    assert!(
        message.contains("64 KiB limit for a group command"),
        "{message}"
    );
    assert!(
        message.contains(&format!("{} bytes", (1 << 20) + 21)),
        "{message}"
    );
    // Few UTF-16 units, many UTF-8 bytes: refused after the copy, by bytes.
    let as_text = JsValue::from_str(&format!(
        r#"{{"valves": {{"V12": "{}"}}}}"#,
        "é".repeat(40_000)
    ));
    let err = t
        .command(as_text, 1, false, 10.0, None, None, None)
        .unwrap_err();
    assert_eq!(code_of(&err), "INPUT_TOO_LARGE", "{}", message_of(&err));
    assert_message_contains(&err, "80023 bytes of JSON");
    still_commands(&mut t, 2);
}

#[wasm_bindgen_test]
fn group_commands_may_come_as_json_text() {
    let mut t = Tracker::new(json(&plant()), 0.0).unwrap();
    assert!(
        t.command(
            JsValue::from_str(r#"{ "valves": { "V12": 40 } }"#),
            1,
            false,
            10.0,
            None,
            None,
            None
        )
        .unwrap()
            > 0
    );
    let err = t
        .command(
            JsValue::from_str("{ \"valves\": \n { \"V13\": } }"),
            2,
            false,
            10.0,
            None,
            None,
            None,
        )
        .unwrap_err();
    assert_eq!(code_of(&err), "INVALID_GROUP");
    assert_message_contains(&err, "(line 2, column");
}

#[wasm_bindgen_test]
fn a_huge_bad_target_or_name_is_quoted_short() {
    let mut t = Tracker::new(json(&plant()), 0.0).unwrap();
    let long = "x".repeat(1_000_000);
    // Under the size limit: whatever a group command holds is echoed short.
    let long = &long[..60_000];
    let cases = [
        (
            format!(r#"{{ "valves": {{ "V12": "{long}" }} }}"#),
            "INVALID_TARGET",
        ),
        (
            format!(r#"{{ "valves": {{ "{long}": 10 }} }}"#),
            "UNKNOWN_ACTUATOR",
        ),
        (
            format!(r#"{{ "{long}": {{ "V12": 10 }} }}"#),
            "INVALID_GROUP",
        ),
        (format!(r#"{{ "valves": ["{long}"] }}"#), "INVALID_GROUP"),
        (format!(r#"["{long}"]"#), "INVALID_GROUP"),
    ];
    for (payload, code) in cases {
        let err = t
            .command(json(&payload), 1, false, 10.0, None, None, None)
            .unwrap_err();
        let message = message_of(&err);
        assert_eq!(code_of(&err), code, "{message:.300}");
        assert!(
            message.chars().count() < 300,
            "{} characters: {message:.300}",
            message.len()
        );
        assert!(message.contains("xxx…"), "{message:.300}");
    }
    let err = t
        .command(
            JsValue::from_str(&format!("[1, {long}")),
            1,
            false,
            10.0,
            None,
            None,
            None,
        )
        .unwrap_err();
    assert_message_short(&err);
    let million = js("return { valves: { V12: 'x'.repeat(1000000) } };");
    let err = t
        .command(million, 1, false, 10.0, None, None, None)
        .unwrap_err();
    assert_eq!(code_of(&err), "INPUT_TOO_LARGE");
    assert_message_short(&err);
}

#[wasm_bindgen_test]
fn a_million_character_plant_value_is_quoted_short() {
    let mut doc = json(&plant());
    let long = JsValue::from_str(&"x".repeat(1_000_000));
    Reflect::set(&get(&get(&doc, "actuators"), "0"), &"device".into(), &long).unwrap();
    let err = Tracker::new(doc, 0.0).err().unwrap();
    assert_eq!(code_of(&err), "INVALID_PLANT");
    assert_message_short(&err);
    doc = json(&plant());
    Reflect::set(&get(&get(&doc, "actuators"), "0"), &"io".into(), &long).unwrap();
    let err = Tracker::new(doc, 0.0).err().unwrap();
    assert_eq!(code_of(&err), "INVALID_PLANT");
    assert_message_starts_with(
        &err,
        "invalid plant document: actuators[0]: io must be a whole number from 0 up, like 5; got 'xxx",
    );
    assert_message_short(&err);
}

#[wasm_bindgen_test]
fn plant_document_errors_name_their_entry() {
    let doc = json(&plant());
    let second: js_sys::Object = get(&get(&doc, "actuators"), "1").unchecked_into();
    Reflect::delete_property(&second, &"lockout".into()).unwrap();
    let err = Tracker::new(doc, 0.0).err().unwrap();
    assert_eq!(code_of(&err), "INVALID_PLANT");
    assert_eq!(
        message_of(&err),
        "invalid plant document: actuators[1]: missing field `lockout`"
    );
    let text = plant().replace(
        r#", "lockout": 0 }
    ]"#,
        " }\n    ]",
    );
    let err = Tracker::new(JsValue::from_str(&text), 0.0).err().unwrap();
    assert_message_starts_with(
        &err,
        "invalid plant document: actuators[1]: missing field `lockout` (line 10, column",
    );
    for (kind, deep) in deep_values() {
        let err = Tracker::new(deep, 0.0).err().unwrap();
        assert_eq!(code_of(&err), "INPUT_TOO_DEEP", "{kind}");
    }
    assert_eq!(
        code_of(&Tracker::new(circular(), 0.0).err().unwrap()),
        "INPUT_CIRCULAR"
    );
    assert!(Tracker::new(json(&plant()), 0.0).is_ok());
}

const CONFIG: &str =
    r#"{ "resources": [{ "name": "YEL", "lockout": { "valves": { "V12": 0 } } }] }"#;

/// An acquire and release on a fresh operation: the interlock still works.
fn still_acquires(lock: &mut Interlock, name: &str) {
    let op = lock.operation(name).unwrap();
    let yel = lock.resource_set(vec!["YEL".into()]).unwrap();
    assert!(
        lock.acquire(op, 1, yel, 5.0).unwrap(),
        "granted after a refusal"
    );
    lock.release(op, 6.0).unwrap();
}

#[wasm_bindgen_test]
fn deep_or_circular_interlock_configs_and_snapshots_are_refused() {
    let mut lock = Interlock::new(json(CONFIG)).unwrap();
    let saved = JSON::stringify(&lock.snapshot(0.0).unwrap()).unwrap();
    let mut refusals = Vec::new();
    for (kind, deep) in deep_values() {
        refusals.push((
            kind,
            "config",
            Interlock::new(deep.clone()).err().unwrap(),
            "INPUT_TOO_DEEP",
        ));
        refusals.push((
            kind,
            "snapshot",
            Interlock::restore(json(CONFIG), deep, true, false, 0.0)
                .err()
                .unwrap(),
            "INPUT_TOO_DEEP",
        ));
    }
    refusals.push((
        "circular",
        "config",
        Interlock::new(circular()).err().unwrap(),
        "INPUT_CIRCULAR",
    ));
    refusals.push((
        "circular",
        "snapshot",
        Interlock::restore(json(CONFIG), circular(), true, false, 0.0)
            .err()
            .unwrap(),
        "INPUT_CIRCULAR",
    ));
    refusals.push((
        "BigInt",
        "snapshot",
        Interlock::restore(json(CONFIG), big_int(), true, false, 0.0)
            .err()
            .unwrap(),
        "INVALID_INPUT",
    ));
    refusals.push((
        "getter",
        "config",
        Interlock::new(throwing_getter()).err().unwrap(),
        "INVALID_INPUT",
    ));
    for (i, (kind, what, err, code)) in refusals.into_iter().enumerate() {
        assert_eq!(code_of(&err), code, "{kind} {what}: {}", message_of(&err));
        still_acquires(&mut lock, &format!("op{i}"));
    }
    let restored = Interlock::restore(json(CONFIG), saved.into(), true, false, 0.0)
        .expect("saved state read as JSON text");
    assert_eq!(restored.faulted_resources(), Vec::<String>::new());
}

#[wasm_bindgen_test]
fn a_non_finite_number_is_refused_where_it_stands_not_taken_for_absent() {
    let pid = r#"{ "pid": { "kp": 2, "tiS": 4, "outMin": 0, "outMax": 100, "fallback": 12 } }"#;
    let config = json(pid);
    Reflect::set(&get(&config, "pid"), &"fallback".into(), &f64::NAN.into()).unwrap();
    let err = PidLoop::new(config).err().unwrap();
    assert_eq!(code_of(&err), "INVALID_CONFIG");
    assert_eq!(
        message_of(&err),
        "PID configuration: pid: fallback must be a number, like 2.5; got NaN"
    );
    let mut rcc = Rcc::new(json(
        r#"{ "id": 2, "thresholdsMs": [200, 500], "tsMs": 200 }"#,
    ))
    .unwrap();
    let err = rcc
        .decide(
            js("return { lastAction: 1, agesMs: [Infinity, 3] };"),
            JsValue::UNDEFINED,
        )
        .unwrap_err();
    assert_eq!(code_of(&err), "INVALID_INPUT");
    assert_message_starts_with(
        &err,
        "I/O state: agesMs[0] must be a number, like 2.5; got Infinity",
    );
    assert!(PidLoop::new(json(pid)).is_ok());
}

#[wasm_bindgen_test]
fn a_misspelt_option_is_still_refused_by_name() {
    let err = Interlock::new(json(
        r#"{ "resources": [{ "name": "YEL", "lockot": {} }] }"#,
    ))
    .err()
    .unwrap();
    assert_eq!(code_of(&err), "INVALID_CONFIG");
    assert_message_starts_with(&err, "invalid interlock configuration: resources[0]");
    assert_message_contains(&err, "unknown field `lockot`");
}

#[wasm_bindgen_test]
fn deep_rcc_states_and_configs_are_refused_and_the_controller_carries_on() {
    let mut rcc = Rcc::new(json(
        r#"{ "id": 2, "thresholdsMs": [200, 500], "tsMs": 200 }"#,
    ))
    .unwrap();
    let state = r#"{ "lastAction": 10, "agesMs": [100, null] }"#;
    for (kind, deep) in deep_values() {
        let err = rcc.decide(deep.clone(), JsValue::UNDEFINED).unwrap_err();
        assert_code(&err, "INPUT_TOO_DEEP", kind);
        assert!(
            rcc.decide(json(state), JsValue::UNDEFINED).is_ok(),
            "a valid state after a refusal"
        );
        assert_eq!(
            code_of(&Rcc::new(deep.clone()).err().unwrap()),
            "INPUT_TOO_DEEP"
        );
        assert_eq!(
            code_of(&PidLoop::new(deep).err().unwrap()),
            "INPUT_TOO_DEEP"
        );
    }
    assert_eq!(
        code_of(&rcc.decide(circular(), JsValue::UNDEFINED).unwrap_err()),
        "INPUT_CIRCULAR"
    );
    let decision = rcc.decide(json(state), JsValue::UNDEFINED).unwrap();
    assert_eq!(get(&decision, "engaged").as_bool(), Some(false));
    let big = js("return { lastAction: 1, agesMs: new Array(40000).fill(1) };");
    assert_eq!(
        code_of(&rcc.decide(big, JsValue::UNDEFINED).unwrap_err()),
        "INPUT_TOO_LARGE"
    );
}

#[wasm_bindgen_test]
fn deep_routine_snapshots_are_refused_and_the_routine_carries_on() {
    let plant = r#"{
        "actuatorTypes": {}, "devices": [{ "id": "st", "kind": "sensor-station" }],
        "resources": [{ "id": "YEL", "lockout": { "valves": {} } }],
        "operations": [{ "id": "10", "priority": 1, "resources": ["YEL"], "steps": [{ "wait": "true", "sensors": [], "timeoutMs": 1000 }] }],
        "routines": [{ "id": "r", "states": ["a", "b"], "initial": "a",
            "transitions": [{ "from": "a", "to": "b", "operation": "10", "trigger": { "msg": "go" } }] }]
    }"#;
    let t = Tracker::new(json(plant), 0.0).unwrap();
    let mut r = t.routine("r").unwrap();
    let saved = r.snapshot().unwrap();
    for (kind, deep) in deep_values() {
        let err = r.restore(deep, Vec::new()).unwrap_err();
        assert_eq!(code_of(&err), "INPUT_TOO_DEEP", "{kind}");
    }
    assert_eq!(
        code_of(&r.restore(circular(), Vec::new()).unwrap_err()),
        "INPUT_CIRCULAR"
    );
    assert!(r.restore(saved, Vec::new()).is_ok());
    assert_eq!(
        get(&r.on_msg("go").unwrap(), "to").as_string().as_deref(),
        Some("b")
    );
}

#[wasm_bindgen_test]
fn a_sample_stamped_in_the_future_is_refused_and_the_next_one_kept() {
    let mut t = Tracker::new(json(&plant()), 0.0).unwrap();
    let lt = t.sensor("LT-3").unwrap();
    assert!(t.record_sensor(lt, 10.0, Some(1000.0), 1000.0).unwrap());
    let err = t.record_sensor(lt, 99.0, Some(9e15), 2000.0).unwrap_err();
    assert_eq!(code_of(&err), "FUTURE_TIMESTAMP");
    assert_message_contains(&err, "clock is 8999999999998000 ms ahead");
    assert_eq!(
        fresh_value(&mut t, "LT-3", 2000.0),
        Ok(10.0),
        "nothing of it kept"
    );
    assert!(
        t.record_sensor(lt, 11.0, Some(1500.0), 2500.0).unwrap(),
        "an older stamp, received later, is kept"
    );
    assert_eq!(fresh_value(&mut t, "LT-3", 2500.0), Ok(11.0));
    assert!(
        t.record_sensor(lt, 12.0, Some(2600.0 + 5000.0), 2600.0)
            .unwrap(),
        "exactly at the default skew"
    );
    assert_eq!(Array::from(&t.take_effects().unwrap()).length(), 0);
}
