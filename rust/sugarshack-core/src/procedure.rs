//! The ISA-88 procedural state model (IEC 61512-1; PackML and the MTP
//! service state machine follow it) for operation runs and routines,
//! declared as data: the states, the operator's commands, and for every
//! state and command whether the command is allowed, and the state it leads
//! to, or refused, and why. [`OperationRun`](crate::operation::OperationRun)
//! and [`RoutineMachine`](crate::routine::RoutineMachine) look a command up
//! here before acting on it; what the plant reports (a grant, a step done, a
//! hold command confirmed) moves them along [`OPERATION_EVENTS`] and
//! [`ROUTINE_EVENTS`]. Nothing else moves them: a test holds both to these
//! tables.
//!
//! Adopted from ISA-88: idle, running, holding, held, restarting, stopping,
//! stopped, aborting, aborted, complete, and reset from a final state back to
//! idle; `restart` leaves held (PackML's and MTP's `unhold`). Not adopted:
//! pausing and paused (ISA-88's pause waits for the procedure's next
//! transition point; an operation's next point is its next step, where a stop
//! already ends it), PackML's starting, completing, suspending and clearing
//! (a machine starved or blocked waits in the interlock's queue instead; a
//! clear is the interlock's). Added for the paper's model: queued (waiting
//! for its lines), completing (releasing them), faulting and faulted (a
//! failure's lockout: the paper's fault, which a person recovers from by
//! clearing the lines), and, for a run that ended before it ran, refused and
//! withdrawn.

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::code::Code;

/// The procedural state of an operation run or a routine.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub enum State {
    /// Not running: ready for a start.
    Idle,
    /// Started, waiting for its lines (an operation only).
    Queued,
    /// Running its steps (an operation), or dispatching its operations (a routine).
    Running,
    /// Its hold command is being carried out.
    Holding,
    /// Paused where it was: it keeps its lines, commands nothing, and its timeouts stand still.
    Held,
    /// Putting back what the hold command changed, before it goes on.
    Restarting,
    /// Finishing as its stop rule says, then returning to idle and releasing its lines.
    Stopping,
    /// Ended by a stop: everything it commanded back to idle, its lines released.
    Stopped,
    /// Its lines' lockouts are going out, as for a fault.
    Aborting,
    /// Ended by an abort: its lines locked out; it waits for a reset.
    Aborted,
    /// Releasing its lines after its last step (an operation only).
    Completing,
    /// Ended with every step done.
    Complete,
    /// A step, a hold or a restart failed: its lines' lockouts are going out.
    Faulting,
    /// Ended by a failure: its lines locked out until a person clears them.
    Faulted,
    /// Its waiting request is being taken out of the queue (an operation only).
    Withdrawing,
    /// Ended before its grant: its request was withdrawn (an operation only).
    Withdrawn,
    /// Ended before its grant: the interlock refused its request (an operation only).
    Refused,
}

impl State {
    /// Every state, in the order of the enum.
    pub const ALL: [State; 17] = [
        State::Idle,
        State::Queued,
        State::Running,
        State::Holding,
        State::Held,
        State::Restarting,
        State::Stopping,
        State::Stopped,
        State::Aborting,
        State::Aborted,
        State::Completing,
        State::Complete,
        State::Faulting,
        State::Faulted,
        State::Withdrawing,
        State::Withdrawn,
        State::Refused,
    ];

    /// Its name, as JS, the state API and the journal see it.
    pub const fn name(self) -> &'static str {
        match self {
            State::Idle => "idle",
            State::Queued => "queued",
            State::Running => "running",
            State::Holding => "holding",
            State::Held => "held",
            State::Restarting => "restarting",
            State::Stopping => "stopping",
            State::Stopped => "stopped",
            State::Aborting => "aborting",
            State::Aborted => "aborted",
            State::Completing => "completing",
            State::Complete => "complete",
            State::Faulting => "faulting",
            State::Faulted => "faulted",
            State::Withdrawing => "withdrawing",
            State::Withdrawn => "withdrawn",
            State::Refused => "refused",
        }
    }

    /// A run in this state has ended (its result was returned).
    pub const fn is_final(self) -> bool {
        matches!(
            self,
            State::Stopped
                | State::Aborted
                | State::Complete
                | State::Faulted
                | State::Withdrawn
                | State::Refused
        )
    }
}

