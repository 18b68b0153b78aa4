#![cfg(target_arch = "wasm32")]

//! Device messages through the boundary, under Node: `ingest` reads them by
//! the plant's profiles and applies them; what it cannot use comes back as
//! `malformed` effects, and foreign topics are told apart.

use js_sys::Array;
use sugarshack_core::text::QUOTE_CHARS;
use sugarshack_wasm::{Ingest, Tracker};
use wasm_bindgen::JsValue;
use wasm_bindgen_test::wasm_bindgen_test;

mod support;
use support::{fresh_value, get, json};

const PLANT: &str = r#"{
    "actuatorTypes": {
        "valve": { "signal": "analog", "tolerance": 2, "noMotionMs": 1000, "completionMs": 5000, "staleMs": 5000 },
        "pump": { "signal": "binary", "noMotionMs": 1000, "completionMs": 3000, "staleMs": 5000 }
    },
    "devices": [
        { "id": "ctrl-1", "kind": "actuator-panel", "profile": "esphome" },
        { "id": "station-2", "kind": "sensor-station", "profile": "esphome" },
        { "id": "ctrl-3", "kind": "actuator-panel" }
    ],
    "actuators": [
        { "id": "V101", "type": "valve", "device": "ctrl-1", "idle": 0, "lockout": 0 },
        { "id": "P1", "type": "pump", "device": "ctrl-1", "idle": false, "lockout": false },
        { "id": "V301", "type": "valve", "device": "ctrl-3", "io": 1, "idle": 0, "lockout": 0 }
    ],
    "sensors": [{ "id": "LT-2", "device": "station-2", "name": "volume", "updateMs": 60000 }]
}"#;

fn effects(t: &mut Tracker) -> Vec<JsValue> {
    Array::from(&t.take_effects().unwrap()).iter().collect()
}

/// Two text fields of an effect, in order.
fn text_pair(effect: &JsValue, first: &str, second: &str) -> (String, String) {
    let text = |key| get(effect, key).as_string().unwrap();
    (text(first), text(second))
}

/// Feeds each message at 0 ms, in order, and checks what it was read as.
#[track_caller]
fn assert_ingests(t: &mut Tracker, messages: &[(&str, &str, Ingest)]) {
    for &(topic, payload, expected) in messages {
        assert_eq!(
            t.ingest(topic, payload, 0.0).unwrap(),
            expected,
            "{topic} {payload}"
        );
    }
}

