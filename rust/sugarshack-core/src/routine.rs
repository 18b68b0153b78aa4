//! A routine (the paper's §III-E, Alg. 3): a state machine R = (S, s0, O, T)
//! that dispatches at most one operation at a time and moves on its return.
//! A trigger is a msg topic, or a sensor condition. A condition is due when
//! its state is entered, then again once its sensors sampled, at most once
//! per `everyMs` (the caller evaluates it and reports the result): a value
//! that did not change cannot make it hold, so nothing polls. The caller
//! keeps one timer at [`RoutineMachine::next_deadline`]. Conditions are
//! checked only while its interlock's gate is open (the caller says when it
//! opens and closes, [`RoutineMachine::gate`]): a deploy's drain or a start
//! fires nothing, and what was due is checked once it opens.

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::code::Code;
use crate::plant::{Edge, Plant, RoutineGraph, StateId, Trigger};
use crate::procedure::{self, Command, CommandRefused, State};
use crate::text::quote;
use crate::time::Millis;

/// The msg topic that sends a routine back to its initial state (an
/// operator's reset). Reserved: plant validation refuses a transition on it.
pub const RESET_TOPIC: &str = "reset";

/// Why a routine refused a call.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum RoutineError {
    /// The plant document has no such routine.
    UnknownRoutine {
        /// The name as given.
        name: String,
    },
    /// One pending operation per routine: a trigger while it runs is refused.
    Busy {
        /// The routine's id.
        routine: String,
        /// The operation's id.
        operation: String,
    },
    /// No transition from the current state fires on this trigger.
    NoTransition {
        /// The routine's id.
        routine: String,
        /// The state's name.
        state: String,
        /// The trigger given.
        trigger: String,
    },
    /// Its last operation faulted and it has no error state: it waits for a reset.
    Halted {
        /// The routine's id.
        routine: String,
        /// The state's name.
        state: String,
    },
    /// An operation's result while none is pending.
    NotPending {
        /// The routine's id.
        routine: String,
    },
    /// A saved routine state that cannot be restored.
    InvalidSnapshot {
        /// Why, in words a person acts on.
        reason: String,
    },
    /// A command (or a trigger) its state, or its operation's, does not allow.
    Refused(CommandRefused),
}

impl From<CommandRefused> for RoutineError {
    fn from(refusal: CommandRefused) -> Self {
        RoutineError::Refused(refusal)
    }
}

impl RoutineError {
    /// The code a Catch node sees.
    pub fn code(&self) -> Code {
        match self {
            Self::UnknownRoutine { .. } => Code::UnknownRoutine,
            Self::Busy { .. } => Code::RoutineBusy,
            Self::NoTransition { .. } => Code::NoTransition,
            Self::Halted { .. } => Code::RoutineHalted,
            Self::NotPending { .. } => Code::NotPending,
            Self::InvalidSnapshot { .. } => Code::InvalidSnapshot,
            Self::Refused(refusal) => refusal.code,
        }
    }
}

impl fmt::Display for RoutineError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::UnknownRoutine { name } => {
                write!(f, "unknown routine '{}': it is not in the plant document", quote(name))
            }
            Self::Busy { routine, operation } => write!(
                f,
                "routine '{}' is waiting for operation '{}'; one operation at a time (the trigger was refused)",
                quote(routine),
                quote(operation)
            ),
            Self::NoTransition {
                routine,
                state,
                trigger,
            } => write!(
                f,
                "routine '{}' has no transition on '{}' from state '{}'",
                quote(routine),
                quote(trigger),
                quote(state)
            ),
            Self::Halted { routine, state } => write!(
                f,
                "routine '{}' halted in state '{}' after a fault; send it 'reset' once the fault is cleared",
                quote(routine),
                quote(state)
            ),
            Self::NotPending { routine } => {
                write!(f, "routine '{}' has no operation pending", quote(routine))
            }
            Self::InvalidSnapshot { reason } => write!(f, "invalid routine snapshot: {reason}"),
            Self::Refused(refusal) => refusal.fmt(f),
        }
    }
}

impl std::error::Error for RoutineError {}

/// A transition that fired: run `operation`, then report its return.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Dispatch {
    /// The transition's index.
    pub transition: usize,
    /// The operation's id.
    pub operation: String,
    /// The state it leaves.
    pub from: String,
    /// The state it enters.
    pub to: String,
}