impl fmt::Display for State {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// An operator's command.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub enum Command {
    /// Run (an operation's msg, a routine's trigger).
    Start,
    /// Pause where it is: the hold command goes out, nothing else is commanded.
    Hold,
    /// Go on from held.
    Restart,
    /// End in order: as the stop rule says, then back to idle and release.
    Stop,
    /// End at once: its lines' lockouts go out, as for a fault.
    Abort,
    /// From a final state back to idle.
    Reset,
}

impl Command {
    /// Every command.
    pub const ALL: [Command; 6] = [
        Command::Start,
        Command::Hold,
        Command::Restart,
        Command::Stop,
        Command::Abort,
        Command::Reset,
    ];

    /// The commands an operator gives from a surface (a start comes as a msg).
    pub const OPERATOR: [Command; 5] = [
        Command::Hold,
        Command::Restart,
        Command::Stop,
        Command::Abort,
        Command::Reset,
    ];

    /// Its name, as msg topics, endpoints and the journal use it.
    pub const fn name(self) -> &'static str {
        match self {
            Command::Start => "start",
            Command::Hold => "hold",
            Command::Restart => "restart",
            Command::Stop => "stop",
            Command::Abort => "abort",
            Command::Reset => "reset",
        }
    }

    /// The command named `name`.
    pub fn from_name(name: &str) -> Option<Command> {
        Command::ALL.into_iter().find(|c| c.name() == name)
    }
}

impl fmt::Display for Command {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// What a command does in a state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Taken: the state it enters.
    To(State),
    /// Refused with this code, and why, in words a person acts on.
    Refused(Code, &'static str),
}

/// One allowed command: in state `from`, `command` leads to `to`.
pub type Allowed = (State, Command, State);
/// One refusal with its own words: in state `from`, `command` is refused because ...
pub type Refusal = (State, Command, Code, &'static str);

/// The commands of a kind of procedure: those allowed, the refusals with
/// words of their own, and for any other pair, why the state takes no command.
#[derive(Debug)]
pub struct Table {
    /// What it is, in a refusal ("operation", "routine").
    pub noun: &'static str,
    /// Every allowed (state, command, next state).
    pub allowed: &'static [Allowed],
    /// Refusals that say more than the state's own reason.
    pub refusals: &'static [Refusal],
    /// Why a state takes none of the commands not allowed in it.
    pub otherwise: fn(State) -> &'static str,
}

impl Table {
    /// What `command` does in state `state`.
    pub fn verdict(&self, state: State, command: Command) -> Verdict {
        if let Some(&(_, _, to)) = self
            .allowed
            .iter()
            .find(|(from, c, _)| *from == state && *c == command)
        {
            return Verdict::To(to);
        }
        if let Some(&(_, _, code, why)) = self
            .refusals
            .iter()
            .find(|(from, c, _, _)| *from == state && *c == command)
        {
            return Verdict::Refused(code, why);
        }
        Verdict::Refused(Code::CommandRefused, (self.otherwise)(state))
    }

    /// The operator's commands allowed in `state` (what an HMI offers).
    pub fn commands(&self, state: State) -> Vec<Command> {
        Command::OPERATOR
            .into_iter()
            .filter(|&c| matches!(self.verdict(state, c), Verdict::To(_)))
            .collect()
    }

    /// `command` in `state` of `subject` (its id): the next state, or the refusal.
    pub fn check(
        &self,
        subject: &str,
        state: State,
        command: Command,
    ) -> Result<State, CommandRefused> {
        match self.verdict(state, command) {
            Verdict::To(next) => Ok(next),
            Verdict::Refused(code, why) => Err(CommandRefused {
                code,
                noun: self.noun,
                subject: subject.to_owned(),
                state,
                command,
                why,
            }),
        }
    }
}

/// A command the state of an operation or routine does not allow.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CommandRefused {
    /// `COMMAND_REFUSED`, or `OPERATION_ABORTED` for a start that waits for a reset.
    pub code: Code,
    /// "operation" or "routine".
    pub noun: &'static str,
    /// Its id.
    pub subject: String,
    /// The state it is in.
    pub state: State,
    /// The command refused.
    pub command: Command,
    /// Why, in words a person acts on.
    pub why: &'static str,
}

impl fmt::Display for CommandRefused {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} refused: {} '{}' is {}; {}",
            self.command,
            self.noun,
            crate::text::quote(&self.subject),
            self.state,
            self.why
        )
    }
}