#[wasm_bindgen_test]
fn esphome_states_complete_a_group_command() {
    let mut t = Tracker::new(json(PLANT), 0.0).unwrap();
    assert_ingests(
        &mut t,
        &[
            ("ctrl-1/status", "online", Ingest::Status),
            ("ctrl-1/valve/v101/position/state", "0", Ingest::Samples),
            ("ctrl-1/switch/p1/state", "OFF", Ingest::Samples),
        ],
    );
    effects(&mut t);
    t.command(
        json(r#"{"valves": {"V101": 100}, "pumps": {"P1": true}}"#),
        7,
        false,
        10.0,
        None,
        None,
        None,
    )
    .unwrap();
    let published: Vec<(String, String)> = effects(&mut t)
        .iter()
        .filter(|e| get(e, "kind").as_string().as_deref() == Some("publish"))
        .map(|e| text_pair(e, "topic", "payload"))
        .collect();
    assert_eq!(
        published,
        vec![
            ("ctrl-1/valve/v101/position/command".into(), "100".into()),
            ("ctrl-1/switch/p1/command".into(), "ON".into())
        ]
    );
    t.ingest("ctrl-1/valve/v101/position/state", "100", 500.0)
        .unwrap();
    t.ingest_bytes("ctrl-1/switch/p1/state", b"ON", 600.0)
        .unwrap();
    let done = effects(&mut t);
    assert!(done
        .iter()
        .any(|e| get(e, "kind").as_string().as_deref() == Some("groupCompleted")));
    assert_eq!(t.last_device(), Some(0));
    assert_eq!(t.last_ts(), None);
}

#[wasm_bindgen_test]
fn foreign_topics_are_told_from_device_topics() {
    let mut t = Tracker::new(json(PLANT), 0.0).unwrap();
    assert_ingests(
        &mut t,
        &[
            (
                "homeassistant/valve/ctrl-1/v101/config",
                "{}",
                Ingest::Foreign,
            ),
            ("ctrl-1/debug", "[D][valve:1]", Ingest::Other),
        ],
    );
    assert_eq!(t.topic_device("ctrl-1/debug"), Some(0));
    assert_eq!(t.topic_device("plant/command"), None);
    assert!(t.is_group_key("valves") && t.is_group_key("pump") && !t.is_group_key("blob"));
    assert_eq!(t.queued(), 0);
}

#[wasm_bindgen_test]
fn bad_payloads_come_back_as_malformed_effects() {
    let mut t = Tracker::new(json(PLANT), 0.0).unwrap();
    assert_ingests(
        &mut t,
        &[
            ("ctrl-1/switch/p1/state", "1", Ingest::Samples),
            ("ctrl-1/status", "maybe", Ingest::Refused),
            ("ctrl-9/state", "{}", Ingest::Refused),
        ],
    );
    let reasons: Vec<(String, String)> = effects(&mut t)
        .iter()
        .map(|e| text_pair(e, "device", "reason"))
        .collect();
    assert_eq!(
        reasons,
        vec![
            ("ctrl-1".into(), "non-numeric value".into()),
            ("ctrl-1".into(), "bad status".into()),
            ("ctrl-9".into(), "unknown device".into())
        ]
    );
    assert!(
        t.ingest("ctrl-1/status", "online", f64::NAN).is_err(),
        "a bad clock throws"
    );
}

#[wasm_bindgen_test]
fn sensors_take_values_and_nan_and_report_which() {
    let mut t = Tracker::new(json(PLANT), 0.0).unwrap();
    let lt = t.sensor("LT-2").unwrap();
    assert_eq!(
        t.ingest("station-2/sensor/volume/state", "1234.5", 100.0)
            .unwrap(),
        Ingest::Samples
    );
    assert_eq!(t.last_sensors(), vec![lt]);
    assert_eq!(fresh_value(&mut t, "LT-2", 200.0), Ok(1234.5));
    // Fresh for five of its 60 s updates.
    assert!(fresh_value(&mut t, "LT-2", 299_000.0).is_ok());
    t.ingest("station-2/sensor/volume/state", "nan", 300.0)
        .unwrap();
    assert_eq!(
        fresh_value(&mut t, "LT-2", 400.0),
        Err("sensor 'LT-2' has no reading: its device reports none (nan); check the probe".into())
    );
}

#[wasm_bindgen_test]
fn the_sugarshack_batch_still_reads_with_its_device_time() {
    let mut t = Tracker::new(json(PLANT), 0.0).unwrap();
    let kind = t
        .ingest("ctrl-3/state", r#"{"ts": 90, "valve": {"1": 40}}"#, 100.0)
        .unwrap();
    assert_eq!(kind, Ingest::Samples);
    assert_eq!(t.last_ts(), Some(90.0));
    assert_eq!(t.position(2), Some(40.0));
}

/// `ingestMsg`'s answer, parsed.
fn answer(text: String) -> serde_json::Value {
    serde_json::from_str(&text).unwrap()
}

#[wasm_bindgen_test]
fn one_call_answers_a_device_msg_with_all_it_did() {
    let mut t = Tracker::new(json(PLANT), 0.0).unwrap();
    // Device 2 (ctrl-3) reports its valve: kind, device, time and the effects, nothing asked again.
    let read = answer(
        t.ingest_msg(
            "ctrl-3/state",
            r#"{"ts": 90, "valve": {"1": 40}}"#,
            100.0,
            None,
            true,
            None,
        )
        .unwrap(),
    );
    assert_eq!(read["kind"], Ingest::Samples as u8);
    assert_eq!(read["device"], 2);
    assert_eq!(read["ts"], 90.0);
    assert_eq!(read["samples"], serde_json::json!([0.0, 2.0, 40.0]));
    assert!(read["effects"].as_array().is_some_and(|e| !e.is_empty()));
    assert_eq!(t.queued(), 0, "the answer took the effects");
    // The same value again: nothing changed, so no effects, and no samples unless asked.
    let read = answer(
        t.ingest_msg(
            "ctrl-3/state",
            r#"{"valve": {"1": 40}}"#,
            200.0,
            None,
            false,
            None,
        )
        .unwrap(),
    );
    assert_eq!(
        read,
        serde_json::json!({ "kind": Ingest::Samples as u8, "device": 2 })
    );
    // A sensor's value names the sensor; a node serving ctrl-1 only is told ctrl-3's msg is not its own.
    let read = answer(
        t.ingest_msg_bytes(
            "station-2/sensor/volume/state",
            b"7",
            300.0,
            None,
            false,
            None,
        )
        .unwrap(),
    );
    assert_eq!(read["sensors"], serde_json::json!([0]));
    let read = answer(
        t.ingest_msg(
            "ctrl-3/state",
            r#"{"valve": {"1": 0}}"#,
            400.0,
            Some(vec![0]),
            false,
            None,
        )
        .unwrap(),
    );
    assert_eq!(read["kind"], Ingest::Unserved as u8);
    assert_eq!(read["device"], 2);
    assert_eq!(
        read["effects"],
        serde_json::json!([{ "kind": "malformed", "device": "ctrl-3", "reason": "device not served",
            "message": "device 'ctrl-3' is not in this node's device list" }])
    );
    assert_eq!(t.position(2), Some(40.0), "an unserved msg is not applied");
    let read = answer(
        t.ingest_msg("elsewhere/x", "{}", 500.0, Some(vec![0]), false, Some(true))
            .unwrap(),
    );
    assert_eq!(read, serde_json::json!({ "kind": Ingest::Foreign as u8 }));
    // The same msg from the flow (not from `mqtt in`): a group command, for the command path to read.
    let read = answer(
        t.ingest_msg(
            "elsewhere/x",
            "{}",
            500.0,
            Some(vec![0]),
            false,
            Some(false),
        )
        .unwrap(),
    );
    assert_eq!(read, serde_json::json!({ "kind": Ingest::Command as u8 }));
    let read = answer(
        t.ingest_msg_value(
            "elsewhere/x",
            JsValue::from(5),
            500.0,
            None,
            false,
            Some(false),
        )
        .unwrap(),
    );
    assert_eq!(read["kind"], Ingest::Command as u8);
}

/// A JS value made by `body` (a function body that returns it).
fn js(body: &str) -> JsValue {
    js_sys::Function::new_no_args(body)
        .call0(&JsValue::NULL)
        .unwrap()
}

/// `ingestMsgValue`'s answer for `payload` on `topic`, parsed, with its malformed reasons.
fn value_answer(
    t: &mut Tracker,
    topic: &str,
    payload: &JsValue,
) -> (serde_json::Value, Vec<String>) {
    let read = answer(
        t.ingest_msg_value(topic, payload.clone(), 100.0, None, false, None)
            .unwrap(),
    );
    let reasons = read["effects"]
        .as_array()
        .map(|effects| {
            effects
                .iter()
                .filter(|e| e["kind"] == "malformed")
                .map(|e| e["reason"].as_str().unwrap().to_owned())
                .collect()
        })
        .unwrap_or_default();
    (read, reasons)
}

#[wasm_bindgen_test]
fn a_payload_as_a_value_is_read_as_the_json_its_device_sent() {
    let mut t = Tracker::new(json(PLANT), 0.0).unwrap();
    // What auto-detect parsed, as text and as bytes: the same reading.
    let (read, reasons) = value_answer(
        &mut t,
        "ctrl-3/state",
        &js(r#"return { ts: 90, valve: { 1: 40 } };"#),
    );
    assert_eq!(
        (read["kind"].clone(), read["ts"].clone()),
        (
            serde_json::json!(Ingest::Samples as u8),
            serde_json::json!(90.0)
        )
    );
    assert!(reasons.is_empty(), "{reasons:?}");
    assert_eq!(t.position(2), Some(40.0));
    let (read, _) = value_answer(&mut t, "station-2/sensor/volume/state", &js("return 7;"));
    assert_eq!(read["kind"], Ingest::Samples as u8);
    let (read, _) = value_answer(
        &mut t,
        "ctrl-3/state",
        &js(r#"return new TextEncoder().encode('{"valve": {"1": 60}}');"#),
    );
    assert_eq!(read["kind"], Ingest::Samples as u8);
    assert_eq!(t.position(2), Some(60.0));
    let (read, _) = value_answer(
        &mut t,
        "ctrl-3/state",
        &JsValue::from_str(r#"{"valve": {"1": 70}}"#),
    );
    assert_eq!(read["kind"], Ingest::Samples as u8);
    assert_eq!(t.position(2), Some(70.0));
    // A group command as a value on no device's topic reads as one; other values are someone else's.
    let (read, _) = value_answer(
        &mut t,
        "plant/command",
        &js("return { valves: { V101: 0 } };"),
    );
    assert_eq!(read["kind"], Ingest::Command as u8);
    let (read, _) = value_answer(&mut t, "elsewhere/x", &js("return { other: 1 };"));
    assert_eq!(read["kind"], Ingest::Foreign as u8);
}

#[wasm_bindgen_test]
fn a_payload_that_cannot_be_written_as_json_is_refused_never_thrown() {
    let mut t = Tracker::new(json(PLANT), 0.0).unwrap();
    // Circular: its readable fields are applied, the circular one is refused in its own field.
    let circular = js("const v = { valve: { 1: 30 } }; v.self = v; return v;");
    let (read, _) = value_answer(&mut t, "ctrl-3/state", &circular);
    assert_eq!(read["kind"], Ingest::Samples as u8);
    assert_eq!(t.position(2), Some(30.0), "the readable field is not lost");
    // A field whose value is circular: refused in that field, nothing applied from it.
    let inner = js("const v = {}; v.v = v; return { valve: { 1: v } };");
    let (read, reasons) = value_answer(&mut t, "ctrl-3/state", &inner);
    assert_eq!(read["kind"], Ingest::Samples as u8);
    assert_eq!(reasons, ["bad group"], "{read}");
    assert_eq!(t.position(2), Some(30.0));
    // A BigInt in a field: that field refused in its own words.
    let (read, reasons) =
        value_answer(&mut t, "ctrl-3/state", &js("return { valve: { 1: 10n } };"));
    assert_eq!(read["kind"], Ingest::Samples as u8);
    assert_eq!(reasons, ["bad group"]);
    assert!(
        read.to_string()
            .contains("unreadable: Do not know how to serialize a BigInt"),
        "{read}"
    );
    // Unreadable as a whole (a getter that throws, a revoked proxy, a BigInt, a deep array): refused at the top.
    for body in [
        "const v = {}; Object.defineProperty(v, 'valve', { enumerable: true, get() { throw new Error('no'); } }); return v;",
        "const p = Proxy.revocable({}, {}); p.revoke(); return p.proxy;",
        "return 10n;",
        "let v = []; for (let i = 0; i < 100000; i++) v = [v]; return v;",
        "return Symbol('x');",
        "return () => 1;",
        "const e = new Error('x'); Object.defineProperty(e, 'message', { get() { throw e; } }); return { toJSON() { throw e; } };",
    ] {
        let (read, reasons) = value_answer(&mut t, "ctrl-3/state", &js(body));
        assert_eq!(read["kind"], Ingest::Refused as u8, "{body}: {read}");
        assert_eq!(reasons.len(), 1, "{body}: {read}");
        assert_eq!(t.position(2), Some(30.0), "{body}");
    }
    // Over the bound: refused unread, as text and as bytes.
    for body in [
        "return { blob: 'x'.repeat(17 * 1024 * 1024) };",
        "return new Uint8Array(17 * 1024 * 1024);",
        "return 'x'.repeat(17 * 1024 * 1024);",
    ] {
        let (read, reasons) = value_answer(&mut t, "ctrl-3/state", &js(body));
        assert_eq!(read["kind"], Ingest::Refused as u8, "{body}: {read}");
        assert_eq!(reasons, ["too large"], "{body}");
    }
    let (read, _) = value_answer(
        &mut t,
        "elsewhere/x",
        &js("return { blob: 'x'.repeat(17 * 1024 * 1024) };"),
    );
    assert_eq!(read["kind"], Ingest::Foreign as u8);
    let (read, _) = value_answer(
        &mut t,
        "lockout/YEL",
        &js("return new Uint8Array(17 * 1024 * 1024);"),
    );
    assert_eq!(read["kind"], Ingest::Command as u8);
    // Undefined is an empty payload, as before.
    let (read, _) = value_answer(&mut t, "ctrl-3/state", &JsValue::UNDEFINED);
    assert_eq!(read["kind"], Ingest::Refused as u8);
}

#[wasm_bindgen_test]
fn an_unreadable_payloads_thrown_message_is_quoted_as_every_error_text_is() {
    let mut t = Tracker::new(json(PLANT), 0.0).unwrap();
    // What the message says the payload was: an array whose toJSON throws `n` characters.
    let mut got = |n: usize| {
        let thrower = format!(
            "const a = []; a.toJSON = () => {{ throw new Error('y'.repeat({n})); }}; return a;"
        );
        let (read, reasons) = value_answer(&mut t, "ctrl-3/state", &js(&thrower));
        assert_eq!(reasons, ["not an object"], "{read}");
        let message = read["effects"][0]["message"].as_str().unwrap().to_owned();
        message.split_once(", got ").unwrap().1.to_owned()
    };
    // Under the bound: whole.
    assert_eq!(got(70), format!("\"(unreadable: {})\"", "y".repeat(70)));
    // Over it: cut once, by the same rule as every quoted value.
    let long = got(500);
    assert!(long.starts_with("\"(unreadable: yyy"), "{long}");
    assert_eq!(long.chars().count(), QUOTE_CHARS, "{long}");
    assert!(
        long.ends_with('…') && long.matches('…').count() == 1,
        "{long}"
    );
    assert!(!long.contains("..."), "{long}");
}

#[wasm_bindgen_test]
fn a_payload_that_passes_for_bytes_but_is_not_is_refused_never_thrown() {
    let mut t = Tracker::new(json(PLANT), 0.0).unwrap();
    for body in [
        "return new Proxy(new Uint8Array(4), { get() { throw new Error('no'); } });",
        "return new Proxy(new Uint8Array(4), {});",
        "const p = Proxy.revocable(new Uint8Array(4), {}); p.revoke(); return p.proxy;",
        "return Object.create(Uint8Array.prototype);",
    ] {
        let (read, reasons) = value_answer(&mut t, "ctrl-3/state", &js(body));
        assert_eq!(read["kind"], Ingest::Refused as u8, "{body}: {read}");
        assert_eq!(reasons.len(), 1, "{body}: {read}");
    }
    // The tracker still answers: no borrow was left open.
    let (read, _) = value_answer(&mut t, "ctrl-3/state", &js("return { valve: { 1: 5 } };"));
    assert_eq!(read["kind"], Ingest::Samples as u8);
}
