use sugarshack_core::alarm::{AlarmError, AlarmsSnapshot, Condition, MAX_ALARMS};
use sugarshack_core::clearance::Attribution;
use sugarshack_core::code::Code;
use sugarshack_core::time::Millis;
use wasm_bindgen::prelude::*;

use crate::{from_js_bounded, js_error, time, to_js, Bound};

/// The TypeScript shapes of what this module's calls return and take
/// (`unchecked_return_type` / `unchecked_param_type` name them).
#[wasm_bindgen(typescript_custom_section)]
const TS_SHAPES: &str = r#"
export type AlarmKind =
    | "line-faulted" | "device-offline" | "device-stale" | "bus-disconnected"
    | "state-not-saved" | "waiting-long" | "held-long" | "failover" | "etcd-member-down";

export type AlarmState =
    | "normal" | "active-unacknowledged" | "active-acknowledged" | "returned-unacknowledged";

/** An abnormal condition that holds now (`text` and `sinceMs` may be left out as input). */
export interface AlarmCondition {
    kind: AlarmKind;
    subject: string;
    text: string;
    sinceMs: number | null;
}

/** An alarm condition as `observe` reads it: `text` and `sinceMs` may be left out. */
export interface AlarmConditionInput {
    kind: AlarmKind;
    subject: string;
    text?: string;
    sinceMs?: number | null;
}

/** Who acknowledged an alarm, and when. */
export interface AlarmStamp {
    by: string;
    atMs: number;
    reason?: string;
}

/** Who shelved an alarm, when, and until when (and, one-shot, until its condition ends). */
export interface AlarmShelf {
    by: string;
    atMs: number;
    untilMs: number;
    reason?: string;
    oneShot?: boolean;
}

/** One listed alarm. */
export interface Alarm {
    id: string;
    kind: AlarmKind;
    subject: string;
    text: string;
    state: AlarmState;
    activeSinceMs: number;
    changedMs: number;
    acked?: AlarmStamp;
    shelved?: AlarmShelf;
}

/** One change of one alarm, for an event list. */
export interface AlarmChange {
    id: string;
    action: "condition" | "acknowledge" | "shelve" | "unshelve" | "shelf-expired";
    from: AlarmState;
    to: AlarmState;
    atMs: number;
    by?: string;
    reason?: string;
}

/** `Alarms.snapshot()`. */
export interface AlarmsSnapshot {
    alarms: Alarm[];
}
"#;

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
    pub fn restore(
        #[wasm_bindgen(unchecked_param_type = "AlarmsSnapshot")] snapshot: JsValue,
    ) -> Result<Alarms, JsValue> {
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
    #[wasm_bindgen(unchecked_return_type = "AlarmChange[]")]
    pub fn observe(
        &mut self,
        #[wasm_bindgen(unchecked_param_type = "AlarmConditionInput[]")] conditions: JsValue,
        now_ms: f64,
    ) -> Result<JsValue, JsValue> {
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
    #[wasm_bindgen(unchecked_return_type = "AlarmChange[]")]
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

    #[wasm_bindgen(unchecked_return_type = "AlarmChange[]")]
    pub fn shelve(
        &mut self,
        id: &str,
        until_ms: f64,
        by: Option<String>,
        reason: Option<String>,
        now_ms: f64,
    ) -> Result<JsValue, JsValue> {
        self.put_on_shelf(id, until_ms, (by, reason), now_ms, false)
    }

    /// Shelves as `shelve` does, and until the alarm's condition next ends.
    #[wasm_bindgen(js_name = shelveOneShot, unchecked_return_type = "AlarmChange[]")]
    pub fn shelve_one_shot(
        &mut self,
        id: &str,
        until_ms: f64,
        by: Option<String>,
        reason: Option<String>,
        now_ms: f64,
    ) -> Result<JsValue, JsValue> {
        self.put_on_shelf(id, until_ms, (by, reason), now_ms, true)
    }

    #[wasm_bindgen(unchecked_return_type = "AlarmChange[]")]
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
    #[wasm_bindgen(unchecked_return_type = "Alarm[]")]
    pub fn list(&self) -> Result<JsValue, JsValue> {
        to_js(&self.core.list().collect::<Vec<_>>())
    }

    #[wasm_bindgen(unchecked_return_type = "AlarmsSnapshot")]
    pub fn snapshot(&self) -> Result<JsValue, JsValue> {
        to_js(&self.core.snapshot())
    }

    /// When the next shelf runs out (ms), or undefined.
    #[wasm_bindgen(js_name = nextExpiryMs)]
    pub fn next_expiry_ms(&self) -> Option<f64> {
        self.core.next_expiry_ms().map(Millis::as_f64)
    }
}

impl Alarms {
    fn put_on_shelf(
        &mut self,
        id: &str,
        until_ms: f64,
        (by, reason): (Option<String>, Option<String>),
        now_ms: f64,
        one_shot: bool,
    ) -> Result<JsValue, JsValue> {
        let now = time(now_ms)?;
        let until = time(until_ms)?;
        let who = Attribution::new(by.as_deref(), reason.as_deref(), false);
        let changes = if one_shot {
            self.core.shelve_one_shot(id, until, &who, now)
        } else {
            self.core.shelve(id, until, &who, now)
        };
        to_js(&changes.map_err(core_error)?)
    }
}
