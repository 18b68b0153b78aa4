use serde::{Deserialize, Serialize};

use super::{OpId, ResourceSet};
use crate::clearance::Attribution;
use crate::time::Millis;

/// The name of an [`Event`]'s kind, as journalled and sent to JS
/// (`"granted"`, `"resource-faulted"`, ...).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum EventKind {
    /// See [`Event::Granted`].
    Granted,
    /// See [`Event::Queued`].
    Queued,
    /// See [`Event::Released`].
    Released,
    /// See [`Event::Cancelled`].
    Cancelled,
    /// See [`Event::Faulted`].
    Faulted,
    /// See [`Event::Dropped`].
    Dropped,
    /// See [`Event::ResourceFaulted`].
    ResourceFaulted,
    /// See [`Event::Cleared`].
    Cleared,
    /// See [`Event::Interrupted`].
    Interrupted,
    /// See [`Event::ResourceAdded`].
    ResourceAdded,
    /// See [`Event::StateUnknown`].
    StateUnknown,
    /// See [`Event::WarnQueued`].
    WarnQueued,
    /// See [`Event::WarnHeld`].
    WarnHeld,
}

impl EventKind {
    /// Every kind.
    pub const ALL: [EventKind; 13] = [
        EventKind::Granted,
        EventKind::Queued,
        EventKind::Released,
        EventKind::Cancelled,
        EventKind::Faulted,
        EventKind::Dropped,
        EventKind::ResourceFaulted,
        EventKind::Cleared,
        EventKind::Interrupted,
        EventKind::ResourceAdded,
        EventKind::StateUnknown,
        EventKind::WarnQueued,
        EventKind::WarnHeld,
    ];

    /// Whether an alarm view keeps events of this kind: faults, clears,
    /// interruptions, lost state, dropped requests and elapsed-time warnings,
    /// not the grants, queueing and releases of normal work.
    ///
    /// ```
    /// use sugarshack_core::interlock::EventKind;
    /// assert!(EventKind::Faulted.is_abnormal());
    /// assert!(!EventKind::Granted.is_abnormal());
    /// ```
    pub fn is_abnormal(self) -> bool {
        match self {
            EventKind::Faulted
            | EventKind::Dropped
            | EventKind::ResourceFaulted
            | EventKind::Cleared
            | EventKind::Interrupted
            | EventKind::StateUnknown
            | EventKind::WarnQueued
            | EventKind::WarnHeld => true,
            EventKind::Granted
            | EventKind::Queued
            | EventKind::Released
            | EventKind::Cancelled
            | EventKind::ResourceAdded => false,
        }
    }
}

/// An operation and the priority it asked with, as events name them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Requester {
    /// The operation.
    pub op: OpId,
    /// The priority of its request (lower goes first).
    pub priority: i32,
}

