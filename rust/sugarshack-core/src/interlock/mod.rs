//! The resource interlock of the Sugar Shack 4.0 paper (§III-C, Algorithms 1
//! and 2): atomic acquisition of resource sets, a priority queue re-evaluated
//! on every release, clear or cancel, and a fault lockout that latches
//! resources until a person clears them.
//!
//! ```
//! use sugarshack_core::interlock::{Acquisition, Interlock, InterlockConfig};
//! use sugarshack_core::time::ms;
//!
//! let mut lock = Interlock::new(InterlockConfig::with_resources(["YEL", "RED"])).unwrap();
//! let load = lock.operation("load truck");
//! let flit = lock.operation("flit downstock");
//! let yel = lock.resource_set(&["YEL"]).unwrap();
//! let yel_red = lock.resource_set(&["YEL", "RED"]).unwrap();
//!
//! assert_eq!(lock.acquire(load, 20, &yel, ms(0)).unwrap(), Acquisition::Granted);
//! assert_eq!(lock.acquire(flit, 92, &yel_red, ms(10)).unwrap(), Acquisition::Queued);
//! let grants = lock.release(load, ms(500)).unwrap();
//! assert_eq!(grants[0].operation, flit);
//! assert_eq!(grants[0].waited_ms, ms(490));
//! ```

mod alarms;
mod config;
mod error;
mod event;
mod saved;
mod snapshot;

use std::borrow::Cow;
use std::collections::{BTreeSet, HashMap, HashSet};
use std::hash::Hasher;
use std::sync::Arc;

use crate::clearance::{Attribution, ClearBlocker, LineBlockers};
use crate::time::Millis;

pub use config::{InterlockConfig, Policy, ResourceConfig, DEFAULT_QUEUE_BOUND};
pub use error::InterlockError;
pub use event::{Event, EventKind, EventRecord, Requester};
pub use saved::{saved_for, Beside, Binding, Opened, SavedState, Start};
pub use snapshot::{
    FaultCause, FaultSnapshot, RequestSnapshot, ResourceSnapshot, ResourceState, RestoreOptions,
    Snapshot, SNAPSHOT_VERSION,
};

/// The longest fault note kept, in characters: a Catch node's message can be
/// any length, and every note is saved with the state.
pub const NOTE_MAX_CHARS: usize = 500;

/// `text` if it has at most `max_chars` characters, else its start cut to
/// `max_chars` characters, the last an ellipsis.
fn cut(text: &str, max_chars: usize) -> Cow<'_, str> {
    // Fewer bytes than the bound means fewer characters too.
    if text.len() <= max_chars || text.chars().nth(max_chars).is_none() {
        return Cow::Borrowed(text);
    }
    let end = text
        .char_indices()
        .nth(max_chars.saturating_sub(1))
        .map_or(text.len(), |(i, _)| i);
    Cow::Owned(format!("{}\u{2026}", &text[..end]))
}

fn bound_note(note: &str) -> Cow<'_, str> {
    cut(note, NOTE_MAX_CHARS)
}

/// How much of a name from outside an error message or event quotes.
const QUOTE_MAX_CHARS: usize = 100;

/// A configured resource, by its index in the configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ResourceId(u32);

impl ResourceId {
    /// Its position in the interlock's operation table.
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// An operation known to the interlock (interned by name): its slot in the
/// operation table and the slot's generation. Slots of forgotten operations
/// are reused under a new generation, so an old handle is refused rather
/// than taken for the operation now in its slot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct OpId {
    index: u32,
    generation: u32,
}

/// Generations wrap below 2^21 so that [`OpId::to_bits`] is exact in an `f64`.
const GENERATION_MASK: u32 = (1 << 21) - 1;

impl OpId {
    /// Its slot in the interlock's operation table.
    pub fn index(self) -> usize {
        self.index as usize
    }
    /// The handle as one integer below 2^53 (exact as a JS number).
    pub fn to_bits(self) -> u64 {
        (u64::from(self.generation) << 32) | u64::from(self.index)
    }
    /// The handle written by [`OpId::to_bits`]; `None` for a number it cannot have written.
    pub fn from_bits(bits: u64) -> Option<Self> {
        let generation = u32::try_from(bits >> 32).ok()?;
        (generation <= GENERATION_MASK).then_some(OpId {
            index: bits as u32,
            generation,
        })
    }
}

impl std::fmt::Display for OpId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "#{}", self.to_bits())
    }
}

/// How many operation names an interlock remembers before it forgets the
/// idle ones (holding, waiting or named by a fault are never forgotten).
/// A flow that names a new operation per msg would otherwise grow the
/// interlock without end.
pub const OPERATION_NAMES_KEPT: usize = 4096;

/// Entries of [`Interlock`]'s recent names: more than the operations a plant runs at once.
const RECENT_NAMES: usize = 1 << RECENT_BITS;
const RECENT_BITS: u32 = 6;

/// Where a name sits among the recent names (the hash needs no key: a clash only misses).
fn recent_slot(name: &str) -> usize {
    let mut hasher = crate::engine::fx::Fx::default();
    hasher.write(name.as_bytes());
    // The top bits: the multiply mixes every byte into them, not into the low ones.
    (hasher.finish() >> (u64::BITS - RECENT_BITS)) as usize
}

/// A set of resources, sorted and without duplicates. Cloning shares it, so
/// holding and queueing a set made once at deploy allocates nothing.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Default)]
pub struct ResourceSet(Arc<[ResourceId]>);

