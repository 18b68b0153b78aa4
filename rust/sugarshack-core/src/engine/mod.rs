//! One engine per interlock (and, later, the plant bound to it): every
//! input the nodes receive goes in with the time, every output the host
//! performs comes out in order, and every timeout is a deadline inside it,
//! as quinn-proto's `Connection` does for a QUIC connection. The host turns
//! msgs into inputs, keeps each msg under the handle it chose, performs the
//! outputs, and keeps one timer from [`Engine::next_deadline`].
//!
//! ```
//! use sugarshack_core::engine::{Engine, Input, MsgFields, MsgId, NodeId, NodeKind, NodeSpec, Output, Raw, Saved, Set};
//! use sugarshack_core::interlock::InterlockConfig;
//! use sugarshack_core::time::ms;
//!
//! let mut engine = Engine::new(InterlockConfig::with_resources(["YEL"]), false).unwrap();
//! engine.handle(Input::Start(Saved::First), ms(0));
//! let acquire = NodeSpec::acquire(Raw::Text("load truck".into()), Raw::Number(20.0), Raw::Text("YEL".into()), ms(0));
//! engine.handle(Input::AddNode { node: NodeId(1), spec: acquire }, ms(0));
//! engine.take_outputs();
//! engine.handle(Input::Acquire { node: NodeId(1), msg: MsgId(7), fields: MsgFields::default() }, ms(5));
//! let out = engine.take_outputs();
//! assert!(out.iter().any(|o| matches!(o,
//!     Output::Send { msg: MsgId(7), port: 0, set: Set::Interlock { operation, priority: 20, .. } }
//!     if &**operation == "load truck")));
//! ```

mod config;
mod deadline;
pub(crate) mod fx;
mod lifecycle;
mod output;
mod request;
mod snapshot;
pub mod view;
pub mod wire;

use std::collections::VecDeque;

use fx::FxMap;
use request::operation_name_of;
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::alarm::{AlarmChange, AlarmKind, Alarms, Condition};
use crate::clearance::{Attribution, ClearBlocker, UNKNOWN_BY};
use crate::code::Code;
use crate::interlock::{
    Binding, EventKind, EventRecord, FaultCause, Grant, Interlock, InterlockConfig, InterlockError,
    OpId, ResourceSet, RestoreOptions, Start,
};
use crate::operation::{AbortedOperations, RunSnapshot};
use crate::plant::Plant;
use crate::procedure::{Command, State};
use crate::time::{ms, Millis};

pub use config::{node_config, ConfigFields, ConfigOf, NodeConfig, MAX_CONFIG_ID, MAX_TIMEOUT_S};
pub use deadline::{Deadlines, Due};
pub use lifecycle::{Admit, Gate, Stage, Step, Work, TRANSITIONS};
pub use output::{
    Action, Cleared, Counts, Journal, Level, LockoutMsg, Output, Param, Refusal, RefusalOf, Set,
    Text, CATALOG_LABELS, CATALOG_TEXTS,
};
pub use request::{
    alarm_id_of, alarm_ids_of, attribution_of, names_of, note_of, operation_of, priority_of,
    read_request, resources_of, shelf_end_of, Asked, Asks, Configured, Raw, SignedIn, Who,
    WhoFields, HEAD, MAX_NAME, MAX_NAMES, MAX_TEXT,
};
pub use snapshot::{EngineState, RequestState, StateDoc, STATE_FORMAT};

/// A msg the host holds (or an operator's request it answers), by the handle it chose.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize, Default,
)]
#[serde(transparent)]
pub struct MsgId(pub u32);

/// A node of the host, by the handle it chose (the same for every deploy of that node).
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize, Default,
)]
#[serde(transparent)]
pub struct NodeId(pub u32);

/// Time-driven checks (elapsed-time warnings, alarms whose text counts time
/// or that wait out an on-delay) fall on whole seconds of the engine's clock,
/// counted from its start: a check a second at most, at a steady beat.
pub const CHECK_MS: Millis = ms(1000);
/// Notable events and alarm changes kept for a page opened late.
pub const RECENT: usize = 50;

/// What a node does with its msgs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "camelCase")]
pub enum NodeKind {
    /// Holds its msg until the operation is granted (then output 1).
    #[serde(rename_all = "camelCase")]
    Acquire {
        /// Withdraw a request waiting this long (0: wait for ever).
        timeout_ms: Millis,
    },
    /// Releases, then sends its msg on.
    Release,
    /// Withdraws a waiting request, then sends its msg on.
    Cancel,
    /// Faults an operation, or (an emergency stop) lines; output 2 gets the lockouts.
    #[serde(rename_all = "camelCase")]
    Fault {
        /// Lines, not an operation.
        by_resources: bool,
        /// The msg ends with an error naming the fault (for the caller's Catch).
        fail_msg: bool,
    },
    /// Clears faulted lines.
    #[serde(rename_all = "camelCase")]
    Clear {
        /// Every faulted line unless the msg names some.
        all_faulted: bool,
        /// A refusal leaves on output 2 instead of going to Catch nodes.
        refusals_wired: bool,
    },
}

/// A node as deployed: its kind and what it is configured with.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct NodeSpec {
    /// What it does.
    pub kind: NodeKind,
    /// Its configured operation.
    #[serde(default)]
    pub operation: Raw,
    /// Its configured priority.
    #[serde(default)]
    pub priority: Raw,
    /// Its configured resources.
    #[serde(default)]
    pub resources: Raw,
}

impl NodeSpec {
    /// An acquire node.
    pub fn acquire(operation: Raw, priority: Raw, resources: Raw, timeout_ms: Millis) -> Self {
        NodeSpec {
            kind: NodeKind::Acquire { timeout_ms },
            operation,
            priority,
            resources,
        }
    }

    /// A node of `kind` configured with `operation` alone.
    pub fn of(kind: NodeKind, operation: Raw) -> Self {
        NodeSpec {
            kind,
            operation,
            priority: Raw::Absent,
            resources: Raw::Absent,
        }
    }
}

/// What a msg carries that a node reads, as the host read it off the msg.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", default)]
pub struct Fields {
    /// msg.operation.
    pub operation: Raw,
    /// msg.priority.
    pub priority: Raw,
    /// msg.resources.
    pub resources: Raw,
    /// msg.interlock.operation (the acquire a release, cancel or fault follows).
    pub follow: Raw,
    /// msg.error.message (a Catch node's msg).
    pub error_message: Raw,
    /// msg.payload.
    pub payload: Raw,
    /// Who asks (a clear, an emergency stop).
    pub who: WhoFields,
    /// The node's values as read for this msg (from context, env or
    /// JSONata), in place of those it was deployed with.
    pub configured: Option<Configured>,
}

/// [`Fields`], boxed, or none when the msg names nothing itself (most
/// msgs): an input stays small on the hot path. A msg that carries only
/// msg.interlock.operation (the usual release) keeps it beside, unboxed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MsgFields {
    all: Option<Box<Fields>>,
    follow: Raw,
}

impl MsgFields {
    /// A msg that carries msg.interlock.operation and nothing else a node reads.
    pub fn following(follow: Raw) -> Self {
        MsgFields { all: None, follow }
    }

    /// msg.interlock.operation, however the msg carried it.
    pub fn followed(&self) -> &Raw {
        match &self.all {
            Some(fields) => &fields.follow,
            None => &self.follow,
        }
    }
}

static NO_FIELDS: Fields = Fields {
    operation: Raw::Absent,
    priority: Raw::Absent,
    resources: Raw::Absent,
    follow: Raw::Absent,
    error_message: Raw::Absent,
    payload: Raw::Absent,
    who: WhoFields {
        user: SignedIn::NONE,
        by: Raw::Absent,
        reason: Raw::Absent,
        force: false,
    },
    configured: None,
};

impl std::ops::Deref for MsgFields {
    type Target = Fields;
    fn deref(&self) -> &Fields {
        self.all.as_deref().unwrap_or(&NO_FIELDS)
    }
}

impl From<Fields> for MsgFields {
    fn from(fields: Fields) -> Self {
        MsgFields {
            all: Some(Box::new(fields)),
            follow: Raw::Absent,
        }
    }
}

/// What the host found saved when the engine starts.
#[derive(Clone, Debug, PartialEq)]
pub enum Saved {
    /// Never ran here: every line free.
    First,
    /// The state it saved.
    Doc(Box<StateDoc>),
    /// It ran here before, and its state is missing or unreadable: every line starts faulted.
    Lost(String),
    /// Its sealed state document, opened by the one restart rule of
    /// [`crate::interlock::saved`] (another owner's, a damaged or an unknown
    /// version's is a lost state).
    Sealed(Box<SealedDoc>),
}

/// A sealed state document as read, and whose it must be.
#[derive(Clone, Debug, PartialEq)]
pub struct SealedDoc {
    /// The document's text.
    pub text: String,
    /// Where it was read (named in a lost state's reason).
    pub source: String,
    /// The interlock node that owns it.
    pub owner: String,
    /// The plant node the interlock is bound to, if any.
    pub plant: Option<String>,
}

/// An alarm action by a person.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "camelCase")]
pub enum AlarmAction {
    /// Acknowledges these alarms, or every unacknowledged one.
    Ack {
        /// Alarm ids, or none for all.
        ids: Option<Vec<String>>,
    },
    /// Shelves an alarm until a time.
    #[serde(rename_all = "camelCase")]
    Shelve {
        /// The alarm.
        id: String,
        /// Until when.
        until_ms: Millis,
        /// Also until its condition next ends.
        #[serde(default)]
        one_shot: bool,
    },
    /// Takes an alarm off its shelf.
    Unshelve {
        /// The alarm.
        id: String,
    },
}

