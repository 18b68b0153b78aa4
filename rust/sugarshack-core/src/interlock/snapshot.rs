use serde::{Deserialize, Serialize};

use super::{
    EventKind, Grant, Interlock, InterlockConfig, InterlockError, OpState, Owner, QueueKey,
    ResourceSet,
};

/// The whole interlock state by name, for persistence across restarts.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Snapshot {
    pub version: u32,
    pub taken_at_ms: u64,
    pub resources: Vec<ResourceSnapshot>,
    /// Waiting requests in grant order (priority, then arrival).
    pub queue: Vec<RequestSnapshot>,
    pub holds: Vec<RequestSnapshot>,
}

pub const SNAPSHOT_VERSION: u32 = 1;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct ResourceSnapshot {
    pub name: String,
    pub state: ResourceState,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", tag = "state")]
pub enum ResourceState {
    Free,
    Held { operation: String },
    Faulted(FaultSnapshot),
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct FaultSnapshot {
    pub cause: FaultCause,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub operation: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
    pub since_ms: u64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FaultCause {
    /// The operation holding the resource faulted.
    Operation,
    /// A person faulted the resource directly.
    Manual,
    /// The resource was held when the state was saved: its physical state is unknown.
    Interrupted,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct RequestSnapshot {
    pub operation: String,
    pub priority: i32,
    pub resources: Vec<String>,
    pub since_ms: u64,
    #[serde(default)]
    pub waited_ms: u64,
}

impl Interlock {
    pub fn snapshot(&self, now_ms: u64) -> Snapshot {
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
                    waited_ms: 0,
                }),
                _ => None,
            })
            .collect();
        let holds = self
            .operations
            .iter()
            .filter_map(|op| match &op.state {
                OpState::Holding(hold) => Some(RequestSnapshot {
                    operation: op.name.clone(),
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
            taken_at_ms: now_ms,
            resources,
            queue,
            holds,
        }
    }

    /// Rebuilds the state saved in `snapshot` under `config`. Nobody knows the
    /// physical state of an operation interrupted mid-way, so every resource
    /// held at the snapshot restores as faulted ("interrupted") and its
    /// operation as idle. Faults stay faulted; waiting requests keep their
    /// order. Resources no longer configured are left out, and so are
    /// waiting requests that name them; each omission is reported as an event.
    ///
    /// With `keep_queue` false the waiting requests are dropped instead (with
    /// an event each): use that when their callers did not survive the restart.
    pub fn restore(
        config: InterlockConfig,
        snapshot: &Snapshot,
        keep_queue: bool,
        now_ms: u64,
    ) -> Result<(Self, Vec<Grant>), InterlockError> {
        if snapshot.version != SNAPSHOT_VERSION {
            return Err(InterlockError::InvalidSnapshot {
                reason: format!(
                    "snapshot version {} is not {SNAPSHOT_VERSION}",
                    snapshot.version
                ),
            });
        }
        let mut lock = Interlock::new(config)?;
        let mut seen = std::collections::HashSet::new();
        for saved in &snapshot.resources {
            if !seen.insert(saved.name.as_str()) {
                return Err(InterlockError::InvalidSnapshot {
                    reason: format!("resource '{}' appears twice", saved.name),
                });
            }
            let Ok(r) = lock.resource(&saved.name) else {
                let note = format!("resource '{}' in the saved state is no longer configured; its state is dropped", saved.name);
                lock.record(
                    now_ms,
                    EventKind::Interrupted,
                    None,
                    None,
                    &ResourceSet::default(),
                    None,
                    None,
                    Some(note),
                );
                continue;
            };
            match &saved.state {
                ResourceState::Free => {}
                ResourceState::Held { operation } => {
                    let op = lock.operation(operation);
                    lock.latch(
                        r,
                        FaultCause::Interrupted,
                        Some(op),
                        Some("held when the interlock state was saved"),
                        now_ms,
                    );
                    lock.record(
                        now_ms,
                        EventKind::Interrupted,
                        Some(op),
                        None,
                        &ResourceSet(vec![r].into()),
                        None,
                        None,
                        None,
                    );
                }
                ResourceState::Faulted(fault) => {
                    let op = fault.operation.as_deref().map(|name| lock.operation(name));
                    lock.latch(r, fault.cause, op, fault.note.as_deref(), fault.since_ms);
                }
            }
        }
        for waiting in &snapshot.queue {
            let op = lock.operation(&waiting.operation);
            let resources = if keep_queue {
                lock.resource_set(&waiting.resources)
                    .map_err(|err| err.to_string())
            } else {
                Err("its caller did not survive the restart".to_owned())
            };
            let resources = match resources {
                Ok(set) => set,
                Err(why) => {
                    lock.record(
                        now_ms,
                        EventKind::Dropped,
                        Some(op),
                        Some(waiting.priority),
                        &ResourceSet::default(),
                        None,
                        None,
                        Some(format!("waiting request dropped on restore: {why}")),
                    );
                    continue;
                }
            };
            if !matches!(lock.operations[op.index()].state, OpState::Idle) {
                return Err(InterlockError::InvalidSnapshot {
                    reason: format!("operation '{}' waits twice", waiting.operation),
                });
            }
            let key = QueueKey {
                priority: waiting.priority,
                seq: lock.next_seq,
                op,
            };
            lock.next_seq += 1;
            lock.enqueue(key, resources, waiting.since_ms);
        }
        // A changed configuration may let restored waiters through at once.
        let unblocked: Vec<QueueKey> = lock
            .queue
            .iter()
            .copied()
            .filter(|key| lock.busy[key.op.index()] == 0)
            .collect();
        let grants = lock.grant_candidates(unblocked, now_ms);
        Ok((lock, grants))
    }
}
