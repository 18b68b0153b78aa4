//! An operation's run as a state machine: acquire its lines at the interlock,
//! run its steps (the last one returning every commanded actuator to idle,
//! C3), release; any failure after the grant faults the operation at the
//! interlock. An operator may hold, restart, stop, abort and reset it as the
//! ISA-88 state model of [`crate::procedure`] allows. Like the tracker it
//! takes inputs with the time and returns effects: the caller turns them into
//! interlock calls, group commands and timers, and reports their outcome back
//! as the next input.
//!
//! Inputs that do not fit the run's state and step (a timer that fired late,
//! a report repeated, anything after the end) change nothing and return no
//! effect. Each step, hold command and restore it asks for carries an attempt
//! number, new for each; an answer names the attempt it answers, so a late
//! answer to an attempt cancelled earlier (the same step before a hold and
//! restart) is told from the current one's and ignored. The one refused misuse is a second `start`, which would otherwise
//! wait for effects that never come; a command its state does not allow is
//! refused with the table's words.
//!
//! The effects of one run, in order:
//! - completed: `Acquire StartStep(0) StartStep(1) ... Release Finished`;
//! - faulted: `Acquire StartStep(0) ... [CancelStep] Fault Failed`, or
//!   `... Release Fault Failed` when the release failed;
//! - refused: `Acquire Failed`;
//! - withdrawn: `Acquire Withdraw [Release [Fault]] Failed`, where the
//!   `Release` hands back a grant that crossed the withdrawal (nothing was
//!   commanded yet) and the `Fault` follows only if that release failed;
//! - held and restarted: `... [CancelStep] Entered(holding) Hold
//!   Entered(held) ... Entered(restarting) [Restore] Entered(running)
//!   StartStep(i) ...`, the hold command and the restore only when there is
//!   something to set (a hold may command nothing);
//! - stopped: `... Entered(stopping) [CancelStep] ... StartStep(return to
//!   idle) Release Stopped`;
//! - aborted: `... [CancelStep] Entered(aborting) Fault Failed`, or
//!   `Acquire Entered(aborting) Withdraw ... Failed` while queued.

use std::fmt;

use serde::{Deserialize, Serialize};

use super::{OperationPlan, PlanStep};
use crate::clearance::Attribution;
use crate::code::Code;
use crate::plant::{GroupCommand, Plant, RestartRule, StopRule};
use crate::procedure::{self, Command, CommandRefused, State};
use crate::text::quote;
use crate::time::{ms, Millis};

/// Interlock refusals that mean the operation already runs (C1).
const ALREADY_RUNNING: [Code; 2] = [Code::AlreadyHolding, Code::AlreadyQueued];
const ABORTED: &str = Code::Aborted.name();

/// Why an operation run could not be made, started or restored.
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
        state: State,
    },
    /// A run saved held cannot come back: its plan changed, or the save does not fit it.
    NotRestorable {
        /// The operation's id.
        operation: String,
        /// Why, in words a person acts on.
        reason: String,
    },
    /// A command its state does not allow.
    Refused(CommandRefused),
}

impl RunError {
    /// The code a Catch node sees.
    pub fn code(&self) -> Code {
        match self {
            Self::UnknownOperation { .. } => Code::UnknownOperation,
            Self::AlreadyStarted { .. } => Code::AlreadyStarted,
            Self::NotRestorable { .. } => Code::InvalidSnapshot,
            Self::Refused(refusal) => refusal.code,
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
            Self::AlreadyStarted { operation, state } => write!(
                f,
                "this run of operation '{operation}' was already started (it is {state}); make a new run for each start"
            ),
            Self::NotRestorable { operation, reason } => write!(
                f,
                "operation '{}' was held when the state was saved but cannot come back held: {reason}",
                quote(operation)
            ),
            Self::Refused(refusal) => refusal.fmt(f),
        }
    }
}

impl std::error::Error for RunError {}

impl From<CommandRefused> for RunError {
    fn from(refusal: CommandRefused) -> Self {
        RunError::Refused(refusal)
    }
}

/// What a step does.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
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
    /// Its hold command.
    Hold,
    /// What a restart puts back.
    Restart,
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

/// One step done, and how long it took (held time not counted).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct StepRecord {
    /// What the step did.
    pub kind: StepKind,
    /// How long it took.
    pub ms: Millis,
}

/// Who supervises a run: kept with a held run's save so that its owner takes it back after a restart.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "camelCase", deny_unknown_fields)]
pub enum RunOwner {
    /// A routine dispatched it.
    Routine {
        /// The routine's id.
        id: String,
    },
    /// An operation node started it.
    Node {
        /// The node's id.
        id: String,
    },
}