/// An operator's action from the editor or a dashboard.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "camelCase")]
pub enum OperatorAction {
    /// Clears these lines, or every faulted one.
    Clear {
        /// The lines (none: every faulted line).
        lines: Option<Vec<String>>,
    },
    /// Stops these lines.
    EStop {
        /// The lines.
        lines: Vec<String>,
    },
    /// Acts on alarms.
    Alarm(AlarmAction),
    /// An ISA-88 command to an operation's run or a routine. No run or
    /// routine is the engine's: only the reset of an operation saved aborted applies.
    Command {
        /// What it commands.
        target: CommandTarget,
        /// The command.
        command: Command,
    },
}

/// What an operator's command names.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub enum CommandTarget {
    /// An operation, by id.
    Operation(String),
    /// A routine, by id.
    Routine(String),
}

/// Why faulted lines send their lockouts again.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub enum Resend {
    /// Restored faulted at start.
    AtStart,
    /// The plant document changed.
    PlantChanged,
    /// Rebuilt after a core failure.
    AfterRebuild,
}

impl Resend {
    fn note(self) -> &'static str {
        match self {
            Resend::AtStart => "restored faulted: lockout sent again at start",
            Resend::PlantChanged => "plant document changed: lockout sent again",
            Resend::AfterRebuild => "rebuilt after a core failure: lockout sent again",
        }
    }
}

/// Everything that goes into an engine.
#[derive(Clone, Debug, PartialEq)]
pub enum Input {
    /// The saved state was read: it runs.
    Start(Saved),
    /// A step of its life (a deploy, a drain, a shutdown, a removal).
    Life(Step),
    /// A node of a deploy.
    AddNode {
        /// Its handle.
        node: NodeId,
        /// What it is.
        spec: NodeSpec,
    },
    /// A node closes: removed, or restarted by a deploy (its next instance takes its msgs over).
    CloseNode {
        /// Its handle.
        node: NodeId,
        /// Removed from the flows.
        removed: bool,
    },
    /// A msg into an acquire node.
    Acquire {
        /// The node.
        node: NodeId,
        /// The msg's handle.
        msg: MsgId,
        /// What the msg carries.
        fields: MsgFields,
    },
    /// A msg into a release node.
    Release {
        /// The node.
        node: NodeId,
        /// The msg's handle.
        msg: MsgId,
        /// What the msg carries.
        fields: MsgFields,
    },
    /// A msg into a cancel node.
    Cancel {
        /// The node.
        node: NodeId,
        /// The msg's handle.
        msg: MsgId,
        /// What the msg carries.
        fields: MsgFields,
    },
    /// A msg into a fault node.
    Fault {
        /// The node.
        node: NodeId,
        /// The msg's handle.
        msg: MsgId,
        /// What the msg carries.
        fields: MsgFields,
    },
    /// A msg into a clear node.
    Clear {
        /// The node.
        node: NodeId,
        /// The msg's handle.
        msg: MsgId,
        /// What the msg carries.
        fields: MsgFields,
        /// Whether msg.resources was set at all (a clear-all node clears the lines named).
        names_given: bool,
    },
    /// A person acts from the editor or a dashboard; the answer goes to `msg`.
    Operator {
        /// The request's handle.
        msg: MsgId,
        /// What they do.
        action: OperatorAction,
        /// Who they are.
        who: WhoFields,
    },
    /// Faulted lines send their lockouts again (the flows started, a new plant).
    ResendLockouts(Resend),
    /// Whether anything listens to events (events nodes, the journal).
    Listen(bool),
    /// Writing the state fails (the store, by where it writes), or works again (none).
    StoreFailing(Option<String>),
    /// The abnormal conditions of the plant bound to the interlock (devices, buses), as they hold now.
    PlantConditions(Vec<Condition>),
    /// Deadlines due.
    Tick,
}

/// Names as a msg gave them (msg.interlock.resources sends them back as given).
type Names = Arc<[Arc<str>]>;

/// A request waiting for its grant (queued, or held back by a drain).
#[derive(Clone, Debug, PartialEq)]
struct Request {
    node: NodeId,
    op: OpId,
    name: Arc<str>,
    priority: i32,
    set: ResourceSet,
    names: Names,
    since: Millis,
    deadline: Option<Millis>,
    held_back: bool,
}

/// An input that arrived while the engine started, with when it arrived
/// (a request's timeout counts from then).
#[derive(Clone, Debug, PartialEq)]
struct Parked {
    input: Input,
    at: Millis,
}

/// A msg's operation (name and handle), priority and lines, as read for an acquire.
type Resolved = (Arc<str>, OpId, i32, ResourceSet, Names);

/// A node's configuration, read once.
#[derive(Clone, Debug)]
struct Node {
    spec: NodeSpec,
    away: bool,
    /// The configured operation, resolved: its name and interlock handle (valid for `epoch`).
    op: Option<(Arc<str>, OpId, u64)>,
    /// The configured resources, resolved.
    set: Option<(ResourceSet, Names)>,
    /// The configured priority, read.
    priority: Option<i32>,
}

/// Why the plant does not show a line isolated yet (none: it does, or there is no plant).
pub type Blockers<'a> = &'a dyn Fn(&str) -> Vec<ClearBlocker>;

/// An interlock and what waits on it.
#[derive(Clone, Debug)]
pub struct Engine {
    stage: Stage,
    config: InterlockConfig,
    plant_bound: bool,
    interlock: Interlock,
    nodes: FxMap<NodeId, Node>,
    requests: FxMap<MsgId, Request>,
    by_op: FxMap<OpId, MsgId>,
    held_back: VecDeque<MsgId>,
    deadlines: Deadlines,
    parked: Vec<Parked>,
    /// Most parked inputs that carry a msg (0: no bound).
    park_bound: usize,
    lost: Option<String>,
    alarms: Alarms,
    alarm_due: Option<Millis>,
    recent_changes: VecDeque<AlarmChange>,
    recent_events: VecDeque<EventRecord>,
    store_failing: Option<String>,
    plant_conditions: Vec<Condition>,
    listening: bool,
    shown: Counts,
    saved_routines: serde_json::Map<String, serde_json::Value>,
    /// Operations aborted and not reset, as saved: an abort stands until a
    /// person resets it, also while the interlock runs without its plant.
    aborted: AbortedOperations,
    /// The runs saved held that came back held at start, their lines kept,
    /// until the host (which supervises runs) takes them.
    restored_runs: Vec<RunSnapshot>,
    /// When it started (or took a state over): its checks beat on whole seconds from then.
    beat: Millis,
    out: Vec<Output>,
}

impl Engine {
    /// An engine for `config`, starting (inputs wait for [`Input::Start`]);
    /// `plant_bound`: its lines are a plant's (their lockouts go to that plant).
    pub fn new(config: InterlockConfig, plant_bound: bool) -> Result<Self, InterlockError> {
        let mut interlock = Interlock::new(recording(&config))?;
        interlock.record_abnormal_only(true);
        Ok(Engine {
            stage: Stage::Starting,
            config,
            plant_bound,
            interlock,
            nodes: FxMap::default(),
            requests: FxMap::default(),
            by_op: FxMap::default(),
            held_back: VecDeque::new(),
            deadlines: Deadlines::default(),
            parked: Vec::new(),
            park_bound: 0,
            lost: None,
            alarms: Alarms::new(),
            alarm_due: None,
            recent_changes: VecDeque::new(),
            recent_events: VecDeque::new(),
            store_failing: None,
            plant_conditions: Vec::new(),
            listening: false,
            // Nothing shown yet: the first input shows the counts.
            shown: Counts {
                holding: usize::MAX,
                ..Counts::default()
            },
            saved_routines: serde_json::Map::new(),
            aborted: AbortedOperations::default(),
            restored_runs: Vec::new(),
            beat: Millis::ZERO,
            out: Vec::new(),
        })
    }

    // ---- what the host reads ---------------------------------------------------

    /// Where it is in its life.
    pub fn stage(&self) -> Stage {
        self.stage
    }

    /// The interlock.
    pub fn interlock(&self) -> &Interlock {
        &self.interlock
    }

    /// Its configuration in force.
    pub fn config(&self) -> &InterlockConfig {
        &self.config
    }

    /// Why the state was unknown at start, until the lines faulted for it are cleared.
    pub fn lost(&self) -> Option<&str> {
        self.lost.as_deref()
    }

    /// The alarms.
    pub fn alarms(&self) -> &Alarms {
        &self.alarms
    }

    /// The latest alarm changes, newest last.
    pub fn recent_changes(&self) -> impl Iterator<Item = &AlarmChange> {
        self.recent_changes.iter()
    }

    /// The latest notable interlock events, newest last.
    pub fn recent_events(&self) -> impl Iterator<Item = &EventRecord> {
        self.recent_events.iter()
    }

    /// The counts as its nodes show them.
    pub fn counts(&self) -> Counts {
        let c = self.interlock.counts();
        Counts {
            holding: c.holding,
            queued: c.queued + self.held_back.len(),
            faulted: c.faulted,
            lost: self.lost.is_some(),
        }
    }

    /// Drained: nothing of its own keeps a deploy waiting (the runs that hold lines come with the plant).
    pub fn quiescent(&self) -> bool {
        true
    }

    /// The waiting requests held back by a drain, oldest first: (operation, priority, lines, since).
    pub fn held_back(&self) -> impl Iterator<Item = (&str, i32, &[Arc<str>], Millis)> {
        self.held_back.iter().filter_map(|msg| {
            self.requests
                .get(msg)
                .map(|r| (&*r.name, r.priority, &*r.names, r.since))
        })
    }

    /// The runs that came back held at start, for the host to supervise again (once).
    pub fn take_restored_runs(&mut self) -> Vec<RunSnapshot> {
        std::mem::take(&mut self.restored_runs)
    }

    /// The operations aborted and not reset.
    pub fn aborted(&self) -> &AbortedOperations {
        &self.aborted
    }

    /// The operations aborted and not reset, for the host's runs and routines
    /// (an abort they accept, a routine's reset); saved with the state.
    pub fn aborted_mut(&mut self) -> &mut AbortedOperations {
        &mut self.aborted
    }