impl ResourceSet {
    /// The lines, in configuration order.
    pub fn ids(&self) -> &[ResourceId] {
        &self.0
    }
    /// How many lines.
    pub fn len(&self) -> usize {
        self.0.len()
    }
    /// Whether it names no line.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
    fn from_unsorted(mut ids: Vec<ResourceId>) -> Self {
        ids.sort_unstable();
        ids.dedup();
        ResourceSet(ids.into())
    }
}

/// What happened to an acquire request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Acquisition {
    /// Granted at once.
    Granted,
    /// Waiting in the queue.
    Queued,
}

/// A queued request granted by a release, clear or cancel: its caller can now be answered.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Grant {
    /// The operation's handle.
    pub operation: OpId,
    /// The request's priority (lower goes first).
    pub priority: i32,
    /// The lines it holds.
    pub resources: ResourceSet,
    /// How long it waited.
    pub waited_ms: Millis,
}

/// A lockout group command to send because a resource is faulted.
#[derive(Clone, Debug, PartialEq)]
pub struct Lockout {
    /// The line's handle.
    pub resource: ResourceId,
    /// The lockout command to send.
    pub command: serde_json::Value,
}

/// The effects of a fault call.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct FaultOutcome {
    /// One per resource now latched in fault, in resource order.
    pub lockouts: Vec<Lockout>,
    /// True when the operation was waiting and its request was dropped.
    pub dropped: bool,
    /// Dropping a waiter can let others through under [`Policy::NoOvertaking`].
    pub grants: Vec<Grant>,
}

/// How many operations hold, wait, and how many resources are faulted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Counts {
    /// Operations holding lines.
    pub holding: usize,
    /// Requests waiting.
    pub queued: usize,
    /// Lines faulted.
    pub faulted: usize,
}

#[derive(Clone, Debug, PartialEq)]
enum Owner {
    Free,
    Held(OpId),
    Faulted(Fault),
}

#[derive(Clone, Debug, PartialEq)]
struct Fault {
    cause: FaultCause,
    operation: Option<OpId>,
    note: Option<String>,
    since_ms: Millis,
}

/// A waiting request's place in the queue: higher priority first, then first
/// come first served. `seq` is unique, so `op` never decides the order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct QueueKey {
    priority: i32,
    seq: u64,
    op: OpId,
}

impl Ord for QueueKey {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        other
            .priority
            .cmp(&self.priority)
            .then(self.seq.cmp(&other.seq))
    }
}

impl PartialOrd for QueueKey {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

#[derive(Clone, Debug)]
struct Waiting {
    key: QueueKey,
    resources: ResourceSet,
    since_ms: Millis,
    warned: bool,
}

#[derive(Clone, Debug)]
struct Hold {
    priority: i32,
    resources: ResourceSet,
    since_ms: Millis,
    waited_ms: Millis,
    warned: bool,
}

#[derive(Clone, Debug)]
enum OpState {
    Idle,
    Queued(Waiting),
    Holding(Hold),
}

#[derive(Clone, Debug)]
struct Operation {
    /// Shared with whoever names the operation (the engine's requests, its wire's table).
    name: Arc<str>,
    state: OpState,
    generation: u32,
    /// False once forgotten, until the slot is reused.
    known: bool,
}

/// The interlock state machine. Every method takes the current time; none reads a clock.
#[derive(Clone, Debug)]
pub struct Interlock {
    config: InterlockConfig,
    resource_index: HashMap<String, ResourceId>,
    /// Each line's name, shared with whoever names it (the engine's requests, its wire's table).
    line_names: Vec<Arc<str>>,
    owners: Vec<Owner>,
    /// Per resource, the requests that need it, in grant order.
    waiters: Vec<BTreeSet<QueueKey>>,
    /// All waiting requests in grant order.
    queue: BTreeSet<QueueKey>,
    operations: Vec<Operation>,
    /// Per operation, how many resources of its waiting request are taken
    /// (held or faulted). Kept up to date on every change of owner, so a
    /// release finds the requests it unblocks without re-reading their sets.
    busy: Vec<u32>,
    /// Reused buffer of candidates for a grant, to spare an allocation per call.
    candidates: Vec<QueueKey>,
    /// Each known name's handle, keyed by the slot's own text (one allocation per name).
    operation_index: HashMap<Arc<str>, OpId>,
    /// Names looked up lately, by a fast hash of their text: a release that
    /// follows its acquire names the same few holders again and again. An
    /// entry only counts when its slot still bears that name, so a collision
    /// or a forgotten name just misses and the keyed index answers.
    recent: [Option<OpId>; RECENT_NAMES],
    /// Slots of forgotten operations, reused before the table grows.
    free_slots: Vec<u32>,
    /// The fewest names kept before forgetting ([`OPERATION_NAMES_KEPT`]; lower in tests).
    names_kept: usize,
    /// Known operations at which registering a new name forgets the idle ones.
    forget_at: usize,
    /// How many times idle operations were forgotten (handles made before may be refused).
    forgettings: u64,
    next_seq: u64,
    holding: usize,
    faulted: usize,
    events: Vec<Event>,
    /// When each wait or hold not warned about yet crosses its warning time,
    /// so the next one is known without reading every request.
    warn_due: BTreeSet<(Millis, OpId)>,
    /// Only abnormal events are recorded (nobody reads the others).
    abnormal_only: bool,
}

impl Interlock {
    /// An interlock for `config`, every line free; refused if the configuration cannot run.
    pub fn new(config: InterlockConfig) -> Result<Self, InterlockError> {
        config.validate()?;
        let count = config.resources.len();
        let resource_index = config
            .resources
            .iter()
            .enumerate()
            .map(|(i, r)| (r.name.clone(), ResourceId(i as u32)))
            .collect();
        let line_names = config
            .resources
            .iter()
            .map(|r| Arc::from(r.name.as_str()))
            .collect();
        Ok(Interlock {
            config,
            resource_index,
            line_names,
            owners: vec![Owner::Free; count],
            waiters: vec![BTreeSet::new(); count],
            queue: BTreeSet::new(),
            operations: Vec::new(),
            busy: Vec::new(),
            candidates: Vec::new(),
            operation_index: HashMap::new(),
            recent: [None; RECENT_NAMES],
            free_slots: Vec::new(),
            names_kept: OPERATION_NAMES_KEPT,
            forget_at: OPERATION_NAMES_KEPT,
            forgettings: 0,
            next_seq: 0,
            holding: 0,
            faulted: 0,
            events: Vec::new(),
            warn_due: BTreeSet::new(),
            abnormal_only: false,
        })
    }