/// One state change, with what that kind of change carries and nothing else.
/// Ids are resolved to names by [`super::Interlock::describe`].
#[derive(Clone, Debug, PartialEq)]
pub enum Event {
    /// An operation now holds `resources`, after waiting `waited_ms` (0 when granted at once).
    Granted {
        /// When, in ms.
        at_ms: Millis,
        /// Who holds them now.
        request: Requester,
        /// What it holds.
        resources: ResourceSet,
        /// How long it waited in the queue.
        waited_ms: Millis,
    },
    /// A request waits in the queue.
    Queued {
        /// When, in ms.
        at_ms: Millis,
        /// Who waits.
        request: Requester,
        /// What it waits for.
        resources: ResourceSet,
    },
    /// An operation freed what it held.
    Released {
        /// When, in ms.
        at_ms: Millis,
        /// Who released.
        request: Requester,
        /// What it freed.
        resources: ResourceSet,
        /// How long it held them.
        held_ms: Millis,
    },
    /// A waiting request was withdrawn (its operation gave up waiting).
    Cancelled {
        /// When, in ms.
        at_ms: Millis,
        /// Whose request.
        request: Requester,
        /// What it waited for.
        resources: ResourceSet,
        /// How long it waited.
        waited_ms: Millis,
    },
    /// An operation faulted: its held resources latch as faulted.
    Faulted {
        /// When, in ms.
        at_ms: Millis,
        /// Who faulted.
        request: Requester,
        /// What latched.
        resources: ResourceSet,
        /// How long it had held them.
        held_ms: Millis,
        /// Why, as its error handler said.
        note: Option<String>,
    },
    /// A queued request dropped: its operation faulted while waiting, or the
    /// request did not survive a restore (then `resources` is empty and
    /// `waited_ms` unknown).
    Dropped {
        /// When, in ms.
        at_ms: Millis,
        /// Whose request.
        request: Requester,
        /// What it waited for.
        resources: ResourceSet,
        /// How long it waited, when known.
        waited_ms: Option<Millis>,
        /// Why.
        note: Option<String>,
    },
    /// A person faulted resources directly (emergency stop).
    ResourceFaulted {
        /// When, in ms.
        at_ms: Millis,
        /// The lines stopped.
        resources: ResourceSet,
        /// Why, as given with the stop.
        note: Option<String>,
        /// Who stopped them, and why.
        attribution: Box<Attribution>,
    },
    /// A person cleared faulted lines.
    Cleared {
        /// When, in ms.
        at_ms: Millis,
        /// The lines cleared.
        resources: ResourceSet,
        /// What a forced clear overrode.
        note: Option<String>,
        /// Who cleared them, why, and whether it was forced.
        attribution: Box<Attribution>,
    },
    /// A restore could not keep something: a hold (`request` is its operation,
    /// its lines now faulted), or a saved line no longer configured (`request` is none).
    Interrupted {
        /// When, in ms.
        at_ms: Millis,
        /// The operation whose hold was interrupted, if any.
        request: Option<Requester>,
        /// The lines latched as faulted.
        resources: ResourceSet,
        /// What happened.
        note: String,
    },
    /// Lines configured now but absent from the saved state: they start free.
    ResourceAdded {
        /// When, in ms.
        at_ms: Millis,
        /// The new lines.
        resources: ResourceSet,
        /// What happened.
        note: String,
    },
    /// No usable saved state: every line starts faulted until a person clears it.
    StateUnknown {
        /// When, in ms.
        at_ms: Millis,
        /// Every line.
        resources: ResourceSet,
        /// Why the state is unknown.
        note: Option<String>,
    },
    /// A request has waited past the configured `warnQueuedMs`.
    WarnQueued {
        /// When, in ms.
        at_ms: Millis,
        /// Who waits.
        request: Requester,
        /// What it waits for.
        resources: ResourceSet,
        /// How long it has waited.
        waited_ms: Millis,
    },
    /// An operation has held its lines past the configured `warnHeldMs`.
    WarnHeld {
        /// When, in ms.
        at_ms: Millis,
        /// Who holds.
        request: Requester,
        /// What it holds.
        resources: ResourceSet,
        /// How long it has held them.
        held_ms: Millis,
    },
}

impl Event {
    /// The name of its kind.
    pub fn kind(&self) -> EventKind {
        match self {
            Self::Granted { .. } => EventKind::Granted,
            Self::Queued { .. } => EventKind::Queued,
            Self::Released { .. } => EventKind::Released,
            Self::Cancelled { .. } => EventKind::Cancelled,
            Self::Faulted { .. } => EventKind::Faulted,
            Self::Dropped { .. } => EventKind::Dropped,
            Self::ResourceFaulted { .. } => EventKind::ResourceFaulted,
            Self::Cleared { .. } => EventKind::Cleared,
            Self::Interrupted { .. } => EventKind::Interrupted,
            Self::ResourceAdded { .. } => EventKind::ResourceAdded,
            Self::StateUnknown { .. } => EventKind::StateUnknown,
            Self::WarnQueued { .. } => EventKind::WarnQueued,
            Self::WarnHeld { .. } => EventKind::WarnHeld,
        }
    }

    /// When it happened, in ms.
    pub fn at_ms(&self) -> Millis {
        match self {
            Self::Granted { at_ms, .. }
            | Self::Queued { at_ms, .. }
            | Self::Released { at_ms, .. }
            | Self::Cancelled { at_ms, .. }
            | Self::Faulted { at_ms, .. }
            | Self::Dropped { at_ms, .. }
            | Self::ResourceFaulted { at_ms, .. }
            | Self::Cleared { at_ms, .. }
            | Self::Interrupted { at_ms, .. }
            | Self::ResourceAdded { at_ms, .. }
            | Self::StateUnknown { at_ms, .. }
            | Self::WarnQueued { at_ms, .. }
            | Self::WarnHeld { at_ms, .. } => *at_ms,
        }
    }

