use std::collections::{HashMap, HashSet};

use serde::{Deserialize, Serialize};

use super::{
    bound_note, cut, Event, Grant, Interlock, InterlockConfig, InterlockError, OpState, Owner,
    QueueKey, Requester, ResourceId, ResourceSet, QUOTE_MAX_CHARS,
};

use crate::time::Millis;

/// The whole interlock state by name, for persistence across restarts.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Snapshot {
    /// The snapshot format's version.
    pub version: u32,
    /// When it was taken, in ms.
    pub taken_at_ms: Millis,
    /// The lines configured when the state was saved, in configuration order.
    /// Absent from version 1, where the names in `resources` stand for it.
    #[serde(default)]
    pub configured: Vec<String>,
    /// Every configured line and its state.
    pub resources: Vec<ResourceSnapshot>,
    /// Waiting requests in grant order (priority, then arrival).
    pub queue: Vec<RequestSnapshot>,
    /// Every hold.
    pub holds: Vec<RequestSnapshot>,
}

/// The version [`Interlock::snapshot`] writes; [`Interlock::restore`] also reads version 1.
pub const SNAPSHOT_VERSION: u32 = 2;

/// One line and its state.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct ResourceSnapshot {
    /// The line's name.
    pub name: String,
    /// Free, held or faulted.
    pub state: ResourceState,
}

/// A line's state.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", tag = "state")]
pub enum ResourceState {
    /// Nobody holds it.
    Free,
    /// An operation holds it.
    Held {
        /// The operation's id.
        operation: String,
    },
    /// Faulted until a person clears it.
    Faulted(FaultSnapshot),
}

/// Why a line is faulted, and since when.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct FaultSnapshot {
    /// What faulted it.
    pub cause: FaultCause,
    /// The operation's id.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub operation: Option<String>,
    /// Free text kept with it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
    /// Since when, in ms.
    pub since_ms: Millis,
}

/// What faulted a line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FaultCause {
    /// The operation holding the resource faulted.
    Operation,
    /// A person faulted the resource directly.
    Manual,
    /// The resource was held when the state was saved: its physical state is unknown.
    Interrupted,
    /// No usable saved state (lost, empty or refused): nothing is known of the line.
    Unknown,
}

/// A hold or a waiting request.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct RequestSnapshot {
    /// The operation's id.
    pub operation: String,
    /// The request's priority (lower goes first).
    pub priority: i32,
    /// The lines' names.
    pub resources: Vec<String>,
    /// Since when, in ms.
    pub since_ms: Millis,
    /// How long it waited before its grant (0 for a waiting request).
    #[serde(default)]
    pub waited_ms: Millis,
}

/// How [`Interlock::restore`] takes a saved state back. The default is a restart.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RestoreOptions {
    /// Keep waiting requests. False drops them, with an event each: after a
    /// restart their callers are gone.
    pub keep_queue: bool,
    /// Keep holds whose lines are all still configured, with their start time:
    /// a hand-over inside one running process. False faults every held line
    /// ("interrupted"): after a restart nobody knows where the operation stopped.
    pub keep_holds: bool,
}

fn quoted(name: &str) -> String {
    format!("'{}'", cut(name, QUOTE_MAX_CHARS))
}

fn invalid(reason: String) -> InterlockError {
    InterlockError::InvalidSnapshot { reason }
}

fn describe_state(state: Option<&ResourceState>) -> String {
    match state {
        Some(ResourceState::Free) => "free".to_owned(),
        Some(ResourceState::Held { operation }) => {
            format!("held by operation {}", quoted(operation))
        }
        Some(ResourceState::Faulted(_)) => "faulted".to_owned(),
        None => "not listed".to_owned(),
    }
}

/// Checks a waiting request or a hold on its own: an operation, at least one
/// line, each line once and each among the snapshot's configured lines.
fn check_request(
    list: &str,
    index: usize,
    request: &RequestSnapshot,
    configured: &HashSet<&str>,
) -> Result<(), InterlockError> {
    let entry = format!("{list}[{index}]");
    if request.operation.trim().is_empty() {
        return Err(invalid(format!("{entry} names no operation")));
    }
    let operation = quoted(&request.operation);
    if request.resources.is_empty() {
        return Err(invalid(format!(
            "{entry} (operation {operation}) names no line"
        )));
    }
    let mut seen = HashSet::new();
    for line in &request.resources {
        if !configured.contains(line.as_str()) {
            return Err(invalid(format!(
                "{entry} (operation {operation}) names line {}, which is not among the snapshot's configured lines",
                quoted(line)
            )));
        }
        if !seen.insert(line.as_str()) {
            return Err(invalid(format!(
                "{entry} (operation {operation}) names line {} twice",
                quoted(line)
            )));
        }
    }
    Ok(())
}