impl std::error::Error for CommandRefused {}

use Command::{Abort, Hold, Reset, Restart, Start, Stop};
use State::*;

/// The operator's commands on an operation (its current run, or its last one
/// once ended). A start from a final state other than aborted is a new run:
/// complete, stopped and faulted reset themselves, so a flow that starts an
/// operation again needs no reset. An aborted one waits for a person's reset.
pub const OPERATION: Table = Table {
    noun: "operation",
    allowed: &[
        (Idle, Start, Queued),
        (Complete, Start, Queued),
        (Stopped, Start, Queued),
        (Faulted, Start, Queued),
        (Withdrawn, Start, Queued),
        (Refused, Start, Queued),
        (Queued, Stop, Stopping),
        (Queued, Abort, Aborting),
        (Running, Hold, Holding),
        (Running, Stop, Stopping),
        (Running, Abort, Aborting),
        (Holding, Abort, Aborting),
        (Held, Restart, Restarting),
        (Held, Stop, Stopping),
        (Held, Abort, Aborting),
        (Restarting, Hold, Holding),
        (Restarting, Abort, Aborting),
        (Stopping, Abort, Aborting),
        (Complete, Reset, Idle),
        (Stopped, Reset, Idle),
        (Aborted, Reset, Idle),
        (Faulted, Reset, Idle),
        (Withdrawn, Reset, Idle),
        (Refused, Reset, Idle),
    ],
    refusals: &[
        (
            Aborted,
            Start,
            Code::OperationAborted,
            "an aborted operation starts again only after a reset",
        ),
        (
            Queued,
            Hold,
            Code::CommandRefused,
            "it waits for its lines and commands nothing yet: stop or abort it instead",
        ),
        (
            Running,
            Restart,
            Code::CommandRefused,
            "restart is for a held operation: hold it first",
        ),
        (
            Holding,
            Restart,
            Code::CommandRefused,
            "its hold command is still being carried out: restart it once held",
        ),
        (
            Holding,
            Stop,
            Code::CommandRefused,
            "its hold command is still being carried out: stop it once held, or abort it now",
        ),
        (
            Restarting,
            Stop,
            Code::CommandRefused,
            "it is putting back what the hold changed: stop it once running, or abort it now",
        ),
        (Held, Hold, Code::CommandRefused, "it is held already"),
        (
            Holding,
            Hold,
            Code::CommandRefused,
            "it is being held already",
        ),
        (
            Stopping,
            Stop,
            Code::CommandRefused,
            "it is stopping already",
        ),
        (
            Aborting,
            Abort,
            Code::CommandRefused,
            "it is aborting already",
        ),
        (
            Idle,
            Reset,
            Code::CommandRefused,
            "it is idle already: nothing to reset",
        ),
    ],
    otherwise: operation_otherwise,
};

fn operation_otherwise(state: State) -> &'static str {
    match state {
        Idle => "it is not running: start it first",
        Queued | Running | Holding | Held | Restarting => {
            "it is running (C1: one instance at a time)"
        }
        Stopping => "it is stopping: abort is the only command it takes",
        Aborting => "its lockouts are going out: reset it once aborted",
        Completing => "its steps are done and its lines are being released",
        Faulting => "it failed and its lockouts are going out",
        Withdrawing => "its request is being withdrawn from the queue",
        Complete | Stopped | Faulted | Withdrawn | Refused => {
            "it has ended: only a start or a reset applies"
        }
        Aborted => "it was aborted: only a reset applies",
    }
}