    /// The resources it is about.
    pub fn resources(&self) -> &ResourceSet {
        match self {
            Self::Granted { resources, .. }
            | Self::Queued { resources, .. }
            | Self::Released { resources, .. }
            | Self::Cancelled { resources, .. }
            | Self::Faulted { resources, .. }
            | Self::Dropped { resources, .. }
            | Self::ResourceFaulted { resources, .. }
            | Self::Cleared { resources, .. }
            | Self::Interrupted { resources, .. }
            | Self::ResourceAdded { resources, .. }
            | Self::StateUnknown { resources, .. }
            | Self::WarnQueued { resources, .. }
            | Self::WarnHeld { resources, .. } => resources,
        }
    }

    /// The operation it is about, and the priority it asked with; none for
    /// changes a person or a restore made to lines.
    pub fn requester(&self) -> Option<Requester> {
        match self {
            Self::Granted { request, .. }
            | Self::Queued { request, .. }
            | Self::Released { request, .. }
            | Self::Cancelled { request, .. }
            | Self::Faulted { request, .. }
            | Self::Dropped { request, .. }
            | Self::WarnQueued { request, .. }
            | Self::WarnHeld { request, .. } => Some(*request),
            Self::Interrupted { request, .. } => *request,
            Self::ResourceFaulted { .. }
            | Self::Cleared { .. }
            | Self::ResourceAdded { .. }
            | Self::StateUnknown { .. } => None,
        }
    }

    /// The operation it is about, if any.
    pub fn operation(&self) -> Option<OpId> {
        self.requester().map(|r| r.op)
    }

    /// How long the request waited, for kinds that know.
    pub fn waited_ms(&self) -> Option<Millis> {
        match self {
            Self::Granted { waited_ms, .. }
            | Self::Cancelled { waited_ms, .. }
            | Self::WarnQueued { waited_ms, .. } => Some(*waited_ms),
            Self::Dropped { waited_ms, .. } => *waited_ms,
            _ => None,
        }
    }

    /// How long the operation held its lines, for kinds that know.
    pub fn held_ms(&self) -> Option<Millis> {
        match self {
            Self::Released { held_ms, .. }
            | Self::Faulted { held_ms, .. }
            | Self::WarnHeld { held_ms, .. } => Some(*held_ms),
            _ => None,
        }
    }

    /// The free-text note, for kinds that carry one.
    pub fn note(&self) -> Option<&str> {
        match self {
            Self::Faulted { note, .. }
            | Self::Dropped { note, .. }
            | Self::ResourceFaulted { note, .. }
            | Self::Cleared { note, .. }
            | Self::StateUnknown { note, .. } => note.as_deref(),
            Self::Interrupted { note, .. } | Self::ResourceAdded { note, .. } => Some(note),
            _ => None,
        }
    }

    /// Who cleared or stopped the lines, and why.
    pub fn attribution(&self) -> Option<&Attribution> {
        match self {
            Self::ResourceFaulted { attribution, .. } | Self::Cleared { attribution, .. } => {
                Some(attribution)
            }
            _ => None,
        }
    }
}

/// An [`Event`] with names, ready to journal or send to JS.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct EventRecord {
    /// When, in ms.
    pub at_ms: Millis,
    /// What kind of change.
    pub kind: EventKind,
    /// The operation's id.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub operation: Option<String>,
    /// The request's priority (lower goes first).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub priority: Option<i32>,
    /// The lines' names.
    pub resources: Vec<String>,
    /// How long the request waited, for kinds that know.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub waited_ms: Option<Millis>,
    /// How long the operation held its lines, for kinds that know.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub held_ms: Option<Millis>,
    /// Free text kept with it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
    /// Who cleared or stopped the lines.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub by: Option<String>,
    /// Why, in words a person acts on.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    /// Whether a clear overrode the plant's reasons to refuse it.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub forced: bool,
}
