use sugarshack_core::code::Code;
use sugarshack_core::plant::Plant;
use sugarshack_core::routine::{RoutineError, RoutineMachine, RoutineSnapshot};
use sugarshack_core::time::Millis;
use wasm_bindgen::prelude::*;

use crate::operation::{command_names, command_of, state_of};
use crate::{from_js_bounded, js_error, time, to_js, Bound};

/// The TypeScript shapes of what this module's calls return and take
/// (`unchecked_return_type` / `unchecked_param_type` name them).
#[wasm_bindgen(typescript_custom_section)]
const TS_SHAPES: &str = r#"
/** A routine dispatching an operation on a transition. */
export interface RoutineDispatch {
    transition: number;
    operation: string;
    from: string;
    to: string;
}

/** A routine's move once its operation ended (or on reset). */
export interface RoutineMove {
    from: string;
    to: string;
    operation: string | null;
    /** A fault with no error state halts the routine. */
    halted: boolean;
}

/** `Routine.runFailed()`: what the failed run was, and the move it made (none for a refusal). */
export interface RoutineFailed {
    outcome: "aborted" | "refused" | "faulted";
    moved: RoutineMove | null;
}

/** The condition of a transition. */
export interface RoutineCondition {
    when: string;
    sensors: string[];
}

/** A condition transition of `Routine.conditions()`. */
export interface RoutineTransitionCondition extends RoutineCondition {
    transition: number;
}

/** `Routine.snapshot()`, for the context store. */
export interface RoutineSnapshot {
    routine: string;
    state: string;
    pending: string | null;
    halted: boolean;
    held?: boolean;
    stopped?: boolean;
    aborted?: boolean;
}

/** `Routine.command()`: the command its pending operation gets, and the move a reset made. */
export interface RoutineCommanded {
    forward: RunCommand | null;
    moved: RoutineMove | null;
}
"#;

fn routine_error(err: RoutineError) -> JsValue {
    js_error(err.code(), &err.to_string())
}

/// One routine's state machine, made by `Tracker.routine(id)`. Dispatches and
/// moves come back as `{ transition, operation, from, to }` and `{ from, to, operation, halted }`.
#[wasm_bindgen]
pub struct Routine {
    core: RoutineMachine,
}

impl Routine {
    pub(crate) fn of(plant: &Plant, id: &str) -> Result<Routine, JsValue> {
        RoutineMachine::new(plant, id)
            .map(|core| Routine { core })
            .map_err(routine_error)
    }

    pub(crate) fn machine(&self) -> &RoutineMachine {
        &self.core
    }
}

#[wasm_bindgen]
impl Routine {
    pub fn state(&self) -> String {
        self.core.state().into()
    }

    pub fn pending(&self) -> Option<String> {
        self.core.pending().map(Into::into)
    }

    pub fn halted(&self) -> bool {
        self.core.halted()
    }

    pub fn operations(&self) -> Vec<String> {
        self.core.operations().into_iter().map(Into::into).collect()
    }

    /// Its ISA-88 state, `operation` being its pending operation's state (if any).
    #[wasm_bindgen(js_name = runState, unchecked_return_type = "RunState")]
    pub fn run_state(
        &self,
        #[wasm_bindgen(unchecked_param_type = "RunState | undefined")] operation: Option<String>,
    ) -> Result<String, JsValue> {
        Ok(self.core.run_state(state_of(operation)?).name().into())
    }

    /// The operator's commands allowed now.
    #[wasm_bindgen(unchecked_return_type = "RunCommand[]")]
    pub fn commands(
        &self,
        #[wasm_bindgen(unchecked_param_type = "RunState | undefined")] operation: Option<String>,
    ) -> Result<Vec<String>, JsValue> {
        Ok(command_names(self.core.commands(state_of(operation)?)))
    }

    /// An operator's command: `{ forward, moved }`, the command its pending
    /// operation gets (if any) and the move of a reset; or the refusal
    /// (`COMMAND_REFUSED`, `ROUTINE_BUSY`), which changes nothing.
    #[wasm_bindgen(unchecked_return_type = "RoutineCommanded")]
    pub fn command(
        &mut self,
        command: &str,
        #[wasm_bindgen(unchecked_param_type = "RunState | undefined")] operation: Option<String>,
    ) -> Result<JsValue, JsValue> {
        let command = command_of(command)?;
        let (forward, moved) = self
            .core
            .command(command, state_of(operation)?)
            .map_err(routine_error)?;
        to_js(&serde_json::json!({ "forward": forward.map(|c| c.name()), "moved": moved }))
    }

    /// Its pending operation was stopped: it stays where it was, stopped until a reset.
    #[wasm_bindgen(js_name = operationStopped, unchecked_return_type = "RoutineMove")]
    pub fn operation_stopped(&mut self) -> Result<JsValue, JsValue> {
        let moved = self.core.operation_stopped().map_err(routine_error)?;
        to_js(&moved)
    }

    /// Its pending operation was aborted: it stays where it was, aborted until a reset.
    #[wasm_bindgen(js_name = operationAborted, unchecked_return_type = "RoutineMove")]
    pub fn operation_aborted(&mut self) -> Result<JsValue, JsValue> {
        let moved = self.core.operation_aborted().map_err(routine_error)?;
        to_js(&moved)
    }

    /// A trigger msg: the dispatch, or a refusal (busy, halted, held, no transition).
    #[wasm_bindgen(js_name = onMsg, unchecked_return_type = "RoutineDispatch")]
    pub fn on_msg(&mut self, topic: &str) -> Result<JsValue, JsValue> {
        let dispatch = self.core.on_msg(topic).map_err(routine_error)?;
        to_js(&dispatch)
    }

