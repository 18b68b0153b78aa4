use std::collections::{BTreeMap, HashMap};

use js_sys::Reflect;
use serde::{Deserialize, Serialize};
use sugarshack_core::alarm::AlarmsSnapshot;
use sugarshack_core::clearance::{Attribution, ClearBlocker, LineBlockers};
use sugarshack_core::code::Code;
use sugarshack_core::interlock::Interlock as CoreInterlock;
use sugarshack_core::interlock::{
    Beside, Binding, FaultOutcome, Grant, InterlockConfig, InterlockError, OpId, ResourceSet,
    RestoreOptions, Snapshot, Start,
};
use sugarshack_core::operation::{AbortedOperations, RunSnapshot};
use sugarshack_core::plant::group_msg::lockout_topic;
use sugarshack_core::routine::RoutineSnapshot;
use sugarshack_core::time::Millis;
use wasm_bindgen::prelude::*;

use crate::{from_js_bounded, js_error, time, to_js, Bound};

/// The TypeScript shapes of what this module's calls return and take
/// (`unchecked_return_type` / `unchecked_param_type` name them).
#[wasm_bindgen(typescript_custom_section)]
const TS_SHAPES: &str = r#"
/** The kind of an interlock event record. */
export type EventKind =
    | "granted" | "queued" | "released" | "cancelled" | "faulted" | "dropped"
    | "resource-faulted" | "cleared" | "interrupted" | "resource-added"
    | "state-unknown" | "warn-queued" | "warn-held";

/** One interlock event with names, as journalled. */
export interface EventRecord {
    atMs: number;
    kind: EventKind;
    operation?: string;
    priority?: number;
    resources: string[];
    waitedMs?: number;
    heldMs?: number;
    note?: string;
    by?: string;
    reason?: string;
    /** Present (true) only on a clear that overrode the plant's reasons. */
    forced?: boolean;
}

/** `Interlock.counts()`. */
export interface InterlockCounts {
    holding: number;
    queued: number;
    faulted: number;
}

/** A lockout command a fault sends for one line. */
export interface LockoutCommand {
    resource: string;
    /** `lockout/<resource>`: the topic its msg goes out on. */
    topic: string;
    command: GroupCommand | null;
}

/** What `fault` and `faultResources` did. */
export interface FaultOutcome {
    lockouts: LockoutCommand[];
    /** Whether the faulted operation's waiting request was dropped. */
    dropped: boolean;
    /** Handles of the operations granted meanwhile, in grant order. */
    grants: number[];
}

/** One line of an interlock configuration. */
export interface ResourceConfig {
    name: string;
    lockout?: GroupCommand | null;
}

/** `new Interlock(config)`. */
export interface InterlockConfig {
    resources: ResourceConfig[];
    policy?: "greedy" | "no-overtaking";
    queueBound?: number;
    warnQueuedMs?: number | null;
    warnHeldMs?: number | null;
    recordEvents?: boolean;
}

/** A reason a line may not be cleared yet. */
export type ClearBlocker =
    | { kind: "lockoutPending"; actuator: string; sends: number }
    | { kind: "offLockout"; actuator: string; position: number; lockout: number }
    | { kind: "noFeedback"; actuator: string }
    | { kind: "stale"; actuator: string }
    | { kind: "deviceOffline"; device: string };

/** Every reason that keeps one line from being cleared (none: it may be). */
export interface LineBlockers {
    line: string;
    reasons: ClearBlocker[];
    /** The core's words for each reason, in order. */
    texts: string[];
}

/** A request (waiting) or hold, by name, in a snapshot. */
export interface RequestSnapshot {
    operation: string;
    priority: number;
    resources: string[];
    sinceMs: number;
    waitedMs: number;
}

/** One line and its state, in a snapshot. */
export interface ResourceSnapshot {
    name: string;
    state:
        | { state: "free" }
        | { state: "held"; operation: string }
        | { state: "faulted"; cause: "operation" | "manual" | "interrupted" | "unknown"; operation?: string; note?: string; sinceMs: number };
}