/// Checks the snapshot whole, so a refused restore builds nothing. Returns
/// the lines configured when it was saved.
fn check(snapshot: &Snapshot) -> Result<Vec<&str>, InterlockError> {
    let configured: Vec<&str> = match snapshot.version {
        1 => {
            if !snapshot.configured.is_empty() {
                return Err(invalid(
                    "a version 1 snapshot has no 'configured' list, yet this one has one".into(),
                ));
            }
            // Legacy: the lines it lists are the lines it knew. A line listed
            // twice is reported below, as an entry of `resources`.
            let mut seen = HashSet::new();
            snapshot
                .resources
                .iter()
                .map(|r| r.name.as_str())
                .filter(|name| seen.insert(*name))
                .collect()
        }
        2 => {
            if snapshot.configured.is_empty() {
                return Err(invalid(
                    "the snapshot does not say which lines were configured ('configured' is missing or empty)".into(),
                ));
            }
            snapshot.configured.iter().map(String::as_str).collect()
        }
        version => {
            return Err(invalid(format!(
                "snapshot version {version} is not supported (versions 1 and 2 are)"
            )))
        }
    };
    let mut known = HashSet::new();
    for name in &configured {
        if name.trim().is_empty() {
            return Err(invalid(
                "'configured' lists a line with an empty name".into(),
            ));
        }
        if !known.insert(*name) {
            return Err(invalid(format!(
                "line {} is listed twice in 'configured'",
                quoted(name)
            )));
        }
    }

    let mut states: HashMap<&str, &ResourceState> = HashMap::new();
    for (index, saved) in snapshot.resources.iter().enumerate() {
        let line = quoted(&saved.name);
        if !known.contains(saved.name.as_str()) {
            return Err(invalid(format!(
                "resources[{index}] is line {line}, which is not among the snapshot's configured lines"
            )));
        }
        if states.insert(saved.name.as_str(), &saved.state).is_some() {
            return Err(invalid(format!(
                "line {line} is listed twice in 'resources'"
            )));
        }
        if let ResourceState::Faulted(fault) = &saved.state {
            if fault
                .operation
                .as_deref()
                .is_some_and(|op| op.trim().is_empty())
            {
                return Err(invalid(format!(
                    "line {line} is faulted under an operation with an empty name"
                )));
            }
        }
    }
    if let Some(missing) = configured.iter().find(|name| !states.contains_key(*name)) {
        return Err(invalid(format!(
            "line {} was configured but 'resources' does not say its state",
            quoted(missing)
        )));
    }

    let mut holders = HashSet::new();
    let mut held_lines = HashSet::new();
    for (index, hold) in snapshot.holds.iter().enumerate() {
        check_request("holds", index, hold, &known)?;
        let operation = quoted(&hold.operation);
        if !holders.insert(hold.operation.as_str()) {
            return Err(invalid(format!(
                "operation {operation} holds twice (holds[{index}]); an operation holds one set of lines at a time"
            )));
        }
        for line in &hold.resources {
            let state = states.get(line.as_str()).copied();
            if !matches!(state, Some(ResourceState::Held { operation }) if *operation == hold.operation)
            {
                return Err(invalid(format!(
                    "holds[{index}]: operation {operation} holds line {}, but 'resources' says that line is {}",
                    quoted(line),
                    describe_state(state)
                )));
            }
            held_lines.insert(line.as_str());
        }
    }
    for saved in &snapshot.resources {
        if let ResourceState::Held { operation } = &saved.state {
            if !held_lines.contains(saved.name.as_str()) {
                return Err(invalid(format!(
                    "line {} is held by operation {}, but no hold of that operation lists it",
                    quoted(&saved.name),
                    quoted(operation)
                )));
            }
        }
    }

    let mut waiters = HashSet::new();
    for (index, waiting) in snapshot.queue.iter().enumerate() {
        check_request("queue", index, waiting, &known)?;
        let operation = quoted(&waiting.operation);
        if holders.contains(waiting.operation.as_str()) {
            return Err(invalid(format!(
                "operation {operation} both holds and waits (queue[{index}]); an operation does one or the other"
            )));
        }
        if !waiters.insert(waiting.operation.as_str()) {
            return Err(invalid(format!(
                "operation {operation} waits twice (queue[{index}])"
            )));
        }
    }
    Ok(configured)
}

