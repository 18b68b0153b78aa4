use sugarshack_core::code::Code;
use sugarshack_core::plant::Plant;
use sugarshack_core::routine::{RoutineError, RoutineMachine, RoutineSnapshot};
use wasm_bindgen::prelude::*;

use crate::{from_js_bounded, js_error, time, to_js, Bound};

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

    /// A trigger msg: the dispatch, or a refusal (busy, halted, no transition).
    #[wasm_bindgen(js_name = onMsg)]
    pub fn on_msg(&mut self, topic: &str) -> Result<JsValue, JsValue> {
        let dispatch = self.core.on_msg(topic).map_err(routine_error)?;
        to_js(&dispatch)
    }

    /// Condition transitions due for evaluation now (they count as checked).
    pub fn due(&mut self, now_ms: f64) -> Result<Vec<u32>, JsValue> {
        let now = time(now_ms)?;
        Ok(self.core.due(now).into_iter().map(|t| t as u32).collect())
    }

    /// `{ when, sensors }` of a condition transition.
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
    pub fn conditions(&self) -> Result<JsValue, JsValue> {
        let all: Vec<serde_json::Value> = self
            .core
            .conditions()
            .into_iter()
            .map(|(t, when, sensors)| serde_json::json!({ "transition": t, "when": when, "sensors": sensors }))
            .collect();
        to_js(&all)
    }

    /// A due condition held: the dispatch, or undefined if the routine moved on meanwhile.
    #[wasm_bindgen(js_name = conditionMet)]
    pub fn condition_met(&mut self, transition: u32) -> Result<JsValue, JsValue> {
        match self.core.condition_met(transition as usize) {
            Some(dispatch) => to_js(&dispatch),
            None => Ok(JsValue::UNDEFINED),
        }
    }

    pub fn completed(&mut self) -> Result<JsValue, JsValue> {
        let moved = self.core.completed().map_err(routine_error)?;
        to_js(&moved)
    }

    /// The dispatched operation was refused before it ran: the routine stays where it was.
    pub fn refused(&mut self) -> Result<(), JsValue> {
        self.core.refused().map_err(routine_error)
    }

    pub fn faulted(&mut self) -> Result<JsValue, JsValue> {
        let moved = self.core.faulted().map_err(routine_error)?;
        to_js(&moved)
    }

    pub fn reset(&mut self) -> Result<JsValue, JsValue> {
        let moved = self.core.reset().map_err(routine_error)?;
        to_js(&moved)
    }

    /// `{ routine, state, pending, halted }`, for the context store.
    pub fn snapshot(&self) -> Result<JsValue, JsValue> {
        to_js(&self.core.snapshot())
    }

    /// Back to a saved snapshot; returns the move made if an operation was pending (it counts as faulted).
    pub fn restore(&mut self, snapshot: JsValue) -> Result<JsValue, JsValue> {
        let snapshot: RoutineSnapshot = from_js_bounded(
            snapshot,
            Code::InvalidSnapshot,
            "invalid routine snapshot",
            Bound::RoutineSnapshot,
        )?;
        match self.core.restore(&snapshot).map_err(routine_error)? {
            Some(moved) => to_js(&moved),
            None => Ok(JsValue::NULL),
        }
    }
}