    /// The routines' saved states, as read at start (kept for their hosts).
    pub fn saved_routines(&self) -> &serde_json::Map<String, serde_json::Value> {
        &self.saved_routines
    }

    /// Bounds the inputs that carry a msg parked while it starts (the host
    /// passes Node-RED's nodeMessageBufferMaxLength; 0: none, the default):
    /// one more is refused (QUEUE_FULL).
    pub fn set_park_bound(&mut self, max: usize) {
        self.park_bound = max;
    }

    /// The inputs parked for the start, with when each arrived, for a host
    /// that frees its engine before it starts (its start failed, or it
    /// stood down) and answers or moves their msgs itself.
    pub fn take_parked(&mut self) -> Vec<(Input, Millis)> {
        std::mem::take(&mut self.parked)
            .into_iter()
            .map(|p| (p.input, p.at))
            .collect()
    }

    /// Takes over the inputs another engine parked (see [`Engine::take_parked`]),
    /// each as of when it arrived: parked here too while this one starts
    /// (within its own bound), else taken now.
    pub fn receive_parked(&mut self, parked: Vec<(Input, Millis)>, now: Millis) {
        for (input, at) in parked {
            let at = at.min(now);
            if self.stage.gate() == Gate::Park {
                self.park(input, at);
            } else {
                self.take_input(input, now, at, &|_| Vec::new(), None);
            }
        }
    }

    /// When [`Engine::tick`] is next due, if ever.
    pub fn next_deadline(&self) -> Option<Millis> {
        if self.stage == Stage::Stopped {
            return None;
        }
        [
            self.deadlines.next(),
            self.parked_due(),
            self.interlock.next_warning().map(|at| self.on_beat(at)),
            self.alarm_due,
        ]
        .into_iter()
        .flatten()
        .min()
    }

    /// The first beat of the engine's checks at or after `at`.
    fn on_beat(&self, at: Millis) -> Millis {
        let since = at.saturating_sub(self.beat);
        let beats = (since.as_f64() / CHECK_MS.as_f64()).ceil();
        self.beat
            .saturating_add(CHECK_MS.mul_f64(beats).unwrap_or(Millis::MAX))
    }

    /// The outputs of the inputs so far, in order; the host performs them.
    pub fn take_outputs(&mut self) -> Vec<Output> {
        std::mem::take(&mut self.out)
    }

    /// The outputs so far, for a host that encodes them in place ([`Engine::clear_outputs`] after).
    pub fn outputs(&self) -> &[Output] {
        &self.out
    }

    /// Forgets the outputs read with [`Engine::outputs`].
    pub fn clear_outputs(&mut self) {
        self.out.clear();
    }

    // ---- inputs ----------------------------------------------------------------

    /// Deadlines due at `now` (see [`Engine::next_deadline`]).
    pub fn tick(&mut self, now: Millis) {
        self.handle(Input::Tick, now);
    }

    /// Takes one input at `now`; its outputs wait in [`Engine::take_outputs`].
    pub fn handle(&mut self, input: Input, now: Millis) {
        self.handle_checked(input, now, &|_| Vec::new());
    }

    /// [`Engine::handle`] for an interlock bound to a plant: `blockers` says
    /// why the plant does not show a line isolated (a clear is refused
    /// until it does, unless forced).
    pub fn handle_checked(&mut self, input: Input, now: Millis, blockers: Blockers<'_>) {
        self.handle_bound(input, now, blockers, None);
    }

    /// [`Engine::handle_checked`] with the plant itself: a start from a
    /// sealed document brings the runs saved held back held when `plant`
    /// still has their plans (see [`Engine::take_restored_runs`]).
    pub fn handle_bound(
        &mut self,
        input: Input,
        now: Millis,
        blockers: Blockers<'_>,
        plant: Option<&Plant>,
    ) {
        self.take_input(input, now, now, blockers, plant);
    }

    /// An input that arrived at `arrived` (before `now` when it was parked).
    fn take_input(
        &mut self,
        input: Input,
        now: Millis,
        arrived: Millis,
        blockers: Blockers<'_>,
        plant: Option<&Plant>,
    ) {
        let before = self.counts();
        match self.stage.gate() {
            Gate::Park if !matches!(input, Input::Start(_) | Input::Life(_)) => {
                if let Input::AddNode { .. } | Input::CloseNode { .. } = input {
                    self.configure(input);
                } else if let Input::Tick = input {
                    self.expire_parked(now);
                } else if let Input::Listen(on) = input {
                    // Who listens decides which events of the start itself go out.
                    self.listening = on;
                } else {
                    self.park(input, now);
                }
                return;
            }
            Gate::Closed => {
                self.refuse_stopped(input);
                return;
            }
            _ => {}
        }
        match input {
            Input::Start(saved) => self.start(saved, now, blockers, plant),
            Input::Life(step) => self.life(step, now),
            input @ (Input::AddNode { .. } | Input::CloseNode { .. }) => {
                if let Some(orphan) = self.configure(input) {
                    self.withdraw_node(orphan, now);
                }
            }
            Input::Acquire { node, msg, fields } => {
                self.acquire(node, msg, &fields, now, arrived.min(now))
            }
            Input::Release { node, msg, fields } => self.release(node, msg, &fields, now),
            Input::Cancel { node, msg, fields } => self.cancel(node, msg, &fields, now),
            Input::Fault { node, msg, fields } => self.fault(node, msg, &fields, now),
            Input::Clear {
                node,
                msg,
                fields,
                names_given,
            } => self.clear(node, msg, &fields, names_given, now, blockers),
            Input::Operator { msg, action, who } => self.operator(msg, action, &who, now, blockers),
            Input::PlantConditions(conditions) => {
                if self.plant_conditions != conditions {
                    self.plant_conditions = conditions;
                    self.observe_alarms(now, false);
                }
            }
            Input::ResendLockouts(why) => self.resend_lockouts(why, now),
            Input::Listen(on) => {
                self.listening = on;
                self.update_recording();
            }
            Input::StoreFailing(failing) => {
                if self.store_failing != failing {
                    self.store_failing = failing;
                    self.observe_alarms(now, false);
                }
            }
            Input::Tick => self.due(now),
        }
        self.after_input(before, now);
    }

    /// After every input: events out, alarms looked at when something abnormal happened, counts.
    fn after_input(&mut self, before: Counts, now: Millis) {
        let abnormal = self.flush_events();
        if abnormal {
            self.observe_alarms(now, true);
        }
        let counts = self.counts();
        if counts != before || counts != self.shown {
            self.shown = counts;
            // Shown at once by the host, whatever its place: only effects wait for a write.
            self.out.push(Output::Counts(counts));
        }
    }

    /// Whether every event goes out: something listens, or a deploy replaces
    /// the nodes (its events go to the listeners of the new flows).
    fn hears_all(&self) -> bool {
        self.listening || matches!(self.stage, Stage::HandingOver | Stage::HandingOverDraining)
    }

    fn update_recording(&mut self) {
        let all = self.hears_all();
        self.interlock.record_abnormal_only(!all);
    }

    /// Moves the interlock's events out; true when one was abnormal (alarms may have changed).
    fn flush_events(&mut self) -> bool {
        if !self.interlock.has_events() {
            return false;
        }
        let mut abnormal = false;
        for event in self.interlock.drain_events() {
            let record = self.interlock.describe(&event);
            if record.kind.is_abnormal() {
                abnormal = true;
                if self.recent_events.len() == RECENT {
                    self.recent_events.pop_front();
                }
                self.recent_events.push_back(record.clone());
            }
            // Abnormal events go out whoever listens now: the host hands them to
            // whoever listens once their state is written (a restart's events to
            // the events nodes of the flows it starts).
            if self.hears_all() || record.kind.is_abnormal() {
                self.out.push(Output::Event {
                    event: Box::new(record),
                });
            }
        }
        abnormal
    }

    // ---- life --------------------------------------------------------------------

    fn start(&mut self, saved: Saved, now: Millis, blockers: Blockers<'_>, plant: Option<&Plant>) {
        if !matches!(self.stage, Stage::Starting | Stage::StartingHeld) {
            return;
        }
        let (interlock, lost) = match self.restored(saved, now, plant) {
            Ok(pair) => pair,
            Err(err) => {
                // The configuration itself cannot run (checked when made): keep the fresh interlock.
                self.log(
                    Level::Error,
                    Text::Plain {
                        text: err.to_string(),
                    },
                );
                (self.interlock.clone(), None)
            }
        };
        self.interlock = interlock;
        self.update_recording();
        if let Some(why) = &lost {
            self.log(
                Level::Error,
                Text::Catalog {
                    key: "logs.stateUnknown",
                    params: vec![("why", Param::Text(why.clone()))],
                },
            );
        }
        self.lost = lost;
        self.beat = now;
        self.stage = self.stage.after(Step::Started);
        // The state as started is the first one on disk.
        self.out.push(Output::Commit { urgent: false });
        self.flush_events();
        self.observe_alarms(now, false);
        self.replay_parked(now, blockers);
    }

    /// Keeps an input that arrived at `now` for the start; past the bound, one that carries a msg is refused.
    fn park(&mut self, input: Input, now: Millis) {
        if self.park_bound > 0 && msg_of(&input).is_some() {
            let carrying = self
                .parked
                .iter()
                .filter(|p| msg_of(&p.input).is_some())
                .count();
            if carrying >= self.park_bound {
                let refusal = Refusal::catalog(
                    Code::QueueFull,
                    "errors.parkedFull",
                    vec![
                        ("kind", Param::Text("interlock".to_owned())),
                        ("max", Param::Text(self.park_bound.to_string())),
                    ],
                );
                return self.refuse_input(input, refusal);
            }
        }
        self.parked.push(Parked { input, at: now });
    }

    /// The inputs parked for the start, in arrival order, each as of when it arrived.
    fn replay_parked(&mut self, now: Millis, blockers: Blockers<'_>) {
        for Parked { input, at } in std::mem::take(&mut self.parked) {
            self.take_input(input, now, at, blockers, None);
        }
    }

