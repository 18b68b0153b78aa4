use sugarshack_core::clearance::Attribution;
use sugarshack_core::code::Code;
use sugarshack_core::operation::{
    AbortedOperations as CoreAborted, OperationRun as CoreRun, RunEffect, RunError, RunOwner,
    RunSnapshot,
};
use sugarshack_core::plant::Plant;
use sugarshack_core::procedure::{Command, State};
use sugarshack_core::time::{ms, Millis};
use wasm_bindgen::prelude::*;

use crate::routine::Routine;
use crate::{from_js_bounded, js_error, time, to_js, Bound};

/// The TypeScript shapes of what this module's calls return and take
/// (`unchecked_return_type` / `unchecked_param_type` name them).
#[wasm_bindgen(typescript_custom_section)]
const TS_SHAPES: &str = r#"
/** How a step goes on after a hold. */
export type RestartRule = "reissue" | "rerun";

/** One step of an operation's plan. */
export type PlanStep =
    | { kind: "command"; command: GroupCommand; timeoutMs: number; restart: RestartRule }
    | { kind: "wait"; condition: string; sensors: string[]; timeoutMs: number; restart: RestartRule }
    | { kind: "returnToIdle"; command: GroupCommand; timeoutMs: number };

/** `Tracker.operationPlan()` and `OperationRun.plan()`. */
export interface OperationPlan {
    id: string;
    priority: number;
    resources: string[];
    steps: PlanStep[];
    hold?: { command: GroupCommand; timeoutMs: number };
    stop: "finish-step" | "now";
}

export type StepKind = "command" | "wait" | "returnToIdle";

/** An ISA-88 state of an operation run or a routine. */
export type RunState =
    | "idle" | "queued" | "running" | "holding" | "held" | "restarting" | "stopping" | "stopped"
    | "aborting" | "aborted" | "completing" | "complete" | "faulting" | "faulted"
    | "withdrawing" | "withdrawn" | "refused";

/** An operator's command. */
export type RunCommand = "start" | "hold" | "restart" | "stop" | "abort" | "reset";

/** How long one step of a finished run took. */
export interface StepRecord {
    kind: StepKind;
    ms: number;
}

/** Who supervises a run (kept with a held run's save). */
export type RunOwner = { kind: "routine"; id: string } | { kind: "node"; id: string };

/** A held run as saved with the interlock's state. */
export interface RunSnapshot {
    operation: string;
    plan: string;
    step: number;
    usedMs: number;
    startedMs: number;
    grantedMs: number;
    heldSinceMs: number;
    heldMs: number;
    held: boolean;
    steps: StepRecord[];
    /** How many attempts it had made (absent in a save from before they were numbered). */
    attempts?: number;
    owner?: RunOwner;
}

/**
 * What an operation run asks JS to do. A step, a hold command and a restore
 * each carry a new `attempt`: its answer names it, and `cancelStep` names the one it stops.
 */
export type RunEffect =
    | { kind: "acquire"; operation: string; priority: number; resources: string[] }
    | { kind: "startStep"; index: number; attempt: number; step: PlanStep; within?: string[]; timeoutMs: number }
    | { kind: "cancelStep"; index: number; attempt: number }
    | { kind: "hold"; attempt: number; command: GroupCommand; timeoutMs: number; within: string[] }
    | { kind: "restore"; attempt: number; command: GroupCommand; timeoutMs: number; within: string[] }
    | { kind: "entered"; state: RunState; step: number | null }
    | { kind: "release"; operation: string }
    | { kind: "withdraw"; operation: string }
    | { kind: "fault"; operation: string; note: string }
    | { kind: "finished"; id: string; queuedMs: number; runMs: number; heldMs: number; steps: StepRecord[] }
    | { kind: "stopped"; id: string; code: string; message: string; queuedMs: number; runMs: number; heldMs: number; steps: StepRecord[]; step: number | null }
    | { kind: "failed"; id: string; code: string; message: string; step: number | null; stage: "acquire" | StepKind | "hold" | "restart" | "release"; lockedOut: string[]; aborted: boolean; state: RunState };

/** `OperationRun.restore()`: the run back held, and what it asks to do (the hold command again, if it was still holding). */
export interface RestoredRun {
    run: OperationRun;
    effects: RunEffect[];
}

/** An aborted operation, as `AbortedOperations.list()` gives it. */
export interface AbortedOperation {
    operation: string;
    sinceMs: number;
    by: { by: string; reason?: string };
}
"#;

/// JS's `Number.MAX_SAFE_INTEGER`: durations up to it come back as exact numbers.
const MAX_SAFE_MS: Millis = ms((1 << 53) - 1);

