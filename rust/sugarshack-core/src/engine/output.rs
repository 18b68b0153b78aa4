//! What the engine asks its host to do, in order: send or complete the msgs
//! it holds, emit new msgs, publish, write the state, and tell (events,
//! counts, alarms, log lines). Outputs that follow a [`Output::Commit`] are
//! effects of a state change: the host performs them once that state is on
//! disk (the commit's `urgent` ones even if the write fails).

use std::sync::Arc;

use serde::Serialize;

use crate::alarm::AlarmChange;
use crate::clearance::LineBlockers;
use crate::code::Code;
use crate::interlock::EventRecord;
use crate::time::Millis;

use super::{MsgId, NodeId};

/// A value in a catalog text: literal text, or another catalog label.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(tag = "kind", content = "value", rename_all = "camelCase")]
pub enum Param {
    /// Put in as is.
    Text(String),
    /// The catalog's `labels.<key>`, in the reader's language.
    Label(&'static str),
}

/// Words for a person: a text of the palette's message catalogs (the host
/// renders it in the reader's language), or the core's own English words.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(tag = "kind", rename_all = "camelCase")]
pub enum Text {
    /// A text of the palette's shared catalog, by its key (`errors.<name>`, `logs.<name>`...).
    Catalog {
        /// The key.
        key: &'static str,
        /// Its placeholders' values.
        params: Vec<(&'static str, Param)>,
    },
    /// Worded by the core.
    Plain {
        /// The text.
        text: String,
    },
    /// A fault node's msg failed for the fault it made: worded by the fault
    /// node's catalog (`<what>: <note>`, what was faulted and locked out).
    Faulted {
        /// The operation faulted, or none for an emergency stop.
        operation: Option<String>,
        /// The lines locked out.
        lines: Vec<String>,
        /// The fault's note.
        note: Option<String>,
    },
}

/// Every catalog text the engine (and `plant::group_msg`) names, with the
/// placeholders it fills: the palette's catalogs must hold each one (its
/// tests read this list).
pub const CATALOG_TEXTS: &[(&str, &[&str])] = &[
    (
        "errors.acquireTimeout",
        &["operation", "resources", "seconds"],
    ),
    ("errors.alarmIdInvalid", &["got"]),
    ("errors.alarmIdsInvalid", &["max"]),
    ("errors.byNotName", &["got"]),
    ("errors.commandTarget", &[]),
    ("errors.groupNotJson", &["message"]),
    ("errors.groupTooLarge", &["length", "max"]),
    ("errors.heldNotListed", &["got"]),
    ("errors.idNotText", &["from", "got"]),
    ("errors.idRequired", &["from"]),
    ("errors.idTooLong", &["from", "max"]),
    ("errors.noLinesToStop", &[]),
    ("errors.noSuchOperationRun", &["id"]),
    ("errors.noSuchRoutineRun", &["id"]),
    ("errors.notACommand", &["command", "commands"]),
    ("errors.notNames", &["from", "names", "length", "got"]),
    ("errors.operationMissing", &[]),
    ("errors.operationNotName", &["from", "got"]),
    ("errors.operationRequired", &[]),
    ("errors.operationTooLong", &["from", "length", "max"]),
    ("errors.parkedFull", &["kind", "max"]),
    ("errors.priorityNotInteger", &["from", "got"]),
    ("errors.reasonNotText", &["got"]),
    ("errors.shelfUnbounded", &[]),
    ("errors.timeoutNotSeconds", &["from", "max", "got"]),
    ("errors.timeoutRequired", &[]),
    ("events.heldLong", &["operation", "seconds", "lines"]),
    ("events.waitedLong", &["operation", "seconds", "lines"]),
    ("logs.alarmsNotUpdated", &["message"]),
    ("logs.alarmsUnreadable", &["message"]),
    ("logs.grantedUnclaimed", &["operation"]),
    ("logs.heldRunNotRestored", &["why"]),
    ("logs.lineAdded", &["line"]),
    ("logs.lineDropped", &["line"]),
    ("logs.lockoutsNotResent", &["lines", "message"]),
    ("logs.stateUnknown", &["why"]),
    ("logs.timedOutNotQueued", &["operation", "message"]),
];

/// The catalog labels a text's placeholder may name ([`Param::Label`]).
pub const CATALOG_LABELS: &[&str] = &[
    "configuredOperation",
    "configuredPriority",
    "configuredResources",
    "configuredRoutine",
    "configuredSensors",
    "configuredTimeout",
];

/// Why a msg was refused: the code a Catch node sees and the words a person reads.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct RefusalOf {
    /// The error code.
    pub code: Code,
    /// The message.
    pub text: Text,
    /// A refused clear: every reason, per line, with their words (`texts`).
    #[serde(
        skip_serializing_if = "Vec::is_empty",
        serialize_with = "crate::clearance::worded_lines"
    )]
    pub lines: Vec<LineBlockers>,
}

