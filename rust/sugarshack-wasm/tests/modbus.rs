#![cfg(target_arch = "wasm32")]

//! The tracker's Modbus connections through the JS boundary, under Node: a
//! poll's bytes become feedback, a command becomes a write on its connection,
//! a lost connection fails the command, and no input traps.

use js_sys::Array;
use sugarshack_wasm::{DeviceSide, Tracker};
use wasm_bindgen_test::wasm_bindgen_test;

mod support;
use support::{code_of, get, json};

const PLANT: &str = r#"{
    "actuatorTypes": {
        "valve": { "signal": "analog", "tolerance": 2, "noMotionMs": 1000, "completionMs": 5000, "staleMs": 5000 }
    },
    "devices": [{ "id": "io", "kind": "actuator-panel", "profile": "modbus",
                  "modbus": { "host": "127.0.0.1", "port": 5020, "unit": 1, "pollMs": 500, "timeoutMs": 200,
                              "outputs": [{ "id": "FCV", "kind": "holding", "address": 10 }] } }],
    "actuators": [{ "id": "V1", "type": "valve", "device": "io", "idle": 0, "lockout": 0, "modbus": {
        "command": { "kind": "holding", "address": 0, "scale": { "raw": [4000, 20000], "value": [0, 100] } },
        "feedback": { "kind": "input", "address": 0, "scale": { "raw": [4000, 20000], "value": [0, 100] } } } }]
}"#;

fn kinds(effects: &wasm_bindgen::JsValue) -> Vec<String> {
    Array::from(effects)
        .iter()
        .map(|e| get(&e, "kind").as_string().unwrap())
        .collect()
}

/// The device's answer to `frame` with `words`, as the simulator gives it.
fn answer(side: &DeviceSide, frame: &[u8], words: Option<Vec<u16>>) -> Vec<u8> {
    side.modbus_reply("tcp", frame, words, None).unwrap()
}

#[wasm_bindgen_test]
fn a_poll_reads_feedback_and_a_command_is_written_then_fails_when_the_connection_is_lost() {
    let mut t = Tracker::new(json(PLANT), 1000.0).unwrap();
    let side = DeviceSide::new(json(PLANT)).unwrap();
    assert_eq!(
        t.modbus_next(0, 1000.0).unwrap(),
        None,
        "nothing before the connection opens"
    );
    t.modbus_opened(0, 1000.0).unwrap();
    let poll = t.modbus_next(0, 1000.0).unwrap().unwrap();
    t.modbus_receive(0, &answer(&side, &poll, Some(vec![4000])), 1010.0)
        .unwrap();
    assert_eq!(t.position(0), Some(0.0));
    assert_eq!(t.last_round_trip_ms(), Some(10.0));
    t.take_effects().unwrap();
    t.command(
        json(r#"{ "valves": { "V1": 50 } }"#),
        7,
        false,
        1100.0,
        None,
        None,
        None,
    )
    .unwrap();
    assert_eq!(kinds(&t.take_effects().unwrap()), ["modbusSend"]);
    let write = t.modbus_next(0, 1100.0).unwrap().unwrap();
    let served = side.modbus_request("tcp", &write).unwrap();
    assert_eq!(get(&served, "kind").as_string().unwrap(), "holding");
    t.modbus_receive(0, &answer(&side, &write, None), 1110.0)
        .unwrap();
    assert_eq!(t.modbus_closed(0, 1200.0).unwrap(), 3);
    assert_eq!(
        kinds(&t.take_effects().unwrap()),
        ["deviceStatus", "fault", "groupFailed"]
    );
    assert_eq!(
        code_of(t.output("FCV", 1.0, 1300.0).unwrap_err()),
        "DEVICE_OFFLINE"
    );
}

#[wasm_bindgen_test]
fn no_input_traps_the_facade() {
    let mut t = Tracker::new(json(PLANT), 0.0).unwrap();
    assert_eq!(
        code_of(t.modbus_receive(9, b"x", 0.0).unwrap_err()),
        "INVALID_INPUT"
    );
    assert_eq!(
        code_of(t.modbus_receive(0, b"x", f64::NAN).unwrap_err()),
        "INVALID_TIME"
    );
    t.modbus_opened(0, 0.0).unwrap();
    t.modbus_next(0, 0.0).unwrap().unwrap();
    // A megabyte of noise: read a frame at a time, kept to two frames' worth.
    let noise: Vec<u8> = (0..1_000_000u64).map(|i| (i * 7919 % 251) as u8).collect();
    t.modbus_receive(0, &noise, 1.0).unwrap();
    assert_eq!(
        code_of(t.output("FCV", f64::NAN, 2.0).unwrap_err()),
        "INVALID_TARGET"
    );
    assert_eq!(
        code_of(t.output("nope", 1.0, 2.0).unwrap_err()),
        "UNKNOWN_OUTPUT"
    );
    t.modbus_timeout(0, 1000.0).unwrap();
    let side = DeviceSide::new(json(PLANT)).unwrap();
    assert_eq!(
        code_of(
            side.modbus_request("tcp", &[0, 1, 0, 0, 0, 2, 1, 99])
                .unwrap_err()
        ),
        "INVALID_INPUT"
    );
    assert_eq!(
        code_of(side.modbus_scan("udp", &[]).unwrap_err()),
        "INVALID_INPUT"
    );
}
