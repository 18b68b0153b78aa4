//! A runtime's life in the palette (an interlock's or a plant's), as the
//! core's one state machine declares it: the host says each step from the
//! stage it is in, and reads where it leads and what it does with a msg
//! there. The host keeps that view until its next step (a msg crosses
//! nothing to learn its way), and no wasm object: a trap loses nothing.

use sugarshack_core::code::Code;
use sugarshack_core::engine::{Admit, Stage, Step, Work};
use sugarshack_core::text::quote;
use wasm_bindgen::prelude::*;

use crate::{js_error, to_js};

/// The TypeScript shapes of what this module's calls return and take.
#[wasm_bindgen(typescript_custom_section)]
const TS_SHAPES: &str = r#"
/** A step of a runtime's life. */
export type LifeStep =
    | "started" | "deploy-begin" | "deploy-end" | "drain-begin" | "drain-end" | "shutdown" | "retire"
    | "fail" | "restart" | "stand-down" | "activate";

/** What a runtime does with a msg now. */
export type LifeAdmit = "take" | "park" | "complete" | "refuse" | "standby";

/** Where a runtime is in its life, and what it does with msgs there. */
export interface LifeView {
    /** The stage, as the core names it ("starting-held", "failed-held"...). */
    stage: string;
    /** Its state as the state API and the nodes' status name it. */
    state: "starting" | "ready" | "failed" | "standby" | "stopped";
    /** A deploy's drain goes on. */
    draining: boolean;
    /** New work waits (the start, or a drain, is not over). */
    waits: boolean;
    /** Stopped: it changes nothing any more. */
    stopped: boolean;
    /** What it does with a msg, by kind: index urgent 1 | passive 2 | standby 4. */
    admit: LifeAdmit[];
}
"#;

#[derive(serde::Serialize)]
struct View {
    stage: &'static str,
    state: &'static str,
    draining: bool,
    waits: bool,
    stopped: bool,
    admit: Vec<Admit>,
}

fn view(stage: Stage) -> Result<JsValue, JsValue> {
    to_js(&View {
        stage: stage.name(),
        state: stage.state(),
        draining: stage.draining(),
        waits: stage.waits(),
        stopped: stage == Stage::Stopped,
        admit: Work::all().map(|work| stage.admit(work)).collect(),
    })
}

fn named<T>(what: &str, name: &str, found: Option<T>) -> Result<T, JsValue> {
    found.ok_or_else(|| {
        js_error(
            Code::InvalidInput,
            &format!("unknown {what} '{}'", quote(name)),
        )
    })
}

/// Stage `stage` (a new runtime's is "starting"), and what a runtime does with msgs there.
#[wasm_bindgen(js_name = lifeView, unchecked_return_type = "LifeView")]
pub fn life_view(stage: &str) -> Result<JsValue, JsValue> {
    view(named("stage", stage, Stage::named(stage))?)
}

/// Where `step` leads from `stage` (a step the stage has no transition for leaves it where it is).
#[wasm_bindgen(js_name = lifeStep, unchecked_return_type = "LifeView")]
pub fn life_step(
    stage: &str,
    #[wasm_bindgen(unchecked_param_type = "LifeStep")] step: &str,
) -> Result<JsValue, JsValue> {
    let from = named("stage", stage, Stage::named(stage))?;
    let step = named("step", step, Step::named(step))?;
    view(from.after(step))
}