impl Interlock {
    /// The whole state by name at `now`, to save and restore.
    pub fn snapshot(&self, now: Millis) -> Snapshot {
        let resources = self
            .owners
            .iter()
            .enumerate()
            .map(|(i, owner)| ResourceSnapshot {
                name: self.config.resources[i].name.clone(),
                state: match owner {
                    Owner::Free => ResourceState::Free,
                    Owner::Held(op) => ResourceState::Held {
                        operation: self.name(*op),
                    },
                    Owner::Faulted(fault) => ResourceState::Faulted(FaultSnapshot {
                        cause: fault.cause,
                        operation: fault.operation.map(|op| self.name(op)),
                        note: fault.note.clone(),
                        since_ms: fault.since_ms,
                    }),
                },
            })
            .collect();
        let queue = self
            .queue
            .iter()
            .filter_map(|key| match &self.operations[key.op.index()].state {
                OpState::Queued(waiting) => Some(RequestSnapshot {
                    operation: self.name(key.op),
                    priority: key.priority,
                    resources: self.names(&waiting.resources),
                    since_ms: waiting.since_ms,
                    waited_ms: Millis::ZERO,
                }),
                _ => None,
            })
            .collect();
        let holds = self
            .operations
            .iter()
            .filter_map(|op| match &op.state {
                OpState::Holding(hold) => Some(RequestSnapshot {
                    operation: op.name.to_string(),
                    priority: hold.priority,
                    resources: self.names(&hold.resources),
                    since_ms: hold.since_ms,
                    waited_ms: hold.waited_ms,
                }),
                _ => None,
            })
            .collect();
        Snapshot {
            version: SNAPSHOT_VERSION,
            taken_at_ms: now,
            configured: self
                .config
                .resources
                .iter()
                .map(|r| r.name.clone())
                .collect(),
            resources,
            queue,
            holds,
        }
    }

