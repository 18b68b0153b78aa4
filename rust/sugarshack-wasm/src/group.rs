//! A group command msg, read by the core's rules (`plant::group_msg`): JS
//! hands in what it read off the msg and gets back, in one call, whether it
//! is a lockout, the lines its command must keep within (C2), and its
//! payload as the command reads it (JSON text parsed once, within its bound),
//! or the refusal to throw.

use js_sys::{Array, Object, Reflect, Uint8Array, JSON};
use sugarshack_core::engine::{Param, Refusal};
use sugarshack_core::plant::group_msg::{self, Interlock, Unread};
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

/// Reads a group command msg: `msg.lockout` and `msg.topic`, then (unless
/// it is a lockout) `msg.interlock`, then `msg.payload` (an object as given;
/// text or a Buffer as JSON). A field that throws as it is read throws here.
#[wasm_bindgen(js_name = readGroupMsg, unchecked_return_type = "GroupMsgRead")]
pub fn read_group_msg(
    #[wasm_bindgen(unchecked_param_type = "object")] msg: &JsValue,
) -> Result<JsValue, JsValue> {
    let flag = raw(&field(msg, "lockout")?);
    let topic = field(msg, "topic")?.as_string();
    let read = group_msg::read_group_msg(topic.as_deref(), &flag, || {
        interlock_of(&field(msg, "interlock")?)
    });
    let out = Object::new();
    let read = match read {
        Ok(read) => read,
        Err(Unread::Unreadable(thrown)) => return Err(thrown),
        Err(Unread::Refused(refusal)) => {
            set(&out, "refusal", &refusal_object(&refusal));
            return Ok(out.into());
        }
    };
    match command_payload(field(msg, "payload")?) {
        Ok(payload) => {
            let within = match read.within {
                Some(lines) => lines
                    .into_iter()
                    .map(JsValue::from)
                    .collect::<Array>()
                    .into(),
                None => JsValue::NULL,
            };
            set(&out, "lockout", &read.lockout.into());
            set(&out, "within", &within);
            set(&out, "payload", &payload);
        }
        Err(refusal) => set(&out, "refusal", &refusal_object(&refusal)),
    }
    Ok(out.into())
}

/// Whether a msg is a lockout (`msg.lockout`, `msg.topic`), its payload unread.
#[wasm_bindgen(js_name = isLockoutMsg)]
pub fn is_lockout_msg(
    #[wasm_bindgen(unchecked_param_type = "object")] msg: &JsValue,
) -> Result<bool, JsValue> {
    let flag = raw(&field(msg, "lockout")?);
    let topic = field(msg, "topic")?.as_string();
    Ok(group_msg::is_lockout(topic.as_deref(), &flag))
}

/// A property of the msg; a getter or proxy that throws throws on to the host.
fn field(msg: &JsValue, key: &str) -> Result<JsValue, JsValue> {
    Reflect::get(msg, &key.into())
}

/// msg.interlock: unset, an object's `resources`, or anything else quoted.
fn interlock_of(interlock: &JsValue) -> Result<Interlock, JsValue> {
    if interlock.is_undefined() {
        return Ok(Interlock::Unset);
    }
    if !interlock.is_object() {
        return Ok(Interlock::Other(quoted(interlock)));
    }
    let resources = field(interlock, "resources")?;
    Ok(if resources.is_undefined() {
        Interlock::Other(quoted(interlock))
    } else {
        Interlock::Holds(raw(&resources))
    })
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
    for (name, param) in refusal.params() {
        let value = match param {
            Param::Text(text) => text,
            Param::Label(label) => label.to_owned(),
        };
        set(&params, name, &value.into());
    }
    let key = refusal.key().unwrap_or_default();
    set(&out, "code", &refusal.code.name().into());
    set(&out, "key", &key.into());
    set(&out, "params", &params);
    out.into()
}

fn set(object: &Object, key: &str, value: &JsValue) {
    // Reflect::set on a fresh plain object cannot fail.
    let _ = Reflect::set(object, &key.into(), value);
}