fn run_error(err: RunError) -> JsValue {
    js_error(err.code(), &err.to_string())
}

/// An operator's command by its name (`hold`, `restart`, `stop`, `abort`, `reset`, `start`).
pub(crate) fn command_of(name: &str) -> Result<Command, JsValue> {
    Command::from_name(name).ok_or_else(|| {
        js_error(
            Code::InvalidInput,
            &format!(
                "'{}' is not a command: hold, restart, stop, abort or reset",
                sugarshack_core::text::quote(name)
            ),
        )
    })
}

/// A state by its name, as a run reports it.
pub(crate) fn state_of(name: Option<String>) -> Result<Option<State>, JsValue> {
    name.map(|name| {
        State::ALL
            .into_iter()
            .find(|s| s.name() == name)
            .ok_or_else(|| {
                js_error(
                    Code::InvalidInput,
                    &format!(
                        "'{}' is not a run state",
                        sugarshack_core::text::quote(&name)
                    ),
                )
            })
    })
    .transpose()
}

/// Who gave a command and why: bounded, an empty name reads "unknown".
pub(crate) fn attribution(by: Option<String>, reason: Option<String>) -> Attribution {
    Attribution::new(by.as_deref(), reason.as_deref(), false)
}

fn names(commands: Vec<Command>) -> Vec<String> {
    commands.into_iter().map(|c| c.name().to_owned()).collect()
}

pub(crate) fn command_names(commands: Vec<Command>) -> Vec<String> {
    names(commands)
}

