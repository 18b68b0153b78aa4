//! WebAssembly facade of the sugarshack core. It only translates: serde for
//! configuration, snapshots, events and outcomes; integer handles, scalars and
//! typed arrays on hot paths. Core errors become JS `Error`s whose `code`
//! property names the error kind. Whatever JS hands in is bounded in size and
//! nesting before anything recursive reads it (see [`Bound`]): the instance
//! is shared by every node of the process and must outlive any input.

mod alarm;
mod condition;
mod contract;
mod control;
mod device;
mod engine;
mod group;
mod interlock;
mod lifecycle;
mod modbus;
pub mod operation;
mod payload;
mod routine;
mod tracker;

pub use alarm::Alarms;
pub use contract::{
    abnormal_event_kinds, alarm_severities, catalog_texts, codes, max_shelve_ms, max_status_chars,
    memory, operator_commands, routine_reset_topic,
};
pub use control::{
    open_pid_state, pid_defaults, seal_pid_state, validate_thresholds, IoModule, PidLoop,
    PidStation, Rcc,
};
pub use device::DeviceSide;
pub use engine::Engine;
pub use group::{is_lockout_msg, read_group_msg};
pub use interlock::{Interlock, RESOURCE_SETS_KEPT};
pub use lifecycle::{life_step, life_view};
pub use routine::Routine;
pub use tracker::{Ingest, Tracker};

use js_sys::{JsString, Reflect, JSON};
use serde::de::DeserializeOwned;
use serde::Serialize;
use sugarshack_core::code::Code;
use sugarshack_core::json::{self, JsonError};
use sugarshack_core::plant::PlantModel;
use sugarshack_core::text::quote;
use sugarshack_core::time::Millis;
use wasm_bindgen::prelude::*;
use wasm_bindgen::JsCast;

pub(crate) fn serializer() -> serde_wasm_bindgen::Serializer {
    serde_wasm_bindgen::Serializer::json_compatible()
}

pub(crate) fn to_js<T: Serialize + ?Sized>(value: &T) -> Result<JsValue, JsValue> {
    value
        .serialize(&serializer())
        .map_err(|e| js_error(Code::Internal, &e.to_string()))
}

pub(crate) fn js_error(code: Code, message: &str) -> JsValue {
    let error = js_sys::Error::new(message);
    error.set_name("SugarshackError");
    // Reflect::set on a fresh Error object cannot fail.
    let _ = js_sys::Reflect::set(&error, &"code".into(), &code.name().into());
    error.into()
}

/// A time from JS in whole milliseconds (a fraction is dropped, as it always was).
pub(crate) fn time(now_ms: f64) -> Result<Millis, JsValue> {
    Millis::whole(now_ms).ok_or_else(|| {
        js_error(
            Code::InvalidTime,
            &format!(
                "time must be a non-negative number of milliseconds, got {}",
                quote(now_ms)
            ),
        )
    })
}

const KIB: usize = 1024;
const MIB: usize = 1024 * KIB;

/// What a value read from JS is, and so how much JSON text it may be: a
/// bound checked before anything recursive reads it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Bound {
    PlantDocument,
    InterlockConfig,
    InterlockSnapshot,
    RoutineSnapshot,
    /// Alarm conditions and saved alarms.
    Alarms,
    GroupCommand,
    /// PID and RCC configurations, RCC decisions and I/O states.
    Control,
    /// Whatever `from_js` reads without naming its kind.
    Unnamed,
}

impl Bound {
    pub(crate) fn max_bytes(self) -> usize {
        match self {
            Bound::PlantDocument => 32 * MIB,
            Bound::InterlockConfig => MIB,
            Bound::InterlockSnapshot => 16 * MIB,
            Bound::RoutineSnapshot => 64 * KIB,
            Bound::Alarms => 8 * MIB,
            Bound::GroupCommand => 64 * KIB,
            Bound::Control => 64 * KIB,
            Bound::Unnamed => MIB,
        }
    }