    /// Its configuration.
    pub fn config(&self) -> &InterlockConfig {
        &self.config
    }

    // ---- names and handles -------------------------------------------------

    /// The handle of an operation, registering the name on first use. Past
    /// [`OPERATION_NAMES_KEPT`] names, registering one first forgets the
    /// idle operations: their handles are refused from then on (see
    /// [`Interlock::forgettings`]), and their names register anew.
    pub fn operation(&mut self, name: &str) -> OpId {
        if let Some(id) = self.known_name(name) {
            return id;
        }
        if self.free_slots.is_empty() && self.operation_index.len() >= self.forget_at {
            self.forget_idle_operations();
        }
        let name: Arc<str> = Arc::from(name);
        let id = match self.free_slots.pop() {
            Some(index) => {
                let slot = &mut self.operations[index as usize];
                slot.name = name.clone();
                slot.known = true;
                OpId {
                    index,
                    generation: slot.generation,
                }
            }
            None => {
                self.operations.push(Operation {
                    name: name.clone(),
                    state: OpState::Idle,
                    generation: 0,
                    known: true,
                });
                self.busy.push(0);
                OpId {
                    index: (self.operations.len() - 1) as u32,
                    generation: 0,
                }
            }
        };
        self.recent[recent_slot(&name)] = Some(id);
        self.operation_index.insert(name, id);
        id
    }

    /// The handle of a known name: from the recent names when there, else the index.
    fn known_name(&mut self, name: &str) -> Option<OpId> {
        let at = recent_slot(name);
        if let Some(id) = self.recent[at] {
            if self.slot(id).is_some_and(|slot| *slot.name == *name) {
                return Some(id);
            }
        }
        let id = self.operation_index.get(name).copied()?;
        self.recent[at] = Some(id);
        Some(id)
    }

    /// How many operation names the interlock knows now.
    pub fn known_operations(&self) -> usize {
        self.operation_index.len()
    }

    /// How many times idle operations were forgotten: a caller that keeps
    /// handles by name drops them when this changes.
    pub fn forgettings(&self) -> u64 {
        self.forgettings
    }

    /// Forgets every operation that neither holds, waits, is named by a
    /// faulted line nor by an event not yet drained. The next forgetting
    /// waits until the known names double, so registering stays O(1) on
    /// average however many operations are busy.
    fn forget_idle_operations(&mut self) {
        let mut named: HashSet<OpId> = self
            .owners
            .iter()
            .filter_map(|owner| match owner {
                Owner::Faulted(fault) => fault.operation,
                _ => None,
            })
            .collect();
        named.extend(self.events.iter().filter_map(Event::operation));
        for (index, slot) in self.operations.iter_mut().enumerate() {
            let id = OpId {
                index: index as u32,
                generation: slot.generation,
            };
            if !slot.known || !matches!(slot.state, OpState::Idle) || named.contains(&id) {
                continue;
            }
            self.operation_index.remove(&*slot.name);
            slot.name = Arc::from("");
            slot.known = false;
            slot.generation = (slot.generation + 1) & GENERATION_MASK;
            self.free_slots.push(index as u32);
        }
        // Lowest slots first, so the table's tail stays the least used.
        self.free_slots.sort_unstable_by(|a, b| b.cmp(a));
        self.forget_at = self.names_kept.max(2 * self.operation_index.len());
        self.forgettings += 1;
    }

    /// The handle of an operation that has used this interlock before.
    pub fn find_operation(&self, name: &str) -> Result<OpId, InterlockError> {
        self.operation_index
            .get(name)
            .copied()
            .ok_or_else(|| InterlockError::UnknownOperation {
                name: name.to_owned(),
            })
    }

    /// The name of the operation with handle `id`.
    pub fn operation_name(&self, id: OpId) -> Option<&str> {
        self.slot(id).map(|op| &*op.name)
    }

    /// [`Interlock::operation_name`], shared: one text however many requests name it.
    pub fn shared_operation_name(&self, id: OpId) -> Option<Arc<str>> {
        self.slot(id).map(|op| op.name.clone())
    }

    /// The line `name`'s name as the interlock keeps it, shared.
    pub fn shared_line_name(&self, name: &str) -> Option<Arc<str>> {
        let id = self.resource_index.get(name)?;
        self.line_names.get(id.index()).cloned()
    }

