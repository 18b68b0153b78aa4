//! A group command msg, read by the core's rules (`plant::group_msg`): JS
//! hands in what it read off the msg and gets back, in one call, whether it
//! is a lockout, the lines its command must keep within (C2), and its
//! payload as the command reads it (JSON text parsed once, within its bound),
//! or the refusal to throw.

use js_sys::{Object, Reflect, Uint8Array, JSON};
use sugarshack_core::engine::{Param, Refusal};
use sugarshack_core::plant::group_msg::{self, Interlock};
use wasm_bindgen::prelude::*;
use wasm_bindgen::JsCast;

use crate::engine::{quoted, raw};

#[wasm_bindgen(typescript_custom_section)]
const TS_GROUP_MSG: &str = r#"
/** A group command msg as the core read it, or why it is refused (a catalog text). */
export type GroupMsgRead =
    | { lockout: boolean; within: string[] | null; payload: unknown }
    | { refusal: { code: string; key: string; params: Record<string, string> } };
"#;

/// Reads a group command msg: `msg.topic`, `msg.lockout`, `msg.interlock`
/// and `msg.payload` (an object as given; text or a Buffer as JSON).
#[wasm_bindgen(js_name = readGroupMsg, unchecked_return_type = "GroupMsgRead")]
pub fn read_group_msg(
    #[wasm_bindgen(unchecked_param_type = "unknown")] topic: JsValue,
    #[wasm_bindgen(unchecked_param_type = "unknown")] lockout: JsValue,
    #[wasm_bindgen(unchecked_param_type = "unknown")] interlock: JsValue,
    #[wasm_bindgen(unchecked_param_type = "unknown")] payload: JsValue,
) -> JsValue {
    let out = Object::new();
    match read_msg(&topic, &lockout, &interlock, payload) {
        Ok((read, payload)) => {
            let within = match read.within {
                Some(lines) => lines
                    .into_iter()
                    .map(JsValue::from)
                    .collect::<js_sys::Array>()
                    .into(),
                None => JsValue::NULL,
            };
            set(&out, "lockout", &read.lockout.into());
            set(&out, "within", &within);
            set(&out, "payload", &payload);
        }
        Err(refusal) => set(&out, "refusal", &refusal_object(&refusal)),
    }
    out.into()
}

/// A group command msg's terms and its payload as the command reads it, or its refusal.
pub(crate) fn read_msg(
    topic: &JsValue,
    lockout: &JsValue,
    interlock: &JsValue,
    payload: JsValue,
) -> Result<(group_msg::GroupMsg, JsValue), Refusal> {
    let read = group_msg::read_group_msg(
        topic.as_string().as_deref(),
        &raw(lockout),
        &interlock_of(interlock),
    )?;
    Ok((read, command_payload(payload)?))
}

/// Whether a msg is a lockout (`msg.topic`, `msg.lockout`), its payload unread.
#[wasm_bindgen(js_name = isLockoutMsg)]
pub fn is_lockout_msg(
    #[wasm_bindgen(unchecked_param_type = "unknown")] topic: JsValue,
    #[wasm_bindgen(unchecked_param_type = "unknown")] lockout: JsValue,
) -> bool {
    group_msg::is_lockout(topic.as_string().as_deref(), &raw(&lockout))
}

/// msg.interlock: unset, an object's `resources`, or anything else quoted.
fn interlock_of(interlock: &JsValue) -> Interlock {
    if interlock.is_undefined() {
        return Interlock::Unset;
    }
    if !interlock.is_object() {
        return Interlock::Other(quoted(interlock));
    }
    match Reflect::get(interlock, &"resources".into()) {
        Ok(resources) if resources.is_undefined() => Interlock::Other(quoted(interlock)),
        Ok(resources) => Interlock::Holds(raw(&resources)),
        Err(_) => Interlock::Other("(unreadable)".to_owned()),
    }
}

/// The payload as the command reads it: text or a Buffer parsed as JSON
/// (JSON.parse, as the nodes always did), anything else as given.
fn command_payload(payload: JsValue) -> Result<JsValue, Refusal> {
    let text = if let Some(text) = payload.dyn_ref::<js_sys::JsString>() {
        group_msg::check_group_text(text.length() as usize)?;
        String::from(text)
    } else if let Some(bytes) = payload.dyn_ref::<Uint8Array>() {
        group_msg::check_group_text(bytes.length() as usize)?;
        String::from_utf8_lossy(&bytes.to_vec()).into_owned()
    } else {
        return Ok(payload);
    };
    JSON::parse(&text).map_err(|err| {
        let message = Reflect::get(&err, &"message".into())
            .ok()
            .and_then(|m| m.as_string())
            .unwrap_or_default();
        group_msg::not_json(&message)
    })
}

/// `{ code, key, params }`: the host words it by its catalog (`errors.<name>`).
fn refusal_object(refusal: &Refusal) -> JsValue {
    let out = Object::new();
    let params = Object::new();
    for (name, value) in refusal_params(refusal) {
        set(&params, name, &value.into());
    }
    set(&out, "code", &refusal.code.name().into());
    set(&out, "key", &refusal.key().unwrap_or_default().into());
    set(&out, "params", &params);
    out.into()
}

/// The same `{ code, key, params }` as JSON, for an answer given as one text.
pub(crate) fn refusal_json(refusal: &Refusal) -> serde_json::Value {
    let params: serde_json::Map<String, serde_json::Value> = refusal_params(refusal)
        .into_iter()
        .map(|(name, value)| (name.to_owned(), value.into()))
        .collect();
    serde_json::json!({
        "code": refusal.code.name(),
        "key": refusal.key().unwrap_or_default(),
        "params": params,
    })
}

fn refusal_params(refusal: &Refusal) -> Vec<(&'static str, String)> {
    let params = refusal.params().into_iter();
    params
        .map(|(name, param)| {
            let value = match param {
                Param::Text(text) => text,
                Param::Label(label) => label.to_owned(),
            };
            (name, value)
        })
        .collect()
}

fn set(object: &Object, key: &str, value: &JsValue) {
    // Reflect::set on a fresh plain object cannot fail.
    let _ = Reflect::set(object, &key.into(), value);
}
