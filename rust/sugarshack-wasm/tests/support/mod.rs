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