    /// The handle of the line `name`.
    pub fn resource(&self, name: &str) -> Result<ResourceId, InterlockError> {
        self.resource_index
            .get(name)
            .copied()
            .ok_or_else(|| InterlockError::UnknownResource {
                name: name.to_owned(),
            })
    }

    /// The name of the line with handle `id`.
    pub fn resource_name(&self, id: ResourceId) -> Option<&str> {
        self.config
            .resources
            .get(id.index())
            .map(|r| r.name.as_str())
    }

    /// Resolves names into a set; refuses unknown names and an empty set.
    pub fn resource_set<S: AsRef<str>>(&self, names: &[S]) -> Result<ResourceSet, InterlockError> {
        let ids = names
            .iter()
            .map(|n| self.resource(n.as_ref()))
            .collect::<Result<Vec<_>, _>>()?;
        let set = ResourceSet::from_unsorted(ids);
        if set.is_empty() {
            return Err(InterlockError::EmptyResourceSet);
        }
        Ok(set)
    }

    // ---- queries -----------------------------------------------------------

    /// How many operations hold, wait, and how many lines are faulted.
    pub fn counts(&self) -> Counts {
        Counts {
            holding: self.holding,
            queued: self.queue.len(),
            faulted: self.faulted,
        }
    }

    /// With recording on, record only the abnormal events (faults, clears,
    /// warnings...: what alarms and an operator's event list keep), or every one.
    pub fn record_abnormal_only(&mut self, only: bool) {
        self.abnormal_only = only;
    }

    /// What faulted the line, if it is faulted.
    pub fn fault_cause(&self, resource: ResourceId) -> Option<FaultCause> {
        match self.owners.get(resource.index()) {
            Some(Owner::Faulted(fault)) => Some(fault.cause),
            _ => None,
        }
    }

    /// Whether the line is faulted.
    pub fn is_faulted(&self, resource: ResourceId) -> bool {
        matches!(self.owners.get(resource.index()), Some(Owner::Faulted(_)))
    }

    /// The operation holding the line, if any.
    pub fn owner_of(&self, resource: ResourceId) -> Option<OpId> {
        match self.owners.get(resource.index()) {
            Some(Owner::Held(op)) => Some(*op),
            _ => None,
        }
    }

    /// Whether the operation holds its lines.
    pub fn is_holding(&self, op: OpId) -> bool {
        matches!(self.slot(op).map(|o| &o.state), Some(OpState::Holding(_)))
    }

    /// Whether the operation holds, waits, or names a faulted line: what an
    /// operation's fault acts on (an idle name is only remembered until the
    /// interlock forgets it, and not across a restart).
    pub fn is_active(&self, op: OpId) -> bool {
        self.slot(op)
            .is_some_and(|o| !matches!(o.state, OpState::Idle))
            || self
                .owners
                .iter()
                .any(|owner| matches!(owner, Owner::Faulted(f) if f.operation == Some(op)))
    }

    /// Whether the operation waits in the queue.
    pub fn is_queued(&self, op: OpId) -> bool {
        matches!(self.slot(op).map(|o| &o.state), Some(OpState::Queued(_)))
    }

    /// Waiting operations in the order they would be considered for a grant.
    pub fn queued_operations(&self) -> Vec<OpId> {
        self.queue.iter().map(|key| key.op).collect()
    }

    // ---- Algorithm 1 -------------------------------------------------------

    /// Grants the whole set at once if it may be taken now, else queues the request.
    pub fn acquire(
        &mut self,
        op: OpId,
        priority: i32,
        resources: &ResourceSet,
        now: Millis,
    ) -> Result<Acquisition, InterlockError> {
        self.check_set(resources)?;
        match &self.op(op)?.state {
            OpState::Idle => {}
            OpState::Holding(_) => {
                return Err(InterlockError::AlreadyHolding {
                    operation: self.name(op),
                })
            }
            OpState::Queued(_) => {
                return Err(InterlockError::AlreadyQueued {
                    operation: self.name(op),
                })
            }
        }
        let key = QueueKey {
            priority,
            seq: self.next_seq,
            op,
        };
        self.next_seq += 1;
        if self.may_take(key, resources) {
            self.grant(op, priority, resources.clone(), now, Millis::ZERO);
            return Ok(Acquisition::Granted);
        }
        if self.queue.len() >= self.config.queue_bound {
            return Err(InterlockError::QueueFull {
                bound: self.config.queue_bound,
            });
        }
        self.enqueue(key, resources.clone(), now);
        if self.records(EventKind::Queued) {
            self.record(Event::Queued {
                at_ms: now,
                request: Requester { op, priority },
                resources: resources.clone(),
            });
        }
        Ok(Acquisition::Queued)
    }

    // ---- Algorithm 2 -------------------------------------------------------

    /// Frees what the operation holds and grants every waiter that may now go, in queue order.
    pub fn release(&mut self, op: OpId, now: Millis) -> Result<Vec<Grant>, InterlockError> {
        if !self.is_holding(op) {
            self.op(op)?;
            return Err(InterlockError::NotHolding {
                operation: self.name(op),
            });
        }
        let Some(hold) = self.end_hold(op) else {
            unreachable!("checked above")
        };
        self.holding -= 1;
        let mut candidates = std::mem::take(&mut self.candidates);
        for &r in hold.resources.ids() {
            debug_assert_eq!(
                self.owners[r.index()],
                Owner::Held(op),
                "a fault takes the whole hold"
            );
            self.vacate(r, &mut candidates);
        }
        let held_ms = now.saturating_sub(hold.since_ms);
        let priority = hold.priority;
        if self.records(EventKind::Released) {
            self.record(Event::Released {
                at_ms: now,
                request: Requester { op, priority },
                resources: hold.resources,
                held_ms,
            });
        }
        Ok(self.grant_candidates(candidates, now))
    }