    fn noun(self) -> &'static str {
        match self {
            Bound::PlantDocument => "a plant document",
            Bound::InterlockConfig => "an interlock configuration",
            Bound::InterlockSnapshot => "an interlock snapshot",
            Bound::RoutineSnapshot => "a routine snapshot",
            Bound::Alarms => "alarms",
            Bound::GroupCommand => "a group command",
            Bound::Control => "a control configuration or state",
            Bound::Unnamed => "this input",
        }
    }
}

fn size_text(bytes: usize) -> String {
    match bytes {
        b if b >= MIB && b % MIB == 0 => format!("{} MiB", b / MIB),
        b if b >= KIB && b % KIB == 0 => format!("{} KiB", b / KIB),
        b => format!("{b} bytes"),
    }
}

/// Reads a JS value as `T` within [`Bound::Unnamed`]; see [`from_js_bounded`].
/// Every reader here names its kind; this stays for readers that do not.
#[allow(dead_code)]
pub(crate) fn from_js<T: DeserializeOwned>(
    value: JsValue,
    code: Code,
    what: &str,
) -> Result<T, JsValue> {
    from_js_bounded(value, code, what, Bound::Unnamed)
}

/// A plant document from JS (an object, or its JSON text), read within its
/// bound; a problem is refused as `INVALID_PLANT` with its path.
pub(crate) fn plant_document(value: JsValue) -> Result<PlantModel, JsValue> {
    from_js_bounded(
        value,
        Code::InvalidPlant,
        "invalid plant document",
        Bound::PlantDocument,
    )
}

/// Reads a JS value as `T`: a string as JSON text, anything else through
/// `JSON.stringify`, which throws rather than overflows on a circular or
/// absurdly deep value. The text is bounded in size and depth before it is
/// parsed, so no input can exhaust the stack this wasm instance shares with
/// every node. A problem in the value is refused with `code`, its message
/// starting with `what` and naming where the problem is; every key is seen,
/// so a misspelt option is refused too.
pub(crate) fn from_js_bounded<T: DeserializeOwned>(
    value: JsValue,
    code: Code,
    what: &str,
    bound: Bound,
) -> Result<T, JsValue> {
    let (text, given_as_text) = json_text(&value, what, bound)?;
    json::from_str(&text).map_err(|err| match err {
        JsonError::TooDeep { limit } => too_deep(what, limit),
        // A position is only of use in text the user wrote.
        invalid if given_as_text => js_error(code, &format!("{what}: {invalid}")),
        invalid => js_error(code, &format!("{what}: {}", invalid.without_position())),
    })
}

thread_local! {
    /// JSON.stringify writes NaN and ±Infinity as null, which an optional
    /// field takes for "absent"; as text they are refused where they stand.
    static NON_FINITE_AS_TEXT: js_sys::Function = js_sys::Function::new_with_args(
        "key, value",
        "return typeof value === 'number' && !Number.isFinite(value) ? String(value) : value;",
    );
}

thread_local! {
    /// Where in a value JSON.stringify stopped at a BigInt, walked in its own
    /// order: `[path, digits]` (`valves.V101`, `100`), or null.
    static BIGINT_AT: js_sys::Function = js_sys::Function::new_with_args(
        "value",
        "const seen = new Set(); let budget = 100000;\n\
         const walk = (v, path, depth) => {\n\
           if (typeof v === 'bigint') return [path, String(v)];\n\
           if (v === null || typeof v !== 'object' || depth > 128 || seen.has(v) || --budget < 0) return null;\n\
           seen.add(v);\n\
           if (typeof v.toJSON === 'function') return null;\n\
           const array = Array.isArray(v);\n\
           for (const k of array ? v.keys() : Object.keys(v)) {\n\
             let item; try { item = v[k]; } catch { return null; }\n\
             const found = walk(item, array ? `${path}[${k}]` : path ? `${path}.${k}` : k, depth + 1);\n\
             if (found) return found;\n\
           }\n\
           return null;\n\
         };\n\
         return walk(value, '', 0);",
    );
}