    /// Rebuilds the state saved in `snapshot` under `config`.
    ///
    /// The snapshot is checked whole first and refused (`InvalidSnapshot`) if
    /// it contradicts itself: a line listed twice, missing, or unknown to its
    /// own `configured` list; holds that disagree with the lines' owners; an
    /// operation holding or waiting twice, or doing both. A refused snapshot
    /// is never read as "all free".
    ///
    /// Faults stay faulted. Held lines come back faulted ("interrupted")
    /// unless `options.keep_holds`; waiting requests are dropped unless
    /// `options.keep_queue`. Lines configured now but not in the snapshot's
    /// `configured` list (version 2) were added since and start free, one
    /// event each; a version 1 snapshot, which has no such list, must give
    /// every configured line's state. Lines saved but no longer configured
    /// are left out, and so are waiting requests that name them, each with
    /// an event.
    pub fn restore(
        config: InterlockConfig,
        snapshot: &Snapshot,
        options: RestoreOptions,
        now: Millis,
    ) -> Result<(Self, Vec<Grant>), InterlockError> {
        let saved_lines = check(snapshot)?;
        let mut lock = Interlock::new(config)?;

        for name in &saved_lines {
            if lock.resource(name).is_err() {
                let note = format!(
                    "resource {} in the saved state is no longer configured; its state is dropped",
                    quoted(name)
                );
                lock.record(Event::Interrupted {
                    at_ms: now,
                    request: None,
                    resources: ResourceSet::default(),
                    note,
                });
            }
        }
        let saved: HashSet<&str> = saved_lines.iter().copied().collect();
        let added: Vec<ResourceId> = (0..lock.owners.len() as u32)
            .map(ResourceId)
            .filter(|&r| !saved.contains(lock.config.resources[r.index()].name.as_str()))
            .collect();
        if let (1, Some(&line)) = (snapshot.version, added.first()) {
            // Version 1 lists the lines it knew, nothing more: a line it does not
            // list may have been added since or lost from it, so it proves nothing.
            return Err(invalid(format!(
                "line {} is configured but this version 1 snapshot does not say its state, and a version 1 snapshot cannot show a line was added after it was saved",
                quoted(&lock.config.resources[line.index()].name)
            )));
        }
        lock.record_added(&added, now);

        for entry in &snapshot.resources {
            let (ResourceState::Faulted(fault), Ok(r)) = (&entry.state, lock.resource(&entry.name))
            else {
                continue;
            };
            let op = fault.operation.as_deref().map(|name| lock.operation(name));
            let note = fault.note.as_deref().map(bound_note);
            lock.latch(r, fault.cause, op, note.as_deref(), fault.since_ms);
        }

        for hold in &snapshot.holds {
            let op = lock.operation(&hold.operation);
            let (kept, lost): (Vec<&String>, Vec<&String>) = hold
                .resources
                .iter()
                .partition(|name| lock.resource(name).is_ok());
            let lines = ResourceSet::from_unsorted(
                kept.iter()
                    .filter_map(|name| lock.resource(name).ok())
                    .collect(),
            );
            if options.keep_holds && lost.is_empty() {
                // Checked: every line of a hold is owned by it, so none is faulted.
                for &r in lines.ids() {
                    lock.occupy(r, Owner::Held(op));
                }
                lock.holding += 1;
                lock.hold(op, hold.priority, lines, hold.since_ms, hold.waited_ms);
                continue;
            }
            if lines.is_empty() {
                continue;
            }
            let note = if options.keep_holds {
                let lost: Vec<String> = lost.iter().map(|name| quoted(name)).collect();
                format!(
                    "held at the hand-over, but its hold names lines no longer configured: {}",
                    lost.join(", ")
                )
            } else {
                "held when the interlock state was saved".to_owned()
            };
            let note = bound_note(&note).into_owned();
            for &r in lines.ids() {
                lock.latch(r, FaultCause::Interrupted, Some(op), Some(&note), now);
            }
            lock.record(Event::Interrupted {
                at_ms: now,
                request: Some(Requester {
                    op,
                    priority: hold.priority,
                }),
                resources: lines,
                note,
            });
        }

        for waiting in &snapshot.queue {
            let op = lock.operation(&waiting.operation);
            let gone = waiting
                .resources
                .iter()
                .find(|name| lock.resource(name).is_err());
            let resources = match (options.keep_queue, gone) {
                (false, _) => Err("its caller did not survive the restart".to_owned()),
                (true, Some(name)) => Err(format!("line {} is no longer configured", quoted(name))),
                (true, None) => lock
                    .resource_set(&waiting.resources)
                    .map_err(|err| err.to_string()),
            };
            let resources = match resources {
                Ok(set) => set,
                Err(why) => {
                    let note = format!("waiting request dropped on restore: {why}");
                    lock.record(Event::Dropped {
                        at_ms: now,
                        request: Requester {
                            op,
                            priority: waiting.priority,
                        },
                        resources: ResourceSet::default(),
                        waited_ms: None,
                        note: Some(bound_note(&note).into_owned()),
                    });
                    continue;
                }
            };
            // Checked: no operation waits twice or both holds and waits.
            debug_assert!(matches!(lock.operations[op.index()].state, OpState::Idle));
            let key = QueueKey {
                priority: waiting.priority,
                seq: lock.next_seq,
                op,
            };
            lock.next_seq += 1;
            lock.enqueue(key, resources, waiting.since_ms);
        }
        // Dropping a waiter that named a removed line may let others through.
        let unblocked: Vec<QueueKey> = lock
            .queue
            .iter()
            .copied()
            .filter(|key| lock.busy[key.op.index()] == 0)
            .collect();
        let grants = lock.grant_candidates(unblocked, now);
        Ok((lock, grants))
    }

    /// A start with no usable saved state (none after a crash, an empty file,
    /// or a refused snapshot): nobody knows what any line is doing, so every
    /// line starts faulted ("unknown") with `note`, until a person clears it.
    pub fn unknown_state(
        config: InterlockConfig,
        note: &str,
        now: Millis,
    ) -> Result<Self, InterlockError> {
        let mut lock = Interlock::new(config)?;
        let note = (!note.trim().is_empty()).then(|| bound_note(note));
        let all = ResourceSet((0..lock.owners.len() as u32).map(ResourceId).collect());
        for &r in all.ids() {
            lock.latch(r, FaultCause::Unknown, None, note.as_deref(), now);
        }
        let note = note.map(|n| n.into_owned());
        lock.record(Event::StateUnknown {
            at_ms: now,
            resources: all,
            note,
        });
        Ok(lock)
    }
}