/// A change of state on an operation's return (or a reset).
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Moved {
    /// The state it leaves.
    pub from: String,
    /// The state it enters.
    pub to: String,
    /// The operation's id.
    pub operation: Option<String>,
    /// Whether it halted (a fault with no error state).
    pub halted: bool,
}

/// What a dispatched operation's run that did not complete means to its routine.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub enum Failure {
    /// Aborted (by an operator, or while queued): aborted until a reset.
    Aborted,
    /// Refused before its grant (already running, queue full...): nothing
    /// ran and nothing locked out, so the routine stays and may dispatch again.
    Refused,
    /// Failed once granted: the error state, or a halt.
    Faulted,
}

/// A failed run's meaning, and the move it made (none for a refusal).
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Failed {
    /// What the failure was.
    pub outcome: Failure,
    /// The move it made.
    pub moved: Option<Moved>,
}

/// What survives a restart: the state, and the operation that was pending (if any).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct RoutineSnapshot {
    /// The routine's id.
    pub routine: String,
    /// The state's name.
    pub state: String,
    /// The operation pending when it was saved.
    #[serde(default)]
    pub pending: Option<String>,
    /// Whether it was halted.
    #[serde(default)]
    pub halted: bool,
    /// Whether an operator held it.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub held: bool,
    /// Whether an operator stopped it (it waits for a reset).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub stopped: bool,
    /// Whether an operator aborted it (it waits for a reset).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub aborted: bool,
}

/// One routine's state machine.
#[derive(Clone, Debug)]
pub struct RoutineMachine {
    graph: RoutineGraph,
    state: StateId,
    pending: Option<usize>,
    halted: bool,
    /// An operator's hold: it fires no trigger until a restart.
    held: bool,
    /// An operator's stop: it fires no trigger until a reset.
    stopped: bool,
    /// An operator's abort: it fires no trigger until a reset.
    aborted: bool,
    /// Per transition: when its condition was last handed out for evaluation.
    checked: Vec<Option<Millis>>,
    /// Per transition: whether its sensors sampled since then.
    changed: Vec<bool>,
    /// Its interlock's gate is closed (starting, or a deploy's drain): no condition is due.
    gate_closed: bool,
}

impl RoutineMachine {
    /// Routine `id` of a validated plant, in its initial state.
    pub fn new(plant: &Plant, id: &str) -> Result<Self, RoutineError> {
        let graph = plant
            .routine(id)
            .cloned()
            .ok_or_else(|| RoutineError::UnknownRoutine { name: id.into() })?;
        Ok(RoutineMachine {
            checked: vec![None; graph.edges().len()],
            changed: vec![false; graph.edges().len()],
            state: graph.initial(),
            graph,
            pending: None,
            halted: false,
            held: false,
            stopped: false,
            aborted: false,
            gate_closed: false,
        })
    }

    /// Back to a saved state (on a machine just made). An operation that was
    /// pending at the save came back held if it is in `held` (its run survived
    /// the restart held, and goes on when restarted); any other did not return
    /// (the restart interrupted it, and the interlock faulted it), so it
    /// counts as faulted: the move that caused is returned. A refused snapshot
    /// changes nothing.
    pub fn restore(
        &mut self,
        snapshot: &RoutineSnapshot,
        held: &[&str],
    ) -> Result<Option<Moved>, RoutineError> {
        let id = self.graph.id();
        if snapshot.routine != id {
            return Err(RoutineError::InvalidSnapshot {
                reason: format!(
                    "it is routine '{}''s, not '{}''s",
                    quote(&snapshot.routine),
                    quote(id)
                ),
            });
        }
        let state =
            self.graph
                .state(&snapshot.state)
                .ok_or_else(|| RoutineError::InvalidSnapshot {
                    reason: format!(
                        "routine '{}' has no state '{}' any more",
                        quote(id),
                        quote(&snapshot.state)
                    ),
                })?;
        let pending = match &snapshot.pending {
            None => None,
            Some(operation) => Some(
                self.graph
                    .edges()
                    .iter()
                    .position(|t| &t.operation == operation && t.from == state)
                    .ok_or_else(|| RoutineError::InvalidSnapshot {
                        reason: format!(
                            "routine '{}' has no transition from '{}' running '{}' any more",
                            quote(id),
                            quote(&snapshot.state),
                            quote(operation)
                        ),
                    })?,
            ),
        };
        self.enter(state);
        self.halted = snapshot.halted;
        self.held = snapshot.held;
        self.stopped = snapshot.stopped;
        self.aborted = snapshot.aborted;
        self.pending = pending;
        match snapshot.pending.as_deref() {
            None => Ok(None),
            Some(operation) if held.contains(&operation) => Ok(None),
            Some(_) if self.aborted => self.operation_aborted().map(Some),
            Some(_) => self.faulted().map(Some),
        }
    }