    /// When the first parked acquire times out, if one has a timeout.
    fn parked_due(&self) -> Option<Millis> {
        self.parked
            .iter()
            .filter_map(|p| self.parked_deadline(p))
            .min()
    }

    /// When a parked input times out: an acquire of a node with a timeout, from its arrival.
    fn parked_deadline(&self, parked: &Parked) -> Option<Millis> {
        match &parked.input {
            Input::Acquire { node, .. } => self
                .node(*node)
                .and_then(timeout_of)
                .map(|t| parked.at.saturating_add(t)),
            _ => None,
        }
    }

    /// Parked acquires whose timeout ran out before the start are refused now,
    /// read without the interlock (the start replaces it): nothing changes, nothing is saved.
    fn expire_parked(&mut self, now: Millis) {
        let (due, kept): (Vec<Parked>, Vec<Parked>) = std::mem::take(&mut self.parked)
            .into_iter()
            .partition(|p| self.parked_deadline(p).is_some_and(|at| at <= now));
        self.parked = kept;
        for Parked { input, at } in due {
            if let Input::Acquire { node, msg, fields } = input {
                let refusal = self.parked_timed_out(node, &fields, at, now);
                self.refuse(node, msg, refusal);
            }
        }
    }

    /// Why a parked acquire is refused at its timeout: timed out, or what its msg's read refuses.
    fn parked_timed_out(
        &self,
        node: NodeId,
        fields: &MsgFields,
        at: Millis,
        now: Millis,
    ) -> Refusal {
        let Some(n) = self.node(node) else {
            return unknown_node(node);
        };
        let name = operation_name_of(
            &fields.operation,
            node_value(n, fields, Value::Operation),
            &Raw::Absent,
        );
        let names = resources_of(&fields.resources, node_value(n, fields, Value::Resources));
        match (name, names) {
            (Ok(name), Ok(names)) => {
                let timeout = timeout_of(n).unwrap_or(now.saturating_sub(at));
                timed_out_after(&name, &names, timeout)
            }
            (Err(refusal), _) | (_, Err(refusal)) => refusal,
        }
    }

    /// Stopped before it started: every parked msg is answered as a stopped engine answers it.
    fn unpark_stopped(&mut self) {
        for parked in std::mem::take(&mut self.parked) {
            self.refuse_stopped(parked.input);
        }
    }

    /// The interlock from what was saved (restored, or all faulted when it
    /// was lost or refused), and why it was lost.
    fn restored(
        &mut self,
        saved: Saved,
        now: Millis,
        plant: Option<&Plant>,
    ) -> Result<(Interlock, Option<String>), InterlockError> {
        let config = recording(&self.config);
        let why = match saved {
            Saved::First => return Ok((Interlock::new(config)?, None)),
            Saved::Lost(why) => why,
            Saved::Sealed(doc) => return self.opened(*doc, config, now, plant),
            Saved::Doc(doc) => {
                let doc = *doc;
                self.saved_routines = doc.routines;
                self.aborted = doc.aborted;
                if let Some(alarms) = doc.alarms {
                    let restored = serde_json::from_value(alarms)
                        .map_err(|e| e.to_string())
                        .and_then(|a| Alarms::restore(a).map_err(|e| e.to_string()));
                    match restored {
                        Ok(alarms) => self.alarms = alarms,
                        Err(err) => self.log(
                            Level::Warn,
                            Text::Catalog {
                                key: "logs.alarmsUnreadable",
                                params: vec![("message", Param::Text(err))],
                            },
                        ),
                    }
                }
                match Interlock::restore(
                    config.clone(),
                    &doc.interlock,
                    RestoreOptions::default(),
                    now,
                ) {
                    Ok((interlock, grants)) => {
                        debug_assert!(grants.is_empty(), "a restart keeps no waiting request");
                        return Ok((interlock, None));
                    }
                    Err(err) => err.to_string(),
                }
            }
        };
        let note = format!("state unknown after restart: {why}");
        Ok((Interlock::unknown_state(config, &note, now)?, Some(why)))
    }

    /// The interlock opened from its sealed document, the routines and alarms
    /// saved with it taken up, and why it was lost if it was.
    fn opened(
        &mut self,
        doc: SealedDoc,
        config: InterlockConfig,
        now: Millis,
        plant: Option<&Plant>,
    ) -> Result<(Interlock, Option<String>), InterlockError> {
        let binding = Binding {
            owner: &doc.owner,
            plant: doc.plant.as_deref(),
        };
        // Without its plant, a run saved held comes back interrupted, its lines faulted.
        let opened = Interlock::open(config, binding, &doc.source, &doc.text, plant, now)?;
        self.aborted = opened.aborted;
        self.restored_runs = opened.runs;
        for why in opened.runs_interrupted {
            self.log(
                Level::Warn,
                Text::Catalog {
                    key: "logs.heldRunNotRestored",
                    params: vec![("why", Param::Text(why))],
                },
            );
        }
        let (added, dropped) = match opened.start {
            Start::Lost { reason } => return Ok((opened.interlock, Some(reason))),
            Start::Restored { added, dropped } => (added, dropped),
        };
        for (key, lines) in [("logs.lineAdded", added), ("logs.lineDropped", dropped)] {
            for line in lines {
                self.log(
                    Level::Warn,
                    Text::Catalog {
                        key,
                        params: vec![("line", Param::Text(line))],
                    },
                );
            }
        }
        self.saved_routines = opened
            .routines
            .into_iter()
            .filter_map(|(id, routine)| Some((id, serde_json::to_value(routine).ok()?)))
            .collect();
        if let Some(alarms) = opened.alarms {
            match Alarms::restore(alarms) {
                Ok(alarms) => self.alarms = alarms,
                Err(err) => self.log(
                    Level::Warn,
                    Text::Catalog {
                        key: "logs.alarmsUnreadable",
                        params: vec![("message", Param::Text(err.to_string()))],
                    },
                ),
            }
        }
        Ok((opened.interlock, None))
    }

    fn life(&mut self, step: Step, now: Millis) {
        // A host that fails or stands down frees its engine instead.
        if step.host_only() {
            return;
        }
        let from = self.stage;
        let to = from.after(step);
        match step {
            Step::Shutdown => self.shut_down(),
            Step::Retire => self.retire(now),
            Step::DeployEnd => {
                let away: Vec<NodeId> = self
                    .nodes
                    .iter()
                    .filter(|(_, n)| n.away)
                    .map(|(id, _)| *id)
                    .collect();
                for node in away {
                    self.nodes.remove(&node);
                    self.withdraw_node(node, now);
                }
            }
            _ => {}
        }
        self.stage = to;
        self.update_recording();
        if from.gate() == Gate::Open && to.gate() == Gate::HoldBack {
            self.hold_back_queue(now);
        }
        if from.gate() == Gate::HoldBack && to.gate() == Gate::Open {
            self.requeue_held_back(now);
        }
    }

    /// A shutdown: nothing changes any more; every held msg is completed unsent.
    fn shut_down(&mut self) {
        let mut msgs: Vec<MsgId> = self.requests.keys().copied().collect();
        msgs.sort_unstable();
        for msg in msgs {
            self.out.push(Output::Complete { msg, refusal: None });
        }
        self.requests.clear();
        self.by_op.clear();
        self.held_back.clear();
        self.deadlines = Deadlines::default();
        self.unpark_stopped();
        self.alarm_due = None;
    }

    /// Removed from the flows: waiting requests are withdrawn (their msgs completed unsent) and the state saved.
    fn retire(&mut self, now: Millis) {
        if self.stage.gate() == Gate::Park {
            // Never started: no state of its own to save (what was saved stays as it was).
            return self.unpark_stopped();
        }
        let msgs: Vec<MsgId> = self.interlock_queue_msgs().into_iter().rev().collect();
        let mut effects = Vec::new();
        for msg in msgs {
            if let Some(request) = self.take_request(msg) {
                let grants = self.interlock.cancel(request.op, now).unwrap_or_default();
                effects.push(Output::Complete { msg, refusal: None });
                self.answer(grants, now, &mut effects);
            }
        }
        for msg in std::mem::take(&mut self.held_back) {
            if self.take_request(msg).is_some() {
                effects.push(Output::Complete { msg, refusal: None });
            }
        }
        self.commit(false, effects);
        self.unpark_stopped();
    }

    /// The msgs of the queued requests, in queue order.
    fn interlock_queue_msgs(&self) -> Vec<MsgId> {
        self.interlock
            .queued_operations()
            .into_iter()
            .filter_map(|op| self.by_op.get(&op).copied())
            .collect()
    }

    /// A drain begins: waiting requests leave the queue, so releases grant nobody until the new settings apply.
    fn hold_back_queue(&mut self, now: Millis) {
        let msgs = self.interlock_queue_msgs();
        let mut effects = Vec::new();
        for &msg in msgs.iter().rev() {
            let Some(request) = self.requests.get_mut(&msg) else {
                continue;
            };
            request.held_back = true;
            let op = request.op;
            self.by_op.remove(&op);
            let grants = self.interlock.cancel(op, now).unwrap_or_default();
            self.answer(grants, now, &mut effects);
        }
        for msg in msgs.into_iter().rev() {
            self.held_back.push_front(msg);
        }
        self.commit(false, effects);
    }

    /// The drain ended: held-back requests queue again in their old order, each with what is left of its timeout.
    fn requeue_held_back(&mut self, now: Millis) {
        for msg in std::mem::take(&mut self.held_back) {
            let Some(mut request) = self.requests.remove(&msg) else {
                continue;
            };
            request.held_back = false;
            if let Some(at) = request.deadline {
                self.deadlines.clear(at, Due::AcquireTimeout { msg });
            }
            // The interlock may have changed meanwhile (new settings): its handles are asked again.
            request.op = self.interlock.operation(&request.name);
            let names: Vec<&str> = request.names.iter().map(|n| &**n).collect();
            match self.interlock.resource_set(&names) {
                Ok(set) => request.set = set,
                Err(err) => {
                    self.refuse(request.node, msg, err.into());
                    continue;
                }
            }
            self.request(msg, request, now);
        }
    }