/// The refusal of a value holding a BigInt, naming where it is (or None when it cannot be found).
fn bigint_refusal(value: &JsValue, what: &str) -> Option<JsValue> {
    let found = BIGINT_AT.with(|at| at.call1(&JsValue::NULL, value)).ok()?;
    let found: js_sys::Array = found.dyn_into().ok()?;
    let (path, digits) = (found.get(0).as_string()?, found.get(1).as_string()?);
    let field = if path.is_empty() {
        "the value".to_owned()
    } else {
        quote(&path)
    };
    Some(js_error(
        Code::InvalidInput,
        &format!(
            "{what}: {field} is a BigInt ({}n), which JSON cannot carry: send it as a plain number",
            quote(digits)
        ),
    ))
}

/// The JSON text of `value`, within `bound`; true when it was given as text.
fn json_text(value: &JsValue, what: &str, bound: Bound) -> Result<(String, bool), JsValue> {
    let given_as_text = value.is_string();
    let text: JsString = if given_as_text {
        value.clone().unchecked_into()
    } else {
        NON_FINITE_AS_TEXT
            .with(|replacer| JSON::stringify_with_replacer(value, replacer))
            .map_err(|thrown| {
                bigint_refusal(value, what).unwrap_or_else(|| unconvertible(&thrown, what, bound))
            })?
    };
    // JSON.stringify gives undefined for undefined, a function or a symbol.
    if !text.is_string() {
        return Err(js_error(
            Code::InvalidInput,
            &format!("{what}: there is nothing to read (undefined, a function or a symbol); pass an object or JSON text"),
        ));
    }
    let limit = bound.max_bytes();
    // UTF-16 units never outnumber UTF-8 bytes: refuse before copying.
    let units = text.length() as usize;
    if units > limit {
        return Err(too_large(what, bound, units, true));
    }
    let text = text.as_string().unwrap_or_default();
    if text.len() > limit {
        return Err(too_large(what, bound, text.len(), false));
    }
    Ok((text, given_as_text))
}

fn too_deep(what: &str, limit: usize) -> JsValue {
    js_error(
        Code::InputTooDeep,
        &format!("{what}: nested deeper than {limit} levels; refused"),
    )
}

fn too_large(what: &str, bound: Bound, size: usize, at_least: bool) -> JsValue {
    js_error(
        Code::InputTooLarge,
        &format!(
            "{what}: {}{size} bytes of JSON, over the {} limit for {}; refused",
            if at_least { "at least " } else { "" },
            size_text(bound.max_bytes()),
            bound.noun()
        ),
    )
}

/// The coded error for a value `JSON.stringify` threw on. Only `Reflect.get`
/// (which catches) reads the thrown value: it may be anything.
fn unconvertible(thrown: &JsValue, what: &str, bound: Bound) -> JsValue {
    let field = |key: &str| {
        Reflect::get(thrown, &JsValue::from_str(key))
            .ok()
            .and_then(|v| v.as_string())
            .unwrap_or_default()
    };
    let (name, message) = match thrown.as_string() {
        Some(text) => (String::new(), text),
        None => (field("name"), field("message")),
    };
    match name.as_str() {
        "TypeError" if message.contains("circular") => js_error(
            Code::InputCircular,
            &format!("{what}: the value refers to itself (a circular structure) and cannot be read; pass plain data"),
        ),
        "RangeError" if message.contains("call stack") => too_deep(what, json::MAX_DEPTH),
        "RangeError" if message.contains("string length") => js_error(
            Code::InputTooLarge,
            &format!(
                "{what}: too large to turn into text, over the {} limit for {}; refused",
                size_text(bound.max_bytes()),
                bound.noun()
            ),
        ),
        _ => {
            let why = match (name.is_empty(), message.is_empty()) {
                (true, true) => "something that is not an Error was thrown".to_string(),
                (true, false) => message,
                (false, _) => format!("{name}: {message}"),
            };
            js_error(
                Code::InvalidInput,
                &format!(
                    "{what}: cannot be turned into JSON ({}); pass plain data: objects, arrays, strings, numbers, booleans",
                    quote(why)
                ),
            )
        }
    }
}