/// A held run as saved with the interlock's state: after a restart it comes
/// back held (its lines kept, nothing commanded) on the same plan.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct RunSnapshot {
    /// The operation's id.
    pub operation: String,
    /// The digest of the plan it ran ([`OperationPlan::digest`]).
    pub plan: String,
    /// The step it was held in.
    pub step: usize,
    /// How long that step had run before the hold.
    pub used_ms: Millis,
    /// When it was started.
    pub started_ms: Millis,
    /// When it was granted.
    pub granted_ms: Millis,
    /// Since when it is held (or holding).
    pub held_since_ms: Millis,
    /// How long it was held before this hold.
    pub held_ms: Millis,
    /// Whether its hold command was confirmed (false: it was still holding,
    /// and the hold command goes out again).
    pub held: bool,
    /// The steps it completed.
    pub steps: Vec<StepRecord>,
    /// How many attempts it had made: numbering goes on from there (a save
    /// made before attempts were numbered reads 0).
    #[serde(default)]
    pub attempts: u32,
    /// Who supervises it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub owner: Option<RunOwner>,
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
    /// Run step `index` within `timeout_ms`; report `step_done` or `step_failed`.
    /// A command step carries the operation's lines as `within`, for the C2 check.
    StartStep {
        /// The step's index.
        index: usize,
        /// This attempt's number: its answer names it.
        attempt: u32,
        /// The step.
        step: PlanStep,
        /// The lines the command must stay within (C2).
        #[serde(skip_serializing_if = "Option::is_none")]
        within: Option<Vec<String>>,
        /// How long it has: its timeout, or what was left of it when a hold paused it.
        timeout_ms: Millis,
    },
    /// Stop what is in progress in step `index` (the step's command or wait,
    /// or a hold or restart command issued in it): attempt `attempt`; report nothing for it.
    CancelStep {
        /// The step's index.
        index: usize,
        /// The attempt cancelled.
        attempt: u32,
    },
    /// Send the hold command; report `hold_done` or `hold_failed`.
    Hold {
        /// This attempt's number: its answer names it.
        attempt: u32,
        /// The group command.
        command: GroupCommand,
        /// How long it may take.
        timeout_ms: Millis,
        /// The lines it must stay within (C2).
        within: Vec<String>,
    },
    /// Put back what the hold command changed; report `restart_done` or `restart_failed`.
    Restore {
        /// This attempt's number: its answer names it.
        attempt: u32,
        /// The group command.
        command: GroupCommand,
        /// How long it may take.
        timeout_ms: Millis,
        /// The lines it must stay within (C2).
        within: Vec<String>,
    },
    /// The run entered an operator's state (holding, held, restarting, back
    /// to running, stopping, aborting, idle after a reset).
    Entered {
        /// The state.
        state: State,
        /// The step it is in, if any.
        step: Option<usize>,
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
        /// How long it ran once granted (held time included).
        run_ms: Millis,
        /// How long it was held.
        held_ms: Millis,
        /// Each step's record.
        steps: Vec<StepRecord>,
    },
    /// An operator stopped the run: what it had commanded is back at idle and its lines are released.
    Stopped {
        /// Its id in the plant document.
        id: String,
        /// The code a Catch node sees (`OPERATION_STOPPED`).
        code: String,
        /// What happened, in words.
        message: String,
        /// How long it waited for its lines.
        queued_ms: Millis,
        /// How long it ran once granted (held time included; 0 if stopped while queued).
        run_ms: Millis,
        /// How long it was held.
        held_ms: Millis,
        /// The steps it completed.
        steps: Vec<StepRecord>,
        /// The step it was in when stopped (none while queued).
        step: Option<usize>,
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
        /// Where it ended: faulted, aborted, refused or withdrawn.
        state: State,
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
    /// An operator's abort: the run ends aborted, not faulted.
    by_command: bool,
}

impl Failure {
    /// What the plant or the interlock reported failed (`code`, `message`) at `place`.
    fn reported(
        code: &str,
        message: &str,
        place: String,
        step: Option<usize>,
        stage: Stage,
    ) -> Self {
        Failure {
            code: code.into(),
            place,
            cause: message.into(),
            step,
            stage,
            aborted: false,
            by_command: false,
        }
    }
}

/// How a withdrawal ends the run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Withdrawal {
    /// Its supervisor went away.
    Interrupted,
    /// An operator's stop.
    Stop,
    /// An operator's abort.
    Abort,
}

/// Where a step's time and the run's held time stand.
#[derive(Clone, Copy, Debug)]
struct InStep {
    index: usize,
    /// How long the step ran before the last hold.
    used_ms: Millis,
}

#[derive(Clone, Debug)]
enum Inner {
    New,
    Queued,
    /// `release_sent` once a grant that crossed the withdrawal was handed back.
    Withdrawing {
        reason: String,
        release_sent: bool,
        end: Withdrawal,
    },
    /// A step in progress since `since_ms`; `stopping` once a stop was asked.
    Step {
        at: InStep,
        since_ms: Millis,
        stopping: bool,
    },
    /// The hold command in flight, held since `since_ms`.
    Holding {
        at: InStep,
        since_ms: Millis,
    },
    Held {
        at: InStep,
        since_ms: Millis,
    },
    /// Putting back what the hold changed, held since `since_ms`.
    Restarting {
        at: InStep,
        since_ms: Millis,
    },
    /// Waiting for the release; `aborted` by whom once an abort came during a stop's release.
    Releasing {
        stopping: bool,
        aborted: Option<String>,
    },
    Faulting(Failure),
    Ended(State),
}

