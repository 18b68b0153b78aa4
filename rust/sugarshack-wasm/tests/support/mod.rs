//! What the facade's tests share to read JS values. Each test file uses some of it.
#![allow(dead_code)]

use js_sys::{Reflect, JSON};
use sugarshack_wasm::Tracker;
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

/// Sensor `id`'s value at `now_ms` as a condition over it reads it (the one
/// way JS reads sensors): `Err` with why not when it is not fresh.
pub fn fresh_value(t: &mut Tracker, id: &str, now_ms: f64) -> Result<f64, String> {
    let condition = t
        .condition(&format!("`{id}` = `{id}`"), vec![id.to_owned()])
        .unwrap();
    let sensor = t.sensor(id).unwrap();
    let check = t.check_condition(condition, &[sensor], now_ms).unwrap();
    let values = get(&check, "values");
    if values.is_null() {
        return Err(get(&check, "reason").as_string().unwrap());
    }
    Ok(get(&values, id).as_f64().unwrap())
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
