use serde::{Deserialize, Serialize};

use super::{OpId, ResourceSet};
use crate::clearance::Attribution;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum EventKind {
    Granted,
    Queued,
    Released,
    Cancelled,
    /// An operation faulted: its held resources latch as faulted.
    Faulted,
    /// A queued request dropped because its operation faulted while waiting.
    Dropped,
    /// A person faulted resources directly (emergency stop).
    ResourceFaulted,
    Cleared,
    /// A resource held when the state was saved, restored as faulted.
    Interrupted,
    /// Lines configured now but absent from the saved state: they start free.
    ResourceAdded,
    /// No usable saved state: every line starts faulted until a person clears it.
    StateUnknown,
    WarnQueued,
    WarnHeld,
}

/// One state change. Ids are resolved to names by [`super::Interlock::describe`].
#[derive(Clone, Debug, PartialEq)]
pub struct Event {
    pub at_ms: u64,
    pub kind: EventKind,
    pub operation: Option<OpId>,
    pub priority: Option<i32>,
    pub resources: ResourceSet,
    pub waited_ms: Option<u64>,
    pub held_ms: Option<u64>,
    pub note: Option<String>,
    /// Who cleared or stopped the lines, and why (clears and emergency stops).
    pub attribution: Option<Box<Attribution>>,
}

/// An [`Event`] with names, ready to journal or send to JS.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct EventRecord {
    pub at_ms: u64,
    pub kind: EventKind,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub operation: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub priority: Option<i32>,
    pub resources: Vec<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub waited_ms: Option<u64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub held_ms: Option<u64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub by: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub forced: bool,
}