    /// What survives a restart.
    pub fn snapshot(&self) -> RoutineSnapshot {
        RoutineSnapshot {
            routine: self.graph.id().into(),
            state: self.state().into(),
            pending: self.pending().map(Into::into),
            halted: self.halted,
            held: self.held,
            stopped: self.stopped,
            aborted: self.aborted,
        }
    }

    /// The routine's id.
    pub fn id(&self) -> &str {
        self.graph.id()
    }

    /// The current state.
    pub fn state(&self) -> &str {
        self.graph.name(self.state)
    }

    /// The operation dispatched and not yet returned.
    pub fn pending(&self) -> Option<&str> {
        self.pending
            .map(|t| self.graph.edges()[t].operation.as_str())
    }

    /// Whether it halted after a fault and waits for a reset.
    pub fn halted(&self) -> bool {
        self.halted
    }

    /// The operations this routine owns (its O), in transition order without repeats.
    pub fn operations(&self) -> Vec<&str> {
        let mut ops: Vec<&str> = Vec::new();
        for t in self.graph.edges() {
            if !ops.contains(&t.operation.as_str()) {
                ops.push(&t.operation);
            }
        }
        ops
    }

    /// Its ISA-88 state, `operation` being its pending operation's (if any):
    /// an operation held, restarted, stopped or aborted on its own shows in
    /// its routine.
    pub fn run_state(&self, operation: Option<State>) -> State {
        let pending = self.pending.is_some();
        let operation = operation.filter(|_| pending);
        if self.aborted {
            return if pending {
                State::Aborting
            } else {
                State::Aborted
            };
        }
        if self.halted {
            return State::Faulted;
        }
        if self.stopped {
            return if pending {
                State::Stopping
            } else {
                State::Stopped
            };
        }
        match operation {
            Some(
                state @ (State::Holding
                | State::Held
                | State::Restarting
                | State::Stopping
                | State::Aborting),
            ) => state,
            _ if self.held => State::Held,
            _ if pending || self.state != self.graph.initial() => State::Running,
            _ => State::Idle,
        }
    }

    /// The operator's commands allowed now (`operation`: its pending operation's state).
    pub fn commands(&self, operation: Option<State>) -> Vec<Command> {
        let state = self.run_state(operation);
        procedure::ROUTINE
            .commands(state)
            .into_iter()
            .filter(|&c| self.clone().command(c, operation).is_ok())
            .collect()
    }

    /// The command its pending operation gets for `command`, if any; refused
    /// when the operation's state does not take it.
    fn forwarded(
        &self,
        command: Command,
        operation: Option<State>,
    ) -> Result<Option<Command>, CommandRefused> {
        let (Some(id), Some(state)) = (self.pending(), operation) else {
            return Ok(None);
        };
        match command {
            Command::Restart if state != State::Held => Ok(None),
            Command::Hold | Command::Restart | Command::Stop | Command::Abort => {
                procedure::OPERATION.check(id, state, command)?;
                Ok(Some(command))
            }
            Command::Start | Command::Reset => Ok(None),
        }
    }

    /// An operator's command, `operation` being its pending operation's state:
    /// the command for that operation, if it gets one. Refused (nothing
    /// changed) when its table or its operation's does not allow it.
    pub fn command(
        &mut self,
        command: Command,
        operation: Option<State>,
    ) -> Result<(Option<Command>, Option<Moved>), RoutineError> {
        let state = self.run_state(operation);
        procedure::ROUTINE.check(self.id(), state, command)?;
        let forward = self.forwarded(command, operation)?;
        match command {
            // With an operation pending, the hold is the operation's (its state shows here).
            Command::Hold => self.held = forward.is_none(),
            Command::Restart => self.held = false,
            Command::Stop => self.stopped = true,
            Command::Abort => self.aborted = true,
            Command::Reset => return self.reset().map(|moved| (None, Some(moved))),
            Command::Start => {}
        }
        Ok((forward, None))
    }