/** `Interlock.open()`: the interlock and how it started. */
export interface OpenedInterlock {
    interlock: Interlock;
    /** Why the saved state was not usable (every line faulted), or null. */
    lost: string | null;
    /** Lines configured after the save: they start free. */
    added: string[];
    /** Lines saved but no longer configured. */
    dropped: string[];
    /** The routines' states saved with it, by routine id. */
    routines: Record<string, RoutineSnapshot>;
    alarms: AlarmsSnapshot | null;
    /** The held runs that came back held, their lines kept: restore each with `Tracker.restoreRun`. */
    runs: RunSnapshot[];
    /** Why each other held run did not come back held (its lines came back faulted). */
    runsInterrupted: string[];
    /** The aborted operations, for `new AbortedOperations(...)`. */
    aborted: Record<string, unknown>;
}

/** What an interlock's state document keeps beside the interlock (`Interlock.seal`). */
export interface SavedBeside {
    routines: Record<string, RoutineSnapshot>;
    alarms?: AlarmsSnapshot;
    runs?: RunSnapshot[];
    aborted?: Record<string, unknown>;
}

/** `Interlock.snapshot()`: the whole state by name, for persistence. */
export interface InterlockSnapshot {
    version: number;
    takenAtMs: number;
    configured: string[];
    resources: ResourceSnapshot[];
    queue: RequestSnapshot[];
    holds: RequestSnapshot[];
}
"#;

/// A line's reasons with the core's words for each, as JS gets them.
#[derive(Serialize)]
struct WordedBlockers<'a> {
    line: &'a str,
    reasons: &'a [ClearBlocker],
    texts: Vec<String>,
}

fn worded(lines: &[LineBlockers]) -> Vec<WordedBlockers<'_>> {
    lines
        .iter()
        .map(|l| WordedBlockers {
            line: &l.line,
            reasons: &l.reasons,
            texts: l.reasons.iter().map(ToString::to_string).collect(),
        })
        .collect()
}

fn core_error(err: InterlockError) -> JsValue {
    let error = js_error(err.code(), &err.to_string());
    if let InterlockError::ClearRefused { lines } = &err {
        // Every reason, per line, for a dashboard to list.
        if let Ok(lines) = to_js(&worded(lines)) {
            let _ = js_sys::Reflect::set(&error, &"lines".into(), &lines);
        }
    }
    error
}

fn parse_config(config: JsValue) -> Result<InterlockConfig, JsValue> {
    from_js_bounded(
        config,
        Code::InvalidConfig,
        "invalid interlock configuration",
        Bound::InterlockConfig,
    )
}

/// An operation's handle as JS holds it: a whole number below 2^53.
fn op_handle(op: OpId) -> f64 {
    op.to_bits() as f64
}

fn handles(grants: &[Grant]) -> Vec<f64> {
    grants.iter().map(|g| op_handle(g.operation)).collect()
}

/// How many resource-set handles an interlock keeps before it drops them all
/// (a flow naming ever new combinations of lines would grow it without end);
/// at about 100 bytes a set, a few MB at most.
pub const RESOURCE_SETS_KEPT: usize = 65_536;

/// The set of a handle made under `generation`; refused otherwise.
fn set_of(sets: &[ResourceSet], generation: u32, handle: f64) -> Result<&ResourceSet, JsValue> {
    whole(handle)
        .filter(|bits| bits >> 32 == u64::from(generation))
        .and_then(|bits| sets.get(bits as u32 as usize))
        .ok_or_else(|| {
            js_error(
                Code::UnknownResourceSet,
                &format!(
                    "resource set handle {handle} was not made by this interlock, or was dropped"
                ),
            )
        })
}

