//! WebAssembly facade of the sugarshack core. It only translates: serde for
//! configuration, snapshots, events and outcomes; integer handles, scalars and
//! typed arrays on hot paths. Core errors become JS `Error`s whose `code`
//! property names the error kind.

mod control;
mod interlock;
pub mod operation;
mod routine;
mod tracker;

pub use control::{validate_thresholds, IoModule, PidLoop, Rcc};
pub use interlock::Interlock;
pub use routine::Routine;
pub use tracker::Tracker;

use serde::Serialize;
use wasm_bindgen::prelude::*;

pub(crate) fn serializer() -> serde_wasm_bindgen::Serializer {
    serde_wasm_bindgen::Serializer::json_compatible()
}

pub(crate) fn to_js<T: Serialize + ?Sized>(value: &T) -> Result<JsValue, JsValue> {
    value
        .serialize(&serializer())
        .map_err(|e| js_error("SERIALIZE", &e.to_string()))
}

pub(crate) fn js_error(code: &str, message: &str) -> JsValue {
    let error = js_sys::Error::new(message);
    error.set_name("SugarshackError");
    // Reflect::set on a fresh Error object cannot fail.
    let _ = js_sys::Reflect::set(&error, &"code".into(), &code.into());
    error.into()
}

pub(crate) fn time(now_ms: f64) -> Result<u64, JsValue> {
    if now_ms.is_finite() && now_ms >= 0.0 {
        Ok(now_ms as u64)
    } else {
        Err(js_error(
            "INVALID_TIME",
            &format!("time must be a non-negative number of milliseconds, got {now_ms}"),
        ))
    }
}

/// Reads a JS value as `T`, seeing every key: serde-wasm-bindgen reads a
/// struct by its known fields only, so a misspelt option would pass unseen.
pub(crate) fn from_js<T: serde::de::DeserializeOwned>(
    value: JsValue,
    code: &str,
    what: &str,
) -> Result<T, JsValue> {
    let failed = |e: &dyn std::fmt::Display| js_error(code, &format!("{what}: {e}"));
    let tree: serde_json::Value = serde_wasm_bindgen::from_value(value).map_err(|e| failed(&e))?;
    serde_json::from_value(tree).map_err(|e| failed(&e))
}