/// A refusal, boxed: outputs stay small on the path of msgs that are not refused.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(transparent)]
pub struct Refusal(Box<RefusalOf>);

impl std::ops::Deref for Refusal {
    type Target = RefusalOf;
    fn deref(&self) -> &RefusalOf {
        &self.0
    }
}

impl Refusal {
    /// A refusal with this code, words and lines.
    pub fn new(code: Code, text: Text, lines: Vec<LineBlockers>) -> Self {
        Refusal(Box::new(RefusalOf { code, text, lines }))
    }

    /// A refusal worded by the catalog's `errors.<key>`.
    pub fn catalog(code: Code, key: &'static str, params: Vec<(&'static str, Param)>) -> Self {
        Refusal::new(code, Text::Catalog { key, params }, Vec::new())
    }

    /// A refusal in the core's words (the interlock's own refusals).
    pub fn plain(code: Code, text: impl Into<String>) -> Self {
        Refusal::new(code, Text::Plain { text: text.into() }, Vec::new())
    }

    /// The catalog key, when worded by the catalog.
    pub fn key(&self) -> Option<&'static str> {
        match &self.text {
            Text::Catalog { key, .. } => Some(key),
            Text::Plain { .. } | Text::Faulted { .. } => None,
        }
    }

    /// The catalog placeholders' values (none for the core's words).
    pub fn params(&self) -> Vec<(&'static str, Param)> {
        match &self.text {
            Text::Catalog { params, .. } => params.clone(),
            Text::Plain { .. } | Text::Faulted { .. } => Vec::new(),
        }
    }
}

impl From<crate::interlock::InterlockError> for Refusal {
    fn from(err: crate::interlock::InterlockError) -> Self {
        let lines = match &err {
            crate::interlock::InterlockError::ClearRefused { lines } => lines.clone(),
            _ => Vec::new(),
        };
        Refusal::new(
            err.code(),
            Text::Plain {
                text: err.to_string(),
            },
            lines,
        )
    }
}

/// What is set on a held msg before it goes on.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "camelCase")]
pub enum Set {
    /// Nothing: it goes on as it came.
    Nothing,
    /// `msg.interlock` of a grant.
    #[serde(rename_all = "camelCase")]
    Interlock {
        /// The operation granted.
        operation: Arc<str>,
        /// Its priority.
        priority: i32,
        /// The lines it asked for, as it named them.
        resources: Arc<[Arc<str>]>,
        /// How long it waited.
        waited_ms: Millis,
    },
    /// `msg.cleared` and `msg.clearedBy` of a clear.
    Cleared(Box<Cleared>),
    /// `msg.refused` of a clear the plant refused (out of the refusals output).
    #[serde(rename_all = "camelCase")]
    Refused {
        /// The refusal.
        refusal: Refusal,
    },
}

/// What a clear sets on its msg.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Cleared {
    /// The lines cleared.
    pub cleared: Vec<String>,
    /// Who cleared them (`"unknown"` when nobody said).
    pub by: String,
    /// Why.
    pub reason: Option<String>,
    /// Over the plant's reasons.
    pub forced: bool,
}

/// An operator's action, as the journal keeps it.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Journal {
    /// What was done.
    pub action: Action,
    /// Who did it.
    pub by: Option<String>,
    /// Why.
    pub reason: Option<String>,
    /// What it named (lines, an operation, alarm ids), or "all".
    pub target: Vec<String>,
}

/// A msg the engine makes: a lockout group command of a faulted line.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct LockoutMsg {
    /// `lockout/<line>`: a group command node takes it for a lockout.
    pub topic: String,
    /// The line's lockout group command (JSON).
    pub payload: serde_json::Value,
    /// The line.
    pub resource: String,
    /// The operation that faulted, or none for an emergency stop.
    pub operation: Option<String>,
    /// The fault's note.
    pub note: Option<String>,
    /// When the fault happened, so the lockout's group command can report
    /// the paper's fault lockout time.
    pub fault_at_ms: Millis,
}

