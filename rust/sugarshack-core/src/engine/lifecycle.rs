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
//!
//! The host around an engine (the JS runtime of an interlock or a plant)
//! lives by the same table, with four stages an engine never reaches (it is
//! freed instead): its start failed ([`Stage::Failed`]) or it is a hot
//! standby ([`Stage::Standby`]), each also while a drain goes on. What the
//! host does with a msg in each stage is [`Stage::admit`].
//!
//! ```text
//! live stage ──fail──▶ Failed ──restart──▶ Starting
//! live stage ──stand-down──▶ Standby ──activate──▶ Starting
//! (each to its -Held twin while a drain goes on; drain-begin / drain-end move between the twins)
//! ```

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
    /// A host whose start failed (its settings, document or saved state refused): every msg gets the reason.
    Failed,
    /// Failed, and a deploy's drain goes on.
    FailedHeld,
    /// A host on a hot standby (another instance acts): msgs are completed unsent.
    Standby,
    /// A hot standby, and a deploy's drain goes on.
    StandbyHeld,
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
    /// A host's start (or new settings, or rebuild) failed.
    Fail,
    /// A host starts again (new settings, or a rebuild).
    Restart,
    /// A host is deposed in a hot-standby cluster.
    StandDown,
    /// A host on standby is elected: it starts from the committed state.
    Activate,
}

impl Step {
    /// Every step.
    pub const ALL: [Step; 11] = [
        Started,
        DeployBegin,
        DeployEnd,
        DrainBegin,
        DrainEnd,
        Shutdown,
        Retire,
        Fail,
        Restart,
        StandDown,
        Activate,
    ];

    /// A step only a host takes: an engine that fails or stands down is freed instead.
    pub fn host_only(self) -> bool {
        matches!(self, Fail | Restart | StandDown | Activate)
    }

    /// Its name, as the host says it.
    pub fn name(self) -> &'static str {
        match self {
            Started => "started",
            DeployBegin => "deploy-begin",
            DeployEnd => "deploy-end",
            DrainBegin => "drain-begin",
            DrainEnd => "drain-end",
            Shutdown => "shutdown",
            Retire => "retire",
            Fail => "fail",
            Restart => "restart",
            StandDown => "stand-down",
            Activate => "activate",
        }
    }

    /// The step of `name` (see [`Step::name`]).
    pub fn named(name: &str) -> Option<Step> {
        Step::ALL.into_iter().find(|s| s.name() == name)
    }
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
    // A host's start fails; a drain going on stays on.
    (Starting, Fail, Failed),
    (StartingHeld, Fail, FailedHeld),
    (Running, Fail, Failed),
    (HandingOver, Fail, Failed),
    (Draining, Fail, FailedHeld),
    (HandingOverDraining, Fail, FailedHeld),
    (Failed, DrainBegin, FailedHeld),
    (FailedHeld, DrainEnd, Failed),
    // It starts again: new settings after a drain, or a rebuild after a trap.
    (Failed, Restart, Starting),
    (FailedHeld, Restart, StartingHeld),
    (Running, Restart, Starting),
    (HandingOver, Restart, Starting),
    (Draining, Restart, StartingHeld),
    (HandingOverDraining, Restart, StartingHeld),
    // A hot standby: deposed from any live stage, elected back to a start.
    (Starting, StandDown, Standby),
    (StartingHeld, StandDown, StandbyHeld),
    (Running, StandDown, Standby),
    (HandingOver, StandDown, Standby),
    (Draining, StandDown, StandbyHeld),
    (HandingOverDraining, StandDown, StandbyHeld),
    (Failed, StandDown, Standby),
    (FailedHeld, StandDown, StandbyHeld),
    (Standby, DrainBegin, StandbyHeld),
    (StandbyHeld, DrainEnd, Standby),
    (Standby, Activate, Starting),
    (StandbyHeld, Activate, StartingHeld),
    (Failed, Shutdown, Stopped),
    (FailedHeld, Shutdown, Stopped),
    (Standby, Shutdown, Stopped),
    (StandbyHeld, Shutdown, Stopped),
    (Failed, Retire, Stopped),
    (FailedHeld, Retire, Stopped),
    (Standby, Retire, Stopped),
    (StandbyHeld, Retire, Stopped),
];