    /// Condition transitions due for evaluation now (they count as checked).
    pub fn due(&mut self, now_ms: f64) -> Result<Vec<u32>, JsValue> {
        let now = time(now_ms)?;
        Ok(self.core.due(now).into_iter().map(|t| t as u32).collect())
    }

    /// Its interlock's gate opened (`true`: ready, not draining) or closed:
    /// while closed no condition is due and none fires.
    pub fn gate(&mut self, open: bool) {
        self.core.gate(open);
    }

    /// A sensor of the condition of `transition` sampled (or its check
    /// failed): it is due again `everyMs` after its last check.
    #[wasm_bindgen(js_name = inputChanged)]
    pub fn input_changed(&mut self, transition: u32) {
        self.core.input_changed(transition as usize);
    }

    /// When `due` next hands out a condition (epoch ms; 0: now), if ever: call it then.
    #[wasm_bindgen(js_name = nextDeadline)]
    pub fn next_deadline(&self) -> Option<f64> {
        self.core.next_deadline().map(Millis::as_f64)
    }

    /// `{ when, sensors }` of a condition transition.
    #[wasm_bindgen(unchecked_return_type = "RoutineCondition")]
    pub fn condition(&self, transition: u32) -> Result<JsValue, JsValue> {
        let (when, sensors) = self.core.condition(transition as usize).ok_or_else(|| {
            js_error(
                Code::NoTransition,
                &format!(
                    "transition #{transition} of routine '{}' has no condition",
                    self.core.id()
                ),
            )
        })?;
        to_js(&serde_json::json!({ "when": when, "sensors": sensors }))
    }

    /// `[{ transition, when, sensors }]`: every condition transition, to compile once.
    #[wasm_bindgen(unchecked_return_type = "RoutineTransitionCondition[]")]
    pub fn conditions(&self) -> Result<JsValue, JsValue> {
        let all: Vec<serde_json::Value> = self
            .core
            .conditions()
            .into_iter()
            .map(|(t, when, sensors)| serde_json::json!({ "transition": t, "when": when, "sensors": sensors }))
            .collect();
        to_js(&all)
    }

    /// A due condition held: the dispatch, or undefined if the routine moved
    /// on meanwhile, or (due again) while an operation is pending or the gate is closed.
    #[wasm_bindgen(js_name = conditionMet, unchecked_return_type = "RoutineDispatch | undefined")]
    pub fn condition_met(&mut self, transition: u32) -> Result<JsValue, JsValue> {
        match self.core.condition_met(transition as usize) {
            Some(dispatch) => to_js(&dispatch),
            None => Ok(JsValue::UNDEFINED),
        }
    }

    #[wasm_bindgen(unchecked_return_type = "RoutineMove")]
    pub fn completed(&mut self) -> Result<JsValue, JsValue> {
        let moved = self.core.completed().map_err(routine_error)?;
        to_js(&moved)
    }

    /// The dispatched operation was refused before it ran: the routine stays where it was.
    pub fn refused(&mut self) -> Result<(), JsValue> {
        self.core.refused().map_err(routine_error)
    }

    /// Its pending operation's run ended without completing, in `ended`
    /// (the run's final state; undefined when no run started): the routine
    /// says whether that was an abort, a refusal or a fault, and moves.
    #[wasm_bindgen(js_name = runFailed, unchecked_return_type = "RoutineFailed")]
    pub fn run_failed(
        &mut self,
        #[wasm_bindgen(unchecked_param_type = "RunState | undefined")] ended: Option<String>,
    ) -> Result<JsValue, JsValue> {
        let ended = state_of(ended)?;
        let failed = self.core.run_failed(ended).map_err(routine_error)?;
        to_js(&failed)
    }

    #[wasm_bindgen(unchecked_return_type = "RoutineMove")]
    pub fn faulted(&mut self) -> Result<JsValue, JsValue> {
        let moved = self.core.faulted().map_err(routine_error)?;
        to_js(&moved)
    }

    #[wasm_bindgen(unchecked_return_type = "RoutineMove")]
    pub fn reset(&mut self) -> Result<JsValue, JsValue> {
        let moved = self.core.reset().map_err(routine_error)?;
        to_js(&moved)
    }

    /// `{ routine, state, pending, halted }`, for the context store.
    #[wasm_bindgen(unchecked_return_type = "RoutineSnapshot")]
    pub fn snapshot(&self) -> Result<JsValue, JsValue> {
        to_js(&self.core.snapshot())
    }

    /// Back to a saved snapshot; returns the move made if an operation was
    /// pending and did not come back held (in `held`): it counts as faulted.
    #[wasm_bindgen(unchecked_return_type = "RoutineMove | null")]
    pub fn restore(
        &mut self,
        #[wasm_bindgen(unchecked_param_type = "RoutineSnapshot")] snapshot: JsValue,
        held: Vec<String>,
    ) -> Result<JsValue, JsValue> {
        let snapshot: RoutineSnapshot = from_js_bounded(
            snapshot,
            Code::InvalidSnapshot,
            "invalid routine snapshot",
            Bound::RoutineSnapshot,
        )?;
        let held: Vec<&str> = held.iter().map(String::as_str).collect();
        match self.core.restore(&snapshot, &held).map_err(routine_error)? {
            Some(moved) => to_js(&moved),
            None => Ok(JsValue::NULL),
        }
    }
}