    fn ready(&self) -> Result<(), RoutineError> {
        if let Some(operation) = self.pending() {
            return Err(RoutineError::Busy {
                routine: self.id().into(),
                operation: operation.into(),
            });
        }
        if self.halted {
            return Err(RoutineError::Halted {
                routine: self.id().into(),
                state: self.state().into(),
            });
        }
        procedure::ROUTINE.check(self.id(), self.run_state(None), Command::Start)?;
        Ok(())
    }

    fn dispatch(&mut self, transition: usize) -> Dispatch {
        self.pending = Some(transition);
        let t = &self.graph.edges()[transition];
        Dispatch {
            transition,
            operation: t.operation.clone(),
            from: self.graph.name(t.from).into(),
            to: self.graph.name(t.to).into(),
        }
    }

    /// A msg with `topic` arrived: the first transition from the current state it triggers fires.
    pub fn on_msg(&mut self, topic: &str) -> Result<Dispatch, RoutineError> {
        self.ready()?;
        let state = self.state;
        let transition = self
            .graph
            .edges()
            .iter()
            .position(|t| {
                t.from == state && matches!(&t.trigger, Trigger::Msg { msg } if msg == topic)
            })
            .ok_or_else(|| RoutineError::NoTransition {
                routine: self.id().into(),
                state: self.state().into(),
                trigger: topic.into(),
            })?;
        Ok(self.dispatch(transition))
    }

    /// When the condition of transition `i` is due: at once (`ZERO`) if not
    /// checked in this state, `everyMs` after its check once its sensors
    /// sampled, else never. None for a transition of another state, or a msg's.
    fn due_at(&self, i: usize, t: &Edge) -> Option<Millis> {
        let Trigger::When { every_ms, .. } = t.trigger else {
            return None;
        };
        if t.from != self.state {
            return None;
        }
        match self.checked[i] {
            None => Some(Millis::ZERO),
            Some(at) => self.changed[i].then(|| at.saturating_add(every_ms)),
        }
    }

    /// Its interlock's gate opened (`true`) or closed: while closed no
    /// condition is due and none fires; what fell due meanwhile is due once it opens.
    pub fn gate(&mut self, open: bool) {
        self.gate_closed = !open;
    }

    /// The condition transitions of the current state due for evaluation at
    /// `now` (never checked in this state, or their sensors sampled since a
    /// check `everyMs` ago). They count as checked now. None while the gate is closed.
    pub fn due(&mut self, now: Millis) -> Vec<usize> {
        if self.gate_closed || self.ready().is_err() {
            return Vec::new();
        }
        let due: Vec<usize> = (0..self.graph.edges().len())
            .filter(|&i| {
                self.due_at(i, &self.graph.edges()[i])
                    .is_some_and(|at| at <= now)
            })
            .collect();
        for &i in &due {
            self.checked[i] = Some(now);
            self.changed[i] = false;
        }
        due
    }

    /// A sensor of the condition of `transition` sampled (or its check could
    /// not be acted on): it is due again `everyMs` after its last check.
    pub fn input_changed(&mut self, transition: usize) {
        if let Some(changed) = self.changed.get_mut(transition) {
            *changed = true;
        }
    }

    /// When [`RoutineMachine::due`] next has something to hand out (`ZERO`:
    /// now), if ever: never while an operation is pending, the gate is closed
    /// or it is halted, held, stopped or aborted, nor while no sensor of its
    /// state's conditions sampled since their check.
    pub fn next_deadline(&self) -> Option<Millis> {
        if self.gate_closed || self.ready().is_err() {
            return None;
        }
        let edges = self.graph.edges();
        (0..edges.len())
            .filter_map(|i| self.due_at(i, &edges[i]))
            .min()
    }

    /// The condition of `transition` held: it fires if the routine is still in its
    /// `from` state with nothing pending (an earlier one may have fired
    /// meanwhile) and the gate open. Held back by a pending operation or the
    /// closed gate, it is due again `everyMs` after its check.
    pub fn condition_met(&mut self, transition: usize) -> Option<Dispatch> {
        let t = self.graph.edges().get(transition)?;
        if t.from != self.state {
            return None;
        }
        if self.gate_closed || self.ready().is_err() {
            self.input_changed(transition);
            return None;
        }
        Some(self.dispatch(transition))
    }

    /// Every condition transition: (index, condition, sensors).
    pub fn conditions(&self) -> Vec<(usize, &str, &[String])> {
        (0..self.graph.edges().len())
            .filter_map(|t| self.condition(t).map(|(when, sensors)| (t, when, sensors)))
            .collect()
    }

