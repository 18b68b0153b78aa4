//! An engine's life, as one state machine declared as data: the table of
//! [`TRANSITIONS`] says where each step leads from each stage, and
//! [`Stage::gate`] what each stage does with new work.
//!
//! ```text
//! Starting ──started──▶ Running ◀──drain-end── Draining
//!    │                   │   ▲                   ▲   │
//! drain-begin    deploy-begin deploy-end  deploy-end deploy-begin
//!    ▼                   ▼   │                   │   ▼
//! StartingHeld       HandingOver ──drain-begin──▶ HandingOverDraining
//! (started ─▶ Draining)          ◀──drain-end───
//! any stage ──shutdown / retire──▶ Stopped
//! ```
//!
//! A deploy hands the running engine to the new node instances (handing
//! over); one that changes its settings drains first: new requests wait,
//! running work finishes, then the new settings apply.

use std::fmt;

use serde::{Deserialize, Serialize};

/// Where an engine is in its life.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Stage {
    /// Its saved state is being read: inputs wait.
    Starting,
    /// Starting, and a deploy's drain began meanwhile: it starts draining.
    StartingHeld,
    /// Taking every input.
    Running,
    /// A deploy replaces the nodes (same settings): held msgs go on from the new instances.
    HandingOver,
    /// A deploy changes its settings: new requests wait until the running work finishes.
    Draining,
    /// Both: the deploy is still replacing nodes, and the drain has begun.
    HandingOverDraining,
    /// Shut down or removed: it changes nothing any more.
    Stopped,
}

/// What moves an engine from stage to stage.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Step {
    /// Its saved state was read.
    Started,
    /// A deploy stops the flows.
    DeployBegin,
    /// The deploy's flows started.
    DeployEnd,
    /// A deploy changes settings: drain.
    DrainBegin,
    /// Drained, the new settings applied.
    DrainEnd,
    /// Node-RED stops.
    Shutdown,
    /// Its config node left the flows.
    Retire,
}

use Stage::*;
use Step::*;

/// Every transition there is; a step not listed for a stage leaves it where it is.
pub const TRANSITIONS: &[(Stage, Step, Stage)] = &[
    (Starting, Started, Running),
    (Starting, DrainBegin, StartingHeld),
    (StartingHeld, Started, Draining),
    (StartingHeld, DrainEnd, Starting),
    (Running, DeployBegin, HandingOver),
    (Running, DrainBegin, Draining),
    (HandingOver, DeployEnd, Running),
    (HandingOver, DrainBegin, HandingOverDraining),
    (HandingOverDraining, DeployEnd, Draining),
    (HandingOverDraining, DrainEnd, HandingOver),
    (Draining, DrainEnd, Running),
    (Draining, DeployBegin, HandingOverDraining),
    (Starting, Shutdown, Stopped),
    (StartingHeld, Shutdown, Stopped),
    (Running, Shutdown, Stopped),
    (HandingOver, Shutdown, Stopped),
    (Draining, Shutdown, Stopped),
    (HandingOverDraining, Shutdown, Stopped),
    (Starting, Retire, Stopped),
    (StartingHeld, Retire, Stopped),
    (Running, Retire, Stopped),
    (HandingOver, Retire, Stopped),
    (Draining, Retire, Stopped),
    (HandingOverDraining, Retire, Stopped),
];

/// What a stage does with an input.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Gate {
    /// Kept, in arrival order, until the engine has started.
    Park,
    /// Taken; new requests are held back until the drain ends.
    HoldBack,
    /// Taken.
    Open,
    /// Completed unsent: the engine is stopped.
    Closed,
}

impl Stage {
    /// Where `step` leads from here.
    pub fn after(self, step: Step) -> Stage {
        TRANSITIONS
            .iter()
            .find(|(from, on, _)| *from == self && *on == step)
            .map_or(self, |(_, _, to)| *to)
    }

    /// What this stage does with inputs.
    pub fn gate(self) -> Gate {
        match self {
            Starting | StartingHeld => Gate::Park,
            Draining | HandingOverDraining => Gate::HoldBack,
            Running | HandingOver => Gate::Open,
            Stopped => Gate::Closed,
        }
    }

    /// Its name, as the state API shows it.
    pub fn name(self) -> &'static str {
        match self {
            Starting => "starting",
            StartingHeld => "starting-held",
            Running => "running",
            HandingOver => "handing-over",
            Draining => "draining",
            HandingOverDraining => "handing-over-draining",
            Stopped => "stopped",
        }
    }

    /// Every stage.
    pub const ALL: [Stage; 7] = [
        Starting,
        StartingHeld,
        Running,
        HandingOver,
        Draining,
        HandingOverDraining,
        Stopped,
    ];
}

impl fmt::Display for Stage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const STEPS: [Step; 7] = [
        Started,
        DeployBegin,
        DeployEnd,
        DrainBegin,
        DrainEnd,
        Shutdown,
        Retire,
    ];

    #[test]
    fn each_stage_has_at_most_one_transition_per_step() {
        for (i, (from, on, _)) in TRANSITIONS.iter().enumerate() {
            assert!(
                !TRANSITIONS[..i]
                    .iter()
                    .any(|(f, o, _)| f == from && o == on),
                "{from} on {on:?} twice"
            );
        }
    }

    #[test]
    fn every_stage_is_reachable_and_every_live_stage_can_stop() {
        let mut seen = vec![Starting];
        let mut todo = vec![Starting];
        while let Some(stage) = todo.pop() {
            for step in STEPS {
                let next = stage.after(step);
                if !seen.contains(&next) {
                    seen.push(next);
                    todo.push(next);
                }
            }
        }
        for stage in Stage::ALL {
            assert!(seen.contains(&stage), "{stage} unreachable");
            assert_eq!(stage.after(Shutdown), Stopped);
            assert_eq!(stage.after(Retire), Stopped);
        }
        for step in STEPS {
            assert_eq!(Stopped.after(step), Stopped, "nothing leaves Stopped");
        }
    }

    #[test]
    fn a_deploy_that_changes_settings_drains_then_runs() {
        let path = [DeployBegin, DrainBegin, DeployEnd, DrainEnd];
        let stages: Vec<Stage> = path
            .iter()
            .scan(Running, |s, step| {
                *s = s.after(*step);
                Some(*s)
            })
            .collect();
        assert_eq!(
            stages,
            [HandingOver, HandingOverDraining, Draining, Running]
        );
        assert_eq!(StartingHeld.after(Started).gate(), Gate::HoldBack);
        assert_eq!(Starting.gate(), Gate::Park);
        assert_eq!(Stopped.gate(), Gate::Closed);
    }
}
