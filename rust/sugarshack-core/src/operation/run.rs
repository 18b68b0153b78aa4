//! An operation's run as a state machine: acquire its lines at the interlock,
//! run its steps (the last one returning every commanded actuator to idle,
//! C3), release; any failure after the grant faults the operation at the
//! interlock. Like the tracker it takes inputs with the time and returns
//! effects: the caller turns them into interlock calls, group commands and
//! timers, and reports their outcome back as the next input.
//!
//! Inputs that do not fit the run's phase and step (a timer that fired late, a
//! report repeated, anything after the end) change nothing and return no
//! effect. The one refused misuse is a second `start`, which would otherwise
//! wait for effects that never come.
//!
//! The effects of one run, in order:
//! - completed: `Acquire StartStep(0) StartStep(1) ... Release Finished`;
//! - faulted: `Acquire StartStep(0) ... [CancelStep] Fault Failed`, or
//!   `... Release Fault Failed` when the release failed;
//! - refused: `Acquire Failed`;
//! - withdrawn: `Acquire Withdraw [Release [Fault]] Failed`, where the
//!   `Release` hands back a grant that crossed the withdrawal (nothing was
//!   commanded yet) and the `Fault` follows only if that release failed.

use std::fmt;

use serde::Serialize;

use super::{OperationPlan, PlanStep};
use crate::code::Code;
use crate::plant::Plant;
use crate::text::quote;
use crate::time::Millis;

/// Interlock refusals that mean the operation already runs (C1).
const ALREADY_RUNNING: [Code; 2] = [Code::AlreadyHolding, Code::AlreadyQueued];
const ABORTED: &str = Code::Aborted.name();

/// Why an operation run could not be made or started.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum RunError {
    /// The plant document has no such operation.
    UnknownOperation {
        /// Its id in the plant document.
        id: String,
    },
    /// A run is one start of its operation; a second start would never be answered.
    AlreadyStarted {
        /// The operation's id.
        operation: String,
        /// Where the run is.
        phase: Phase,
    },
}

impl RunError {
    /// The code a Catch node sees.
    pub fn code(&self) -> Code {
        match self {
            Self::UnknownOperation { .. } => Code::UnknownOperation,
            Self::AlreadyStarted { .. } => Code::AlreadyStarted,
        }
    }
}

impl fmt::Display for RunError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::UnknownOperation { id } => write!(
                f,
                "unknown operation '{}': it is not in the plant document",
                quote(id)
            ),
            Self::AlreadyStarted { operation, phase } => write!(
                f,
                "this run of operation '{operation}' was already started (it is {phase}); make a new run for each start"
            ),
        }
    }
}

impl std::error::Error for RunError {}

/// Where a run is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub enum Phase {
    /// Made, not started.
    New,
    /// Waiting for the grant.
    Queued,
    /// Waiting for the interlock to withdraw the request (aborted while queued).
    Withdrawing,
    /// A step is in progress.
    Running,
    /// Every step done, waiting for the release.
    Releasing,
    /// Waiting for the interlock to fault the operation and the lockouts to go out.
    Faulting,
    /// It completed and released its lines.
    Done,
    /// It faulted; its lines are locked out.
    Faulted,
    /// The interlock refused it before any grant.
    Refused,
    /// Its waiting request was withdrawn.
    Withdrawn,
}

impl Phase {
    /// Its name, as JS and the journal see it.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::New => "new",
            Self::Queued => "queued",
            Self::Withdrawing => "withdrawing",
            Self::Running => "running",
            Self::Releasing => "releasing",
            Self::Faulting => "faulting",
            Self::Done => "done",
            Self::Faulted => "faulted",
            Self::Refused => "refused",
            Self::Withdrawn => "withdrawn",
        }
    }

    /// The run is over: its `Finished` or `Failed` has been returned.
    pub fn is_ended(self) -> bool {
        matches!(
            self,
            Self::Done | Self::Faulted | Self::Refused | Self::Withdrawn
        )
    }
}

impl fmt::Display for Phase {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// What a step does.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub enum StepKind {
    /// A group command.
    Command,
    /// A condition wait.
    Wait,
    /// The return to idle.
    ReturnToIdle,
}

impl StepKind {
    /// As an error message names it.
    pub fn words(self) -> &'static str {
        match self {
            Self::Command => "command",
            Self::Wait => "wait",
            Self::ReturnToIdle => "return to idle",
        }
    }
}

impl PlanStep {
    /// What it does.
    pub fn kind(&self) -> StepKind {
        match self {
            Self::Command { .. } => StepKind::Command,
            Self::Wait { .. } => StepKind::Wait,
            Self::ReturnToIdle { .. } => StepKind::ReturnToIdle,
        }
    }
}

