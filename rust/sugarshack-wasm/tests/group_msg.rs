#![cfg(target_arch = "wasm32")]

//! Group command msgs through the boundary, under Node: one call reads a
//! msg's topic, lockout flag, msg.interlock and payload by the core's rules;
//! `ingest` tells a command on no device's topic from someone else's traffic.

mod support;

use js_sys::{Array, Object, Reflect, Uint8Array, JSON};
use sugarshack_wasm::{is_lockout_msg, read_group_msg, Ingest, Tracker};
use wasm_bindgen::{JsCast, JsValue};
use wasm_bindgen_test::wasm_bindgen_test;

use support::{get, json, valve_plant};

fn plant() -> Tracker {
    let doc = valve_plant(
        r#""actuators": [{ "id": "V12", "type": "valve", "device": "ctrl-1", "io": 12, "idle": 0, "lockout": 0 }]"#,
    );
    Tracker::new(json(&doc), 0.0).unwrap()
}

fn text(s: &str) -> JsValue {
    JsValue::from_str(s)
}

const U: JsValue = JsValue::UNDEFINED;

/// The refusal's code and catalog key, or "" when read.
fn refused(read: &JsValue) -> (String, String) {
    let refusal = get(read, "refusal");
    if refusal.is_undefined() {
        return (String::new(), String::new());
    }
    let text = |k| get(&refusal, k).as_string().unwrap();
    (text("code"), text("key"))
}