    // ---- cancel, fault, clear ----------------------------------------------

    /// Withdraws a waiting request (its operation timed out while queued).
    pub fn cancel(&mut self, op: OpId, now: Millis) -> Result<Vec<Grant>, InterlockError> {
        let key = match &self.op(op)?.state {
            OpState::Queued(waiting) => waiting.key,
            _ => {
                return Err(InterlockError::NotQueued {
                    operation: self.name(op),
                })
            }
        };
        let waiting = self.dequeue(key);
        let waited = now.saturating_sub(waiting.since_ms);
        if self.records(EventKind::Cancelled) {
            self.record(Event::Cancelled {
                at_ms: now,
                request: Requester {
                    op,
                    priority: key.priority,
                },
                resources: waiting.resources.clone(),
                waited_ms: waited,
            });
        }
        Ok(self.after_withdrawal(&waiting.resources, now))
    }

    /// [`Self::release`] by name. An operation this interlock has never seen
    /// holds nothing; the name is not registered, so bad input cannot grow
    /// the operation table.
    pub fn release_named(&mut self, name: &str, now: Millis) -> Result<Vec<Grant>, InterlockError> {
        match self.known_name(name) {
            Some(op) => self.release(op, now),
            None => Err(InterlockError::NotHolding {
                operation: cut(name, QUOTE_MAX_CHARS).into_owned(),
            }),
        }
    }

    /// [`Self::cancel`] by name. An operation this interlock has never seen
    /// waits for nothing; the name is not registered.
    pub fn cancel_named(&mut self, name: &str, now: Millis) -> Result<Vec<Grant>, InterlockError> {
        match self.operation_index.get(name) {
            Some(&op) => self.cancel(op, now),
            None => Err(InterlockError::NotQueued {
                operation: cut(name, QUOTE_MAX_CHARS).into_owned(),
            }),
        }
    }

    /// The operation faulted: what it holds latches as faulted; a waiting
    /// request is dropped instead. Returns the lockout of every resource
    /// latched under this operation, so a repeated fault (an error handler
    /// called twice) re-sends the same lockouts instead of failing. An
    /// operation that neither holds, waits, nor is named by a faulted line is
    /// refused (`UnknownOperation`): whether it was seen before, in this run or
    /// the last, never changes the answer. The note is kept to [`NOTE_MAX_CHARS`].
    pub fn fault(
        &mut self,
        op: OpId,
        note: Option<&str>,
        now: Millis,
    ) -> Result<FaultOutcome, InterlockError> {
        let note = note.map(bound_note);
        let note = note.as_deref();
        let mut outcome = FaultOutcome::default();
        match self.op(op)?.state.clone() {
            // Nothing to fault: an id never used, or one that has released and is
            // named by no fault (as a restart or a forgetting would leave it).
            OpState::Idle if self.latched_under(op).is_empty() => {
                return Err(InterlockError::UnknownOperation {
                    name: self.name(op),
                });
            }
            OpState::Idle => {}
            OpState::Queued(waiting) => {
                let waiting = self.dequeue(waiting.key);
                let waited = now.saturating_sub(waiting.since_ms);
                self.record(Event::Dropped {
                    at_ms: now,
                    request: Requester {
                        op,
                        priority: waiting.key.priority,
                    },
                    resources: waiting.resources.clone(),
                    waited_ms: Some(waited),
                    note: note.map(str::to_owned),
                });
                outcome.dropped = true;
                outcome.grants = self.after_withdrawal(&waiting.resources, now);
            }
            OpState::Holding(_) => self.fault_holder(op, FaultCause::Operation, note, now),
        }
        outcome.lockouts = self.lockouts(&self.latched_under(op));
        Ok(outcome)
    }

    /// A person faults resources directly (emergency stop), owned or not.
    /// An operation holding one of them is faulted whole: it lost part of its
    /// line mid-run, so none of what it holds is in a known state. Returns the
    /// lockout of every resource named or latched that way, even one already faulted.
    pub fn fault_resources(
        &mut self,
        resources: &ResourceSet,
        note: Option<&str>,
        now: Millis,
    ) -> Result<FaultOutcome, InterlockError> {
        self.fault_resources_by(resources, note, &Attribution::unknown(), now)
    }

    /// [`Self::fault_resources`] by a person: its event says who and why.
    pub fn fault_resources_by(
        &mut self,
        resources: &ResourceSet,
        note: Option<&str>,
        by: &Attribution,
        now: Millis,
    ) -> Result<FaultOutcome, InterlockError> {
        self.check_set(resources)?;
        let note = note.map(bound_note);
        let note = note.as_deref();
        let mut latched = resources.ids().to_vec();
        for &r in resources.ids() {
            match self.owners[r.index()] {
                Owner::Faulted(_) => {}
                Owner::Held(holder) => {
                    latched.extend(self.latched_under_hold(holder));
                    self.fault_holder(holder, FaultCause::Manual, note, now);
                }
                Owner::Free => self.latch(r, FaultCause::Manual, None, note, now),
            }
        }
        self.record(Event::ResourceFaulted {
            at_ms: now,
            resources: resources.clone(),
            note: note.map(str::to_owned),
            attribution: Box::new(by.clone()),
        });
        let latched = ResourceSet::from_unsorted(latched);
        Ok(FaultOutcome {
            lockouts: self.lockouts(&latched),
            dropped: false,
            grants: Vec::new(),
        })
    }