/// What a stage does with an input.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Gate {
    /// Kept, in arrival order, until the engine has started (within its
    /// park bound); answered as by a stopped engine if it stops first.
    Park,
    /// Taken; new requests are held back until the drain ends.
    HoldBack,
    /// Taken.
    Open,
    /// Completed unsent: the engine is stopped.
    Closed,
    /// Completed with the reason the host failed.
    Refuse,
    /// Completed unsent, the node showing `standby` (the active instance answers the same msg).
    Standby,
}

/// What a host's msg is, for [`Stage::admit`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Work {
    /// It does not wait for a drain (a fault, a lockout, a clear, a release, device feedback): the drain may wait for it.
    pub urgent: bool,
    /// It runs on a hot standby too (device feedback keeps it warm).
    pub passive: bool,
    /// The host follows another instance (a plant on a hot standby, whose stage is its own).
    pub standby: bool,
}

impl Work {
    /// Every kind of work, in the order of [`Work::index`].
    pub fn all() -> impl Iterator<Item = Work> {
        (0..8u8).map(|i| Work {
            urgent: i & 1 != 0,
            passive: i & 2 != 0,
            standby: i & 4 != 0,
        })
    }

    /// Its place in [`Work::all`]: urgent 1, passive 2, standby 4.
    pub fn index(self) -> usize {
        usize::from(self.urgent) | usize::from(self.passive) << 1 | usize::from(self.standby) << 2
    }
}

