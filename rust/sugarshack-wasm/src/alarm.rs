use sugarshack_core::alarm::{AlarmError, AlarmsSnapshot, Condition, MAX_ALARMS};
use sugarshack_core::clearance::Attribution;
use sugarshack_core::code::Code;
use wasm_bindgen::prelude::*;

use crate::{from_js_bounded, js_error, time, to_js, Bound};

fn core_error(err: AlarmError) -> JsValue {
    js_error(err.code(), &err.to_string())
}

/// The alarms of one interlock and its plant (see the core's `alarm`), as JS
/// sees them. Every call that changes them returns the changes, for an event list.
#[wasm_bindgen]
pub struct Alarms {
    core: sugarshack_core::alarm::Alarms,
}

#[wasm_bindgen]
impl Alarms {
    #[wasm_bindgen(constructor)]
    #[allow(clippy::new_without_default)]
    pub fn new() -> Alarms {
        Alarms {
            core: sugarshack_core::alarm::Alarms::new(),
        }
    }

    /// The alarms as saved by `snapshot()`; refused with `INVALID_SNAPSHOT`.
    pub fn restore(snapshot: JsValue) -> Result<Alarms, JsValue> {
        let snapshot: AlarmsSnapshot = from_js_bounded(
            snapshot,
            Code::InvalidSnapshot,
            "cannot restore the alarms",
            Bound::Alarms,
        )?;
        let core = sugarshack_core::alarm::Alarms::restore(snapshot).map_err(core_error)?;
        Ok(Alarms { core })
    }

    /// `conditions`: every `{ kind, subject, text, sinceMs }` that holds now.
    pub fn observe(&mut self, conditions: JsValue, now_ms: f64) -> Result<JsValue, JsValue> {
        let now = time(now_ms)?;
        let conditions: Vec<Condition> = from_js_bounded(
            conditions,
            Code::InvalidInput,
            "invalid alarm conditions",
            Bound::Alarms,
        )?;
        to_js(&self.core.observe(&conditions, now).map_err(core_error)?)
    }

    /// Acknowledges the alarms named by `ids`, or every unacknowledged one when absent.
    pub fn acknowledge(
        &mut self,
        ids: Option<Vec<String>>,
        by: Option<String>,
        reason: Option<String>,
        now_ms: f64,
    ) -> Result<JsValue, JsValue> {
        let now = time(now_ms)?;
        if ids.as_ref().is_some_and(|ids| ids.len() > MAX_ALARMS) {
            return Err(js_error(
                Code::InvalidInput,
                &format!("at most {MAX_ALARMS} alarms may be acknowledged at once"),
            ));
        }
        let who = Attribution::new(by.as_deref(), reason.as_deref(), false);
        to_js(
            &self
                .core
                .acknowledge(ids.as_deref(), &who, now)
                .map_err(core_error)?,
        )
    }

    pub fn shelve(
        &mut self,
        id: &str,
        until_ms: f64,
        by: Option<String>,
        reason: Option<String>,
        now_ms: f64,
    ) -> Result<JsValue, JsValue> {
        let now = time(now_ms)?;
        let until = time(until_ms)?;
        let who = Attribution::new(by.as_deref(), reason.as_deref(), false);
        to_js(&self.core.shelve(id, until, &who, now).map_err(core_error)?)
    }

    pub fn unshelve(
        &mut self,
        id: &str,
        by: Option<String>,
        reason: Option<String>,
        now_ms: f64,
    ) -> Result<JsValue, JsValue> {
        let now = time(now_ms)?;
        let who = Attribution::new(by.as_deref(), reason.as_deref(), false);
        to_js(&self.core.unshelve(id, &who, now).map_err(core_error)?)
    }

    /// Every listed alarm, by id.
    pub fn list(&self) -> Result<JsValue, JsValue> {
        to_js(&self.core.list().collect::<Vec<_>>())
    }

    pub fn snapshot(&self) -> Result<JsValue, JsValue> {
        to_js(&self.core.snapshot())
    }

    /// When the next shelf runs out (ms), or undefined.
    #[wasm_bindgen(js_name = nextExpiryMs)]
    pub fn next_expiry_ms(&self) -> Option<f64> {
        self.core.next_expiry_ms().map(|t| t as f64)
    }
}