/// Where a run failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub enum Stage {
    /// Acquiring its lines.
    Acquire,
    /// A group command step.
    Command,
    /// A condition wait step.
    Wait,
    /// The return to idle.
    ReturnToIdle,
    /// Releasing its lines.
    Release,
}

impl From<StepKind> for Stage {
    fn from(kind: StepKind) -> Self {
        match kind {
            StepKind::Command => Self::Command,
            StepKind::Wait => Self::Wait,
            StepKind::ReturnToIdle => Self::ReturnToIdle,
        }
    }
}

/// One step done, and how long it took.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct StepRecord {
    /// What the step did.
    pub kind: StepKind,
    /// How long it took.
    pub ms: Millis,
}

/// What the caller does next.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(
    tag = "kind",
    rename_all = "camelCase",
    rename_all_fields = "camelCase"
)]
pub enum RunEffect {
    /// Request the operation's lines at the interlock; report `granted` or `refused`.
    Acquire {
        /// The operation's id.
        operation: String,
        /// The request's priority (lower goes first).
        priority: i32,
        /// The lines' names.
        resources: Vec<String>,
    },
    /// Run step `index` within its timeout; report `step_done` or `step_failed`.
    /// A command step carries the operation's lines as `within`, for the C2 check.
    StartStep {
        /// The step's index.
        index: usize,
        /// The step.
        step: PlanStep,
        /// The lines the command must stay within (C2).
        #[serde(skip_serializing_if = "Option::is_none")]
        within: Option<Vec<String>>,
    },
    /// Stop step `index` (its timers, its wait); report nothing for it.
    CancelStep {
        /// The step's index.
        index: usize,
    },
    /// Release the operation's lines; report `released` or `release_failed`.
    Release {
        /// The operation's id.
        operation: String,
    },
    /// Withdraw the queued request; report `withdrawn` once it is gone.
    Withdraw {
        /// The operation's id.
        operation: String,
    },
    /// Fault the operation at the interlock and send its lines' lockouts;
    /// report `fault_applied` with the lines locked out.
    Fault {
        /// The operation's id.
        operation: String,
        /// Why, kept with the fault.
        note: String,
    },
    /// The run completed.
    Finished {
        /// Its id in the plant document.
        id: String,
        /// How long it waited for its lines.
        queued_ms: Millis,
        /// How long it ran once granted.
        run_ms: Millis,
        /// Each step's record.
        steps: Vec<StepRecord>,
    },
    /// The run ended without completing.
    Failed {
        /// Its id in the plant document.
        id: String,
        /// The code a Catch node sees.
        code: String,
        /// What happened, in words.
        message: String,
        /// The step that failed, if it failed in one.
        step: Option<usize>,
        /// Where it failed.
        stage: Stage,
        /// The lines locked out.
        locked_out: Vec<String>,
        /// Whether it was stopped from outside rather than failing.
        aborted: bool,
    },
}

#[derive(Clone, Debug)]
struct Failure {
    code: String,
    /// `step 3 (wait)` or `its release`.
    place: String,
    cause: String,
    step: Option<usize>,
    stage: Stage,
    aborted: bool,
}

#[derive(Clone, Debug)]
enum State {
    New,
    Queued,
    /// `release_sent` once a grant that crossed the withdrawal was handed back.
    Withdrawing {
        reason: String,
        release_sent: bool,
    },
    Running {
        index: usize,
        since_ms: Millis,
    },
    Releasing,
    Faulting(Failure),
    Ended(Phase),
}

/// One start of an operation, from its request to its end. It holds all its
/// state, so it outlives whoever drives it.
#[derive(Clone, Debug)]
pub struct OperationRun {
    plan: OperationPlan,
    state: State,
    started_ms: Millis,
    granted_ms: Millis,
    steps: Vec<StepRecord>,
}

impl OperationRun {
    /// A run of `plan`, not started.
    pub fn new(plan: OperationPlan) -> Self {
        OperationRun {
            steps: Vec::with_capacity(plan.steps.len()),
            plan,
            state: State::New,
            started_ms: Millis::ZERO,
            granted_ms: Millis::ZERO,
        }
    }

    /// A run of operation `id` of a validated plant.
    pub fn of(plant: &Plant, id: &str) -> Result<Self, RunError> {
        plant
            .operation_plan(id)
            .map(Self::new)
            .ok_or_else(|| RunError::UnknownOperation { id: id.into() })
    }

    /// The operation's id.
    pub fn id(&self) -> &str {
        &self.plan.id
    }

