//! Conditions over the plant's sensors (wait steps, routine transitions, the
//! wait node's own), read and evaluated by the core: `checkCondition` reads
//! the sensors' fresh values, decides and says why not, in one call.
//! A wait on one is the core's too: its deadline is among the tracker's
//! (`nextDeadline`), and `expireWaits` says which ran out, with its
//! CONDITION_TIMEOUT error worded.

use std::collections::HashMap;

use sugarshack_core::code::Code;
use sugarshack_core::condition::{
    Checked, Condition, TimedOut, TooManyWaits, WaitId, Waits, TIMEOUT_CODE,
};
use sugarshack_core::text::{abridge, quote};
use sugarshack_core::time::Millis;
use wasm_bindgen::prelude::*;

use crate::{js_error, time, to_js, Tracker};

/// The TypeScript shapes of what the waits' calls return.
#[wasm_bindgen(typescript_custom_section)]
const TS_SHAPES: &str = r#"
/** `Tracker.checkCondition()`: whether it held, its sensors' values by id (null: one was not fresh), why not. */
export interface ConditionCheck {
    met: boolean;
    values: Record<string, number> | null;
    reason: string | null;
}

/**
 * A wait that ran out of time, why its condition last did not hold (null: never checked),
 * and the error its msg fails with (CONDITION_TIMEOUT, worded by the core).
 */
export interface WaitTimedOut {
    wait: number;
    reason: string | null;
    code: string;
    message: string;
}

/** `Tracker.waitChecked()`: met, still waiting, timed out (checked after its deadline), or ended before. */
export type WaitChecked =
    | { state: "met" | "waiting" | "ended" }
    | { state: "timedOut"; reason: string | null; code: string; message: string };
"#;

/// More distinct conditions than any plant has waits: not conditions a person wrote.
const MAX_CONDITIONS: usize = 10_000;
/// The longest reason kept for a wait's timeout.
const MAX_REASON_CHARS: usize = 2_000;

/// The conditions read for one tracker, each once.
#[derive(Debug, Default)]
pub(crate) struct Conditions {
    list: Vec<Condition>,
    by_key: HashMap<(String, Vec<String>), u32>,
    pub(crate) waits: Waits,
}

