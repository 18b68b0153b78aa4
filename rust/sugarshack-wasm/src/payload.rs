//! A device msg's payload as Node-RED handed it over, read as what its device
//! sent: `mqtt in` gives text, a Buffer, or what auto-detect parsed from JSON
//! text, which is written back as JSON here. A value that cannot be written
//! (circular, too deep, a getter that throws, a revoked proxy) becomes a
//! string saying so, which the core refuses as it would any wrong value: at
//! the top, or in its own field when only some fields of an object are. No
//! value throws out of here, and no text read is over `max` bytes.

use js_sys::{Array, JsString, Reflect, Uint8Array, JSON};
use sugarshack_core::text::quote;
use wasm_bindgen::prelude::*;
use wasm_bindgen::JsCast;

/// An object JSON cannot write whole is read field by field, at most this many.
const MAX_KEYS: usize = 1000;

#[wasm_bindgen]
extern "C" {
    // All catch: a proxy's trap or a toString may throw anything.
    #[wasm_bindgen(catch, js_namespace = Object, js_name = keys)]
    fn object_keys(value: &JsValue) -> Result<Array, JsValue>;
    #[wasm_bindgen(catch, js_name = String)]
    fn js_string(value: &JsValue) -> Result<JsString, JsValue>;
    #[wasm_bindgen(catch, js_namespace = Array, js_name = isArray)]
    fn is_array(value: &JsValue) -> Result<bool, JsValue>;
    /// A plain copy: a proxy that passes for a Uint8Array is read through its traps once, here.
    #[wasm_bindgen(catch, js_namespace = Uint8Array, js_name = from)]
    fn uint8_array_from(value: &JsValue) -> Result<Uint8Array, JsValue>;
}

/// What a payload crosses as.
#[derive(Debug, PartialEq, Eq)]
pub(crate) enum Payload {
    Text(String),
    Bytes(Vec<u8>),
    /// Over the bound: at least this many bytes, left in JS.
    TooLarge(usize),
}

/// `value` as its device's text or bytes, within `max` bytes.
pub(crate) fn read(value: &JsValue, max: usize) -> Payload {
    if value.is_undefined() {
        return Payload::Text(String::new());
    }
    if let Some(text) = value.dyn_ref::<JsString>() {
        return from(bounded(text, max));
    }
    if value.is_instance_of::<Uint8Array>() {
        if let Some(bytes) = byte_copy(value, max) {
            return bytes;
        }
    }
    from(json_text(value, true, max))
}

/// The bytes of a Uint8Array (a Buffer), or None when it cannot be read as one.
fn byte_copy(value: &JsValue, max: usize) -> Option<Payload> {
    let over = |len: f64| (len > max as f64).then_some(Payload::TooLarge(len as usize));
    // Sized before it is copied, even in JS.
    let len = Reflect::get(value, &JsValue::from_str("length"))
        .ok()?
        .as_f64()?;
    if let Some(too_large) = over(len) {
        return Some(too_large);
    }
    let bytes = uint8_array_from(value).ok()?;
    Some(over(f64::from(bytes.length())).unwrap_or_else(|| Payload::Bytes(bytes.to_vec())))
}

fn from(text: Result<String, usize>) -> Payload {
    text.map_or_else(Payload::TooLarge, Payload::Text)
}

/// A JS string as Rust text, or its size when over `max` bytes.
fn bounded(text: &JsString, max: usize) -> Result<String, usize> {
    // UTF-16 units never outnumber UTF-8 bytes: refused before copying.
    let units = text.length() as usize;
    if units > max {
        return Err(units);
    }
    let text = String::from(text);
    if text.len() > max {
        return Err(text.len());
    }
    Ok(text)
}

/// The JSON text of `value`; `top`: a payload itself, whose fields are read
/// one by one when it cannot be written whole.
fn json_text(value: &JsValue, top: bool, max: usize) -> Result<String, usize> {
    let thrown = match JSON::stringify(value) {
        Ok(text) if text.is_string() => return bounded(&text, max),
        // undefined, a function, a symbol: what String() makes of it, as a JSON string.
        Ok(_) => match js_string(value) {
            Ok(text) => return bounded(&text, max).map(|t| json_string(&t)),
            Err(thrown) => thrown,
        },
        Err(thrown) => thrown,
    };
    if top && value.is_object() && is_array(value) == Ok(false) {
        if let Some(text) = fields(value, max) {
            return text;
        }
    }
    Ok(unreadable(&thrown))
}

/// `{"key": <json_text>, ...}` of an object's first `MAX_KEYS` fields; None
/// when its keys or one of its fields cannot be read at all (a proxy, a getter that throws).
fn fields(value: &JsValue, max: usize) -> Option<Result<String, usize>> {
    let keys = object_keys(value).ok()?;
    let mut text = String::from("{");
    for (i, key) in keys.iter().take(MAX_KEYS).enumerate() {
        let field = Reflect::get(value, &key).ok()?;
        if i > 0 {
            text.push(',');
        }
        text.push_str(&json_string(&key.as_string().unwrap_or_default()));
        text.push(':');
        match json_text(&field, false, max) {
            Ok(part) => text.push_str(&part),
            Err(size) => return Some(Err(size)),
        }
        if text.len() > max {
            return Some(Err(text.len()));
        }
    }
    text.push('}');
    Some(Ok(text))
}

/// A JSON string saying why a value cannot be read (the thrown error's
/// message, quoted as every error text is).
fn unreadable(thrown: &JsValue) -> String {
    let message = if thrown.is_object() {
        Reflect::get(thrown, &JsValue::from_str("message"))
            .ok()
            .and_then(|m| m.as_string())
    } else {
        thrown.as_string()
    }
    .unwrap_or_else(|| "not an Error".to_owned());
    json_string(&format!("(unreadable: {})", quote(message)))
}

fn json_string(text: &str) -> String {
    serde_json::Value::from(text).to_string()
}