    /// Its plan.
    pub fn plan(&self) -> &OperationPlan {
        &self.plan
    }

    /// Where it is.
    pub fn phase(&self) -> Phase {
        match &self.state {
            State::New => Phase::New,
            State::Queued => Phase::Queued,
            State::Withdrawing { .. } => Phase::Withdrawing,
            State::Running { .. } => Phase::Running,
            State::Releasing => Phase::Releasing,
            State::Faulting(_) => Phase::Faulting,
            State::Ended(phase) => *phase,
        }
    }

    /// The index of the step in progress.
    pub fn step(&self) -> Option<usize> {
        match self.state {
            State::Running { index, .. } => Some(index),
            _ => None,
        }
    }

    /// Requests the operation's lines. Refused on a run already started.
    pub fn start(&mut self, now: Millis) -> Result<Vec<RunEffect>, RunError> {
        if !matches!(self.state, State::New) {
            return Err(RunError::AlreadyStarted {
                operation: self.plan.id.clone(),
                phase: self.phase(),
            });
        }
        self.started_ms = now;
        self.state = State::Queued;
        Ok(vec![RunEffect::Acquire {
            operation: self.plan.id.clone(),
            priority: self.plan.priority,
            resources: self.plan.resources.clone(),
        }])
    }

    /// The interlock granted the lines: the first step starts. A grant that
    /// crossed a withdrawal is handed back at once (nothing was commanded yet).
    pub fn granted(&mut self, now: Millis) -> Vec<RunEffect> {
        match &mut self.state {
            State::Queued => {
                self.granted_ms = now;
                self.begin(0, now)
            }
            State::Withdrawing { release_sent, .. } if !*release_sent => {
                *release_sent = true;
                vec![self.release()]
            }
            _ => Vec::new(),
        }
    }

    /// Step `index` completed: the next one starts, or the release after the last.
    pub fn step_done(&mut self, index: usize, now: Millis) -> Vec<RunEffect> {
        let since_ms = match self.state {
            State::Running { index: i, since_ms } if i == index => since_ms,
            _ => return Vec::new(),
        };
        self.steps.push(StepRecord {
            kind: self.plan.steps[index].kind(),
            ms: now.saturating_sub(since_ms),
        });
        self.begin(index + 1, now)
    }

    /// The interlock released the lines.
    pub fn released(&mut self, now: Millis) -> Vec<RunEffect> {
        match &self.state {
            State::Releasing => {
                self.state = State::Ended(Phase::Done);
                vec![RunEffect::Finished {
                    id: self.plan.id.clone(),
                    queued_ms: self.granted_ms.saturating_sub(self.started_ms),
                    run_ms: now.saturating_sub(self.granted_ms),
                    steps: std::mem::take(&mut self.steps),
                }]
            }
            State::Withdrawing {
                release_sent: true, ..
            } => self.end_withdrawn(),
            _ => Vec::new(),
        }
    }

    /// Step `index` failed (refused, failed, or not done within its timeout).
    pub fn step_failed(
        &mut self,
        index: usize,
        code: &str,
        message: &str,
        _now: Millis,
    ) -> Vec<RunEffect> {
        if self.step() != Some(index) {
            return Vec::new();
        }
        let kind = self.plan.steps[index].kind();
        let place = describe_step(index, kind);
        let note = format!("{place}: {message}");
        vec![self.fault(
            Failure {
                code: code.into(),
                place,
                cause: message.into(),
                step: Some(index),
                stage: kind.into(),
                aborted: false,
            },
            note,
        )]
    }

    /// The interlock refused the release.
    pub fn release_failed(&mut self, code: &str, message: &str, _now: Millis) -> Vec<RunEffect> {
        let aborted = match self.state {
            State::Releasing => false,
            State::Withdrawing {
                release_sent: true, ..
            } => true,
            _ => return Vec::new(),
        };
        let place = "its release".to_owned();
        let note = format!("{place}: {message}");
        vec![self.fault(
            Failure {
                code: code.into(),
                place,
                cause: message.into(),
                step: None,
                stage: Stage::Release,
                aborted,
            },
            note,
        )]
    }