    /// A person clears faulted resources of an interlock that knows no
    /// plant (nothing to check them against); the queue is re-evaluated.
    /// Refused whole if any of them is not faulted.
    pub fn clear(
        &mut self,
        resources: &ResourceSet,
        now: Millis,
    ) -> Result<Vec<Grant>, InterlockError> {
        self.clear_checked(resources, &Attribution::unknown(), |_| Vec::new(), now)
    }

    /// A person clears faulted lines; the queue is re-evaluated. Refused
    /// whole if any of them is not faulted, or, unless `by.forced`, if
    /// `blockers` (the plant's reasons, per line name) gives any line a
    /// reason: every reason of every line is listed in the refusal. The
    /// `cleared` event records who, why, and whether it was forced.
    pub fn clear_checked(
        &mut self,
        resources: &ResourceSet,
        by: &Attribution,
        blockers: impl Fn(&str) -> Vec<ClearBlocker>,
        now: Millis,
    ) -> Result<Vec<Grant>, InterlockError> {
        self.check_set(resources)?;
        if let Some(&r) = resources.ids().iter().find(|r| !self.is_faulted(**r)) {
            return Err(InterlockError::NotFaulted {
                resource: self.config.resources[r.index()].name.clone(),
            });
        }
        let lines: Vec<LineBlockers> = resources
            .ids()
            .iter()
            .map(|r| {
                let line = self.config.resources[r.index()].name.clone();
                let reasons = blockers(&line);
                LineBlockers { line, reasons }
            })
            .filter(|l| !l.reasons.is_empty())
            .collect();
        if !lines.is_empty() && !by.forced {
            return Err(InterlockError::ClearRefused { lines });
        }
        // Forced with nothing to override is an ordinary clear.
        let by = Attribution {
            forced: by.forced && !lines.is_empty(),
            ..by.clone()
        };
        let note = (!lines.is_empty()).then(|| {
            let overridden: Vec<String> = lines.iter().map(ToString::to_string).collect();
            bound_note(&format!("forced over: {}", overridden.join(" | "))).into_owned()
        });
        let mut candidates = std::mem::take(&mut self.candidates);
        for &r in resources.ids() {
            self.faulted -= 1;
            self.vacate(r, &mut candidates);
        }
        self.record(Event::Cleared {
            at_ms: now,
            resources: resources.clone(),
            note,
            attribution: Box::new(by),
        });
        Ok(self.grant_candidates(candidates, now))
    }

    /// Every faulted resource, for an operator's "clear all".
    pub fn faulted_resources(&self) -> ResourceSet {
        let faulted = (0..self.owners.len() as u32)
            .map(ResourceId)
            .filter(|r| self.is_faulted(*r));
        ResourceSet(faulted.collect())
    }

    // ---- elapsed-time warnings ---------------------------------------------

    /// Warnings for requests queued, and operations holding, at or past their
    /// threshold; each wait or hold warns once.
    pub fn tick(&mut self, now: Millis) -> Vec<Event> {
        let mut warnings = Vec::new();
        if let Some(limit) = self.config.warn_queued_ms {
            for key in &self.queue {
                let OpState::Queued(waiting) = &mut self.operations[key.op.index()].state else {
                    unreachable!("a queue key belongs to a waiting operation")
                };
                let waited = now.saturating_sub(waiting.since_ms);
                if !waiting.warned && waited >= limit {
                    waiting.warned = true;
                    self.warn_due
                        .remove(&(waiting.since_ms.saturating_add(limit), key.op));
                    warnings.push(Event::WarnQueued {
                        at_ms: now,
                        request: Requester {
                            op: key.op,
                            priority: key.priority,
                        },
                        resources: waiting.resources.clone(),
                        waited_ms: waited,
                    });
                }
            }
        }
        if let Some(limit) = self.config.warn_held_ms {
            for (index, op) in self.operations.iter_mut().enumerate() {
                if let OpState::Holding(hold) = &mut op.state {
                    let held = now.saturating_sub(hold.since_ms);
                    if !hold.warned && held >= limit {
                        hold.warned = true;
                        let id = OpId {
                            index: index as u32,
                            generation: op.generation,
                        };
                        self.warn_due
                            .remove(&(hold.since_ms.saturating_add(limit), id));
                        warnings.push(Event::WarnHeld {
                            at_ms: now,
                            request: Requester {
                                op: id,
                                priority: hold.priority,
                            },
                            resources: hold.resources.clone(),
                            held_ms: held,
                        });
                    }
                }
            }
        }
        if self.config.record_events {
            self.events.extend(warnings.iter().cloned());
        }
        warnings
    }

    /// When [`Self::tick`] next has a warning to give: the earliest time a
    /// wait or hold not warned about yet crosses its warning time.
    pub fn next_warning(&self) -> Option<Millis> {
        self.warn_due.first().map(|(at, _)| *at)
    }

    fn due_after(since_ms: Millis, limit: Option<Millis>) -> Option<Millis> {
        limit.map(|limit| since_ms.saturating_add(limit))
    }

    // ---- events ------------------------------------------------------------

    /// Takes the events recorded since the last call (empty when recording is off).
    pub fn drain_events(&mut self) -> Vec<Event> {
        std::mem::take(&mut self.events)
    }