    // ---- nodes -------------------------------------------------------------------

    /// A node added or closed; returns a removed node whose requests must be withdrawn.
    fn configure(&mut self, input: Input) -> Option<NodeId> {
        match input {
            Input::AddNode { node, spec } => {
                self.nodes.insert(
                    node,
                    Node {
                        spec,
                        away: false,
                        op: None,
                        set: None,
                        priority: None,
                    },
                );
                None
            }
            Input::CloseNode { node, removed } => {
                if removed {
                    self.nodes.remove(&node);
                    Some(node)
                } else {
                    if let Some(n) = self.nodes.get_mut(&node) {
                        n.away = true;
                    }
                    None
                }
            }
            _ => None,
        }
    }

    /// A node left for good: its waiting requests are withdrawn (their msgs were completed when it closed).
    fn withdraw_node(&mut self, node: NodeId, now: Millis) {
        let mut effects = Vec::new();
        let queued: Vec<MsgId> = self.interlock_queue_msgs();
        let mut changed = false;
        for msg in queued.into_iter().rev() {
            if self.requests.get(&msg).is_some_and(|r| r.node == node) {
                let request = self.take_request(msg).expect("listed");
                let grants = self.interlock.cancel(request.op, now).unwrap_or_default();
                effects.push(Output::Complete { msg, refusal: None });
                self.answer(grants, now, &mut effects);
                changed = true;
            }
        }
        let held: Vec<MsgId> = self.held_back.iter().copied().collect();
        for msg in held {
            if self.requests.get(&msg).is_some_and(|r| r.node == node) {
                self.take_request(msg);
                self.out.push(Output::Complete { msg, refusal: None });
            }
        }
        if changed {
            self.commit(false, effects);
        }
    }

    fn node(&self, node: NodeId) -> Option<&Node> {
        self.nodes.get(&node)
    }

    // ---- requests ----------------------------------------------------------------

    /// The operation a msg names, with its interlock handle; a node's
    /// configured operation is resolved once (until the interlock forgets idle names).
    fn operation(
        &mut self,
        node: NodeId,
        fields: &MsgFields,
        follow: bool,
    ) -> Result<(Arc<str>, OpId), Refusal> {
        let epoch = self.interlock.forgettings();
        let Some(n) = self.nodes.get(&node) else {
            return Err(unknown_node(node));
        };
        let deployed = fields.configured.is_none();
        if !fields.operation.present() && deployed {
            if let Some((name, op, at)) = &n.op {
                if *at == epoch {
                    return Ok((name.clone(), *op));
                }
            }
        }
        let follow_value = if follow {
            fields.followed()
        } else {
            &Raw::Absent
        };
        let name = operation_name_of(
            &fields.operation,
            node_value(n, fields, Value::Operation),
            follow_value,
        )?;
        let configured = deployed && !fields.operation.present() && n.spec.operation.present();
        let op = self.interlock.operation(&name);
        // The interlock's text: the same name from every msg is one text, which the wire sends once.
        let name: Arc<str> = self
            .interlock
            .shared_operation_name(op)
            .unwrap_or_else(|| Arc::from(&*name));
        if configured {
            let epoch = self.interlock.forgettings();
            if let Some(n) = self.nodes.get_mut(&node) {
                n.op = Some((name.clone(), op, epoch));
            }
        }
        Ok((name, op))
    }

    /// The lines a msg asks for, as named and as a set.
    fn resources(
        &mut self,
        node: NodeId,
        fields: &MsgFields,
    ) -> Result<(ResourceSet, Names), Refusal> {
        let Some(n) = self.nodes.get(&node) else {
            return Err(unknown_node(node));
        };
        let deployed = fields.configured.is_none();
        if !fields.resources.present() && deployed {
            if let Some(set) = &n.set {
                return Ok(set.clone());
            }
        }
        let names = resources_of(&fields.resources, node_value(n, fields, Value::Resources))?;
        let set = match self.interlock.resource_set(&names) {
            Ok(set) => set,
            // A drain: the new settings may have the line. The request waits by its names,
            // read again when they apply (refused then if they lack it).
            Err(InterlockError::UnknownResource { .. }) if self.stage.gate() == Gate::HoldBack => {
                let names: Names = names.into_iter().map(Arc::from).collect();
                return Ok((ResourceSet::default(), names));
            }
            Err(err) => return Err(err.into()),
        };
        let names: Names = names
            .into_iter()
            .map(|n| {
                self.interlock
                    .shared_line_name(&n)
                    .unwrap_or_else(|| Arc::from(n))
            })
            .collect();
        if !fields.resources.present() && deployed {
            if let Some(n) = self.nodes.get_mut(&node) {
                n.set = Some((set.clone(), names.clone()));
            }
        }
        Ok((set, names))
    }

    fn priority(&mut self, node: NodeId, fields: &MsgFields) -> Result<i32, Refusal> {
        let Some(n) = self.nodes.get(&node) else {
            return Err(unknown_node(node));
        };
        let deployed = fields.configured.is_none();
        if !fields.priority.present() && deployed {
            if let Some(p) = n.priority {
                return Ok(p);
            }
        }
        let priority = priority_of(&fields.priority, node_value(n, fields, Value::Priority))?;
        if !fields.priority.present() && deployed {
            if let Some(n) = self.nodes.get_mut(&node) {
                n.priority = Some(priority);
            }
        }
        Ok(priority)
    }

    /// A deployed node's operation, priority, lines and timeout, when the msg
    /// names none and all three are resolved already: one look-up of the node.
    fn resolved(&self, node: NodeId, fields: &MsgFields) -> Option<(Resolved, Option<Millis>)> {
        if fields.configured.is_some()
            || fields.operation.present()
            || fields.priority.present()
            || fields.resources.present()
        {
            return None;
        }
        let n = self.nodes.get(&node)?;
        let (name, op, at) = n.op.as_ref()?;
        let (set, names) = n.set.as_ref()?;
        let priority = n.priority?;
        (*at == self.interlock.forgettings()).then(|| {
            let read = (name.clone(), *op, priority, set.clone(), names.clone());
            (read, timeout_of(n))
        })
    }

    /// An acquire that arrived at `arrived`: it waits, and times out, from then.
    fn acquire(
        &mut self,
        node: NodeId,
        msg: MsgId,
        fields: &MsgFields,
        now: Millis,
        arrived: Millis,
    ) {
        let read = self.resolved(node, fields).map(Ok).unwrap_or_else(|| {
            let (name, op) = self.operation(node, fields, false)?;
            let priority = self.priority(node, fields)?;
            let (set, names) = self.resources(node, fields)?;
            let timeout = self.node(node).and_then(timeout_of);
            Ok::<_, Refusal>(((name, op, priority, set, names), timeout))
        });
        let ((name, op, priority, set, names), timeout) = match read {
            Ok(read) => read,
            Err(refusal) => return self.refuse(node, msg, refusal),
        };
        let request = Request {
            node,
            op,
            name,
            priority,
            set,
            names,
            since: arrived,
            deadline: timeout.map(|t| arrived.saturating_add(t)),
            held_back: false,
        };
        if request.deadline.is_some_and(|at| at <= now) {
            // Parked while it started, past its timeout: it timed out waiting.
            return self.refuse(node, msg, timed_out(&request));
        }
        if self.stage.gate() == Gate::HoldBack {
            // A drain: it queues once the new settings apply. Refused now if it never could.
            if self.interlock.is_holding(op) || self.interlock.is_queued(op) {
                let refusal = self.interlock.acquire(op, priority, &request.set, now);
                if let Err(err) = refusal {
                    return self.refuse(node, msg, err.into());
                }
            }
            let mut request = request;
            request.held_back = true;
            self.keep(msg, request);
            self.held_back.push_back(msg);
            return;
        }
        self.request(msg, request, now);
    }

    /// Asks the interlock for a request's grant: granted (answered once saved), queued, or refused.
    fn request(&mut self, msg: MsgId, request: Request, now: Millis) {
        match self
            .interlock
            .acquire(request.op, request.priority, &request.set, now)
        {
            Ok(crate::interlock::Acquisition::Granted) => {
                // Kept nowhere: its names move into what is sent.
                let set = Set::Interlock {
                    waited_ms: now.saturating_sub(request.since),
                    operation: request.name,
                    priority: request.priority,
                    resources: request.names,
                };
                self.out.push(Output::Commit { urgent: false });
                self.out.push(Output::Send { msg, port: 0, set });
            }
            Ok(crate::interlock::Acquisition::Queued) => {
                if request.deadline.is_some_and(|at| at <= now) {
                    // Its time ran out while held back by a drain.
                    self.by_op.insert(request.op, msg);
                    self.keep(msg, request);
                    self.expire(msg, now);
                    return;
                }
                self.by_op.insert(request.op, msg);
                self.keep(msg, request);
                self.out.push(Output::Commit { urgent: false });
            }
            Err(err) => self.refuse(request.node, msg, err.into()),
        }
    }

    fn keep(&mut self, msg: MsgId, request: Request) {
        if let Some(at) = request.deadline {
            self.deadlines.set(at, Due::AcquireTimeout { msg });
        }
        self.requests.insert(msg, request);
    }

    /// Removes a waiting request (from the queue's index and its deadline).
    fn take_request(&mut self, msg: MsgId) -> Option<Request> {
        let request = self.requests.remove(&msg)?;
        if !request.held_back {
            self.by_op.remove(&request.op);
        } else {
            self.held_back.retain(|m| *m != msg);
        }
        if let Some(at) = request.deadline {
            self.deadlines.clear(at, Due::AcquireTimeout { msg });
        }
        Some(request)
    }

