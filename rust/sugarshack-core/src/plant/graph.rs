//! A routine with its states resolved once, when the plant is checked: a
//! running routine moves between state handles and never looks a name up.

use super::{Routine, Trigger};

/// A state of one routine: its position in the routine's `states`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct StateId(usize);

/// A transition of a [`RoutineGraph`], its states resolved.
#[derive(Clone, Debug, PartialEq)]
pub struct Edge {
    /// The state it leaves.
    pub from: StateId,
    /// The state it enters.
    pub to: StateId,
    /// The operation it runs.
    pub operation: String,
    /// What fires it.
    pub trigger: Trigger,
}

/// A routine of a checked plant: states by handle, transitions in document order.
#[derive(Clone, Debug, PartialEq)]
pub struct RoutineGraph {
    id: String,
    states: Vec<String>,
    initial: StateId,
    error_state: Option<StateId>,
    edges: Vec<Edge>,
}

impl RoutineGraph {
    /// The routine resolved, or `None` when it names a state it does not list
    /// (plant validation reports that with its path).
    pub(super) fn resolve(routine: &Routine) -> Option<RoutineGraph> {
        let state = |name: &str| position(&routine.states, name);
        let edges = routine
            .transitions
            .iter()
            .map(|t| {
                Some(Edge {
                    from: state(&t.from)?,
                    to: state(&t.to)?,
                    operation: t.operation.clone(),
                    trigger: t.trigger.clone(),
                })
            })
            .collect::<Option<Vec<_>>>()?;
        let error_state = match &routine.error_state {
            Some(name) => Some(state(name)?),
            None => None,
        };
        Some(RoutineGraph {
            id: routine.id.clone(),
            states: routine.states.clone(),
            initial: state(&routine.initial)?,
            error_state,
            edges,
        })
    }

    /// The routine's id.
    pub fn id(&self) -> &str {
        &self.id
    }

    /// The name of `state`.
    pub fn name(&self, state: StateId) -> &str {
        &self.states[state.0]
    }

    /// The state called `name`.
    pub fn state(&self, name: &str) -> Option<StateId> {
        position(&self.states, name)
    }

    /// The state it starts in, and returns to on a reset.
    pub fn initial(&self) -> StateId {
        self.initial
    }

    /// Where it goes when its operation faults; with none it halts.
    pub fn error_state(&self) -> Option<StateId> {
        self.error_state
    }

    /// Its transitions, in document order (the first that fires wins).
    pub fn edges(&self) -> &[Edge] {
        &self.edges
    }
}

fn position(states: &[String], name: &str) -> Option<StateId> {
    states.iter().position(|s| s == name).map(StateId)
}
