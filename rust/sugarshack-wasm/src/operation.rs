use sugarshack_core::code::Code;
use sugarshack_core::operation::{OperationRun as CoreRun, RunEffect, RunError};
use sugarshack_core::plant::Plant;
use sugarshack_core::time::{ms, Millis};
use wasm_bindgen::prelude::*;

use crate::{js_error, time, to_js};

/// The TypeScript shapes of what this module's calls return and take
/// (`unchecked_return_type` / `unchecked_param_type` name them).
#[wasm_bindgen(typescript_custom_section)]
const TS_SHAPES: &str = r#"
/** One step of an operation's plan. */
export type PlanStep =
    | { kind: "command"; command: GroupCommand; timeoutMs: number }
    | { kind: "wait"; condition: string; sensors: string[]; timeoutMs: number }
    | { kind: "returnToIdle"; command: GroupCommand; timeoutMs: number };

/** `Tracker.operationPlan()` and `OperationRun.plan()`. */
export interface OperationPlan {
    id: string;
    priority: number;
    resources: string[];
    steps: PlanStep[];
}

export type StepKind = "command" | "wait" | "returnToIdle";

/** How long one step of a finished run took. */
export interface StepRecord {
    kind: StepKind;
    ms: number;
}

/** What an operation run asks JS to do. */
export type RunEffect =
    | { kind: "acquire"; operation: string; priority: number; resources: string[] }
    | { kind: "startStep"; index: number; step: PlanStep; within?: string[] }
    | { kind: "cancelStep"; index: number }
    | { kind: "release"; operation: string }
    | { kind: "withdraw"; operation: string }
    | { kind: "fault"; operation: string; note: string }
    | { kind: "finished"; id: string; queuedMs: number; runMs: number; steps: StepRecord[] }
    | { kind: "failed"; id: string; code: string; message: string; step: number | null; stage: "acquire" | StepKind | "release"; lockedOut: string[]; aborted: boolean };
"#;

/// JS's `Number.MAX_SAFE_INTEGER`: durations up to it come back as exact numbers.
const MAX_SAFE_MS: Millis = ms((1 << 53) - 1);

fn run_error(err: RunError) -> JsValue {
    js_error(err.code(), &err.to_string())
}

/// A step index from JS: wasm-bindgen would read `undefined` or NaN as step 0.
fn step_index(index: f64) -> Result<usize, JsValue> {
    if index.is_finite() && index >= 0.0 && index.fract() == 0.0 && index <= u32::MAX as f64 {
        Ok(index as usize)
    } else {
        Err(js_error(
            Code::InvalidStep,
            &format!("a step index is a whole number from 0, got {index}"),
        ))
    }
}

/// A time that keeps every duration of the run an exact JS number, checked
/// before the input changes anything.
fn run_time(now_ms: f64) -> Result<Millis, JsValue> {
    let now = time(now_ms)?;
    if now > MAX_SAFE_MS {
        return Err(js_error(
            Code::InvalidTime,
            &format!("time must be at most Number.MAX_SAFE_INTEGER milliseconds, got {now_ms}"),
        ));
    }
    Ok(now)
}

fn effects(effects: Vec<RunEffect>) -> Result<JsValue, JsValue> {
    to_js(&effects)
}

/// One start of an operation of the plant, made by `Tracker.operationRun(id)`.
/// Every input returns the effects to carry out, as plain objects with a
/// `kind`: `acquire`, `startStep`, `cancelStep`, `release`, `withdraw`,
/// `fault`, `finished`, `failed`. Inputs that do not fit the run's phase and
/// step (a late timer, a repeated report) return `[]` and change nothing.
#[wasm_bindgen]
pub struct OperationRun {
    core: CoreRun,
}

impl OperationRun {
    pub(crate) fn of(plant: &Plant, id: &str) -> Result<OperationRun, JsValue> {
        CoreRun::of(plant, id)
            .map(|core| OperationRun { core })
            .map_err(run_error)
    }
}