    /// Answers each grant, in grant order: a waiting msg goes on; a grant
    /// nobody waits for has nobody to do the work, so it is released at once
    /// (which may grant more).
    fn answer(&mut self, grants: Vec<Grant>, now: Millis, effects: &mut Vec<Output>) {
        let mut todo: VecDeque<Grant> = grants.into();
        while let Some(grant) = todo.pop_front() {
            if let Some(msg) = self.by_op.get(&grant.operation).copied() {
                let request = self.take_request(msg).expect("indexed");
                effects.push(Output::Send {
                    msg,
                    port: 0,
                    set: grant_set(&request, now),
                });
                continue;
            }
            let name = self
                .interlock
                .operation_name(grant.operation)
                .unwrap_or_default()
                .to_owned();
            effects.push(Output::Log {
                level: Level::Warn,
                text: Box::new(Text::Catalog {
                    key: "logs.grantedUnclaimed",
                    params: vec![("operation", Param::Text(name))],
                }),
            });
            if let Ok(more) = self.interlock.release(grant.operation, now) {
                todo.extend(more);
            }
        }
    }

    /// Answers grants straight into the outputs (after the commit already there).
    fn answer_here(&mut self, grants: Vec<Grant>, now: Millis) {
        if grants.is_empty() {
            return;
        }
        let mut out = std::mem::take(&mut self.out);
        self.answer(grants, now, &mut out);
        self.out = out;
    }

    fn release(&mut self, node: NodeId, msg: MsgId, fields: &MsgFields, now: Millis) {
        let Some(n) = self.nodes.get(&node) else {
            return self.refuse(node, msg, unknown_node(node));
        };
        // A node's configured operation is resolved once; a name from a msg each time.
        let configured = fields.configured.is_none()
            && !fields.operation.present()
            && n.spec.operation.present();
        let released = if configured {
            match self.operation(node, fields, false) {
                Ok((_, op)) => self.interlock.release(op, now),
                Err(refusal) => return self.refuse(node, msg, refusal),
            }
        } else {
            // The name borrowed from the msg: nothing is copied to look it up.
            let named = operation_name_of(
                &fields.operation,
                node_value(n, fields, Value::Operation),
                fields.followed(),
            );
            match named {
                Ok(name) => self.interlock.release_named(&name, now),
                Err(refusal) => return self.refuse(node, msg, refusal),
            }
        };
        match released {
            Ok(grants) => {
                self.out.push(Output::Commit { urgent: false });
                self.out.push(Output::Send {
                    msg,
                    port: 0,
                    set: Set::Nothing,
                });
                self.answer_here(grants, now);
            }
            Err(err) => self.refuse(node, msg, err.into()),
        }
    }

    /// The operation a release, cancel or fault names (msg, node, then the acquire it follows).
    fn named_operation(&self, node: NodeId, fields: &MsgFields) -> Result<String, Refusal> {
        let Some(n) = self.node(node) else {
            return Err(unknown_node(node));
        };
        operation_of(
            &fields.operation,
            node_value(n, fields, Value::Operation),
            fields.followed(),
        )
    }

    fn cancel(&mut self, node: NodeId, msg: MsgId, fields: &MsgFields, now: Millis) {
        let name = match self.named_operation(node, fields) {
            Ok(name) => name,
            Err(refusal) => return self.refuse(node, msg, refusal),
        };
        let who = attribution_of(&fields.who).unwrap_or_default();
        self.out.push(journal(
            Action::Cancel,
            who.by,
            who.reason,
            vec![name.clone()],
        ));
        let held = self
            .held_back
            .iter()
            .copied()
            .find(|m| self.requests.get(m).is_some_and(|r| *r.name == *name));
        if let Some(waiting) = held {
            // Taken out of the queue while a deploy drains: it is withdrawn here.
            self.take_request(waiting);
            self.out.push(Output::After);
            self.out.push(Output::Complete {
                msg: waiting,
                refusal: None,
            });
            self.out.push(Output::Send {
                msg,
                port: 0,
                set: Set::Nothing,
            });
            return;
        }
        match self.interlock.cancel_named(&name, now) {
            Ok(grants) => {
                let mut effects = Vec::new();
                if let Ok(op) = self.interlock.find_operation(&name) {
                    if let Some(waiting) = self.by_op.get(&op).copied() {
                        self.take_request(waiting);
                        effects.push(Output::Complete {
                            msg: waiting,
                            refusal: None,
                        });
                    }
                }
                effects.push(Output::Send {
                    msg,
                    port: 0,
                    set: Set::Nothing,
                });
                self.answer(grants, now, &mut effects);
                self.commit(false, effects);
            }
            Err(err) => self.refuse(node, msg, err.into()),
        }
    }

    fn fault(&mut self, node: NodeId, msg: MsgId, fields: &MsgFields, now: Millis) {
        let Some(NodeKind::Fault {
            by_resources,
            fail_msg,
        }) = self.node(node).map(|n| n.spec.kind.clone())
        else {
            return self.refuse(node, msg, unknown_node(node));
        };
        let read = (|| {
            let who = if by_resources {
                Some(attribution_of(&fields.who)?)
            } else {
                None
            };
            // A Catch node's error is the fault note, else an operator's stated reason, else a text payload.
            let note = note_of(&fields.error_message, &Raw::Absent)
                .or_else(|| who.as_ref().and_then(|w| w.reason.clone()))
                .or_else(|| note_of(&Raw::Absent, &fields.payload));
            let target = if by_resources {
                let n = self.node(node).expect("checked");
                Err(resources_of(
                    &fields.resources,
                    node_value(n, fields, Value::Resources),
                )?)
            } else {
                Ok(self.named_operation(node, fields)?)
            };
            Ok::<_, Refusal>((who, note, target))
        })();
        let (who, note, target) = match read {
            Ok(read) => read,
            Err(refusal) => return self.refuse(node, msg, refusal),
        };
        let outcome = match &target {
            Ok(operation) => self
                .interlock
                .find_operation(operation)
                .ok()
                .filter(|op| self.interlock.is_active(*op))
                .ok_or_else(|| InterlockError::UnknownOperation {
                    name: operation.clone(),
                })
                .and_then(|op| {
                    self.interlock
                        .fault(op, note.as_deref(), now)
                        .map(|o| (o, Some(op)))
                }),
            Err(lines) => {
                let who = who.clone().unwrap_or_default();
                self.out.push(journal(
                    Action::EStop,
                    who.by.clone(),
                    who.reason.clone(),
                    lines.clone(),
                ));
                self.interlock.resource_set(lines).and_then(|set| {
                    let by = Attribution::new(who.by.as_deref(), who.reason.as_deref(), false);
                    self.interlock
                        .fault_resources_by(&set, note.as_deref(), &by, now)
                        .map(|o| (o, None))
                })
            }
        };
        let (outcome, op) = match outcome {
            Ok(pair) => pair,
            Err(err) => return self.refuse(node, msg, err.into()),
        };
        let operation = target.as_ref().ok().cloned();
        let lockouts = self.lockout_msgs(
            &outcome.lockouts,
            operation.as_deref(),
            note.as_deref(),
            now,
        );
        let lines: Vec<String> = lockouts.iter().map(|l| l.resource.clone()).collect();
        let mut urgent = vec![Output::Emit {
            msg,
            port: 1,
            msgs: lockouts,
        }];
        if fail_msg {
            urgent.push(Output::Complete {
                msg,
                refusal: Some(Refusal::new(
                    Code::Faulted,
                    Text::Faulted {
                        operation: operation.clone(),
                        lines,
                        note: note.clone(),
                    },
                    Vec::new(),
                )),
            });
        } else {
            urgent.push(Output::Send {
                msg,
                port: 0,
                set: Set::Nothing,
            });
        }
        self.commit(true, urgent);
        let mut effects = Vec::new();
        if outcome.dropped {
            if let Some(waiting) = op.and_then(|op| self.by_op.get(&op).copied()) {
                self.take_request(waiting);
                effects.push(Output::Complete {
                    msg: waiting,
                    refusal: None,
                });
            }
        }
        self.answer(outcome.grants, now, &mut effects);
        self.commit(false, effects);
    }

    fn lockout_msgs(
        &self,
        lockouts: &[crate::interlock::Lockout],
        operation: Option<&str>,
        note: Option<&str>,
        now: Millis,
    ) -> Vec<LockoutMsg> {
        lockouts
            .iter()
            .map(|l| {
                let resource = self
                    .interlock
                    .resource_name(l.resource)
                    .unwrap_or_default()
                    .to_owned();
                LockoutMsg {
                    topic: lockout_topic(&resource),
                    payload: l.command.clone(),
                    resource,
                    operation: operation.map(str::to_owned),
                    note: note.map(str::to_owned),
                    fault_at_ms: now,
                }
            })
            .collect()
    }

    fn clear(
        &mut self,
        node: NodeId,
        msg: MsgId,
        fields: &MsgFields,
        names_given: bool,
        now: Millis,
        blockers: Blockers<'_>,
    ) {
        let Some(NodeKind::Clear {
            all_faulted,
            refusals_wired,
        }) = self.node(node).map(|n| n.spec.kind.clone())
        else {
            return self.refuse(node, msg, unknown_node(node));
        };
        let read = (|| {
            let names = if all_faulted && !names_given {
                None
            } else {
                let n = self.node(node).expect("checked");
                Some(resources_of(
                    &fields.resources,
                    node_value(n, fields, Value::Resources),
                )?)
            };
            Ok::<_, Refusal>((names, attribution_of(&fields.who)?))
        })();
        let (names, who) = match read {
            Ok(read) => read,
            Err(refusal) => return self.refuse(node, msg, refusal),
        };
        let target = names.clone().unwrap_or_else(|| vec!["all".to_owned()]);
        match self.clear_lines(names, &who, now, blockers) {
            Ok((cleared, effects_after)) => {
                let action = if who.force {
                    Action::ClearForced
                } else {
                    Action::Clear
                };
                let mut effects = vec![
                    journal(action, who.by.clone(), who.reason.clone(), target),
                    Output::Send {
                        msg,
                        port: 0,
                        set: Set::Cleared(Box::new(Cleared {
                            cleared,
                            by: who.by.clone().unwrap_or_else(|| UNKNOWN_BY.to_owned()),
                            reason: who.reason.clone(),
                            forced: who.force,
                        })),
                    },
                ];
                effects.extend(effects_after);
                self.commit_or_after(effects);
            }
            Err(refusal) => {
                if refusal.code == Code::ClearRefused {
                    self.out.push(journal(
                        Action::ClearRefused,
                        who.by.clone(),
                        who.reason.clone(),
                        target,
                    ));
                }
                if refusal.code == Code::ClearRefused && refusals_wired {
                    self.out.push(Output::NodeError {
                        node,
                        code: refusal.code,
                    });
                    self.out.push(Output::Send {
                        msg,
                        port: 1,
                        set: Set::Refused { refusal },
                    });
                } else {
                    self.refuse(node, msg, refusal);
                }
            }
        }
    }

