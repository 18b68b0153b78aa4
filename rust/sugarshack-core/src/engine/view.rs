//! The engine as a person (or a dashboard) reads it: every line (free, held
//! by an operation since when, or faulted with its cause, since when, and
//! why it may not be cleared yet), the queue with priorities and waited
//! times (requests a drain holds back included), whether the state was lost
//! at start, the alarms, the latest notable events and the operations
//! aborted and not reset.

use serde::Serialize;

use super::{Blockers, Engine};
use crate::alarm::{Alarm, AlarmChange};
use crate::clearance::ClearBlocker;
use crate::interlock::{EventRecord, RequestSnapshot, ResourceState};
use crate::procedure::Command;
use crate::time::Millis;

/// One waiting request.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Waiting {
    /// The operation.
    pub operation: String,
    /// Its priority.
    pub priority: i32,
    /// The lines it asks for.
    pub resources: Vec<String>,
    /// Since when it waits.
    pub since_ms: Millis,
    /// How long it has waited.
    pub waited_ms: Millis,
}

/// Who holds a line.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Holder {
    /// The operation.
    pub operation: String,
    /// Its priority.
    pub priority: i32,
    /// Since when it holds.
    pub since_ms: Millis,
    /// How long it has held.
    pub held_ms: Millis,
}

/// An operation aborted and not reset: it refuses every start until a person resets it.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct AbortedView {
    /// The operation.
    pub operation: String,
    /// Since when.
    pub since_ms: Millis,
    /// Who aborted it.
    pub by: String,
    /// Why.
    pub reason: Option<String>,
    /// What an operator may command it: a reset.
    pub commands: [Command; 1],
}

/// Why a line is faulted.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct FaultView {
    /// What faulted it.
    pub cause: crate::interlock::FaultCause,
    /// The operation, if one faulted.
    pub operation: Option<String>,
    /// The note.
    pub note: Option<String>,
    /// Since when.
    pub since_ms: Millis,
}

/// One line.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct LineView {
    /// Its name.
    pub name: String,
    /// Its state, as saved.
    pub state: ResourceState,
    /// Who holds it.
    pub holder: Option<Holder>,
    /// Why it is faulted.
    pub fault: Option<FaultView>,
    /// The operations waiting for it.
    pub waiting: Vec<String>,
    /// Why it may not be cleared now, each with its words (`text`).
    #[serde(serialize_with = "crate::clearance::worded_reasons")]
    pub clear_blockers: Vec<ClearBlocker>,
}

/// The whole view.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct EngineView {
    /// When.
    pub at_ms: Millis,
    /// Where it is in its life.
    pub stage: super::Stage,
    /// Every line.
    pub lines: Vec<LineView>,
    /// Every hold.
    pub holds: Vec<RequestSnapshot>,
    /// Every waiting request, in grant order, then those a drain holds back.
    pub queue: Vec<Waiting>,
    /// Why the state was unknown at start, while it matters.
    pub lost_state: Option<String>,
    /// The alarms.
    pub alarms: Vec<Alarm>,
    /// The latest alarm changes.
    pub alarm_changes: Vec<AlarmChange>,
    /// The latest notable events.
    pub recent_events: Vec<EventRecord>,
    /// The operations aborted and not reset.
    pub aborted: Vec<AbortedView>,
}

impl Engine {
    /// The engine as a person reads it at `now`; `blockers` says why the
    /// plant does not show a faulted line isolated yet.
    pub fn view(&self, now: Millis, blockers: Blockers<'_>) -> EngineView {
        let snapshot = self.interlock.snapshot(now);
        let queue: Vec<Waiting> = snapshot
            .queue
            .iter()
            .map(|q| {
                (
                    q.operation.clone(),
                    q.priority,
                    q.resources.clone(),
                    q.since_ms,
                )
            })
            .chain(self.held_back().map(|(op, priority, names, since)| {
                (
                    op.to_owned(),
                    priority,
                    names.iter().map(|n| n.to_string()).collect(),
                    since,
                )
            }))
            .map(|(operation, priority, resources, since_ms)| Waiting {
                operation,
                priority,
                resources,
                since_ms,
                waited_ms: now.saturating_sub(since_ms),
            })
            .collect();
        let lines = snapshot
            .resources
            .iter()
            .map(|line| {
                let holder = match &line.state {
                    ResourceState::Held { operation } => snapshot
                        .holds
                        .iter()
                        .find(|h| &h.operation == operation)
                        .map(|h| Holder {
                            operation: h.operation.clone(),
                            priority: h.priority,
                            since_ms: h.since_ms,
                            held_ms: now.saturating_sub(h.since_ms),
                        }),
                    _ => None,
                };
                let (fault, clear_blockers) = match &line.state {
                    ResourceState::Faulted(f) => (
                        Some(FaultView {
                            cause: f.cause,
                            operation: f.operation.clone(),
                            note: f.note.clone(),
                            since_ms: f.since_ms,
                        }),
                        blockers(&line.name),
                    ),
                    _ => (None, Vec::new()),
                };
                LineView {
                    name: line.name.clone(),
                    state: line.state.clone(),
                    holder,
                    fault,
                    waiting: queue
                        .iter()
                        .filter(|q| q.resources.contains(&line.name))
                        .map(|q| q.operation.clone())
                        .collect(),
                    clear_blockers,
                }
            })
            .collect();
        EngineView {
            at_ms: now,
            stage: self.stage,
            lines,
            holds: snapshot.holds,
            queue,
            lost_state: self.lost.clone(),
            alarms: self.alarms.list().cloned().collect(),
            alarm_changes: self.recent_changes.iter().cloned().collect(),
            recent_events: self.recent_events.iter().cloned().collect(),
            aborted: self
                .aborted
                .iter()
                .map(|(operation, record)| AbortedView {
                    operation: operation.to_owned(),
                    since_ms: record.since_ms,
                    by: record.by.by.clone(),
                    reason: record.by.reason.clone(),
                    commands: [Command::Reset],
                })
                .collect(),
        }
    }
}
