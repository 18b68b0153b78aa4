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

/// A msg with these fields (undefined ones left out).
fn msg(topic: JsValue, lockout: JsValue, interlock: JsValue, payload: JsValue) -> JsValue {
    let msg = Object::new();
    for (key, value) in [
        ("topic", topic),
        ("lockout", lockout),
        ("interlock", interlock),
        ("payload", payload),
    ] {
        if !value.is_undefined() {
            Reflect::set(&msg, &key.into(), &value).unwrap();
        }
    }
    msg.into()
}

/// Reads a msg of these fields.
fn read(topic: JsValue, lockout: JsValue, interlock: JsValue, payload: JsValue) -> JsValue {
    read_group_msg(&msg(topic, lockout, interlock, payload)).unwrap()
}

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
    let lockout = |topic, flag| is_lockout_msg(&msg(topic, flag, U, U)).unwrap();
    assert!(lockout(text("ctrl-1/valve/12/state"), JsValue::TRUE));
    assert!(!lockout(text("ctrl-1/valve/12/state"), text("true")));
    assert!(lockout(text("lockout/YEL"), U));
    assert_eq!(t.lockout_topic("YEL"), "lockout/YEL");
}

#[wasm_bindgen_test]
fn one_call_reads_lockout_lines_and_payload() {
    let interlock = json(r#"{"operation": "12", "resources": ["YEL"]}"#);
    let got = read(
        text("plant/command"),
        U,
        interlock.clone(),
        text(r#"{"valves": {"V12": 5}}"#),
    );
    assert_eq!(refused(&got).0, "");
    assert_eq!(get(&got, "lockout"), JsValue::FALSE);
    let within: Vec<String> = Array::from(&get(&got, "within"))
        .iter()
        .map(|v| v.as_string().unwrap())
        .collect();
    assert_eq!(within, ["YEL"]);
    let payload = JSON::stringify(&get(&got, "payload"))
        .unwrap()
        .as_string()
        .unwrap();
    assert_eq!(payload, r#"{"valves":{"V12":5}}"#);

    // A lockout keeps within nothing, whatever msg.interlock is; an object payload is handed back as given.
    let object = json(r#"{"valves": {"V12": 0}}"#);
    let got = read(text("lockout/YEL"), U, json("5"), object.clone());
    assert_eq!(get(&got, "lockout"), JsValue::TRUE);
    assert!(get(&got, "within").is_null());
    assert!(Object::is(&get(&got, "payload"), &object));
    let got = read(U, JsValue::TRUE, U, object);
    assert_eq!(get(&got, "lockout"), JsValue::TRUE);
}

#[wasm_bindgen_test]
fn a_buffer_is_read_as_its_text() {
    let bytes = Uint8Array::from(&br#"{"valves": {"V12": 5}}"#[..]);
    let got = read(U, U, U, bytes.into());
    assert_eq!(
        get(&get(&get(&got, "payload"), "valves"), "V12").as_f64(),
        Some(5.0)
    );
}

#[wasm_bindgen_test]
fn refusals_name_their_catalog_text() {
    let at = |interlock: JsValue| refused(&read(U, U, interlock, json("{}")));
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
        &get(&read(U, U, json(r#"{"operation": "op"}"#), U), "refusal"),
        "params",
    );
    assert_eq!(
        get(&params, "got").as_string().unwrap(),
        r#"{"operation":"op"}"#
    );

    let big = format!(r#"{{"valves": {{}}, "pad": "{}"}}"#, "x".repeat(70_000));
    assert_eq!(
        refused(&read(U, U, U, text(&big))),
        ("INPUT_TOO_LARGE".into(), "errors.groupTooLarge".into())
    );
    let bytes = Uint8Array::from(big.as_bytes());
    assert_eq!(
        refused(&read(U, U, U, bytes.into())),
        ("INPUT_TOO_LARGE".into(), "errors.groupTooLarge".into())
    );
    assert_eq!(
        refused(&read(U, U, U, text("not json"))),
        ("INVALID_GROUP".into(), "errors.groupNotJson".into())
    );
}

#[wasm_bindgen_test]
fn hostile_values_are_read_without_a_trap() {
    // A getter that throws on msg.interlock.resources, or on msg.topic, throws on to the host (INVALID_INPUT there).
    let throwing = |body: &str| js_sys::Function::new_no_args(body).call0(&U).unwrap();
    let interlock = throwing("return { get resources() { throw new Error('boom'); } };");
    assert!(read_group_msg(&msg(U, U, interlock.clone(), U)).is_err());
    // ...but a lockout's msg.interlock is never read.
    let lockout = read(text("lockout/YEL"), U, interlock, json("{}"));
    assert_eq!(get(&lockout, "lockout"), JsValue::TRUE);
    let topic = throwing("return { get topic() { throw new Error('no topic'); } };");
    assert!(read_group_msg(&topic).is_err());
    assert!(is_lockout_msg(&topic).is_err());
    // A BigInt where the lines should be.
    let holds = Object::new();
    Reflect::set(
        &holds,
        &"resources".into(),
        &js_sys::BigInt::from(10u32).into(),
    )
    .unwrap();
    assert_eq!(refused(&read(U, U, holds.into(), U)).0, "INVALID_RESOURCES");
    // JSON text nested deep, and a __proto__ key: parsed as JSON.parse reads them.
    let deep = format!("{}{}", "[".repeat(10_000), "]".repeat(10_000));
    assert_eq!(refused(&read(U, U, U, text(&deep))).0, "");
    let parsed = read(U, U, U, text(r#"{"__proto__": {"V12": 1}}"#));
    let payload: Object = get(&parsed, "payload").dyn_into().unwrap();
    assert!(
        Object::keys(&payload).includes(&"__proto__".into(), 0),
        "an own key, not a prototype"
    );
    // A number past f64 parses to Infinity here; the command refuses it where it stands.
    let parsed = read(U, U, U, text(r#"{"valves": {"V12": 1e400}}"#));
    assert_eq!(
        get(&get(&get(&parsed, "payload"), "valves"), "V12").as_f64(),
        Some(f64::INFINITY)
    );
}