/// An attempt's number from JS: wasm-bindgen would read `undefined` or NaN as 0.
fn attempt_of(attempt: f64) -> Result<u32, JsValue> {
    if attempt.is_finite() && attempt >= 0.0 && attempt.fract() == 0.0 && attempt <= u32::MAX as f64
    {
        Ok(attempt as u32)
    } else {
        Err(js_error(
            Code::InvalidStep,
            &format!("an attempt is a whole number from 0, got {attempt}"),
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
/// `kind`: `acquire`, `startStep`, `cancelStep`, `hold`, `restore`,
/// `entered`, `release`, `withdraw`, `fault`, `finished`, `stopped`, `failed`. Inputs that do not fit the run's phase and
/// step (a late timer, a repeated report, an answer to an attempt that is not the current one) return `[]` and change nothing.
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

    /// A run saved held, back on `plant`'s plan of it: `{ run, effects }`.
    pub(crate) fn restore(plant: &Plant, snapshot: JsValue) -> Result<JsValue, JsValue> {
        let saved: RunSnapshot = from_js_bounded(
            snapshot,
            Code::InvalidSnapshot,
            "invalid run snapshot",
            Bound::RoutineSnapshot,
        )?;
        let plan = plant.operation_plan(&saved.operation).ok_or_else(|| {
            run_error(RunError::UnknownOperation {
                id: saved.operation.clone(),
            })
        })?;
        let (core, restored) = CoreRun::restore(plan, &saved).map_err(run_error)?;
        let view = js_sys::Object::new();
        js_sys::Reflect::set(&view, &"effects".into(), &effects(restored)?)?;
        js_sys::Reflect::set(&view, &"run".into(), &OperationRun { core }.into())?;
        Ok(view.into())
    }
}

/// The operations of an interlock aborted and not reset since: every start of
/// one is refused until a person resets it. Saved with the interlock's state.
#[wasm_bindgen]
pub struct AbortedOperations {
    core: CoreAborted,
}

#[wasm_bindgen]
impl AbortedOperations {
    /// As saved (`{}` or undefined: none).
    #[wasm_bindgen(constructor)]
    pub fn new(
        #[wasm_bindgen(unchecked_param_type = "Record<string, unknown> | undefined")]
        saved: JsValue,
    ) -> Result<AbortedOperations, JsValue> {
        let core = if saved.is_undefined() || saved.is_null() {
            CoreAborted::default()
        } else {
            from_js_bounded(
                saved,
                Code::InvalidSnapshot,
                "invalid aborted operations",
                Bound::InterlockSnapshot,
            )?
        };
        Ok(AbortedOperations { core })
    }

    /// Throws `OPERATION_ABORTED` while `operation` waits for a reset.
    #[wasm_bindgen(js_name = checkStart)]
    pub fn check_start(&self, operation: &str) -> Result<(), JsValue> {
        self.core.check_start(operation).map_err(run_error)
    }

    /// `aborted` or `idle`.
    #[wasm_bindgen(unchecked_return_type = "RunState")]
    pub fn state(&self, operation: &str) -> String {
        self.core.state(operation).name().into()
    }

    /// A run of `operation` ended in `state` (its name), by `by` for `reason`.
    pub fn ended(
        &mut self,
        operation: &str,
        state: &str,
        by: Option<String>,
        reason: Option<String>,
        now_ms: f64,
    ) -> Result<(), JsValue> {
        let state = state_of(Some(state.to_owned()))?.unwrap_or(State::Idle);
        let now = time(now_ms)?;
        self.core
            .ended(operation, state, &attribution(by, reason), now);
        Ok(())
    }

    /// A person's reset; throws `COMMAND_REFUSED` unless it is aborted.
    pub fn reset(&mut self, operation: &str) -> Result<(), JsValue> {
        self.core.reset(operation).map(|_| ()).map_err(run_error)
    }

    /// `routine`'s reset: its operations that wait for a reset after an
    /// abort are reset with it. Their ids.
    #[wasm_bindgen(js_name = resetRoutine)]
    pub fn reset_routine(&mut self, routine: &Routine) -> Vec<String> {
        self.core.reset_routine(&routine.machine().operations())
    }

    /// A person's command to `operation` while no run of it exists: a reset
    /// of an aborted one is taken; anything else is refused
    /// (`COMMAND_REFUSED`, with the state and what it allows). Its state after.
    #[wasm_bindgen(unchecked_return_type = "RunState")]
    pub fn command(&mut self, operation: &str, command: &str) -> Result<String, JsValue> {
        let command = command_of(command)?;
        self.core
            .command(operation, command)
            .map(|state| state.name().into())
            .map_err(run_error)
    }

    /// `[{ operation, sinceMs, by }]`.
    #[wasm_bindgen(unchecked_return_type = "AbortedOperation[]")]
    pub fn list(&self) -> Result<JsValue, JsValue> {
        let all: Vec<serde_json::Value> = self
            .core
            .iter()
            .map(
                |(id, r)| serde_json::json!({ "operation": id, "sinceMs": r.since_ms, "by": r.by }),
            )
            .collect();
        to_js(&all)
    }

    /// What is saved with the interlock's state.
    #[wasm_bindgen(unchecked_return_type = "Record<string, unknown>")]
    pub fn snapshot(&self) -> Result<JsValue, JsValue> {
        to_js(&self.core)
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

    /// Its ISA-88 state (`idle`, `queued`, `running`, `holding`, `held`,
    /// `restarting`, `stopping`, `aborting`, `completing`, `faulting`,
    /// `withdrawing`, or once ended `complete`, `stopped`, `aborted`,
    /// `faulted`, `refused`, `withdrawn`).
    #[wasm_bindgen(unchecked_return_type = "RunState")]
    pub fn state(&self) -> String {
        self.core.state().name().into()
    }

    /// The operator's commands its state allows now.
    #[wasm_bindgen(unchecked_return_type = "RunCommand[]")]
    pub fn commands(&self) -> Vec<String> {
        names(self.core.commands())
    }

    /// An operator's command (`hold`, `restart`, `stop`, `abort`, `reset`)
    /// by `by` for `reason`: its effects, or the table's refusal
    /// (`COMMAND_REFUSED`), which changes nothing.
    #[wasm_bindgen(unchecked_return_type = "RunEffect[]")]
    pub fn command(
        &mut self,
        command: &str,
        by: Option<String>,
        reason: Option<String>,
        now_ms: f64,
    ) -> Result<JsValue, JsValue> {
        let (command, now) = (command_of(command)?, run_time(now_ms)?);
        let who = attribution(by, reason);
        effects(self.core.command(command, &who, now).map_err(run_error)?)
    }

    /// The hold command of attempt `attempt` completed.
    #[wasm_bindgen(js_name = holdDone, unchecked_return_type = "RunEffect[]")]
    pub fn hold_done(&mut self, attempt: f64, now_ms: f64) -> Result<JsValue, JsValue> {
        let (attempt, now) = (attempt_of(attempt)?, run_time(now_ms)?);
        effects(self.core.hold_done(attempt, now))
    }

    #[wasm_bindgen(js_name = holdFailed, unchecked_return_type = "RunEffect[]")]
    pub fn hold_failed(
        &mut self,
        attempt: f64,
        code: &str,
        message: &str,
        now_ms: f64,
    ) -> Result<JsValue, JsValue> {
        let (attempt, now) = (attempt_of(attempt)?, run_time(now_ms)?);
        effects(self.core.hold_failed(attempt, code, message, now))
    }

    /// The restore of attempt `attempt` completed.
    #[wasm_bindgen(js_name = restartDone, unchecked_return_type = "RunEffect[]")]
    pub fn restart_done(&mut self, attempt: f64, now_ms: f64) -> Result<JsValue, JsValue> {
        let (attempt, now) = (attempt_of(attempt)?, run_time(now_ms)?);
        effects(self.core.restart_done(attempt, now))
    }

    #[wasm_bindgen(js_name = restartFailed, unchecked_return_type = "RunEffect[]")]
    pub fn restart_failed(
        &mut self,
        attempt: f64,
        code: &str,
        message: &str,
        now_ms: f64,
    ) -> Result<JsValue, JsValue> {
        let (attempt, now) = (attempt_of(attempt)?, run_time(now_ms)?);
        effects(self.core.restart_failed(attempt, code, message, now))
    }

    /// Held (or holding): what survives a restart, kept with `owner`; else undefined.
    #[wasm_bindgen(unchecked_return_type = "RunSnapshot | undefined")]
    pub fn snapshot(
        &self,
        #[wasm_bindgen(unchecked_param_type = "RunOwner | undefined")] owner: JsValue,
    ) -> Result<JsValue, JsValue> {
        let owner: Option<RunOwner> = if owner.is_undefined() || owner.is_null() {
            None
        } else {
            Some(from_js_bounded(
                owner,
                Code::InvalidInput,
                "invalid run owner",
                Bound::RoutineSnapshot,
            )?)
        };
        match self.core.snapshot(owner) {
            Some(snapshot) => to_js(&snapshot),
            None => Ok(JsValue::UNDEFINED),
        }
    }

    /// An operator aborted it: its operation refuses every start until a person's reset.
    #[wasm_bindgen(js_name = awaitsReset)]
    pub fn awaits_reset(&self) -> bool {
        self.core.awaits_reset()
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

    /// The step of attempt `attempt` completed.
    #[wasm_bindgen(js_name = stepDone, unchecked_return_type = "RunEffect[]")]
    pub fn step_done(&mut self, attempt: f64, now_ms: f64) -> Result<JsValue, JsValue> {
        let (attempt, now) = (attempt_of(attempt)?, run_time(now_ms)?);
        effects(self.core.step_done(attempt, now))
    }

    #[wasm_bindgen(js_name = stepFailed, unchecked_return_type = "RunEffect[]")]
    pub fn step_failed(
        &mut self,
        attempt: f64,
        code: &str,
        message: &str,
        now_ms: f64,
    ) -> Result<JsValue, JsValue> {
        let (attempt, now) = (attempt_of(attempt)?, run_time(now_ms)?);
        effects(self.core.step_failed(attempt, code, message, now))
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

    /// The interlock refused the fault: the run ends, nothing locked out.
    #[wasm_bindgen(js_name = faultRefused, unchecked_return_type = "RunEffect[]")]
    pub fn fault_refused(&mut self, now_ms: f64) -> Result<JsValue, JsValue> {
        let now = run_time(now_ms)?;
        effects(self.core.fault_refused(now))
    }

    #[wasm_bindgen(unchecked_return_type = "RunEffect[]")]
    pub fn refused(&mut self, code: &str, message: &str) -> Result<JsValue, JsValue> {
        effects(self.core.refused(code, message))
    }

    /// Its supervisor is gone: a queued request is withdrawn, a granted run faulted.
    #[wasm_bindgen(unchecked_return_type = "RunEffect[]")]
    pub fn interrupt(&mut self, reason: &str, now_ms: f64) -> Result<JsValue, JsValue> {
        let now = run_time(now_ms)?;
        effects(self.core.interrupt(reason, now))
    }

    /// Someone else took its request out of the queue: it ends refused, or as its withdrawal says.
    #[wasm_bindgen(js_name = takenOutOfQueue, unchecked_return_type = "RunEffect[]")]
    pub fn taken_out_of_queue(&mut self, now_ms: f64) -> Result<JsValue, JsValue> {
        let now = run_time(now_ms)?;
        effects(self.core.taken_out_of_queue(now))
    }

    #[wasm_bindgen(unchecked_return_type = "RunEffect[]")]
    pub fn withdrawn(&mut self, now_ms: f64) -> Result<JsValue, JsValue> {
        let now = run_time(now_ms)?;
        effects(self.core.withdrawn(now))
    }

    /// The interlock refused the withdrawal: the request is gone all the same.
    #[wasm_bindgen(js_name = withdrawRefused, unchecked_return_type = "RunEffect[]")]
    pub fn withdraw_refused(&mut self, now_ms: f64) -> Result<JsValue, JsValue> {
        let now = run_time(now_ms)?;
        effects(self.core.withdraw_refused(now))
    }
}