/// An operator's action, as the journal keeps it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Action {
    /// A clear.
    Clear,
    /// A clear over the plant's reasons.
    ClearForced,
    /// A clear the plant refused.
    ClearRefused,
    /// An emergency stop of lines.
    EStop,
    /// A cancel of a waiting operation.
    Cancel,
    /// Alarms acknowledged.
    AlarmAck,
    /// An alarm shelved.
    AlarmShelve,
    /// An alarm taken off its shelf.
    AlarmUnshelve,
    /// An aborted operation reset.
    Reset,
}

/// Log levels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub enum Level {
    /// Something that needs a look.
    Warn,
    /// Something failed.
    Error,
}

/// The interlock's counts, as its nodes' status shows them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Counts {
    /// Operations holding lines.
    pub holding: usize,
    /// Requests waiting (held back by a drain included).
    pub queued: usize,
    /// Lines faulted.
    pub faulted: usize,
    /// The state was unknown at start and lines faulted for it are not cleared yet.
    pub lost: bool,
}

/// One thing for the host to do.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "camelCase")]
pub enum Output {
    /// The state changed: what follows (up to the next `Commit` or `After`)
    /// leaves once it is on disk; `urgent`: even if writing it fails.
    Commit {
        /// Isolation first: performed even when the state cannot be saved.
        urgent: bool,
    },
    /// No state change, but what follows waits behind the effects still
    /// waiting for their write.
    After,
    /// Set `set` on held msg `msg`, send it on output `port` of its node, and complete it.
    Send {
        /// The msg.
        msg: MsgId,
        /// The output, from 0.
        port: u32,
        /// What to set on it.
        set: Set,
    },
    /// Lockout group commands for the plant bound to the interlock to carry out.
    Lockouts {
        /// One per line.
        lockouts: Vec<LockoutMsg>,
    },
    /// Send new msgs on output `port` of the node holding `msg`.
    Emit {
        /// The msg whose node sends them.
        msg: MsgId,
        /// The output, from 0.
        port: u32,
        /// The msgs.
        msgs: Vec<LockoutMsg>,
    },
    /// Complete held msg `msg` without sending it: done, or done with the refusal.
    Complete {
        /// The msg.
        msg: MsgId,
        /// Why it failed, if it did.
        refusal: Option<Refusal>,
    },
    /// Answer an operator's request (`msg` is the request's handle).
    Reply {
        /// The request.
        msg: MsgId,
        /// The answer (JSON), or the refusal.
        answer: Result<serde_json::Value, Refusal>,
    },
    /// An interlock event, for the events nodes and the journal.
    Event {
        /// The event.
        event: Box<EventRecord>,
    },
    /// An operator's action, for the journal.
    Journal(Box<Journal>),
    /// The counts changed.
    Counts(Counts),
    /// A node shows a refusal's code.
    NodeError {
        /// The node.
        node: NodeId,
        /// The code.
        code: Code,
    },
    /// An alarm changed.
    Alarm {
        /// The change.
        change: Box<AlarmChange>,
    },
    /// A log line.
    Log {
        /// How bad.
        level: Level,
        /// What to say.
        text: Box<Text>,
    },
}

#[cfg(test)]
mod tests {
    use super::{CATALOG_LABELS, CATALOG_TEXTS};

    /// Every catalog key and label the engine's sources name is in the lists.
    #[test]
    fn the_catalog_lists_name_every_text_the_engine_words() {
        let sources = [
            include_str!("mod.rs"),
            include_str!("config.rs"),
            include_str!("request.rs"),
            include_str!("snapshot.rs"),
            include_str!("../plant/group_msg/mod.rs"),
        ];
        for source in sources {
            for (at, _) in source.match_indices('"') {
                let rest = &source[at + 1..];
                let end = rest.find('"').unwrap_or(0);
                let literal = &rest[..end];
                let is_key = ["errors.", "logs.", "events."]
                    .iter()
                    .any(|p| literal.starts_with(p))
                    && literal
                        .chars()
                        .all(|c| c.is_ascii_alphanumeric() || c == '.');
                if is_key {
                    assert!(
                        CATALOG_TEXTS.iter().any(|(key, _)| *key == literal),
                        "{literal} is not in CATALOG_TEXTS"
                    );
                }
            }
            let labels = source.split("Configured(\"").skip(1);
            for label in labels.chain(source.split("Label(\"").skip(1)) {
                let label = &label[..label.find('"').unwrap_or(0)];
                assert!(CATALOG_LABELS.contains(&label), "label {label}");
            }
        }
    }
}
