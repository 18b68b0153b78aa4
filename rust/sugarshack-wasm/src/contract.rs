//! What the nodes read from the core instead of copying it: the table of
//! codes with their status texts, and the reserved names.

use sugarshack_core::code::{self, MAX_STATUS_CHARS};
use sugarshack_core::interlock::EventKind;
use sugarshack_core::routine::RESET_TOPIC;
use wasm_bindgen::prelude::*;

use crate::to_js;

/// `[{ code, status, stem }]`: every error and status code, with the text a
/// node's status shows for it and the stem of its message.
#[wasm_bindgen]
pub fn codes() -> Result<JsValue, JsValue> {
    to_js(&code::table())
}

/// The longest status text, in characters, a node shows uncut.
#[wasm_bindgen(js_name = maxStatusChars)]
pub fn max_status_chars() -> u32 {
    MAX_STATUS_CHARS as u32
}

/// The msg topic that sends a routine back to its initial state.
#[wasm_bindgen(js_name = routineResetTopic)]
pub fn routine_reset_topic() -> String {
    RESET_TOPIC.into()
}

/// The interlock event kinds an operator looks back on (faults, clears,
/// warnings, ...): the ones `drainAbnormalEvents` keeps.
#[wasm_bindgen(js_name = abnormalEventKinds)]
pub fn abnormal_event_kinds() -> Result<JsValue, JsValue> {
    let kinds: Vec<EventKind> = EventKind::ALL
        .into_iter()
        .filter(|k| k.is_abnormal())
        .collect();
    to_js(&kinds)
}