    /// Whether events wait to be drained.
    pub fn has_events(&self) -> bool {
        !self.events.is_empty()
    }

    /// An event with names in place of handles.
    pub fn describe(&self, event: &Event) -> EventRecord {
        let request = event.requester();
        let attribution = event.attribution();
        EventRecord {
            at_ms: event.at_ms(),
            kind: event.kind(),
            operation: request.map(|r| self.name(r.op)),
            priority: request.map(|r| r.priority),
            resources: self.names(event.resources()),
            waited_ms: event.waited_ms(),
            held_ms: event.held_ms(),
            note: event.note().map(str::to_owned),
            by: attribution.map(|a| a.by.clone()),
            reason: attribution.and_then(|a| a.reason.clone()),
            forced: attribution.is_some_and(|a| a.forced),
        }
    }

    // ---- internals ---------------------------------------------------------

    /// The operation of a handle still valid: known, and of the slot's generation.
    fn slot(&self, op: OpId) -> Option<&Operation> {
        self.operations
            .get(op.index())
            .filter(|slot| slot.known && slot.generation == op.generation)
    }

    fn op(&self, op: OpId) -> Result<&Operation, InterlockError> {
        self.slot(op)
            .ok_or_else(|| InterlockError::UnknownOperation {
                name: op.to_string(),
            })
    }

    fn name(&self, op: OpId) -> String {
        self.operation_name(op)
            .map_or_else(|| op.to_string(), str::to_owned)
    }

    fn names(&self, set: &ResourceSet) -> Vec<String> {
        set.ids()
            .iter()
            .map(|r| self.config.resources[r.index()].name.clone())
            .collect()
    }

    fn check_set(&self, set: &ResourceSet) -> Result<(), InterlockError> {
        if set.is_empty() {
            return Err(InterlockError::EmptyResourceSet);
        }
        if let Some(r) = set.ids().iter().find(|r| r.index() >= self.owners.len()) {
            return Err(InterlockError::UnknownResource {
                name: format!("#{}", r.0),
            });
        }
        Ok(())
    }

    fn lockouts(&self, set: &ResourceSet) -> Vec<Lockout> {
        set.ids()
            .iter()
            .map(|&r| Lockout {
                resource: r,
                command: self.config.resources[r.index()].lockout.clone(),
            })
            .collect()
    }

    /// May a new request take these resources now? All must be free, and
    /// under no-overtaking no waiter ahead of it may need one.
    fn may_take(&self, key: QueueKey, resources: &ResourceSet) -> bool {
        resources.ids().iter().all(|r| {
            self.owners[r.index()] == Owner::Free
                && (self.config.policy == Policy::Greedy
                    || self.waiters[r.index()]
                        .first()
                        .is_none_or(|head| *head >= key))
        })
    }

    fn grant(
        &mut self,
        op: OpId,
        priority: i32,
        resources: ResourceSet,
        now: Millis,
        waited_ms: Millis,
    ) {
        for &r in resources.ids() {
            self.occupy(r, Owner::Held(op));
        }
        self.holding += 1;
        if self.records(EventKind::Granted) {
            self.record(Event::Granted {
                at_ms: now,
                request: Requester { op, priority },
                resources: resources.clone(),
                waited_ms,
            });
        }
        self.hold(op, priority, resources, now, waited_ms);
    }

    /// `op` holds `resources` since `since_ms` (its lines are already its own).
    fn hold(
        &mut self,
        op: OpId,
        priority: i32,
        resources: ResourceSet,
        since_ms: Millis,
        waited_ms: Millis,
    ) {
        if let Some(at) = Self::due_after(since_ms, self.config.warn_held_ms) {
            self.warn_due.insert((at, op));
        }
        self.operations[op.index()].state = OpState::Holding(Hold {
            priority,
            resources,
            since_ms,
            waited_ms,
            warned: false,
        });
    }

    /// `op` holds nothing any more: its hold ends.
    fn end_hold(&mut self, op: OpId) -> Option<Hold> {
        let OpState::Holding(hold) =
            std::mem::replace(&mut self.operations[op.index()].state, OpState::Idle)
        else {
            return None;
        };
        if let Some(at) = Self::due_after(hold.since_ms, self.config.warn_held_ms) {
            self.warn_due.remove(&(at, op));
        }
        Some(hold)
    }

    fn enqueue(&mut self, key: QueueKey, resources: ResourceSet, since_ms: Millis) {
        let mut taken = 0;
        for r in resources.ids() {
            self.waiters[r.index()].insert(key);
            taken += u32::from(self.owners[r.index()] != Owner::Free);
        }
        self.busy[key.op.index()] = taken;
        self.queue.insert(key);
        if let Some(at) = Self::due_after(since_ms, self.config.warn_queued_ms) {
            self.warn_due.insert((at, key.op));
        }
        self.operations[key.op.index()].state = OpState::Queued(Waiting {
            key,
            resources,
            since_ms,
            warned: false,
        });
    }

    fn dequeue(&mut self, key: QueueKey) -> Waiting {
        let OpState::Queued(waiting) =
            std::mem::replace(&mut self.operations[key.op.index()].state, OpState::Idle)
        else {
            unreachable!("a queue key belongs to a waiting operation")
        };
        self.queue.remove(&key);
        for r in waiting.resources.ids() {
            self.waiters[r.index()].remove(&key);
        }
        if let Some(at) = Self::due_after(waiting.since_ms, self.config.warn_queued_ms) {
            self.warn_due.remove(&(at, key.op));
        }
        waiting
    }