/// The operator's commands on a routine. A routine's command goes to its
/// pending operation too, whose own table may refuse it (then the routine's
/// command is refused with the operation's reason). A held routine fires no
/// trigger, and neither does a stopped, aborted or faulted (halted) one until
/// its reset.
pub const ROUTINE: Table = Table {
    noun: "routine",
    allowed: &[
        (Idle, Start, Running),
        (Running, Start, Running),
        (Idle, Hold, Held),
        (Running, Hold, Holding),
        (Restarting, Hold, Holding),
        (Held, Restart, Restarting),
        (Idle, Stop, Stopped),
        (Running, Stop, Stopping),
        (Held, Stop, Stopping),
        (Idle, Abort, Aborted),
        (Running, Abort, Aborting),
        (Holding, Abort, Aborting),
        (Held, Abort, Aborting),
        (Restarting, Abort, Aborting),
        (Stopping, Abort, Aborting),
        (Idle, Reset, Idle),
        (Running, Reset, Idle),
        (Stopped, Reset, Idle),
        (Aborted, Reset, Idle),
        (Faulted, Reset, Idle),
        (Complete, Reset, Idle),
    ],
    refusals: &[
        (Held, Start, Code::RoutineHeld, "a held routine fires no trigger: restart it first"),
        (Holding, Start, Code::RoutineHeld, "a held routine fires no trigger: restart it first"),
        (Running, Restart, Code::CommandRefused, "restart is for a held routine: hold it first"),
        (Held, Hold, Code::CommandRefused, "it is held already"),
        (Holding, Hold, Code::CommandRefused, "it is being held already"),
        (Holding, Restart, Code::CommandRefused, "its operation's hold command is still being carried out: restart it once held"),
        (Holding, Stop, Code::CommandRefused, "its operation's hold command is still being carried out: stop it once held, or abort it now"),
        (Stopping, Stop, Code::CommandRefused, "it is stopping already"),
        (Aborting, Abort, Code::CommandRefused, "it is aborting already"),
        (Held, Reset, Code::CommandRefused, "restart it first, or stop or abort it"),
    ],
    otherwise: routine_otherwise,
};

fn routine_otherwise(state: State) -> &'static str {
    match state {
        Holding | Held | Restarting | Stopping | Aborting => {
            "its operation is being held, restarted, stopped or aborted: wait until it settles"
        }
        Stopped | Aborted | Faulted | Complete => "it has ended: reset it first",
        _ => "the command does not apply to a routine in this state",
    }
}

/// What the plant reports to an operation run (or, for [`Event::Interrupted`],
/// its supervisor): each moves it as [`OPERATION_EVENTS`] says.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "camelCase")]
pub enum Event {
    /// The interlock granted its lines.
    Granted,
    /// The interlock refused its request.
    RequestRefused,
    /// Its request left the queue.
    Withdrawn,
    /// A step completed and another follows.
    StepDone,
    /// The last step completed (or, while stopping, the return to idle).
    LastStepDone,
    /// A step, the hold command or the restart command failed or timed out.
    Failed,
    /// The hold command completed (or there was none).
    HoldDone,
    /// The restart command completed (or there was nothing to put back).
    RestartDone,
    /// The interlock released its lines.
    Released,
    /// The interlock refused the release.
    ReleaseFailed,
    /// The interlock faulted it and its lockouts went out.
    FaultApplied,
    /// Whoever supervised it is gone (its interlock left the flows).
    Interrupted,
}

/// Every move an event makes an operation run take.
pub const OPERATION_EVENTS: &[(State, Event, State)] = &[
    (Queued, Event::Granted, Running),
    (Queued, Event::RequestRefused, Refused),
    (Queued, Event::Interrupted, Withdrawing),
    (Withdrawing, Event::Withdrawn, Withdrawn),
    (Withdrawing, Event::Released, Withdrawn),
    (Withdrawing, Event::ReleaseFailed, Aborting),
    (Stopping, Event::Withdrawn, Stopped),
    (Stopping, Event::Released, Stopped),
    (Stopping, Event::ReleaseFailed, Faulting),
    (Aborting, Event::Withdrawn, Aborted),
    (Aborting, Event::Released, Aborted),
    (Aborting, Event::FaultApplied, Aborted),
    (Aborting, Event::ReleaseFailed, Aborting),
    (Running, Event::LastStepDone, Completing),
    (Running, Event::Failed, Faulting),
    (Running, Event::Interrupted, Aborting),
    (Holding, Event::HoldDone, Held),
    (Holding, Event::Failed, Faulting),
    (Holding, Event::Interrupted, Aborting),
    (Held, Event::Interrupted, Aborting),
    (Restarting, Event::RestartDone, Running),
    (Restarting, Event::Failed, Faulting),
    (Restarting, Event::Interrupted, Aborting),
    (Stopping, Event::Failed, Faulting),
    (Stopping, Event::Interrupted, Aborting),
    (Completing, Event::Released, Complete),
    (Completing, Event::ReleaseFailed, Faulting),
    (Faulting, Event::FaultApplied, Faulted),
];