    /// Clears `names`, or every faulted line; the lines cleared and what the
    /// grants it made send. Nothing to clear changes nothing.
    fn clear_lines(
        &mut self,
        names: Option<Vec<String>>,
        who: &Who,
        now: Millis,
        blockers: Blockers<'_>,
    ) -> Result<(Vec<String>, Vec<Output>), Refusal> {
        let targets = match names {
            Some(names) => names,
            None => {
                let faulted = self.interlock.faulted_resources();
                if faulted.is_empty() {
                    return Ok((Vec::new(), Vec::new()));
                }
                self.names_of(&faulted)
            }
        };
        let set = self.interlock.resource_set(&targets)?;
        let by = Attribution::new(who.by.as_deref(), who.reason.as_deref(), who.force);
        let grants = self.interlock.clear_checked(&set, &by, blockers, now)?;
        if self.lost.is_some() && !self.has_unknown_lines() {
            self.lost = None;
        }
        let mut effects = Vec::new();
        self.answer(grants, now, &mut effects);
        effects.insert(0, Output::Commit { urgent: false });
        Ok((targets, effects))
    }

    /// Outputs that begin with a commit are effects of a state change; others wait behind the effects waiting.
    fn commit_or_after(&mut self, mut effects: Vec<Output>) {
        if let Some(at) = effects
            .iter()
            .position(|o| matches!(o, Output::Commit { .. }))
        {
            // The commit goes first: the msg's answer is an effect of the clear.
            let commit = effects.remove(at);
            self.out.push(commit);
        } else {
            self.out.push(Output::After);
        }
        self.out.extend(effects);
    }

    fn has_unknown_lines(&self) -> bool {
        self.interlock
            .faulted_resources()
            .ids()
            .iter()
            .any(|r| self.interlock.fault_cause(*r) == Some(FaultCause::Unknown))
    }

    fn names_of(&self, set: &ResourceSet) -> Vec<String> {
        set.ids()
            .iter()
            .filter_map(|r| self.interlock.resource_name(*r))
            .map(str::to_owned)
            .collect()
    }

    /// Faulted lines send their lockouts again (faulted anew with a note that says why).
    fn resend_lockouts(&mut self, why: Resend, now: Millis) {
        if !self.plant_bound {
            return;
        }
        let faulted = self.interlock.faulted_resources();
        if faulted.is_empty() {
            return;
        }
        match self.interlock.fault_resources_by(
            &faulted,
            Some(why.note()),
            &Attribution::unknown(),
            now,
        ) {
            Ok(outcome) => {
                let lockouts = self.lockout_msgs(&outcome.lockouts, None, Some(why.note()), now);
                self.commit(true, vec![Output::Lockouts { lockouts }]);
            }
            Err(err) => self.log(
                Level::Error,
                Text::Catalog {
                    key: "logs.lockoutsNotResent",
                    params: vec![
                        ("lines", Param::Text(self.names_of(&faulted).join(", "))),
                        ("message", Param::Text(err.to_string())),
                    ],
                },
            ),
        }
    }

    // ---- operators ---------------------------------------------------------------

    fn operator(
        &mut self,
        msg: MsgId,
        action: OperatorAction,
        who: &WhoFields,
        now: Millis,
        blockers: Blockers<'_>,
    ) {
        let who = match attribution_of(who) {
            Ok(who) => who,
            Err(refusal) => {
                self.out.push(Output::Reply {
                    msg,
                    answer: Err(refusal),
                });
                return;
            }
        };
        let by = who.by.clone().unwrap_or_else(|| UNKNOWN_BY.to_owned());
        match action {
            OperatorAction::Clear { lines } => match self.clear_lines(lines, &who, now, blockers) {
                Ok((cleared, mut effects)) => {
                    effects.push(Output::Reply {
                        msg,
                        answer: Ok(serde_json::json!({ "cleared": cleared, "by": by })),
                    });
                    self.commit_or_after(effects);
                }
                Err(refusal) => self.out.push(Output::Reply {
                    msg,
                    answer: Err(refusal),
                }),
            },
            OperatorAction::EStop { lines } => {
                if lines.is_empty() {
                    self.out.push(Output::Reply {
                        msg,
                        answer: Err(Refusal::catalog(
                            Code::InvalidResources,
                            "errors.noLinesToStop",
                            Vec::new(),
                        )),
                    });
                    return;
                }
                let note = who
                    .reason
                    .clone()
                    .unwrap_or_else(|| "emergency stop from the editor".to_owned());
                let by_who = Attribution::new(who.by.as_deref(), who.reason.as_deref(), false);
                let outcome = self.interlock.resource_set(&lines).and_then(|set| {
                    self.interlock
                        .fault_resources_by(&set, Some(&note), &by_who, now)
                });
                match outcome {
                    Ok(outcome) => {
                        let lockouts = self.lockout_msgs(&outcome.lockouts, None, Some(&note), now);
                        let stopped: Vec<String> =
                            lockouts.iter().map(|l| l.resource.clone()).collect();
                        self.commit(
                            true,
                            vec![
                                Output::Lockouts { lockouts },
                                Output::Reply {
                                    msg,
                                    answer: Ok(serde_json::json!({ "stopped": stopped, "by": by })),
                                },
                            ],
                        );
                    }
                    Err(err) => self.out.push(Output::Reply {
                        msg,
                        answer: Err(err.into()),
                    }),
                }
            }
            OperatorAction::Alarm(action) => self.alarm_action(msg, action, &who, now),
            OperatorAction::Command { target, command } => {
                self.command(msg, target, command, &who, by)
            }
        }
    }

    /// An operator's command: the reset of an operation saved aborted; nothing else runs here.
    fn command(
        &mut self,
        msg: MsgId,
        target: CommandTarget,
        command: Command,
        who: &Who,
        by: String,
    ) {
        let refusal = |key, id: String| {
            Refusal::catalog(Code::UnknownRun, key, vec![("id", Param::Text(id))])
        };
        let answer = match target {
            CommandTarget::Routine(id) => Err(refusal("errors.noSuchRoutineRun", id)),
            CommandTarget::Operation(id) if self.aborted.state(&id) == State::Aborted => {
                match self.aborted.command(&id, command) {
                    Ok(state) => {
                        let effects = vec![
                            journal(
                                Action::Reset,
                                who.by.clone(),
                                who.reason.clone(),
                                vec![id.clone()],
                            ),
                            Output::Reply {
                                msg,
                                answer: Ok(serde_json::json!({
                                    "operation": id, "command": command, "state": state, "by": by
                                })),
                            },
                        ];
                        // Saved before it is answered: the reset stands once said.
                        self.commit(false, effects);
                        return;
                    }
                    Err(err) => Err(Refusal::plain(err.code(), err.to_string())),
                }
            }
            CommandTarget::Operation(id) => Err(refusal("errors.noSuchOperationRun", id)),
        };
        self.out.push(Output::Reply { msg, answer });
    }

    /// An alarm action, on the alarm states as of now (a person acts on what the page shows).
    fn alarm_action(&mut self, msg: MsgId, action: AlarmAction, who: &Who, now: Millis) {
        self.observe_alarms(now, false);
        let by = Attribution::new(who.by.as_deref(), who.reason.as_deref(), false);
        let (kind, result) = match &action {
            AlarmAction::Ack { ids } => (
                Action::AlarmAck,
                self.alarms.acknowledge(ids.as_deref(), &by, now),
            ),
            AlarmAction::Shelve {
                id,
                until_ms,
                one_shot,
            } => (
                Action::AlarmShelve,
                if *one_shot {
                    self.alarms.shelve_one_shot(id, *until_ms, &by, now)
                } else {
                    self.alarms.shelve(id, *until_ms, &by, now)
                },
            ),
            AlarmAction::Unshelve { id } => {
                (Action::AlarmUnshelve, self.alarms.unshelve(id, &by, now))
            }
        };
        let changes = match result {
            Ok(changes) => changes,
            Err(err) => {
                self.out.push(Output::Reply {
                    msg,
                    answer: Err(Refusal::plain(err.code(), err.to_string())),
                });
                return;
            }
        };
        let mut done: Vec<String> = changes
            .iter()
            .filter(|c| c.action != crate::alarm::AlarmAction::ShelfExpired)
            .map(|c| c.id.clone())
            .collect();
        done.dedup();
        if !done.is_empty() {
            self.out
                .push(journal(kind, who.by.clone(), who.reason.clone(), done));
        }
        self.keep_changes(&changes);
        let mut effects: Vec<Output> = changes
            .iter()
            .cloned()
            .map(|change| Output::Alarm {
                change: Box::new(change),
            })
            .collect();
        effects.push(Output::Reply {
            msg,
            answer: Ok(serde_json::json!({
                "changes": changes,
                "by": who.by.clone().unwrap_or_else(|| UNKNOWN_BY.to_owned()),
            })),
        });
        self.commit(false, effects);
        self.schedule_alarms(now);
    }