/// One start of an operation, from its request to its end. It holds all its
/// state, so it outlives whoever drives it.
#[derive(Clone, Debug)]
pub struct OperationRun {
    plan: OperationPlan,
    state: Inner,
    started_ms: Millis,
    granted_ms: Millis,
    held_ms: Millis,
    steps: Vec<StepRecord>,
    /// Where an operator's stop found it.
    stopped_at: Option<usize>,
    /// An operator aborted it (not its supervisor going away).
    aborted_by_operator: bool,
    /// How many attempts (steps, hold commands, restores) it asked for; the
    /// last one is the only one whose answer counts.
    attempts: u32,
}

impl OperationRun {
    /// A run of `plan`, not started.
    pub fn new(plan: OperationPlan) -> Self {
        OperationRun {
            steps: Vec::with_capacity(plan.steps.len()),
            plan,
            state: Inner::New,
            started_ms: Millis::ZERO,
            granted_ms: Millis::ZERO,
            held_ms: Millis::ZERO,
            stopped_at: None,
            aborted_by_operator: false,
            attempts: 0,
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

    /// Its ISA-88 state.
    pub fn state(&self) -> State {
        match &self.state {
            Inner::New => State::Idle,
            Inner::Queued => State::Queued,
            Inner::Withdrawing { end, .. } => match end {
                Withdrawal::Interrupted => State::Withdrawing,
                Withdrawal::Stop => State::Stopping,
                Withdrawal::Abort => State::Aborting,
            },
            Inner::Step { stopping, .. } => {
                if *stopping {
                    State::Stopping
                } else {
                    State::Running
                }
            }
            Inner::Holding { .. } => State::Holding,
            Inner::Held { .. } => State::Held,
            Inner::Restarting { .. } => State::Restarting,
            Inner::Releasing { stopping, aborted } => match (stopping, aborted) {
                (_, Some(_)) => State::Aborting,
                (true, None) => State::Stopping,
                (false, None) => State::Completing,
            },
            Inner::Faulting(failure) => {
                if failure.aborted {
                    State::Aborting
                } else {
                    State::Faulting
                }
            }
            Inner::Ended(state) => *state,
        }
    }

    /// The operator's commands its state allows now.
    pub fn commands(&self) -> Vec<Command> {
        procedure::OPERATION.commands(self.state())
    }

    /// An operator aborted it: its operation refuses every start until a
    /// person's reset, recorded at the abort (in the same write as its lockouts).
    pub fn awaits_reset(&self) -> bool {
        self.aborted_by_operator
    }

    /// The attempt whose answer it waits for (a step, a hold command or a
    /// restore in flight), if any. Its caller never needs it: each effect
    /// carries its attempt.
    pub fn attempt(&self) -> Option<u32> {
        match self.state {
            Inner::Step { .. } | Inner::Holding { .. } | Inner::Restarting { .. } => {
                self.attempts.checked_sub(1)
            }
            _ => None,
        }
    }

    /// Whether `attempt` is the one it waits for: an answer to any other
    /// (cancelled, superseded, or never asked for) changes nothing.
    fn answers(&self, attempt: u32) -> bool {
        self.attempt() == Some(attempt)
    }

    /// A new attempt's number.
    fn next_attempt(&mut self) -> u32 {
        let attempt = self.attempts;
        self.attempts = self.attempts.saturating_add(1);
        attempt
    }

    /// The index of the step in progress (or held, or being restarted).
    pub fn step(&self) -> Option<usize> {
        match self.state {
            Inner::Step { at, .. }
            | Inner::Holding { at, .. }
            | Inner::Held { at, .. }
            | Inner::Restarting { at, .. } => Some(at.index),
            _ => None,
        }
    }

    /// Requests the operation's lines. Refused on a run already started.
    pub fn start(&mut self, now: Millis) -> Result<Vec<RunEffect>, RunError> {
        if !matches!(self.state, Inner::New) {
            return Err(RunError::AlreadyStarted {
                operation: self.plan.id.clone(),
                state: self.state(),
            });
        }
        self.started_ms = now;
        self.state = Inner::Queued;
        Ok(vec![RunEffect::Acquire {
            operation: self.plan.id.clone(),
            priority: self.plan.priority,
            resources: self.plan.resources.clone(),
        }])
    }

    /// An operator's command, by `who`: the effects, or the table's refusal
    /// (which changes nothing).
    pub fn command(
        &mut self,
        command: Command,
        who: &Attribution,
        now: Millis,
    ) -> Result<Vec<RunEffect>, RunError> {
        procedure::OPERATION.check(&self.plan.id, self.state(), command)?;
        Ok(match command {
            Command::Start => self.start(now)?,
            Command::Hold => self.hold(now),
            Command::Restart => self.restart(now),
            Command::Stop => self.stop(now),
            Command::Abort => {
                self.aborted_by_operator = true;
                self.abort(who, now)
            }
            Command::Reset => {
                // Numbering goes on: an answer from before the reset stays stale.
                let attempts = self.attempts;
                *self = OperationRun::new(self.plan.clone());
                self.attempts = attempts;
                vec![RunEffect::Entered {
                    state: State::Idle,
                    step: None,
                }]
            }
        })
    }

    fn entered(&self) -> RunEffect {
        RunEffect::Entered {
            state: self.state(),
            step: self.step(),
        }
    }

    /// Running or restarting: what is in flight stops, and the hold command goes out.
    fn hold(&mut self, now: Millis) -> Vec<RunEffect> {
        let (at, since_ms) = match self.state {
            Inner::Step { at, since_ms, .. } => (
                InStep {
                    index: at.index,
                    used_ms: at.used_ms.saturating_add(now.saturating_sub(since_ms)),
                },
                now,
            ),
            Inner::Restarting { at, since_ms } => (at, since_ms),
            _ => return Vec::new(),
        };
        let mut effects = vec![self.cancel(at.index)];
        effects.extend(self.begin_hold(at, since_ms));
        effects
    }

    fn begin_hold(&mut self, at: InStep, since_ms: Millis) -> Vec<RunEffect> {
        match self.plan.hold.clone() {
            Some(hold) => {
                self.state = Inner::Holding { at, since_ms };
                vec![
                    self.entered(),
                    RunEffect::Hold {
                        attempt: self.next_attempt(),
                        command: hold.command,
                        timeout_ms: hold.timeout_ms,
                        within: self.plan.resources.clone(),
                    },
                ]
            }
            None => {
                self.state = Inner::Held { at, since_ms };
                vec![self.entered()]
            }
        }
    }

    /// The hold command (attempt `attempt`) completed: held, commanding nothing.
    pub fn hold_done(&mut self, attempt: u32, _now: Millis) -> Vec<RunEffect> {
        let Inner::Holding { at, since_ms } = self.state else {
            return Vec::new();
        };
        if !self.answers(attempt) {
            return Vec::new();
        }
        self.state = Inner::Held { at, since_ms };
        vec![self.entered()]
    }

    /// The hold command (attempt `attempt`) failed or timed out: the operation faults.
    pub fn hold_failed(
        &mut self,
        attempt: u32,
        code: &str,
        message: &str,
        _now: Millis,
    ) -> Vec<RunEffect> {
        let Inner::Holding { at, .. } = self.state else {
            return Vec::new();
        };
        if !self.answers(attempt) {
            return Vec::new();
        }
        let place = format!("its hold command in {}", self.describe(at.index));
        self.fault_reported(Failure::reported(
            code,
            message,
            place,
            Some(at.index),
            Stage::Hold,
        ))
    }

    /// Held: what the hold changed goes back, then the step goes on.
    fn restart(&mut self, now: Millis) -> Vec<RunEffect> {
        let Inner::Held { at, since_ms } = self.state else {
            return Vec::new();
        };
        self.state = Inner::Restarting { at, since_ms };
        let mut effects = vec![self.entered()];
        match self.plan.restore_before(at.index) {
            Some(restore) => effects.push(RunEffect::Restore {
                attempt: self.next_attempt(),
                command: restore.command,
                timeout_ms: restore.timeout_ms,
                within: self.plan.resources.clone(),
            }),
            None => effects.extend(self.resume(now)),
        }
        effects
    }

    /// What the hold changed is back (the restore, attempt `attempt`): the
    /// step goes on as its restart rule says.
    pub fn restart_done(&mut self, attempt: u32, now: Millis) -> Vec<RunEffect> {
        if !self.answers(attempt) {
            return Vec::new();
        }
        self.resume(now)
    }

    /// Restarting, nothing left to put back: the step goes on as its restart rule says.
    fn resume(&mut self, now: Millis) -> Vec<RunEffect> {
        let Inner::Restarting { at, since_ms } = self.state else {
            return Vec::new();
        };
        self.held_ms = self.held_ms.saturating_add(now.saturating_sub(since_ms));
        let at = match self.plan.steps[at.index].restart() {
            RestartRule::Reissue => at,
            RestartRule::Rerun => InStep {
                index: at.index,
                used_ms: Millis::ZERO,
            },
        };
        self.state = Inner::Step {
            at,
            since_ms: now,
            stopping: false,
        };
        let mut effects = vec![self.entered()];
        effects.push(self.start_step(at));
        effects
    }

    /// What a restart sends (attempt `attempt`) failed or timed out: the operation faults.
    pub fn restart_failed(
        &mut self,
        attempt: u32,
        code: &str,
        message: &str,
        _now: Millis,
    ) -> Vec<RunEffect> {
        let Inner::Restarting { at, .. } = self.state else {
            return Vec::new();
        };
        if !self.answers(attempt) {
            return Vec::new();
        }
        let place = format!("its restart in {}", self.describe(at.index));
        self.fault_reported(Failure::reported(
            code,
            message,
            place,
            Some(at.index),
            Stage::Restart,
        ))
    }

    /// An operator's stop: withdrawn while queued; else as the plan's stop rule says, then back to idle and released.
    fn stop(&mut self, now: Millis) -> Vec<RunEffect> {
        match self.state {
            Inner::Queued => {
                self.state = Inner::Withdrawing {
                    reason: "stopped by an operator".into(),
                    release_sent: false,
                    end: Withdrawal::Stop,
                };
                vec![
                    self.entered(),
                    RunEffect::Withdraw {
                        operation: self.plan.id.clone(),
                    },
                ]
            }
            Inner::Step { at, since_ms, .. } => {
                self.stopped_at = Some(at.index);
                let to_idle = matches!(self.plan.steps[at.index], PlanStep::ReturnToIdle { .. });
                if self.plan.stop == StopRule::FinishStep || to_idle {
                    self.state = Inner::Step {
                        at,
                        since_ms,
                        stopping: true,
                    };
                    return vec![self.entered()];
                }
                let cancel = self.cancel(at.index);
                let next = self.stop_to_idle(at.index, now);
                let mut effects = vec![cancel, self.entered()];
                effects.extend(next);
                effects
            }
            Inner::Held { at, since_ms } => {
                self.stopped_at = Some(at.index);
                self.held_ms = self.held_ms.saturating_add(now.saturating_sub(since_ms));
                let next = self.stop_to_idle(at.index, now);
                let mut effects = vec![self.entered()];
                effects.extend(next);
                effects
            }
            _ => Vec::new(),
        }
    }

    /// Stopping from step `index`: the return to idle next (unless past it),
    /// then the release. The state's `Entered` is the caller's to say.
    fn stop_to_idle(&mut self, index: usize, now: Millis) -> Vec<RunEffect> {
        let to_idle = self
            .plan
            .steps
            .iter()
            .position(|s| matches!(s, PlanStep::ReturnToIdle { .. }))
            .filter(|&i| i >= index);
        match to_idle {
            Some(i) => {
                let at = InStep {
                    index: i,
                    used_ms: Millis::ZERO,
                };
                self.state = Inner::Step {
                    at,
                    since_ms: now,
                    stopping: true,
                };
                vec![self.start_step(at)]
            }
            None => {
                self.state = Inner::Releasing {
                    stopping: true,
                    aborted: None,
                };
                vec![self.release()]
            }
        }
    }

    /// An operator's abort: withdrawn while queued; else its lines' lockouts go out at once, as for a fault.
    fn abort(&mut self, who: &Attribution, now: Millis) -> Vec<RunEffect> {
        let by = match &who.reason {
            Some(reason) => format!("aborted by {}: {reason}", who.by),
            None => format!("aborted by {}", who.by),
        };
        match self.state.clone() {
            Inner::Queued => {
                self.state = Inner::Withdrawing {
                    reason: by,
                    release_sent: false,
                    end: Withdrawal::Abort,
                };
                vec![
                    self.entered(),
                    RunEffect::Withdraw {
                        operation: self.plan.id.clone(),
                    },
                ]
            }
            Inner::Withdrawing {
                release_sent,
                end: Withdrawal::Stop,
                ..
            } => {
                self.state = Inner::Withdrawing {
                    reason: by,
                    release_sent,
                    end: Withdrawal::Abort,
                };
                vec![self.entered()]
            }
            Inner::Releasing { stopping: true, .. } => {
                // Everything is back at idle and the release is on its way: nothing is left to lock out.
                self.state = Inner::Releasing {
                    stopping: true,
                    aborted: Some(by),
                };
                vec![self.entered()]
            }
            Inner::Step { at, .. }
            | Inner::Holding { at, .. }
            | Inner::Held { at, .. }
            | Inner::Restarting { at, .. } => self.abort_in_step(at.index, by, true, now),
            _ => Vec::new(),
        }
    }

    /// A granted run in step `index` ends at once, aborted with its lines'
    /// lockouts (an operator's abort, `by_command`, or its supervisor gone):
    /// the time held so far counts, the step in flight (none while held) is
    /// cancelled, and an operator's abort shows its aborting state first.
    fn abort_in_step(
        &mut self,
        index: usize,
        cause: String,
        by_command: bool,
        now: Millis,
    ) -> Vec<RunEffect> {
        if let Inner::Held { since_ms, .. } = self.state {
            self.held_ms = self.held_ms.saturating_add(now.saturating_sub(since_ms));
        }
        let cancel = (!matches!(self.state, Inner::Held { .. })).then(|| self.cancel(index));
        let fault = self.fault(
            Failure {
                code: ABORTED.into(),
                place: self.describe(index),
                cause: cause.clone(),
                step: Some(index),
                stage: self.plan.steps[index].kind().into(),
                aborted: true,
                by_command,
            },
            cause,
        );
        let mut effects = Vec::with_capacity(3);
        effects.extend(cancel);
        if by_command {
            effects.push(self.entered());
        }
        effects.push(fault);
        effects
    }

    /// The interlock granted the lines: the first step starts. A grant that
    /// crossed a withdrawal is handed back at once (nothing was commanded yet).
    pub fn granted(&mut self, now: Millis) -> Vec<RunEffect> {
        match &mut self.state {
            Inner::Queued => {
                self.granted_ms = now;
                self.begin(0, now, false)
            }
            Inner::Withdrawing { release_sent, .. } if !*release_sent => {
                *release_sent = true;
                vec![self.release()]
            }
            _ => Vec::new(),
        }
    }

    /// The step in progress completed (its attempt `attempt`): the next one
    /// starts, or the release after the last. Stopping, the return to idle is next.
    pub fn step_done(&mut self, attempt: u32, now: Millis) -> Vec<RunEffect> {
        let (at, since_ms, stopping) = match self.state {
            Inner::Step {
                at,
                since_ms,
                stopping,
            } if self.answers(attempt) => (at, since_ms, stopping),
            _ => return Vec::new(),
        };
        let index = at.index;
        self.steps.push(StepRecord {
            kind: self.plan.steps[index].kind(),
            ms: at.used_ms.saturating_add(now.saturating_sub(since_ms)),
        });
        if stopping {
            return self.stop_to_idle(index + 1, now);
        }
        self.begin(index + 1, now, false)
    }

    /// The interlock released the lines.
    pub fn released(&mut self, now: Millis) -> Vec<RunEffect> {
        match &self.state {
            Inner::Releasing {
                stopping: false, ..
            } => {
                self.state = Inner::Ended(State::Complete);
                vec![RunEffect::Finished {
                    id: self.plan.id.clone(),
                    queued_ms: self.queued_ms(),
                    run_ms: now.saturating_sub(self.granted_ms),
                    held_ms: self.held_ms,
                    steps: std::mem::take(&mut self.steps),
                }]
            }
            Inner::Releasing {
                stopping: true,
                aborted: Some(by),
            } => {
                let failed = self.aborted_failure(by.clone(), Stage::Release);
                self.state = Inner::Ended(State::Aborted);
                vec![failed]
            }
            Inner::Releasing {
                stopping: true,
                aborted: None,
            } => vec![self.end_stopped(now.saturating_sub(self.granted_ms))],
            Inner::Withdrawing {
                release_sent: true, ..
            } => self.end_withdrawn(),
            _ => Vec::new(),
        }
    }

    /// The step in progress failed (its attempt `attempt`: refused, failed,
    /// or not done within its timeout).
    pub fn step_failed(
        &mut self,
        attempt: u32,
        code: &str,
        message: &str,
        _now: Millis,
    ) -> Vec<RunEffect> {
        let Inner::Step { at, .. } = self.state else {
            return Vec::new();
        };
        if !self.answers(attempt) {
            return Vec::new();
        }
        let index = at.index;
        let stage = self.plan.steps[index].kind().into();
        self.fault_reported(Failure::reported(
            code,
            message,
            self.describe(index),
            Some(index),
            stage,
        ))
    }

    /// The interlock refused the release.
    pub fn release_failed(&mut self, code: &str, message: &str, _now: Millis) -> Vec<RunEffect> {
        let (aborted, by_command) = match &self.state {
            Inner::Releasing { aborted, .. } => (aborted.is_some(), aborted.is_some()),
            Inner::Withdrawing {
                release_sent: true,
                end,
                ..
            } => (*end != Withdrawal::Stop, *end == Withdrawal::Abort),
            _ => return Vec::new(),
        };
        let place = "its release".to_owned();
        self.fault_reported(Failure {
            aborted,
            by_command,
            ..Failure::reported(code, message, place, None, Stage::Release)
        })
    }

    /// The interlock faulted the operation; `locked_out` are the lines whose lockouts went out.
    pub fn fault_applied(&mut self, locked_out: Vec<String>, _now: Millis) -> Vec<RunEffect> {
        let Inner::Faulting(failure) = &self.state else {
            return Vec::new();
        };
        let verb = if failure.by_command {
            "was aborted"
        } else {
            "faulted"
        };
        let mut message = format!(
            "operation '{}' {verb} at {}: {}",
            self.plan.id, failure.place, failure.cause
        );
        if !locked_out.is_empty() {
            message.push_str(&format!(
                "; {} locked out until cleared",
                locked_out.join(", ")
            ));
        }
        let state = if failure.by_command || failure.aborted {
            State::Aborted
        } else {
            State::Faulted
        };
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
            state,
        };
        self.state = Inner::Ended(state);
        vec![failed]
    }

    /// The interlock refused the fault: the run ends all the same, nothing locked out.
    pub fn fault_refused(&mut self, now: Millis) -> Vec<RunEffect> {
        self.fault_applied(Vec::new(), now)
    }

    /// The interlock refused the request before any grant (C1, a full queue, a
    /// request dropped by a fault).
    pub fn refused(&mut self, code: &str, message: &str) -> Vec<RunEffect> {
        if !matches!(self.state, Inner::Queued) {
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
        self.state = Inner::Ended(State::Refused);
        vec![RunEffect::Failed {
            id: self.plan.id.clone(),
            code,
            message,
            step: None,
            stage: Stage::Acquire,
            locked_out: Vec::new(),
            aborted: false,
            state: State::Refused,
        }]
    }

    /// Whoever supervised the run is gone: a queued request is withdrawn; a
    /// granted operation is faulted, since nobody watches its actuators any
    /// more. Nothing to stop in any other state (a release under way goes on).
    pub fn interrupt(&mut self, reason: &str, now: Millis) -> Vec<RunEffect> {
        match self.state {
            Inner::Queued => {
                self.state = Inner::Withdrawing {
                    reason: reason.into(),
                    release_sent: false,
                    end: Withdrawal::Interrupted,
                };
                vec![RunEffect::Withdraw {
                    operation: self.plan.id.clone(),
                }]
            }
            Inner::Step { at, .. }
            | Inner::Holding { at, .. }
            | Inner::Held { at, .. }
            | Inner::Restarting { at, .. } => {
                self.abort_in_step(at.index, format!("interrupted: {reason}"), false, now)
            }
            _ => Vec::new(),
        }
    }

    /// Someone else took the request out of the queue (a cancel, a fault
    /// while it waited): a queued run ends refused, nothing ran; one already
    /// withdrawing ends as its withdrawal says.
    pub fn taken_out_of_queue(&mut self, now: Millis) -> Vec<RunEffect> {
        if !matches!(self.state, Inner::Queued) {
            return self.withdrawn(now);
        }
        let message = format!(
            "operation '{}' was taken out of the queue (a cancel, or a fault while it waited) before it was granted",
            self.plan.id
        );
        self.refused(ABORTED, &message)
    }

    /// The queued request is gone (withdrawn, or found no longer queued).
    pub fn withdrawn(&mut self, _now: Millis) -> Vec<RunEffect> {
        match &self.state {
            Inner::Withdrawing {
                release_sent: false,
                ..
            } => self.end_withdrawn(),
            _ => Vec::new(),
        }
    }

    /// The interlock refused the withdrawal: the request is no longer queued, so it is gone all the same.
    pub fn withdraw_refused(&mut self, now: Millis) -> Vec<RunEffect> {
        self.withdrawn(now)
    }

    // ---- a held run across a restart ----------------------------------------

    /// A held (or holding) run as saved with the interlock's state, owned by
    /// `owner`; none in any other state (a restart faults a running one's lines).
    pub fn snapshot(&self, owner: Option<RunOwner>) -> Option<RunSnapshot> {
        let (at, since_ms, held) = match self.state {
            Inner::Holding { at, since_ms } => (at, since_ms, false),
            Inner::Held { at, since_ms } => (at, since_ms, true),
            _ => return None,
        };
        Some(RunSnapshot {
            operation: self.plan.id.clone(),
            plan: self.plan.digest(),
            step: at.index,
            used_ms: at.used_ms,
            started_ms: self.started_ms,
            granted_ms: self.granted_ms,
            held_since_ms: since_ms,
            held_ms: self.held_ms,
            held,
            steps: self.steps.clone(),
            attempts: self.attempts,
            owner,
        })
    }

    /// A run saved held, back on `plan` after a restart: held as it was, or,
    /// if its hold command was not confirmed yet, holding with the hold
    /// command sent again. Refused when `plan` is not the plan it ran.
    pub fn restore(
        plan: OperationPlan,
        saved: &RunSnapshot,
    ) -> Result<(Self, Vec<RunEffect>), RunError> {
        let not = |reason: String| RunError::NotRestorable {
            operation: saved.operation.clone(),
            reason,
        };
        if saved.operation != plan.id {
            return Err(not(format!(
                "the save is operation '{}''s",
                quote(&saved.operation)
            )));
        }
        if saved.plan != plan.digest() {
            return Err(not(
                "the operation in the plant document changed since".into()
            ));
        }
        if saved.step >= plan.steps.len() || saved.steps.len() > saved.step {
            return Err(not(format!(
                "its step {} does not fit its plan of {} steps",
                saved.step + 1,
                plan.steps.len()
            )));
        }
        let mut run = OperationRun::new(plan);
        run.started_ms = saved.started_ms;
        run.granted_ms = saved.granted_ms;
        run.held_ms = saved.held_ms;
        run.steps = saved.steps.clone();
        run.attempts = saved.attempts;
        let at = InStep {
            index: saved.step,
            used_ms: saved.used_ms,
        };
        if saved.held {
            run.state = Inner::Held {
                at,
                since_ms: saved.held_since_ms,
            };
            return Ok((run, Vec::new()));
        }
        let effects = run.begin_hold(at, saved.held_since_ms);
        Ok((run, effects))
    }

    // ---- the way through ------------------------------------------------------

    fn queued_ms(&self) -> Millis {
        self.granted_ms.saturating_sub(self.started_ms)
    }

    fn end_stopped(&mut self, run_ms: Millis) -> RunEffect {
        let step = self.stopped_at;
        let message = match step {
            Some(i) => format!(
                "operation '{}' was stopped by an operator at {}; what it commanded is back at idle and its lines are released",
                self.plan.id,
                self.describe(i)
            ),
            None => format!(
                "operation '{}' was stopped by an operator while it waited for its lines",
                self.plan.id
            ),
        };
        self.state = Inner::Ended(State::Stopped);
        RunEffect::Stopped {
            id: self.plan.id.clone(),
            code: Code::OperationStopped.name().into(),
            message,
            queued_ms: if step.is_some() {
                self.queued_ms()
            } else {
                Millis::ZERO
            },
            run_ms,
            held_ms: self.held_ms,
            steps: std::mem::take(&mut self.steps),
            step,
        }
    }

    /// A withdrawal is over: the run ends as its cause says.
    fn end_withdrawn(&mut self) -> Vec<RunEffect> {
        let Inner::Withdrawing { reason, end, .. } = &self.state else {
            return Vec::new();
        };
        match end {
            Withdrawal::Interrupted => {
                let failed = self.withdrawn_failure(reason);
                self.state = Inner::Ended(State::Withdrawn);
                vec![failed]
            }
            Withdrawal::Stop => vec![self.end_stopped(Millis::ZERO)],
            Withdrawal::Abort => {
                let failed = self.aborted_failure(reason.clone(), Stage::Acquire);
                self.state = Inner::Ended(State::Aborted);
                vec![failed]
            }
        }
    }

    fn aborted_failure(&self, by: String, stage: Stage) -> RunEffect {
        let message = if stage == Stage::Acquire {
            format!(
                "operation '{}' was withdrawn from the queue ({by}); it waits for a reset",
                self.plan.id
            )
        } else {
            format!(
                "operation '{}' was {by} while its lines were being released; it waits for a reset",
                self.plan.id
            )
        };
        RunEffect::Failed {
            id: self.plan.id.clone(),
            code: ABORTED.into(),
            message,
            step: None,
            stage,
            locked_out: Vec::new(),
            aborted: true,
            state: State::Aborted,
        }
    }

    /// Cancels the attempt in flight, in step `index`.
    fn cancel(&self, index: usize) -> RunEffect {
        RunEffect::CancelStep {
            index,
            attempt: self.attempts.saturating_sub(1),
        }
    }

    fn start_step(&mut self, at: InStep) -> RunEffect {
        let step = self.plan.steps[at.index].clone();
        let within = match step {
            PlanStep::Command { .. } | PlanStep::ReturnToIdle { .. } => {
                Some(self.plan.resources.clone())
            }
            PlanStep::Wait { .. } => None,
        };
        // A JS timeout of 0 waits for ever: what is left is at least a millisecond.
        let timeout_ms = step.timeout_ms().saturating_sub(at.used_ms).max(ms(1));
        RunEffect::StartStep {
            index: at.index,
            attempt: self.next_attempt(),
            step,
            within,
            timeout_ms,
        }
    }

    fn begin(&mut self, index: usize, now: Millis, stopping: bool) -> Vec<RunEffect> {
        if index >= self.plan.steps.len() {
            self.state = Inner::Releasing {
                stopping,
                aborted: None,
            };
            return vec![self.release()];
        }
        let at = InStep {
            index,
            used_ms: Millis::ZERO,
        };
        self.state = Inner::Step {
            at,
            since_ms: now,
            stopping,
        };
        vec![self.start_step(at)]
    }

    fn release(&self) -> RunEffect {
        RunEffect::Release {
            operation: self.plan.id.clone(),
        }
    }

    /// A reported failure faults the run, noted with where and why.
    fn fault_reported(&mut self, failure: Failure) -> Vec<RunEffect> {
        let note = format!("{}: {}", failure.place, failure.cause);
        vec![self.fault(failure, note)]
    }

    fn fault(&mut self, failure: Failure, note: String) -> RunEffect {
        self.state = Inner::Faulting(failure);
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
            state: State::Withdrawn,
        }
    }

    /// Step `index` in words: `step 3 (wait)`.
    fn describe(&self, index: usize) -> String {
        let kind = self.plan.steps[index].kind();
        format!("step {} ({})", index + 1, kind.words())
    }
}