#[wasm_bindgen]
impl OperationRun {
    pub fn id(&self) -> String {
        self.core.id().into()
    }

    /// `{ id, priority, resources, steps: [{ kind, ... }] }`, as `Tracker.operationPlan` gives it.
    #[wasm_bindgen(unchecked_return_type = "OperationPlan")]
    pub fn plan(&self) -> Result<JsValue, JsValue> {
        to_js(self.core.plan())
    }

    /// `new`, `queued`, `withdrawing`, `running`, `releasing`, `faulting`, or
    /// once ended `done`, `faulted`, `refused`, `withdrawn`.
    pub fn phase(&self) -> String {
        self.core.phase().as_str().into()
    }

    /// The index of the step in progress (phase `running`), else undefined.
    pub fn step(&self) -> Option<u32> {
        self.core.step().map(|i| i as u32)
    }

    /// `[acquire]`; throws `ALREADY_STARTED` on a run already started.
    #[wasm_bindgen(unchecked_return_type = "RunEffect[]")]
    pub fn start(&mut self, now_ms: f64) -> Result<JsValue, JsValue> {
        let now = run_time(now_ms)?;
        effects(self.core.start(now).map_err(run_error)?)
    }

    #[wasm_bindgen(unchecked_return_type = "RunEffect[]")]
    pub fn granted(&mut self, now_ms: f64) -> Result<JsValue, JsValue> {
        let now = run_time(now_ms)?;
        effects(self.core.granted(now))
    }

    #[wasm_bindgen(js_name = stepDone, unchecked_return_type = "RunEffect[]")]
    pub fn step_done(&mut self, index: f64, now_ms: f64) -> Result<JsValue, JsValue> {
        let (index, now) = (step_index(index)?, run_time(now_ms)?);
        effects(self.core.step_done(index, now))
    }

    #[wasm_bindgen(js_name = stepFailed, unchecked_return_type = "RunEffect[]")]
    pub fn step_failed(
        &mut self,
        index: f64,
        code: &str,
        message: &str,
        now_ms: f64,
    ) -> Result<JsValue, JsValue> {
        let (index, now) = (step_index(index)?, run_time(now_ms)?);
        effects(self.core.step_failed(index, code, message, now))
    }

    #[wasm_bindgen(unchecked_return_type = "RunEffect[]")]
    pub fn released(&mut self, now_ms: f64) -> Result<JsValue, JsValue> {
        let now = run_time(now_ms)?;
        effects(self.core.released(now))
    }

    #[wasm_bindgen(js_name = releaseFailed, unchecked_return_type = "RunEffect[]")]
    pub fn release_failed(
        &mut self,
        code: &str,
        message: &str,
        now_ms: f64,
    ) -> Result<JsValue, JsValue> {
        let now = run_time(now_ms)?;
        effects(self.core.release_failed(code, message, now))
    }

    /// `lines`: the resources whose lockouts went out.
    #[wasm_bindgen(js_name = faultApplied, unchecked_return_type = "RunEffect[]")]
    pub fn fault_applied(&mut self, lines: Vec<String>, now_ms: f64) -> Result<JsValue, JsValue> {
        let now = run_time(now_ms)?;
        effects(self.core.fault_applied(lines, now))
    }

    #[wasm_bindgen(unchecked_return_type = "RunEffect[]")]
    pub fn refused(&mut self, code: &str, message: &str) -> Result<JsValue, JsValue> {
        effects(self.core.refused(code, message))
    }

    #[wasm_bindgen(unchecked_return_type = "RunEffect[]")]
    pub fn abort(&mut self, reason: &str, now_ms: f64) -> Result<JsValue, JsValue> {
        let now = run_time(now_ms)?;
        effects(self.core.abort(reason, now))
    }

    #[wasm_bindgen(unchecked_return_type = "RunEffect[]")]
    pub fn withdrawn(&mut self, now_ms: f64) -> Result<JsValue, JsValue> {
        let now = run_time(now_ms)?;
        effects(self.core.withdrawn(now))
    }
}