    /// The condition and sensors of a condition transition.
    pub fn condition(&self, transition: usize) -> Option<(&str, &[String])> {
        match &self.graph.edges().get(transition)?.trigger {
            Trigger::When { when, sensors, .. } => Some((when, sensors)),
            Trigger::Msg { .. } => None,
        }
    }

    fn enter(&mut self, state: StateId) {
        self.state = state;
        self.checked.iter_mut().for_each(|c| *c = None);
        self.changed.iter_mut().for_each(|c| *c = false);
    }

    /// A move from `from` to where the routine is now.
    fn moved(&self, from: StateId, operation: Option<String>, halted: bool) -> Moved {
        Moved {
            from: self.graph.name(from).into(),
            to: self.state().into(),
            operation,
            halted,
        }
    }

    /// The pending operation returned: move to the transition's target state.
    pub fn completed(&mut self) -> Result<Moved, RoutineError> {
        let t = self.take_pending()?;
        let (from, to, operation) = (t.from, t.to, t.operation.clone());
        self.enter(to);
        Ok(self.moved(from, Some(operation), false))
    }

    /// The pending operation was refused before it ran (the interlock refused its
    /// request, or it was already running elsewhere): nothing moved, the routine
    /// stays where it was and may dispatch again (a condition that fired it
    /// is due again `everyMs` after its check).
    pub fn refused(&mut self) -> Result<(), RoutineError> {
        let transition = self.pending;
        self.take_pending()?;
        if let Some(t) = transition {
            self.input_changed(t);
        }
        Ok(())
    }

    /// The pending operation faulted: go to the error state, or halt where it is.
    pub fn faulted(&mut self) -> Result<Moved, RoutineError> {
        let t = self.take_pending()?;
        let (from, operation) = (t.from, t.operation.clone());
        let halted = match self.graph.error_state() {
            Some(error_state) => {
                self.enter(error_state);
                false
            }
            None => {
                self.halted = true;
                true
            }
        };
        Ok(self.moved(from, Some(operation), halted))
    }

    /// The pending operation's run ended without completing, in `ended`
    /// (its run's final state; none when no run started): aborted, faulted,
    /// or else refused before it ran (refused, withdrawn), and moved as each says.
    pub fn run_failed(&mut self, ended: Option<State>) -> Result<Failed, RoutineError> {
        let outcome = match ended {
            Some(State::Aborted) => Failure::Aborted,
            Some(State::Faulted) => Failure::Faulted,
            _ => Failure::Refused,
        };
        let moved = match outcome {
            Failure::Aborted => Some(self.operation_aborted()?),
            Failure::Refused => self.refused().map(|()| None)?,
            Failure::Faulted => Some(self.faulted()?),
        };
        Ok(Failed { outcome, moved })
    }

    /// The pending operation was stopped: the routine stays where it was, stopped until a reset.
    pub fn operation_stopped(&mut self) -> Result<Moved, RoutineError> {
        let t = self.take_pending()?;
        let (from, operation) = (t.from, t.operation.clone());
        self.stopped = true;
        Ok(self.moved(from, Some(operation), false))
    }

    /// The pending operation was aborted: the routine stays where it was, aborted until a reset.
    pub fn operation_aborted(&mut self) -> Result<Moved, RoutineError> {
        let t = self.take_pending()?;
        let (from, operation) = (t.from, t.operation.clone());
        self.aborted = true;
        Ok(self.moved(from, Some(operation), false))
    }

    fn take_pending(&mut self) -> Result<&Edge, RoutineError> {
        let t = self
            .pending
            .take()
            .ok_or_else(|| RoutineError::NotPending {
                routine: self.id().into(),
            })?;
        Ok(&self.graph.edges()[t])
    }

    /// Back to the initial state (an operator's reset, which also ends a
    /// hold, a stop or an abort); refused while an operation runs.
    pub fn reset(&mut self) -> Result<Moved, RoutineError> {
        if let Some(operation) = self.pending() {
            return Err(RoutineError::Busy {
                routine: self.id().into(),
                operation: operation.into(),
            });
        }
        let from = self.state;
        self.halted = false;
        self.held = false;
        self.stopped = false;
        self.aborted = false;
        self.enter(self.graph.initial());
        Ok(self.moved(from, None, false))
    }
}

#[cfg(test)]
mod tests;