    // ---- time --------------------------------------------------------------------

    /// Every deadline due at `now`.
    fn due(&mut self, now: Millis) {
        while let Some(due) = self.deadlines.pop_due(now) {
            match due {
                Due::AcquireTimeout { msg } => self.expire(msg, now),
            }
        }
        if self
            .interlock
            .next_warning()
            .is_some_and(|at| self.on_beat(at) <= now)
        {
            for warning in self.interlock.tick(now) {
                let record = self.interlock.describe(&warning);
                let (key, seconds) = match record.kind {
                    EventKind::WarnQueued => ("events.waitedLong", record.waited_ms),
                    _ => ("events.heldLong", record.held_ms),
                };
                let seconds = seconds.unwrap_or_default().as_secs_f64().round();
                self.log(
                    Level::Warn,
                    Text::Catalog {
                        key,
                        params: vec![
                            (
                                "operation",
                                Param::Text(record.operation.clone().unwrap_or_default()),
                            ),
                            ("seconds", Param::Text(crate::text::js_number(seconds))),
                            ("lines", Param::Text(record.resources.join(", "))),
                        ],
                    },
                );
            }
            self.out.push(Output::Commit { urgent: false });
        }
        if self.alarm_due.is_some_and(|at| at <= now) {
            self.alarm_due = None;
            self.observe_alarms(now, false);
        }
    }

    /// A request waited past its acquire timeout: it is withdrawn and its msg refused.
    fn expire(&mut self, msg: MsgId, now: Millis) {
        let Some(request) = self.take_request(msg) else {
            return;
        };
        let mut effects = Vec::new();
        if !request.held_back {
            match self.interlock.cancel(request.op, now) {
                Ok(grants) => self.answer(grants, now, &mut effects),
                Err(err) => self.log(
                    Level::Warn,
                    Text::Catalog {
                        key: "logs.timedOutNotQueued",
                        params: vec![
                            ("operation", Param::Text(request.name.to_string())),
                            ("message", Param::Text(err.to_string())),
                        ],
                    },
                ),
            }
        }
        effects.push(Output::NodeError {
            node: request.node,
            code: Code::AcquireTimeout,
        });
        effects.push(Output::Complete {
            msg,
            refusal: Some(timed_out(&request)),
        });
        self.commit(false, effects);
    }

    // ---- alarms ------------------------------------------------------------------

    /// The conditions that hold now, to the alarms; `in_write`: the change is saved with the write already due.
    fn observe_alarms(&mut self, now: Millis, in_write: bool) {
        let mut conditions = self.interlock.alarm_conditions(now);
        if let Some(store) = &self.store_failing {
            conditions.push(Condition::new(AlarmKind::StateNotSaved, store));
        }
        conditions.extend(self.plant_conditions.iter().cloned());
        match self.alarms.observe(&conditions, now) {
            Ok(changes) if !changes.is_empty() => {
                self.keep_changes(&changes);
                if !in_write {
                    self.out.push(Output::Commit { urgent: false });
                }
                self.out
                    .extend(changes.into_iter().map(|change| Output::Alarm {
                        change: Box::new(change),
                    }));
            }
            Ok(_) => {}
            Err(err) => self.log(
                Level::Error,
                Text::Catalog {
                    key: "logs.alarmsNotUpdated",
                    params: vec![("message", Param::Text(err.to_string()))],
                },
            ),
        }
        self.schedule_alarms(now);
    }

    /// Alarms that change with time alone are looked at again: a shelf runs
    /// out, an on-delay ends, a long wait's text counts on.
    fn schedule_alarms(&mut self, now: Millis) {
        let timed = self.alarms.list().any(|a| {
            a.state.is_active() && matches!(a.kind, AlarmKind::WaitingLong | AlarmKind::HeldLong)
        }) || self.alarms.has_delayed();
        let refresh = timed.then(|| self.on_beat(now.saturating_add(ms(1))));
        self.alarm_due = [refresh, self.alarms.next_expiry_ms()]
            .into_iter()
            .flatten()
            .min();
    }

    fn keep_changes(&mut self, changes: &[AlarmChange]) {
        for change in changes {
            if self.recent_changes.len() == RECENT {
                self.recent_changes.pop_front();
            }
            self.recent_changes.push_back(change.clone());
        }
    }

    // ---- outputs -------------------------------------------------------------------

    /// A state change whose effects are `effects`.
    fn commit(&mut self, urgent: bool, effects: Vec<Output>) {
        self.out.push(Output::Commit { urgent });
        self.out.extend(effects);
    }

    fn refuse(&mut self, node: NodeId, msg: MsgId, refusal: Refusal) {
        self.out.push(Output::NodeError {
            node,
            code: refusal.code,
        });
        self.out.push(Output::Complete {
            msg,
            refusal: Some(refusal),
        });
    }

    /// An input after the engine stopped: its msg is completed unsent.
    fn refuse_stopped(&mut self, input: Input) {
        match msg_of(&input) {
            Some((None, msg)) => self.out.push(Output::Reply {
                msg,
                answer: Err(Refusal::plain(
                    Code::InterlockStopped,
                    "the interlock has stopped",
                )),
            }),
            Some((Some(_), msg)) => self.out.push(Output::Complete { msg, refusal: None }),
            None => {}
        }
    }

    /// Refuses an input's msg (an operator's request is answered with the refusal).
    fn refuse_input(&mut self, input: Input, refusal: Refusal) {
        match msg_of(&input) {
            Some((Some(node), msg)) => self.refuse(node, msg, refusal),
            Some((None, msg)) => self.out.push(Output::Reply {
                msg,
                answer: Err(refusal),
            }),
            None => {}
        }
    }

    /// Refuses a msg before it became an input (its time unreadable).
    pub fn refuse_msg(&mut self, msg: MsgId, refusal: Refusal) {
        self.out.push(Output::Complete {
            msg,
            refusal: Some(refusal),
        });
    }

    /// Answers an operator's request refused before it became an input (its fields unreadable).
    pub fn refuse_reply(&mut self, msg: MsgId, refusal: Refusal) {
        self.out.push(Output::Reply {
            msg,
            answer: Err(refusal),
        });
    }

    fn log(&mut self, level: Level, text: Text) {
        self.out.push(Output::Log {
            level,
            text: Box::new(text),
        });
    }
}

/// The configuration as the engine's interlock runs it: events recorded (the engine forwards them).
fn recording(config: &InterlockConfig) -> InterlockConfig {
    InterlockConfig {
        record_events: true,
        ..config.clone()
    }
}

impl Input {
    /// The msg it carries, if any (a node's msg, or an operator's request).
    pub fn msg(&self) -> Option<MsgId> {
        msg_of(self).map(|(_, msg)| msg)
    }
}

/// The node and msg an input carries (no node: an operator's request, answered by a reply).
fn msg_of(input: &Input) -> Option<(Option<NodeId>, MsgId)> {
    match *input {
        Input::Acquire { node, msg, .. }
        | Input::Release { node, msg, .. }
        | Input::Cancel { node, msg, .. }
        | Input::Fault { node, msg, .. }
        | Input::Clear { node, msg, .. } => Some((Some(node), msg)),
        Input::Operator { msg, .. } => Some((None, msg)),
        _ => None,
    }
}

/// Why a request that waited its whole timeout is refused.
fn timed_out(request: &Request) -> Refusal {
    let timeout = request
        .deadline
        .map_or(Millis::ZERO, |at| at.saturating_sub(request.since));
    timed_out_after(&request.name, &request.names, timeout)
}

/// Why a request of `operation` for `lines` that waited `timeout` is refused.
fn timed_out_after<S: AsRef<str>>(operation: &str, lines: &[S], timeout: Millis) -> Refusal {
    let lines: Vec<&str> = lines.iter().map(AsRef::as_ref).collect();
    Refusal::catalog(
        Code::AcquireTimeout,
        "errors.acquireTimeout",
        vec![
            ("operation", Param::Text(operation.to_owned())),
            ("resources", Param::Text(lines.join(", "))),
            (
                "seconds",
                Param::Text(crate::text::js_number(timeout.as_f64() / 1000.0)),
            ),
        ],
    )
}

fn grant_set(request: &Request, now: Millis) -> Set {
    Set::Interlock {
        operation: request.name.clone(),
        priority: request.priority,
        resources: request.names.clone(),
        waited_ms: now.saturating_sub(request.since),
    }
}

/// A value a node reads where the msg gives none.
#[derive(Clone, Copy)]
enum Value {
    Operation,
    Priority,
    Resources,
}

/// The node's `value`: as read for this msg when the host read it, else as deployed.
fn node_value<'a>(n: &'a Node, fields: &'a Fields, value: Value) -> &'a Raw {
    let values = fields.configured.as_ref();
    match value {
        Value::Operation => values.map_or(&n.spec.operation, |c| &c.operation),
        Value::Priority => values.map_or(&n.spec.priority, |c| &c.priority),
        Value::Resources => values.map_or(&n.spec.resources, |c| &c.resources),
    }
}

/// An acquire node's timeout, when it has one.
fn timeout_of(n: &Node) -> Option<Millis> {
    match n.spec.kind {
        NodeKind::Acquire { timeout_ms } if timeout_ms > Millis::ZERO => Some(timeout_ms),
        _ => None,
    }
}

fn unknown_node(node: NodeId) -> Refusal {
    Refusal::plain(
        Code::Internal,
        format!("node #{} is not known to this interlock", node.0),
    )
}

/// An operator's action for the journal.
fn journal(
    action: Action,
    by: Option<String>,
    reason: Option<String>,
    target: Vec<String>,
) -> Output {
    Output::Journal(Box::new(Journal {
        action,
        by,
        reason,
        target,
    }))
}

pub use crate::plant::group_msg::{lockout_topic, LOCKOUT_PREFIX};

#[cfg(test)]
mod tests;