    /// The interlock faulted the operation; `locked_out` are the lines whose lockouts went out.
    pub fn fault_applied(&mut self, locked_out: Vec<String>, _now: Millis) -> Vec<RunEffect> {
        let State::Faulting(failure) = &self.state else {
            return Vec::new();
        };
        let mut message = format!(
            "operation '{}' faulted at {}: {}",
            self.plan.id, failure.place, failure.cause
        );
        if !locked_out.is_empty() {
            message.push_str(&format!(
                "; {} locked out until cleared",
                locked_out.join(", ")
            ));
        }
        let failed = RunEffect::Failed {
            id: self.plan.id.clone(),
            code: if failure.aborted {
                ABORTED.into()
            } else {
                failure.code.clone()
            },
            message,
            step: failure.step,
            stage: failure.stage,
            locked_out,
            aborted: failure.aborted,
        };
        self.state = State::Ended(Phase::Faulted);
        vec![failed]
    }

    /// The interlock refused the request before any grant (C1, a full queue, a
    /// request dropped by a fault).
    pub fn refused(&mut self, code: &str, message: &str) -> Vec<RunEffect> {
        if !matches!(self.state, State::Queued) {
            return Vec::new();
        }
        let (code, message) = if ALREADY_RUNNING.iter().any(|c| c.name() == code) {
            (
                Code::OperationRunning.name().to_owned(),
                format!(
                    "operation '{}' is already running (C1: one instance at a time); this start was refused and the running one goes on",
                    self.plan.id
                ),
            )
        } else {
            (code.to_owned(), message.to_owned())
        };
        self.state = State::Ended(Phase::Refused);
        vec![RunEffect::Failed {
            id: self.plan.id.clone(),
            code,
            message,
            step: None,
            stage: Stage::Acquire,
            locked_out: Vec::new(),
            aborted: false,
        }]
    }

    /// Whoever supervised the run is gone: a queued request is withdrawn; a
    /// running operation is faulted, since nobody watches its actuators any
    /// more. Nothing to stop in any other phase (a release under way goes on).
    pub fn abort(&mut self, reason: &str, _now: Millis) -> Vec<RunEffect> {
        match self.state {
            State::Queued => {
                self.state = State::Withdrawing {
                    reason: reason.into(),
                    release_sent: false,
                };
                vec![RunEffect::Withdraw {
                    operation: self.plan.id.clone(),
                }]
            }
            State::Running { index, .. } => {
                let kind = self.plan.steps[index].kind();
                let cause = format!("interrupted: {reason}");
                let fault = self.fault(
                    Failure {
                        code: ABORTED.into(),
                        place: describe_step(index, kind),
                        cause: cause.clone(),
                        step: Some(index),
                        stage: kind.into(),
                        aborted: true,
                    },
                    cause,
                );
                vec![RunEffect::CancelStep { index }, fault]
            }
            _ => Vec::new(),
        }
    }

    /// The queued request is gone (withdrawn, or found no longer queued).
    pub fn withdrawn(&mut self, _now: Millis) -> Vec<RunEffect> {
        match &self.state {
            State::Withdrawing {
                release_sent: false,
                ..
            } => self.end_withdrawn(),
            _ => Vec::new(),
        }
    }

    /// A withdrawal is over: the run ends with its failure.
    fn end_withdrawn(&mut self) -> Vec<RunEffect> {
        let State::Withdrawing { reason, .. } = &self.state else {
            return Vec::new();
        };
        let failed = self.withdrawn_failure(reason);
        self.state = State::Ended(Phase::Withdrawn);
        vec![failed]
    }

    fn begin(&mut self, index: usize, now: Millis) -> Vec<RunEffect> {
        let Some(step) = self.plan.steps.get(index) else {
            self.state = State::Releasing;
            return vec![self.release()];
        };
        let within = match step {
            PlanStep::Command { .. } | PlanStep::ReturnToIdle { .. } => {
                Some(self.plan.resources.clone())
            }
            PlanStep::Wait { .. } => None,
        };
        let effect = RunEffect::StartStep {
            index,
            step: step.clone(),
            within,
        };
        self.state = State::Running {
            index,
            since_ms: now,
        };
        vec![effect]
    }

    fn release(&self) -> RunEffect {
        RunEffect::Release {
            operation: self.plan.id.clone(),
        }
    }

    fn fault(&mut self, failure: Failure, note: String) -> RunEffect {
        self.state = State::Faulting(failure);
        RunEffect::Fault {
            operation: self.plan.id.clone(),
            note,
        }
    }

    fn withdrawn_failure(&self, reason: &str) -> RunEffect {
        RunEffect::Failed {
            id: self.plan.id.clone(),
            code: ABORTED.into(),
            message: format!(
                "operation '{}' was withdrawn from the queue ({reason})",
                self.plan.id
            ),
            step: None,
            stage: Stage::Acquire,
            locked_out: Vec::new(),
            aborted: true,
        }
    }
}

fn describe_step(index: usize, kind: StepKind) -> String {
    format!("step {} ({})", index + 1, kind.words())
}
