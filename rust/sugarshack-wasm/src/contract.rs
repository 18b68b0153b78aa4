//! What the nodes read from the core instead of copying it: the table of
//! codes with their status texts, and the reserved names.

use sugarshack_core::alarm::{AlarmKind, MAX_SHELVE_MS};
use sugarshack_core::code::{self, MAX_STATUS_CHARS};
use sugarshack_core::interlock::EventKind;
use sugarshack_core::procedure::Command;
use sugarshack_core::routine::RESET_TOPIC;
use wasm_bindgen::prelude::*;

use crate::to_js;

/// The TypeScript shapes of what this module's calls return and take
/// (`unchecked_return_type` / `unchecked_param_type` name them).
#[wasm_bindgen(typescript_custom_section)]
const TS_SHAPES: &str = r#"
/** One row of `codes()`: a code, the status text a node shows for it, its message stem. */
export interface CodeEntry {
    code: string;
    status: string;
    stem: string;
}

/** What a facade call throws: an `Error` whose `code` names a row of `codes()`. */
export interface SugarshackError extends Error {
    code: string;
    /** On `CLEAR_REFUSED`: every reason, per line. */
    lines?: LineBlockers[];
}

/** A group command: `{ valves: { V12: 100 }, pumps: { P1: true } }`. */
export type GroupCommand = Record<string, Record<string, number | boolean>>;
"#;

/// `[{ code, status, stem }]`: every error and status code, with the text a
/// node's status shows for it and the stem of its message.
#[wasm_bindgen(unchecked_return_type = "CodeEntry[]")]
pub fn codes() -> Result<JsValue, JsValue> {
    to_js(&code::table())
}

/// The longest status text, in characters, a node shows uncut.
#[wasm_bindgen(js_name = maxStatusChars)]
pub fn max_status_chars() -> u32 {
    MAX_STATUS_CHARS as u32
}

/// The longest an alarm may stay shelved, in ms (OPC UA's MaxTimeShelved).
#[wasm_bindgen(js_name = maxShelveMs)]
pub fn max_shelve_ms() -> f64 {
    MAX_SHELVE_MS.as_f64()
}

/// Each alarm kind's priority as OPC UA's Severity: `{ "line-faulted": 800, ... }`.
#[wasm_bindgen(js_name = alarmSeverities, unchecked_return_type = "Record<AlarmKind, number>")]
pub fn alarm_severities() -> Result<JsValue, JsValue> {
    let table: std::collections::BTreeMap<&str, u16> = AlarmKind::ALL
        .into_iter()
        .map(|k| (k.name(), k.severity()))
        .collect();
    to_js(&table)
}

/// The msg topic that sends a routine back to its initial state.
#[wasm_bindgen(js_name = routineResetTopic)]
pub fn routine_reset_topic() -> String {
    RESET_TOPIC.into()
}

/// The operator's commands (`hold`, `restart`, `stop`, `abort`, `reset`):
/// also the msg topics that give them to an operation or routine node.
#[wasm_bindgen(js_name = operatorCommands, unchecked_return_type = "RunCommand[]")]
pub fn operator_commands() -> Vec<String> {
    crate::operation::command_names(Command::OPERATOR.to_vec())
}

/// The interlock event kinds an operator looks back on (faults, clears,
/// warnings, ...): the ones `drainAbnormalEvents` keeps.
#[wasm_bindgen(js_name = abnormalEventKinds, unchecked_return_type = "EventKind[]")]
pub fn abnormal_event_kinds() -> Result<JsValue, JsValue> {
    let kinds: Vec<EventKind> = EventKind::ALL
        .into_iter()
        .filter(|k| k.is_abnormal())
        .collect();
    to_js(&kinds)
}

/// The instance's memory: an engine's outputs are read from it, where its `headerPtr()` says.
#[wasm_bindgen(js_name = wasmMemory, unchecked_return_type = "{ buffer: ArrayBuffer }")]
pub fn memory() -> JsValue {
    wasm_bindgen::memory()
}

/// Every text of the palette's catalogs the engine names (`key`, under the
/// shared `sugarshack` texts) with the placeholders it fills, and the labels
/// a placeholder may name: `{ texts: [{ key, params }], labels }`.
#[wasm_bindgen(js_name = catalogTexts, unchecked_return_type = "{ texts: { key: string, params: string[] }[], labels: string[] }")]
pub fn catalog_texts() -> Result<JsValue, JsValue> {
    use sugarshack_core::engine::{CATALOG_LABELS, CATALOG_TEXTS};
    let texts: Vec<serde_json::Value> = CATALOG_TEXTS
        .iter()
        .map(|(key, params)| serde_json::json!({ "key": key, "params": params }))
        .collect();
    to_js(&serde_json::json!({ "texts": texts, "labels": CATALOG_LABELS }))
}