#[wasm_bindgen_test]
fn text_on_no_devices_topic_is_a_command_when_it_reads_as_one() {
    let mut t = plant();
    let kind = |t: &mut Tracker, payload: &str| t.ingest("plant/command", payload, 0.0).unwrap();
    assert_eq!(kind(&mut t, r#"{"valves": {"V12": 10}}"#), Ingest::Command);
    assert_eq!(kind(&mut t, "[1]"), Ingest::Command);
    assert_eq!(kind(&mut t, "{broken"), Ingest::Command);
    assert_eq!(kind(&mut t, r#"{"state": "ON"}"#), Ingest::Foreign);
    assert_eq!(kind(&mut t, "online"), Ingest::Foreign);
    // Bytes (a Buffer) on no device's topic are never a command.
    let bytes = t
        .ingest_bytes("plant/command", br#"{"valves": {}}"#, 0.0)
        .unwrap();
    assert_eq!(bytes, Ingest::Foreign);
    assert_eq!(t.queued(), 0);
}

#[wasm_bindgen_test]
fn a_lockout_is_a_command_even_on_a_devices_topic() {
    let mut t = plant();
    assert_eq!(
        t.ingest("lockout/state", r#"{"valves": {"V12": 0}}"#, 0.0)
            .unwrap(),
        Ingest::Command
    );
    let bytes = t.ingest_bytes("lockout/ctrl-1", b"{}", 0.0).unwrap();
    assert_eq!(bytes, Ingest::Command);
    assert_eq!(
        t.ingest("ctrl-1/valve/12/state", "0", 0.0).unwrap(),
        Ingest::Samples
    );
    assert!(is_lockout_msg(text("ctrl-1/valve/12/state"), JsValue::TRUE));
    assert!(!is_lockout_msg(text("ctrl-1/valve/12/state"), text("true")));
    assert!(is_lockout_msg(text("lockout/YEL"), U));
    assert_eq!(t.lockout_topic("YEL"), "lockout/YEL");
}

#[wasm_bindgen_test]
fn one_call_reads_lockout_lines_and_payload() {
    let interlock = json(r#"{"operation": "12", "resources": ["YEL"]}"#);
    let read = read_group_msg(
        text("plant/command"),
        U,
        interlock.clone(),
        text(r#"{"valves": {"V12": 5}}"#),
    );
    assert_eq!(refused(&read).0, "");
    assert_eq!(get(&read, "lockout"), JsValue::FALSE);
    let within: Vec<String> = Array::from(&get(&read, "within"))
        .iter()
        .map(|v| v.as_string().unwrap())
        .collect();
    assert_eq!(within, ["YEL"]);
    let payload = JSON::stringify(&get(&read, "payload"))
        .unwrap()
        .as_string()
        .unwrap();
    assert_eq!(payload, r#"{"valves":{"V12":5}}"#);

    // A lockout keeps within nothing, whatever msg.interlock is; an object payload is handed back as given.
    let object = json(r#"{"valves": {"V12": 0}}"#);
    let read = read_group_msg(text("lockout/YEL"), U, json("5"), object.clone());
    assert_eq!(get(&read, "lockout"), JsValue::TRUE);
    assert!(get(&read, "within").is_null());
    assert!(Object::is(&get(&read, "payload"), &object));
    let read = read_group_msg(U, JsValue::TRUE, U, object);
    assert_eq!(get(&read, "lockout"), JsValue::TRUE);
}

#[wasm_bindgen_test]
fn a_buffer_is_read_as_its_text() {
    let bytes = Uint8Array::from(&br#"{"valves": {"V12": 5}}"#[..]);
    let read = read_group_msg(U, U, U, bytes.into());
    assert_eq!(
        get(&get(&get(&read, "payload"), "valves"), "V12").as_f64(),
        Some(5.0)
    );
}

#[wasm_bindgen_test]
fn refusals_name_their_catalog_text() {
    let at = |interlock: JsValue| refused(&read_group_msg(U, U, interlock, json("{}")));
    for interlock in [
        "null",
        "\"x\"",
        "5",
        "[]",
        r#"{"resources": "YEL"}"#,
        r#"{"resources": [1]}"#,
        r#"{"operation": "op"}"#,
    ] {
        assert_eq!(
            at(json(interlock)),
            ("INVALID_RESOURCES".into(), "errors.heldNotListed".into()),
            "{interlock}"
        );
    }
    let params = get(
        &get(
            &read_group_msg(U, U, json(r#"{"operation": "op"}"#), U),
            "refusal",
        ),
        "params",
    );
    assert_eq!(
        get(&params, "got").as_string().unwrap(),
        r#"{"operation":"op"}"#
    );

    let big = format!(r#"{{"valves": {{}}, "pad": "{}"}}"#, "x".repeat(70_000));
    assert_eq!(
        refused(&read_group_msg(U, U, U, text(&big))),
        ("INPUT_TOO_LARGE".into(), "errors.groupTooLarge".into())
    );
    let bytes = Uint8Array::from(big.as_bytes());
    assert_eq!(
        refused(&read_group_msg(U, U, U, bytes.into())),
        ("INPUT_TOO_LARGE".into(), "errors.groupTooLarge".into())
    );
    assert_eq!(
        refused(&read_group_msg(U, U, U, text("not json"))),
        ("INVALID_GROUP".into(), "errors.groupNotJson".into())
    );
}

#[wasm_bindgen_test]
fn hostile_values_are_read_without_a_trap() {
    // A getter that throws on msg.interlock.resources, a BigInt, a proxy's object.
    let throwing =
        js_sys::Function::new_no_args("return { get resources() { throw new Error('boom'); } };")
            .call0(&U)
            .unwrap();
    assert_eq!(
        refused(&read_group_msg(U, U, throwing, U)).0,
        "INVALID_RESOURCES"
    );
    let bigint = js_sys::BigInt::from(10u32);
    let holds = Object::new();
    Reflect::set(&holds, &"resources".into(), &bigint.into()).unwrap();
    assert_eq!(
        refused(&read_group_msg(U, U, holds.into(), U)).0,
        "INVALID_RESOURCES"
    );
    // JSON text nested deep, and a __proto__ key: parsed as JSON.parse reads them.
    let deep = format!("{}{}", "[".repeat(10_000), "]".repeat(10_000));
    assert_eq!(refused(&read_group_msg(U, U, U, text(&deep))).0, "");
    let read = read_group_msg(U, U, U, text(r#"{"__proto__": {"V12": 1}}"#));
    let payload: Object = get(&read, "payload").dyn_into().unwrap();
    assert!(
        Object::keys(&payload).includes(&"__proto__".into(), 0),
        "an own key, not a prototype"
    );
    // A number past f64 parses to Infinity here; the command refuses it where it stands.
    let read = read_group_msg(U, U, U, text(r#"{"valves": {"V12": 1e400}}"#));
    assert_eq!(
        get(&get(&get(&read, "payload"), "valves"), "V12").as_f64(),
        Some(f64::INFINITY)
    );
}

#[wasm_bindgen_test]
fn one_call_reads_and_issues_a_command_msg_and_answers_its_effects_deadline_and_counts() {
    let mut t = plant();
    let payload = text(r#"{"valves": {"V12": 50}}"#);
    let out = t
        .command_msg(
            text("plant/command"),
            U,
            U,
            payload,
            0.0,
            None,
            Some(1000.0),
        )
        .unwrap();
    let read: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(read["lockout"], false);
    assert_eq!(read["deadline"], 1000.0);
    assert!(read["counts"]["lockoutsPending"].is_u64());
    let kinds: Vec<&str> = read["effects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["kind"].as_str().unwrap())
        .collect();
    assert_eq!(kinds, ["publish"]);
    assert_eq!(t.queued(), 0);
    // Its refusal comes back as readGroupMsg's; a command outside the lines held throws the core's code.
    let out = t
        .command_msg(U, U, json("5"), json("{}"), 0.0, None, None)
        .unwrap();
    let read: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(read["refusal"]["code"], "INVALID_RESOURCES");
    assert_eq!(read["refusal"]["key"], "errors.heldNotListed");
    let err = t
        .command_msg(U, U, U, text(r#"{"valves": {"NOPE": 0}}"#), 0.0, None, None)
        .unwrap_err();
    assert!(get(&err, "code").as_string().is_some());
}

#[wasm_bindgen_test]
fn a_command_msg_gets_its_caller_from_the_tracker_and_its_outcome_names_it() {
    let mut t = plant();
    let issue = |t: &mut Tracker, target: &str| {
        let out = t
            .command_msg(text("plant/command"), U, U, text(target), 0.0, None, None)
            .unwrap();
        serde_json::from_str::<serde_json::Value>(&out).unwrap()
    };
    let first = issue(&mut t, r#"{"valves": {"V12": 50}}"#);
    assert_eq!(first["caller"], 1);
    assert_eq!(t.next_caller(), 2, "the next caller follows");
    t.feedback(0, 50.0, None, 10.0).unwrap();
    let done: Vec<serde_json::Value> = Array::from(&t.take_effects().unwrap())
        .iter()
        .map(|e| serde_json::from_str(&JSON::stringify(&e).unwrap().as_string().unwrap()).unwrap())
        .filter(|e: &serde_json::Value| e["kind"] == "groupCompleted")
        .collect();
    assert_eq!(
        done.first().map(|e| e["caller"].clone()),
        Some(serde_json::json!(1)),
        "{done:?}"
    );
    assert_eq!(issue(&mut t, r#"{"valves": {"V12": 0}}"#)["caller"], 3);
}
