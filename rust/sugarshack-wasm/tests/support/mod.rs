//! What the facade's tests share to read JS values. Each test file uses some of it.
#![allow(dead_code)]

use js_sys::{Reflect, JSON};
use wasm_bindgen::{JsCast, JsValue};

/// A JS value from JSON text.
pub fn json(text: &str) -> JsValue {
    JSON::parse(text).expect("test JSON parses")
}

/// A property of a JS object.
pub fn get(value: &JsValue, key: &str) -> JsValue {
    Reflect::get(value, &key.into()).unwrap()
}

/// The `code` of a thrown error, which must be a JS `Error`.
pub fn code_of(error: JsValue) -> String {
    assert!(
        error.is_instance_of::<js_sys::Error>(),
        "errors are JS Error objects"
    );
    get(&error, "code").as_string().unwrap()
}

/// The message of a thrown JS `Error`.
pub fn message_of(error: &JsValue) -> String {
    error.dyn_ref::<js_sys::Error>().unwrap().message().into()
}

/// A plant document: valves on panel ctrl-1 and the volume sensor LT-3 on
/// station-3; `rest` is its other members (actuators, resources, operations...).
pub fn valve_plant(rest: &str) -> String {
    format!(
        r#"{{
    "actuatorTypes": {{
        "valve": {{ "signal": "analog", "tolerance": 2, "noMotionMs": 1000, "completionMs": 5000, "staleMs": 5000 }}
    }},
    "devices": [{{ "id": "ctrl-1", "kind": "actuator-panel" }}, {{ "id": "station-3", "kind": "sensor-station" }}],
    "sensors": [{{ "id": "LT-3", "device": "station-3", "name": "volume", "staleMs": 2000 }}],
    {rest}
}}"#
    )
}