/// What a host does with a msg now.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Admit {
    /// It runs now.
    Take,
    /// Kept in arrival order until the host starts or the drain ends (within Node-RED's msg buffer bound).
    Park,
    /// Completed unsent: the host is stopped.
    Complete,
    /// Completed with the reason the host failed.
    Refuse,
    /// Completed unsent, the node showing `standby`.
    Standby,
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
            Failed | FailedHeld => Gate::Refuse,
            Standby | StandbyHeld => Gate::Standby,
        }
    }

    /// A deploy's drain goes on: new work waits for it, unless urgent.
    pub fn draining(self) -> bool {
        matches!(
            self,
            StartingHeld | Draining | HandingOverDraining | FailedHeld | StandbyHeld
        )
    }

    /// New work waits here: the start, or a drain, is not over.
    pub fn waits(self) -> bool {
        self.gate() == Gate::Park || self.draining()
    }

    /// What a host does with `work` now.
    pub fn admit(self, work: Work) -> Admit {
        match self.gate() {
            Gate::Closed => Admit::Complete,
            Gate::Refuse => Admit::Refuse,
            gate if (work.standby || gate == Gate::Standby) && !work.passive => Admit::Standby,
            Gate::Park => Admit::Park,
            _ if self.draining() && !work.urgent => Admit::Park,
            _ => Admit::Take,
        }
    }

    /// The host's state as the state API and the nodes' status name it.
    pub fn state(self) -> &'static str {
        match self {
            Starting | StartingHeld => "starting",
            Running | HandingOver | Draining | HandingOverDraining => "ready",
            Failed | FailedHeld => "failed",
            Standby | StandbyHeld => "standby",
            Stopped => "stopped",
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
            Failed => "failed",
            FailedHeld => "failed-held",
            Standby => "standby",
            StandbyHeld => "standby-held",
        }
    }

    /// The stage of `name` (see [`Stage::name`]).
    pub fn named(name: &str) -> Option<Stage> {
        Stage::ALL.into_iter().find(|s| s.name() == name)
    }

    /// Every stage.
    pub const ALL: [Stage; 11] = [
        Starting,
        StartingHeld,
        Running,
        HandingOver,
        Draining,
        HandingOverDraining,
        Stopped,
        Failed,
        FailedHeld,
        Standby,
        StandbyHeld,
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

    const STEPS: [Step; 11] = Step::ALL;

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

    #[test]
    fn an_engine_never_reaches_a_host_stage() {
        let mut seen = vec![Starting];
        let mut todo = vec![Starting];
        while let Some(stage) = todo.pop() {
            for step in STEPS.into_iter().filter(|s| !s.host_only()) {
                let next = stage.after(step);
                if !seen.contains(&next) {
                    seen.push(next);
                    todo.push(next);
                }
            }
        }
        for stage in [Failed, FailedHeld, Standby, StandbyHeld] {
            assert!(!seen.contains(&stage), "an engine reaches {stage}");
        }
    }

    #[test]
    fn a_drain_survives_a_failure_a_restart_and_a_standby() {
        let path = [
            DrainBegin, Fail, Restart, StandDown, Activate, Started, DrainEnd,
        ];
        let stages: Vec<Stage> = path
            .iter()
            .scan(Starting, |s, step| {
                *s = s.after(*step);
                Some(*s)
            })
            .collect();
        assert_eq!(
            stages,
            [
                StartingHeld,
                FailedHeld,
                StartingHeld,
                StandbyHeld,
                StartingHeld,
                Draining,
                Running
            ]
        );
        // The stages said to be draining are those a drain's end leaves, and a drain's begin enters.
        for stage in Stage::ALL {
            assert_eq!(stage.draining(), stage.after(DrainEnd) != stage, "{stage}");
            if stage != Stopped {
                assert!(stage.after(DrainBegin).draining(), "{stage}");
            }
        }
    }

    #[test]
    fn what_a_host_does_with_a_msg_in_each_stage() {
        let plain = Work::default();
        let urgent = Work {
            urgent: true,
            ..plain
        };
        let feedback = Work {
            urgent: true,
            passive: true,
            ..plain
        };
        let on_standby = Work {
            standby: true,
            ..plain
        };
        assert_eq!(Starting.admit(urgent), Admit::Park);
        assert_eq!(Running.admit(plain), Admit::Take);
        assert_eq!(Draining.admit(plain), Admit::Park);
        assert_eq!(Draining.admit(urgent), Admit::Take);
        assert_eq!(Failed.admit(urgent), Admit::Refuse);
        assert_eq!(FailedHeld.admit(plain), Admit::Refuse);
        assert_eq!(Stopped.admit(feedback), Admit::Complete);
        assert_eq!(Standby.admit(urgent), Admit::Standby);
        assert_eq!(Standby.admit(feedback), Admit::Take);
        assert_eq!(
            StandbyHeld.admit(Work {
                passive: true,
                ..plain
            }),
            Admit::Park
        );
        // A plant on a hot standby keeps its own stage: only its feedback goes in.
        assert_eq!(Running.admit(on_standby), Admit::Standby);
        assert_eq!(
            Running.admit(Work {
                standby: true,
                ..feedback
            }),
            Admit::Take
        );
        assert!(Starting.waits() && FailedHeld.waits() && !Failed.waits() && !Running.waits());
        assert_eq!(
            [Starting, Draining, FailedHeld, StandbyHeld, Stopped].map(Stage::state),
            ["starting", "ready", "failed", "standby", "stopped"]
        );
    }

    #[test]
    fn steps_and_work_are_named_and_indexed_one_way() {
        for step in Step::ALL {
            assert_eq!(Step::named(step.name()), Some(step));
        }
        for stage in Stage::ALL {
            assert_eq!(Stage::named(stage.name()), Some(stage));
        }
        assert_eq!(Step::named("start"), None);
        for (i, work) in Work::all().enumerate() {
            assert_eq!(work.index(), i);
        }
    }
}