/// What moves a routine besides a command: its operation's end, and a restart settling.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "camelCase")]
pub enum RoutineEvent {
    /// A trigger fired: it dispatched an operation.
    Dispatched,
    /// Its operation completed and it entered the transition's state (its
    /// initial state: idle; any other: running).
    Completed,
    /// Its operation was refused or withdrawn before it ran.
    NotRun,
    /// Its operation was held.
    OperationHeld,
    /// Its operation runs again after a restart (or nothing was pending).
    OperationRunning,
    /// Its operation stopped.
    OperationStopped,
    /// Its operation was aborted.
    OperationAborted,
    /// Its operation faulted: it enters its error state (running) or halts (faulted).
    OperationFaulted,
    /// Nothing was pending: a hold, restart, stop or abort took effect at once.
    Settled,
}

/// Every move an event makes a routine take.
pub const ROUTINE_EVENTS: &[(State, RoutineEvent, State)] = &[
    (Idle, RoutineEvent::Dispatched, Running),
    (Running, RoutineEvent::Dispatched, Running),
    (Running, RoutineEvent::Completed, Idle),
    (Running, RoutineEvent::Completed, Running),
    (Running, RoutineEvent::NotRun, Idle),
    (Running, RoutineEvent::NotRun, Running),
    (Running, RoutineEvent::OperationFaulted, Running),
    (Running, RoutineEvent::OperationFaulted, Faulted),
    (Running, RoutineEvent::OperationStopped, Stopped),
    (Running, RoutineEvent::OperationAborted, Aborted),
    (Running, RoutineEvent::OperationHeld, Held),
    (Holding, RoutineEvent::OperationHeld, Held),
    (Holding, RoutineEvent::OperationFaulted, Running),
    (Holding, RoutineEvent::OperationFaulted, Faulted),
    (Holding, RoutineEvent::OperationAborted, Aborted),
    (Holding, RoutineEvent::OperationStopped, Stopped),
    (Held, RoutineEvent::OperationAborted, Aborted),
    (Held, RoutineEvent::OperationStopped, Stopped),
    (Restarting, RoutineEvent::OperationRunning, Running),
    (Restarting, RoutineEvent::OperationRunning, Idle),
    (Restarting, RoutineEvent::OperationFaulted, Running),
    (Restarting, RoutineEvent::OperationFaulted, Faulted),
    (Restarting, RoutineEvent::OperationAborted, Aborted),
    (Restarting, RoutineEvent::OperationStopped, Stopped),
    (Restarting, RoutineEvent::OperationHeld, Held),
    (Stopping, RoutineEvent::Completed, Stopped),
    (Stopping, RoutineEvent::NotRun, Stopped),
    (Stopping, RoutineEvent::OperationStopped, Stopped),
    (Stopping, RoutineEvent::OperationFaulted, Stopped),
    (Stopping, RoutineEvent::OperationFaulted, Faulted),
    (Stopping, RoutineEvent::OperationAborted, Aborted),
    (Aborting, RoutineEvent::OperationAborted, Aborted),
    (Aborting, RoutineEvent::OperationFaulted, Aborted),
    (Aborting, RoutineEvent::Completed, Aborted),
    (Aborting, RoutineEvent::NotRun, Aborted),
    (Aborting, RoutineEvent::OperationStopped, Aborted),
    (Holding, RoutineEvent::Settled, Held),
    (Restarting, RoutineEvent::Settled, Running),
    (Restarting, RoutineEvent::Settled, Idle),
    (Stopping, RoutineEvent::Settled, Stopped),
    (Aborting, RoutineEvent::Settled, Aborted),
];