fn timed_out(t: TimedOut) -> serde_json::Value {
    serde_json::json!({
        "wait": t.wait.0,
        "reason": t.reason,
        "code": TIMEOUT_CODE.name(),
        "message": t.message,
    })
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

    /// Checks condition `handle` at `nowMs` on its sensors `sensors` (their
    /// handles, in the order listed): the core reads their fresh values,
    /// decides (a stale or missing sensor: not met) and words why not.
    #[wasm_bindgen(js_name = checkCondition, unchecked_return_type = "ConditionCheck")]
    pub fn check_condition(
        &self,
        handle: u32,
        sensors: &[u32],
        now_ms: f64,
    ) -> Result<JsValue, JsValue> {
        let condition = self.condition_of(handle, sensors.len())?;
        let now = time(now_ms)?;
        let ids = sensors
            .iter()
            .map(|&h| self.sensor_id(h))
            .collect::<Result<Vec<_>, _>>()?;
        let verdict = condition.verdict(self.sensors.read(&ids, now));
        to_js(&serde_json::json!({
            "met": verdict.met(),
            "values": verdict.values,
            "reason": verdict.reason,
        }))
    }

    fn condition_of(&self, handle: u32, values: usize) -> Result<&Condition, JsValue> {
        let condition =
            self.conditions.list.get(handle as usize).ok_or_else(|| {
                js_error(Code::InvalidCondition, &format!("no condition #{handle}"))
            })?;
        if values != condition.sensors().len() {
            return Err(js_error(
                Code::InvalidInput,
                &format!(
                    "condition #{handle} reads {} sensors, given {values} values",
                    condition.sensors().len(),
                ),
            ));
        }
        Ok(condition)
    }

    /// A wait of `timeoutMs` from `nowMs` on `condition` (its text, for the
    /// words of its timeout); its number. Its deadline is in `nextDeadline`
    /// from now on. Throws `QUEUE_FULL` past the most waits one plant keeps.
    #[wasm_bindgen(js_name = waitStart)]
    pub fn wait_start(
        &mut self,
        timeout_ms: f64,
        now_ms: f64,
        condition: &str,
    ) -> Result<u32, JsValue> {
        let timeout = wait_timeout(timeout_ms)?;
        let now = time(now_ms)?;
        wait_number(self.conditions.waits.start(condition, timeout, now))
    }

    /// A wait of `timeoutMs` on `condition` until `deadlineMs`, carried over
    /// from a tracker that is gone (a trap); its number.
    #[wasm_bindgen(js_name = waitUntil)]
    pub fn wait_until(
        &mut self,
        deadline_ms: f64,
        timeout_ms: f64,
        condition: &str,
    ) -> Result<u32, JsValue> {
        let deadline = time(deadline_ms)?;
        let timeout = wait_timeout(timeout_ms)?;
        wait_number(self.conditions.waits.until(condition, timeout, deadline))
    }

    /// When wait `wait` times out (epoch ms), if it is still in progress.
    #[wasm_bindgen(js_name = waitDeadline)]
    pub fn wait_deadline(&self, wait: u32) -> Option<f64> {
        self.conditions
            .waits
            .deadline(WaitId(wait))
            .map(Millis::as_f64)
    }

    /// Its condition was checked at `nowMs`: held (`reason` undefined) or not, and why.
    #[wasm_bindgen(js_name = waitChecked, unchecked_return_type = "WaitChecked")]
    pub fn wait_checked(
        &mut self,
        wait: u32,
        reason: Option<String>,
        now_ms: f64,
    ) -> Result<JsValue, JsValue> {
        let now = time(now_ms)?;
        let reason = reason.map(|r| abridge(&r, MAX_REASON_CHARS));
        let outcome = match self.conditions.waits.checked(WaitId(wait), reason, now) {
            Checked::Met => serde_json::json!({ "state": "met" }),
            Checked::Waiting => serde_json::json!({ "state": "waiting" }),
            Checked::Unknown => serde_json::json!({ "state": "ended" }),
            Checked::TimedOut(t) => serde_json::json!({
                "state": "timedOut",
                "reason": t.reason,
                "code": TIMEOUT_CODE.name(),
                "message": t.message,
            }),
        };
        to_js(&outcome)
    }

    /// Ends wait `wait` unmet (its msg went away); false when it had ended.
    #[wasm_bindgen(js_name = waitCancel)]
    pub fn wait_cancel(&mut self, wait: u32) -> bool {
        self.conditions.waits.cancel(WaitId(wait))
    }

    /// The waits whose deadline is reached at `nowMs`, earliest first: `[{ wait, reason }]`; they end.
    #[wasm_bindgen(js_name = expireWaits, unchecked_return_type = "WaitTimedOut[]")]
    pub fn expire_waits(&mut self, now_ms: f64) -> Result<JsValue, JsValue> {
        let now = time(now_ms)?;
        let out: Vec<serde_json::Value> = self
            .conditions
            .waits
            .expire(now)
            .into_iter()
            .map(timed_out)
            .collect();
        to_js(&out)
    }

    /// How many waits are in progress.
    #[wasm_bindgen(js_name = waiting)]
    pub fn waiting(&self) -> u32 {
        self.conditions.waits.len() as u32
    }
}

/// A wait's number, or the core's QUEUE_FULL.
fn wait_number(started: Result<WaitId, TooManyWaits>) -> Result<u32, JsValue> {
    started
        .map(|wait| wait.0)
        .map_err(|full| js_error(full.code(), &full.to_string()))
}

fn wait_timeout(timeout_ms: f64) -> Result<Millis, JsValue> {
    Millis::new(timeout_ms).ok_or_else(|| {
        js_error(
            Code::InvalidInput,
            &format!(
                "a wait's timeout must be a number of ms, got {}",
                quote(timeout_ms)
            ),
        )
    })
}
