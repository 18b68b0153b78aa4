//! Conditions over the plant's sensors (wait steps, routine transitions, the
//! wait node's own), read and evaluated by the core: JS reads the sensors'
//! fresh values (`readSensors`) and asks whether the condition holds on them.

use std::collections::HashMap;

use sugarshack_core::code::Code;
use sugarshack_core::condition::Condition;
use sugarshack_core::text::quote;
use wasm_bindgen::prelude::*;

use crate::{js_error, Tracker};

/// More distinct conditions than any plant has waits: not conditions a person wrote.
const MAX_CONDITIONS: usize = 10_000;

/// The conditions read for one tracker, each once.
#[derive(Debug, Default)]
pub(crate) struct Conditions {
    list: Vec<Condition>,
    by_key: HashMap<(String, Vec<String>), u32>,
}

#[wasm_bindgen]
impl Tracker {
    /// The handle of `condition` over the plant sensors `sensors` (read once
    /// per text and list). Throws `UNKNOWN_SENSOR` for a listed id the plant
    /// lacks and `INVALID_CONDITION` (`condition '…': why`) for a text that is
    /// no condition over them.
    pub fn condition(&mut self, condition: &str, sensors: Vec<String>) -> Result<u32, JsValue> {
        let key = (condition.to_owned(), sensors);
        if let Some(&handle) = self.conditions.by_key.get(&key) {
            return Ok(handle);
        }
        for name in &key.1 {
            self.sensor(name)?;
        }
        let plant = self.core.plant();
        let ids: Vec<&str> = plant.sensors.iter().map(|s| s.id.as_str()).collect();
        let compiled = Condition::compile(condition, &key.1, &ids).map_err(|err| {
            js_error(
                Code::InvalidCondition,
                &format!("condition '{}': {err}", quote(condition)),
            )
        })?;
        if self.conditions.list.len() >= MAX_CONDITIONS {
            return Err(js_error(
                Code::InvalidCondition,
                &format!("more than {MAX_CONDITIONS} different conditions on one plant; refused"),
            ));
        }
        let handle = self.conditions.list.len() as u32;
        self.conditions.list.push(compiled);
        self.conditions.by_key.insert(key, handle);
        Ok(handle)
    }

    /// Whether condition `handle` holds on `values` (its sensors' fresh
    /// values, in the order listed): `true`, `false`, or why it gives no
    /// answer (arithmetic met no number), which means it does not hold.
    #[wasm_bindgen(js_name = conditionHolds, unchecked_return_type = "boolean | string")]
    pub fn condition_holds(&self, handle: u32, values: &[f64]) -> Result<JsValue, JsValue> {
        let condition =
            self.conditions.list.get(handle as usize).ok_or_else(|| {
                js_error(Code::InvalidCondition, &format!("no condition #{handle}"))
            })?;
        if values.len() != condition.sensors().len() {
            return Err(js_error(
                Code::InvalidInput,
                &format!(
                    "condition #{handle} reads {} sensors, given {} values",
                    condition.sensors().len(),
                    values.len()
                ),
            ));
        }
        Ok(match condition.holds(values) {
            Ok(holds) => JsValue::from_bool(holds),
            Err(no_number) => JsValue::from_str(&no_number.to_string()),
        })
    }
}