/// A whole number below 2^53 as an integer, or `None`.
fn whole(handle: f64) -> Option<u64> {
    (handle >= 0.0 && handle.fract() == 0.0 && handle < 9_007_199_254_740_992.0)
        .then_some(handle as u64)
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct LockoutView<'a> {
    resource: &'a str,
    topic: String,
    command: &'a serde_json::Value,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct FaultView<'a> {
    lockouts: Vec<LockoutView<'a>>,
    dropped: bool,
    grants: Vec<f64>,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct OpenedView<'a> {
    lost: Option<String>,
    added: Vec<String>,
    dropped: Vec<String>,
    routines: &'a BTreeMap<String, RoutineSnapshot>,
    alarms: Option<&'a AlarmsSnapshot>,
    runs: &'a [RunSnapshot],
    runs_interrupted: &'a [String],
    aborted: &'a AbortedOperations,
}

/// What the JS gives `seal` to keep beside the interlock.
#[derive(Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
struct SavedBeside {
    routines: BTreeMap<String, RoutineSnapshot>,
    #[serde(default)]
    alarms: Option<AlarmsSnapshot>,
    #[serde(default)]
    runs: Vec<RunSnapshot>,
    #[serde(default)]
    aborted: AbortedOperations,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct CountsView {
    holding: usize,
    queued: usize,
    faulted: usize,
}

/// The resource interlock, as JS sees it.
#[wasm_bindgen]
pub struct Interlock {
    core: CoreInterlock,
    sets: Vec<ResourceSet>,
    set_index: HashMap<Vec<u32>, u32>,
    /// How many times the resource-set handles were dropped; part of each
    /// handle, so one made before is refused, never taken for another set.
    set_generation: u32,
    /// Operations granted by the last release, cancel or clear, read with
    /// `granted(i)`: returning a count spares a typed array per call.
    granted: Vec<f64>,
    /// The refusal of the last `acquireCode` or `releaseCode` that returned -1.
    error: Option<JsValue>,
}

impl Interlock {
    fn wrap(core: CoreInterlock) -> Self {
        Interlock {
            core,
            sets: Vec::new(),
            set_index: HashMap::new(),
            set_generation: 0,
            granted: Vec::new(),
            error: None,
        }
    }

    fn refused(&mut self, err: JsValue) -> i32 {
        self.error = Some(err);
        -1
    }

    fn op(&self, handle: f64) -> Result<OpId, JsValue> {
        whole(handle)
            .and_then(OpId::from_bits)
            .filter(|&op| self.core.operation_name(op).is_some())
            .ok_or_else(|| {
                core_error(InterlockError::UnknownOperation {
                    name: format!("#{handle}"),
                })
            })
    }

    fn set(&self, handle: f64) -> Result<&ResourceSet, JsValue> {
        set_of(&self.sets, self.set_generation, handle)
    }

    fn set_handle(&self, index: u32) -> f64 {
        (u64::from(self.set_generation) << 32 | u64::from(index)) as f64
    }

    /// A release or cancel by name; what it granted is kept for `granted(i)`.
    fn by_name(
        &mut self,
        name: &str,
        now_ms: f64,
        call: fn(&mut CoreInterlock, &str, Millis) -> Result<Vec<Grant>, InterlockError>,
    ) -> Result<u32, JsValue> {
        if name.is_empty() {
            return Err(js_error(
                Code::MissingOperation,
                "an operation id is required",
            ));
        }
        let grants = call(&mut self.core, name, time(now_ms)?).map_err(core_error)?;
        Ok(self.keep_granted(&grants))
    }

    /// A clear of `set` by `who`, each line checked against `blockers`; what it granted is kept.
    fn clear_with(
        &mut self,
        set: f64,
        (by, reason, force): (Option<String>, Option<String>, bool),
        now_ms: f64,
        blockers: impl Fn(&str) -> Vec<ClearBlocker>,
    ) -> Result<u32, JsValue> {
        let who = &Attribution::new(by.as_deref(), reason.as_deref(), force);
        let now = time(now_ms)?;
        let set = self.set(set)?.clone();
        let grants = self
            .core
            .clear_checked(&set, who, blockers, now)
            .map_err(core_error)?;
        Ok(self.keep_granted(&grants))
    }

    fn keep_granted(&mut self, grants: &[Grant]) -> u32 {
        self.granted.clear();
        self.granted
            .extend(grants.iter().map(|g| op_handle(g.operation)));
        self.granted.len() as u32
    }

    fn fault_view(&self, outcome: FaultOutcome) -> Result<JsValue, JsValue> {
        let lockouts = outcome
            .lockouts
            .iter()
            .map(|l| {
                let resource = self.core.resource_name(l.resource).unwrap_or_default();
                LockoutView {
                    resource,
                    topic: lockout_topic(resource),
                    command: &l.command,
                }
            })
            .collect();
        to_js(&FaultView {
            lockouts,
            dropped: outcome.dropped,
            grants: handles(&outcome.grants),
        })
    }
}

#[wasm_bindgen]
impl Interlock {
    /// `config`: `{ resources: [{ name, lockout }], policy: "greedy" | "no-overtaking",
    /// queueBound, warnQueuedMs, warnHeldMs, recordEvents }`.
    #[wasm_bindgen(constructor)]
    pub fn new(
        #[wasm_bindgen(unchecked_param_type = "InterlockConfig")] config: JsValue,
    ) -> Result<Interlock, JsValue> {
        let config = parse_config(config)?;
        CoreInterlock::new(config)
            .map(Interlock::wrap)
            .map_err(core_error)
    }

    /// Rebuilds a saved state (snapshot version 1 or 2), checked whole first:
    /// a snapshot that contradicts itself is refused (`INVALID_SNAPSHOT`).
    /// `keepQueue` false drops waiting requests (their callers are gone).
    /// `keepHolds` false (a restart) restores held lines as faulted; true (a
    /// hand-over inside one running process) keeps each hold whose lines are
    /// all still configured. Operations a changed configuration lets through
    /// at once are read with `granted(i)`.
    pub fn restore(
        #[wasm_bindgen(unchecked_param_type = "InterlockConfig")] config: JsValue,
        #[wasm_bindgen(unchecked_param_type = "InterlockSnapshot")] snapshot: JsValue,
        keep_queue: bool,
        keep_holds: bool,
        now_ms: f64,
    ) -> Result<Interlock, JsValue> {
        let config = parse_config(config)?;
        let snapshot: Snapshot = from_js_bounded(
            snapshot,
            Code::InvalidSnapshot,
            "cannot restore interlock state",
            Bound::InterlockSnapshot,
        )?;
        let options = RestoreOptions {
            keep_queue,
            keep_holds,
        };
        let (core, grants) = CoreInterlock::restore(config, &snapshot, options, time(now_ms)?)
            .map_err(core_error)?;
        let mut lock = Interlock::wrap(core);
        lock.keep_granted(&grants);
        Ok(lock)
    }

    /// A restart from the state document `text` read from `source` (named in
    /// a refusal), as the interlock `owner` bound to `plant`: restored (a line
    /// added to the configuration since the save starts free, in `added`), or,
    /// when it is not this interlock's usable state, every line faulted with
    /// the reason in `lost`. Refused only for a configuration that cannot run.
    /// Without a plant's tracker, no held run comes back held (see `openBound`).
    #[wasm_bindgen(unchecked_return_type = "OpenedInterlock")]
    pub fn open(
        #[wasm_bindgen(unchecked_param_type = "InterlockConfig")] config: JsValue,
        owner: &str,
        plant: Option<String>,
        source: &str,
        text: &str,
        now_ms: f64,
    ) -> Result<JsValue, JsValue> {
        Self::opened(config, owner, plant, source, text, now_ms, None)
    }

    /// `open` for an interlock bound to `tracker`'s plant: a run saved held
    /// comes back held (in `runs`, its lines kept) when the plant still has
    /// the plan it ran.
    #[wasm_bindgen(js_name = openBound, unchecked_return_type = "OpenedInterlock")]
    pub fn open_bound(
        #[wasm_bindgen(unchecked_param_type = "InterlockConfig")] config: JsValue,
        owner: &str,
        plant: Option<String>,
        source: &str,
        text: &str,
        now_ms: f64,
        tracker: &crate::Tracker,
    ) -> Result<JsValue, JsValue> {
        Self::opened(
            config,
            owner,
            plant,
            source,
            text,
            now_ms,
            Some(tracker.core.plant()),
        )
    }

    /// Its state document at `nowMs`, with what is kept beside it (the
    /// routines' states by routine id, the alarms, the held runs, the aborted
    /// operations), sealed as the interlock `owner` bound to `plant`.
    pub fn seal(
        &self,
        owner: &str,
        plant: Option<String>,
        #[wasm_bindgen(unchecked_param_type = "SavedBeside")] beside: JsValue,
        now_ms: f64,
    ) -> Result<String, JsValue> {
        let now = time(now_ms)?;
        let beside: SavedBeside = from_js_bounded(
            beside,
            Code::InvalidSnapshot,
            "invalid state beside the interlock",
            Bound::InterlockSnapshot,
        )?;
        let binding = Binding {
            owner,
            plant: plant.as_deref(),
        };
        let beside = Beside {
            routines: beside.routines,
            alarms: beside.alarms,
            runs: beside.runs,
            aborted: beside.aborted,
        };
        Ok(self.core.seal(binding, beside, now))
    }

    /// A start without a usable saved state: every line faulted (cause
    /// `"unknown"`) with `note`, until a person clears it.
    #[wasm_bindgen(js_name = unknownState)]
    pub fn unknown_state(
        #[wasm_bindgen(unchecked_param_type = "InterlockConfig")] config: JsValue,
        note: Option<String>,
        now_ms: f64,
    ) -> Result<Interlock, JsValue> {
        let config = parse_config(config)?;
        let now = time(now_ms)?;
        CoreInterlock::unknown_state(config, note.as_deref().unwrap_or_default(), now)
            .map(Interlock::wrap)
            .map_err(core_error)
    }

    /// The handle of an operation, registering the name on first use. Past
    /// the names an interlock keeps, registering forgets the idle ones and
    /// `handleEpoch()` changes: handles kept by name must be asked again.
    pub fn operation(&mut self, name: &str) -> Result<f64, JsValue> {
        if name.is_empty() {
            return Err(js_error(
                Code::MissingOperation,
                "an operation id is required",
            ));
        }
        Ok(op_handle(self.core.operation(name)))
    }

    /// The handle of an operation that holds, waits or is named by a fault.
    #[wasm_bindgen(js_name = findOperation)]
    pub fn find_operation(&self, name: &str) -> Result<f64, JsValue> {
        self.core
            .find_operation(name)
            .map(op_handle)
            .map_err(core_error)
    }

    #[wasm_bindgen(js_name = operationName)]
    pub fn operation_name(&self, handle: f64) -> Option<String> {
        let op = self.op(handle).ok()?;
        self.core.operation_name(op).map(str::to_owned)
    }

    /// Changes whenever handles made before may be refused (idle operations
    /// forgotten, resource-set handles dropped): a cache of handles by name
    /// is emptied then. It changes only in `operation` and `resourceSet`.
    #[wasm_bindgen(js_name = handleEpoch)]
    pub fn handle_epoch(&self) -> f64 {
        self.core.forgettings() as f64 + f64::from(self.set_generation)
    }

    /// A handle for a set of resource names; the same names give the same
    /// handle until `handleEpoch()` changes.
    #[wasm_bindgen(js_name = resourceSet)]
    pub fn resource_set(&mut self, names: Vec<String>) -> Result<f64, JsValue> {
        let set = self.core.resource_set(&names).map_err(core_error)?;
        let key: Vec<u32> = set.ids().iter().map(|r| r.index() as u32).collect();
        if let Some(&index) = self.set_index.get(&key) {
            return Ok(self.set_handle(index));
        }
        if self.sets.len() >= RESOURCE_SETS_KEPT {
            self.sets.clear();
            self.set_index.clear();
            self.set_generation = (self.set_generation + 1) & ((1 << 21) - 1);
        }
        let index = self.sets.len() as u32;
        self.sets.push(set);
        self.set_index.insert(key, index);
        Ok(self.set_handle(index))
    }

    /// True when granted at once, false when queued.
    pub fn acquire(
        &mut self,
        op: f64,
        priority: i32,
        set: f64,
        now_ms: f64,
    ) -> Result<bool, JsValue> {
        let op = self.op(op)?;
        let now = time(now_ms)?;
        // The set is borrowed apart from the core it is given to.
        let set = set_of(&self.sets, self.set_generation, set)?;
        let acquisition = self
            .core
            .acquire(op, priority, set, now)
            .map_err(core_error)?;
        Ok(acquisition == sugarshack_core::interlock::Acquisition::Granted)
    }

    /// `acquire` as the nodes call it per msg: 1 granted, 0 queued, -1 refused
    /// (read the error with `takeError()`). A number crosses back where a
    /// `Result` costs a three-value array allocated in JS on every call.
    #[wasm_bindgen(js_name = acquireCode)]
    pub fn acquire_code(&mut self, op: f64, priority: i32, set: f64, now_ms: f64) -> i32 {
        match self.acquire(op, priority, set, now_ms) {
            Ok(granted) => i32::from(granted),
            Err(err) => self.refused(err),
        }
    }

    /// `release` as the nodes call it: how many waiting operations it granted, or -1 (see `takeError()`).
    #[wasm_bindgen(js_name = releaseCode)]
    pub fn release_code(&mut self, op: f64, now_ms: f64) -> f64 {
        match self.release(op, now_ms) {
            Ok(count) => f64::from(count),
            Err(err) => f64::from(self.refused(err)),
        }
    }

    /// The refusal of the last call that returned -1, once.
    #[wasm_bindgen(js_name = takeError, unchecked_return_type = "SugarshackError | undefined")]
    pub fn take_error(&mut self) -> JsValue {
        self.error.take().unwrap_or(JsValue::UNDEFINED)
    }

    /// Releases and returns how many waiting operations it granted; read them with `granted(i)`.
    pub fn release(&mut self, op: f64, now_ms: f64) -> Result<u32, JsValue> {
        let op = self.op(op)?;
        let grants = self.core.release(op, time(now_ms)?).map_err(core_error)?;
        Ok(self.keep_granted(&grants))
    }

    /// Withdraws a waiting request; returns how many others it let through (see `granted`).
    pub fn cancel(&mut self, op: f64, now_ms: f64) -> Result<u32, JsValue> {
        let op = self.op(op)?;
        let grants = self.core.cancel(op, time(now_ms)?).map_err(core_error)?;
        Ok(self.keep_granted(&grants))
    }

    /// `release` by operation name; a name never seen holds nothing (`NOT_HOLDING`)
    /// and is not registered.
    #[wasm_bindgen(js_name = releaseNamed)]
    pub fn release_named(&mut self, name: &str, now_ms: f64) -> Result<u32, JsValue> {
        self.by_name(name, now_ms, CoreInterlock::release_named)
    }

    /// `cancel` by operation name; a name never seen waits for nothing (`NOT_QUEUED`)
    /// and is not registered.
    #[wasm_bindgen(js_name = cancelNamed)]
    pub fn cancel_named(&mut self, name: &str, now_ms: f64) -> Result<u32, JsValue> {
        self.by_name(name, now_ms, CoreInterlock::cancel_named)
    }

    /// The handle of the i-th operation granted by the last release, cancel,
    /// clear or restore, in grant order.
    pub fn granted(&self, index: u32) -> Option<f64> {
        self.granted.get(index as usize).copied()
    }

    /// `{ lockouts: [{ resource, topic, command }], dropped, grants }`.
    #[wasm_bindgen(unchecked_return_type = "FaultOutcome")]
    pub fn fault(
        &mut self,
        op: f64,
        note: Option<String>,
        now_ms: f64,
    ) -> Result<JsValue, JsValue> {
        let op = self.op(op)?;
        let outcome = self
            .core
            .fault(op, note.as_deref(), time(now_ms)?)
            .map_err(core_error)?;
        self.fault_view(outcome)
    }

    /// An emergency stop of lines by a person (`by`, `"unknown"` when absent) for `reason`.
    #[wasm_bindgen(js_name = faultResources, unchecked_return_type = "FaultOutcome")]
    pub fn fault_resources(
        &mut self,
        set: f64,
        note: Option<String>,
        by: Option<String>,
        reason: Option<String>,
        now_ms: f64,
    ) -> Result<JsValue, JsValue> {
        let now = time(now_ms)?;
        let set = self.set(set)?.clone();
        let by = Attribution::new(by.as_deref(), reason.as_deref(), false);
        let outcome = self
            .core
            .fault_resources_by(&set, note.as_deref(), &by, now)
            .map_err(core_error)?;
        self.fault_view(outcome)
    }

    /// Clears faulted lines of an interlock that knows no plant; returns how
    /// many waiting operations it granted (see `granted`).
    pub fn clear(
        &mut self,
        set: f64,
        by: Option<String>,
        reason: Option<String>,
        force: bool,
        now_ms: f64,
    ) -> Result<u32, JsValue> {
        self.clear_with(set, (by, reason, force), now_ms, |_| Vec::new())
    }

    /// Clears faulted lines once `plant` shows them isolated (see the core's
    /// `clear_checked`), or over its reasons when `force`; refused with
    /// `CLEAR_REFUSED` and every reason (`lines` on the error) otherwise.
    #[wasm_bindgen(js_name = clearAgainst)]
    pub fn clear_against(
        &mut self,
        set: f64,
        plant: &crate::Tracker,
        by: Option<String>,
        reason: Option<String>,
        force: bool,
        now_ms: f64,
    ) -> Result<u32, JsValue> {
        self.clear_with(set, (by, reason, force), now_ms, |line| {
            plant.core.clear_blockers(line)
        })
    }

    /// Why each named line may not be cleared now (empty reasons: it may), against `plant`.
    #[wasm_bindgen(js_name = clearBlockers, unchecked_return_type = "LineBlockers[]")]
    pub fn clear_blockers(&self, set: f64, plant: &crate::Tracker) -> Result<JsValue, JsValue> {
        let set = self.set(set)?;
        let lines: Vec<LineBlockers> = set
            .ids()
            .iter()
            .filter_map(|r| self.core.resource_name(*r))
            .map(|line| LineBlockers {
                line: line.to_owned(),
                reasons: plant.core.clear_blockers(line),
            })
            .collect();
        to_js(&worded(&lines))
    }

    #[wasm_bindgen(js_name = faultedResources)]
    pub fn faulted_resources(&self) -> Vec<String> {
        let faulted = self.core.faulted_resources();
        faulted
            .ids()
            .iter()
            .filter_map(|r| self.core.resource_name(*r))
            .map(str::to_owned)
            .collect()
    }

    /// Elapsed-time warnings as event records; each crossing warns once.
    #[wasm_bindgen(unchecked_return_type = "EventRecord[]")]
    pub fn tick(&mut self, now_ms: f64) -> Result<JsValue, JsValue> {
        let warnings = self.core.tick(time(now_ms)?);
        let records: Vec<_> = warnings.iter().map(|e| self.core.describe(e)).collect();
        to_js(&records)
    }

    /// Event records since the last call.
    #[wasm_bindgen(js_name = drainEvents, unchecked_return_type = "EventRecord[]")]
    pub fn drain_events(&mut self) -> Result<JsValue, JsValue> {
        let events = self.core.drain_events();
        let records: Vec<_> = events.iter().map(|e| self.core.describe(e)).collect();
        to_js(&records)
    }

    /// The abnormal event records since the last call (faults, clears,
    /// warnings...: what an alarm view keeps); the others are dropped unread.
    #[wasm_bindgen(js_name = drainAbnormalEvents, unchecked_return_type = "EventRecord[]")]
    pub fn drain_abnormal_events(&mut self) -> Result<JsValue, JsValue> {
        let events = self.core.drain_events();
        let records: Vec<_> = events
            .iter()
            .filter(|e| e.kind().is_abnormal())
            .map(|e| self.core.describe(e))
            .collect();
        to_js(&records)
    }

    #[wasm_bindgen(unchecked_return_type = "InterlockSnapshot")]
    pub fn snapshot(&self, now_ms: f64) -> Result<JsValue, JsValue> {
        to_js(&self.core.snapshot(time(now_ms)?))
    }

    /// The alarm conditions that hold now: faulted lines, waits and holds past the warning times.
    #[wasm_bindgen(js_name = alarmConditions, unchecked_return_type = "AlarmCondition[]")]
    pub fn alarm_conditions(&self, now_ms: f64) -> Result<JsValue, JsValue> {
        to_js(&self.core.alarm_conditions(time(now_ms)?))
    }

    /// `{ holding, queued, faulted }`.
    #[wasm_bindgen(unchecked_return_type = "InterlockCounts")]
    pub fn counts(&self) -> Result<JsValue, JsValue> {
        let c = self.core.counts();
        to_js(&CountsView {
            holding: c.holding,
            queued: c.queued,
            faulted: c.faulted,
        })
    }

    #[wasm_bindgen(js_name = isHolding)]
    pub fn is_holding(&self, op: f64) -> bool {
        self.op(op).is_ok_and(|op| self.core.is_holding(op))
    }

    #[wasm_bindgen(js_name = isQueued)]
    pub fn is_queued(&self, op: f64) -> bool {
        self.op(op).is_ok_and(|op| self.core.is_queued(op))
    }

    /// Handles of the waiting operations, in the order they would be granted.
    #[wasm_bindgen(js_name = queuedOperations)]
    pub fn queued_operations(&self) -> Vec<f64> {
        self.core
            .queued_operations()
            .into_iter()
            .map(op_handle)
            .collect()
    }
}

impl Interlock {
    fn opened(
        config: JsValue,
        owner: &str,
        plant: Option<String>,
        source: &str,
        text: &str,
        now_ms: f64,
        plant_doc: Option<&sugarshack_core::plant::Plant>,
    ) -> Result<JsValue, JsValue> {
        let config = parse_config(config)?;
        let now = time(now_ms)?;
        if text.len() > Bound::InterlockSnapshot.max_bytes() {
            return Err(js_error(
                Code::InputTooLarge,
                &format!("{source}: {} bytes, more than a state can be", text.len()),
            ));
        }
        let binding = Binding {
            owner,
            plant: plant.as_deref(),
        };
        let opened = CoreInterlock::open(config, binding, source, text, plant_doc, now)
            .map_err(core_error)?;
        let (lost, added, dropped) = match opened.start {
            Start::Restored { added, dropped } => (None, added, dropped),
            Start::Lost { reason } => (Some(reason), Vec::new(), Vec::new()),
        };
        let view = to_js(&OpenedView {
            lost,
            added,
            dropped,
            routines: &opened.routines,
            alarms: opened.alarms.as_ref(),
            runs: &opened.runs,
            runs_interrupted: &opened.runs_interrupted,
            aborted: &opened.aborted,
        })?;
        Reflect::set(
            &view,
            &"interlock".into(),
            &Interlock::wrap(opened.interlock).into(),
        )?;
        Ok(view)
    }
}