    /// A free resource is taken: every request waiting on it has one more taken.
    fn occupy(&mut self, r: ResourceId, owner: Owner) {
        debug_assert_eq!(self.owners[r.index()], Owner::Free);
        for key in &self.waiters[r.index()] {
            self.busy[key.op.index()] += 1;
        }
        self.owners[r.index()] = owner;
    }

    /// A taken resource is freed; requests left with nothing taken become candidates.
    fn vacate(&mut self, r: ResourceId, candidates: &mut Vec<QueueKey>) {
        debug_assert_ne!(self.owners[r.index()], Owner::Free);
        self.owners[r.index()] = Owner::Free;
        for key in &self.waiters[r.index()] {
            let taken = &mut self.busy[key.op.index()];
            *taken -= 1;
            if *taken == 0 {
                candidates.push(*key);
            }
        }
    }

    /// A waiting request left the queue. Under no-overtaking it may have been
    /// the one ahead that kept others with free resources waiting; under
    /// greedy its leaving unblocks nobody.
    fn after_withdrawal(&mut self, resources: &ResourceSet, now: Millis) -> Vec<Grant> {
        if self.config.policy == Policy::Greedy {
            return Vec::new();
        }
        let mut candidates = std::mem::take(&mut self.candidates);
        for r in resources.ids() {
            let behind = self.waiters[r.index()]
                .iter()
                .filter(|key| self.busy[key.op.index()] == 0);
            candidates.extend(behind);
        }
        self.grant_candidates(candidates, now)
    }

    /// Algorithm 2's pass over the queue, limited to requests whose resources
    /// just became all free (or whose way was just cleared): every other
    /// waiter was blocked before and still is, since a grant only takes
    /// resources. Candidates go in queue order, so the grants equal a full pass.
    fn grant_candidates(&mut self, mut candidates: Vec<QueueKey>, now: Millis) -> Vec<Grant> {
        candidates.sort_unstable();
        candidates.dedup();
        let mut grants = Vec::new();
        for &key in &candidates {
            // An earlier grant of this pass may have taken one of its resources.
            if self.busy[key.op.index()] != 0 || !self.first_in_line(key) {
                continue;
            }
            let waiting = self.dequeue(key);
            let waited_ms = now.saturating_sub(waiting.since_ms);
            grants.push(Grant {
                operation: key.op,
                priority: key.priority,
                resources: waiting.resources.clone(),
                waited_ms,
            });
            self.grant(key.op, key.priority, waiting.resources, now, waited_ms);
        }
        candidates.clear();
        self.candidates = candidates;
        grants
    }

    /// Under no-overtaking, is this waiting request ahead of every other
    /// request on each of its resources?
    fn first_in_line(&self, key: QueueKey) -> bool {
        if self.config.policy == Policy::Greedy {
            return true;
        }
        let OpState::Queued(waiting) = &self.operations[key.op.index()].state else {
            return false;
        };
        waiting
            .resources
            .ids()
            .iter()
            .all(|r| self.waiters[r.index()].first() == Some(&key))
    }

    /// Latches everything a holding operation holds and makes it idle.
    fn fault_holder(&mut self, op: OpId, cause: FaultCause, note: Option<&str>, now: Millis) {
        let Some(hold) = self.end_hold(op) else {
            return;
        };
        self.holding -= 1;
        for &r in hold.resources.ids() {
            self.latch(r, cause, Some(op), note, now);
        }
        let held_ms = now.saturating_sub(hold.since_ms);
        self.record(Event::Faulted {
            at_ms: now,
            request: Requester {
                op,
                priority: hold.priority,
            },
            resources: hold.resources,
            held_ms,
            note: note.map(str::to_owned),
        });
    }

    fn latched_under_hold(&self, op: OpId) -> Vec<ResourceId> {
        match &self.operations[op.index()].state {
            OpState::Holding(hold) => hold.resources.ids().to_vec(),
            _ => Vec::new(),
        }
    }

    /// Resources faulted while this operation held them and not cleared since.
    fn latched_under(&self, op: OpId) -> ResourceSet {
        ResourceSet(
            (0..self.owners.len() as u32)
                .map(ResourceId)
                .filter(|r| matches!(&self.owners[r.index()], Owner::Faulted(f) if f.operation == Some(op)))
                .collect(),
        )
    }

    fn latch(
        &mut self,
        r: ResourceId,
        cause: FaultCause,
        operation: Option<OpId>,
        note: Option<&str>,
        now: Millis,
    ) {
        let fault = Owner::Faulted(Fault {
            cause,
            operation,
            note: note.map(str::to_owned),
            since_ms: now,
        });
        match self.owners[r.index()] {
            Owner::Free => {
                self.faulted += 1;
                self.occupy(r, fault);
            }
            Owner::Held(_) => {
                self.faulted += 1;
                self.owners[r.index()] = fault;
            }
            Owner::Faulted(_) => self.owners[r.index()] = fault,
        }
    }

    /// Whether an event of `kind` would be kept (spares making one that would not).
    fn records(&self, kind: EventKind) -> bool {
        self.config.record_events && (!self.abnormal_only || kind.is_abnormal())
    }

    /// Keeps `event` for [`Self::drain_events`] when recording is on.
    fn record(&mut self, event: Event) {
        if self.config.record_events && (!self.abnormal_only || event.kind().is_abnormal()) {
            self.events.push(event);
        }
    }
}

#[cfg(test)]
mod tests;
