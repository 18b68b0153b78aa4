#![cfg(target_arch = "wasm32")]

//! Device messages through the boundary, under Node: `ingest` reads them by
//! the plant's profiles and applies them; what it cannot use comes back as
//! `malformed` effects, and foreign topics are told apart.

use js_sys::Array;
use sugarshack_wasm::{Ingest, Tracker};
use wasm_bindgen::JsValue;
use wasm_bindgen_test::wasm_bindgen_test;

mod support;
use support::{get, json};

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
    assert_eq!(t.read_sensors(&[lt], 200.0).unwrap(), vec![1234.5]);
    // Fresh for five of its 60 s updates.
    assert!(t.read_sensors(&[lt], 299_000.0).is_ok());
    t.ingest("station-2/sensor/volume/state", "nan", 300.0)
        .unwrap();
    let err = t.read_sensors(&[lt], 400.0).err().unwrap();
    assert_eq!(get(&err, "code").as_string().unwrap(), "SENSOR_UNAVAILABLE");
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