/// Whether an operation run may move from `from` to `to`: by a command the
/// table allows, or by an event [`OPERATION_EVENTS`] lists.
pub fn operation_move_declared(from: State, to: State) -> bool {
    from == to
        || OPERATION
            .allowed
            .iter()
            .any(|&(f, _, t)| f == from && t == to)
        || OPERATION_EVENTS
            .iter()
            .any(|&(f, _, t)| f == from && t == to)
}

/// Whether a routine may move from `from` to `to`: by a command the table
/// allows, or by an event [`ROUTINE_EVENTS`] lists.
pub fn routine_move_declared(from: State, to: State) -> bool {
    from == to
        || ROUTINE
            .allowed
            .iter()
            .any(|&(f, _, t)| f == from && t == to)
        || ROUTINE_EVENTS.iter().any(|&(f, _, t)| f == from && t == to)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;

    #[test]
    fn each_pair_is_allowed_or_refused_once() {
        for table in [&OPERATION, &ROUTINE] {
            let mut seen = HashSet::new();
            for &(from, command, _) in table.allowed {
                assert!(seen.insert((from, command)), "{from} {command} twice");
            }
            for &(from, command, _, why) in table.refusals {
                assert!(
                    seen.insert((from, command)),
                    "{from} {command} both allowed and refused"
                );
                assert!(!why.is_empty() && !why.ends_with('.'));
            }
            for state in State::ALL {
                let why = (table.otherwise)(state);
                assert!(!why.is_empty() && !why.ends_with('.'), "{state}");
            }
        }
    }

    #[test]
    fn an_aborted_operation_leaves_only_by_reset() {
        for command in Command::ALL {
            let verdict = OPERATION.verdict(Aborted, command);
            match command {
                Reset => assert_eq!(verdict, Verdict::To(Idle)),
                _ => assert!(matches!(verdict, Verdict::Refused(..)), "{command}"),
            }
        }
        assert_eq!(
            OPERATION.verdict(Aborted, Start),
            Verdict::Refused(
                Code::OperationAborted,
                "an aborted operation starts again only after a reset"
            )
        );
        for &(from, _, to) in OPERATION_EVENTS {
            assert!(from != Aborted, "an event moves aborted to {to}");
        }
        for &(from, event, to) in ROUTINE_EVENTS {
            assert!(
                from != Aborted,
                "{event:?} moves an aborted routine to {to}"
            );
        }
    }

    #[test]
    fn restart_of_a_running_operation_is_refused_in_words() {
        let err = OPERATION.check("10", Running, Restart).unwrap_err();
        assert_eq!(err.code, Code::CommandRefused);
        assert_eq!(
            err.to_string(),
            "restart refused: operation '10' is running; restart is for a held operation: hold it first"
        );
    }

    #[test]
    fn an_hmi_offers_what_the_state_allows() {
        let offered = |state| -> Vec<&str> {
            OPERATION
                .commands(state)
                .into_iter()
                .map(Command::name)
                .collect()
        };
        assert_eq!(offered(Running), ["hold", "stop", "abort"]);
        assert_eq!(offered(Held), ["restart", "stop", "abort"]);
        assert_eq!(offered(Holding), ["abort"]);
        assert_eq!(offered(Queued), ["stop", "abort"]);
        assert_eq!(offered(Aborted), ["reset"]);
        assert_eq!(offered(Completing), Vec::<&str>::new());
        assert_eq!(
            ROUTINE
                .commands(Idle)
                .into_iter()
                .map(Command::name)
                .collect::<Vec<_>>(),
            ["hold", "stop", "abort", "reset"]
        );
    }

    #[test]
    fn every_declared_move_ends_where_a_state_is() {
        // A final state is left only by a start or a reset.
        for &(from, command, to) in OPERATION.allowed {
            if from.is_final() {
                assert!(matches!(command, Start | Reset), "{from} {command} -> {to}");
            }
        }
        for &(from, event, _) in OPERATION_EVENTS {
            assert!(!from.is_final(), "{event:?} leaves the final state {from}");
        }
        assert_eq!(Command::from_name("hold"), Some(Hold));
        assert_eq!(Command::from_name("HOLD"), None);
    }
}
