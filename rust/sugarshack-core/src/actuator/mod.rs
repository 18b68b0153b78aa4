//! Actuator tracking (the paper's §III-A and §III-B): every command is
//! followed from issuance to motion to completion against the feedback the
//! devices publish; failures are retried, then escalated. A group command
//! completes once every one of its commands has. A lockout is also a standing
//! order: re-sent without limit until feedback shows the actuator there.
//!
//! ```
//! use sugarshack_core::actuator::{Effect, Tracker};
//! use sugarshack_core::plant::PlantModel;
//! use sugarshack_core::time::ms;
//!
//! let plant: PlantModel = serde_json::from_str(r#"{
//!   "actuatorTypes": { "valve": { "signal": "analog", "tolerance": 2,
//!     "noMotionMs": 3000, "completionMs": 10000, "staleMs": 5000 } },
//!   "devices": [{ "id": "ctrl-1", "kind": "actuator-panel" }],
//!   "actuators": [{ "id": "V12", "type": "valve", "device": "ctrl-1", "io": 12, "idle": 0, "lockout": 0 }]
//! }"#).unwrap();
//! let mut tracker = Tracker::new(plant, ms(0)).unwrap();
//! let v12 = tracker.actuator("V12").unwrap();
//! tracker.feedback(v12, 0.0, None, ms(0)).unwrap();
//! let sent = tracker.command(&[(v12, 100.0)], 7, false, ms(10)).unwrap();
//! assert!(matches!(&sent[0], Effect::Publish { topic, payload, retain: false, .. }
//!     if topic == "ctrl-1/valve/12/command" && payload == "100"));
//! tracker.feedback(v12, 40.0, None, ms(2010)).unwrap();
//! let done = tracker.feedback(v12, 99.0, None, ms(4010)).unwrap();
//! assert!(done.iter().any(|e| matches!(e, Effect::GroupCompleted { caller: 7, completion_ms, .. }
//!     if *completion_ms == ms(4000))));
//! ```

mod error;
mod fault;
pub mod outbox;

use std::collections::HashMap;

use serde::Serialize;

pub use error::TrackError;
pub use fault::{describe_fault, Heard};

use crate::clearance::ClearBlocker;
use crate::code::Code;
use crate::plant::{
    state_value, Escalation, GroupError, Plant, PlantErrors, PlantModel, Range, Signal,
};
use crate::time::Millis;
use crate::topics::Contract;

/// An actuator of the plant, by its index in the plant document.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(transparent)]
pub struct ActuatorId(u32);

impl ActuatorId {
    /// Its position in the plant document's list.
    pub fn index(self) -> usize {
        self.0 as usize
    }
    /// The handle at `index` in the plant document's list.
    pub const fn from_index(index: u32) -> Self {
        ActuatorId(index)
    }
}

/// A device of the plant, by its index in the plant document.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(transparent)]
pub struct DeviceId(u32);

impl DeviceId {
    /// Its position in the plant document's list.
    pub fn index(self) -> usize {
        self.0 as usize
    }
    /// The handle at `index` in the plant document's list.
    pub const fn from_index(index: u32) -> Self {
        DeviceId(index)
    }
}

/// The caller's handle for a group command (one msg waiting for it).
pub type Caller = u64;

/// The largest caller [`Tracker::new_caller`] gives: a host's plain integer (u32).
pub const MAX_CALLER: Caller = u32::MAX as Caller;

/// Where an actuator is in carrying out its command.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Phase {
    /// Never commanded, or its command was withdrawn.
    Idle,
    /// Commanded; no motion seen yet.
    Pending,
    /// Feedback shows it moving towards its target.
    Moving,
    /// At its last commanded position.
    Stopped,
    /// It failed its command; see its [`FaultKind`].
    Faulted,
}

/// Why an actuator failed its command.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum FaultKind {
    /// No motion within `noMotionMs` of the command.
    NoMotion,
    /// Target not reached within `completionMs` of the command.
    NotReached,
    /// Moved while no command was active.
    Uncommanded,
    /// No feedback within `staleMs`.
    Stale,
    /// Its device reported offline (status or last will).
    DeviceOffline,
    /// A lockout command took it over.
    LockedOut,
}

/// What a tracker call asks the caller to do or tell.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase", tag = "kind")]
pub enum Effect {
    /// Send this MQTT message (to `device`, through the node that serves it).
    Publish {
        /// The device to send it to.
        device: DeviceId,
        /// The MQTT topic.
        topic: String,
        /// The MQTT payload.
        payload: String,
        /// Whether the broker keeps it for later subscribers.
        retain: bool,
    },
    /// Write this request to a Modbus device (queued on its connection, see `topics::modbus::link`).
    Write {
        /// The device to write to.
        device: DeviceId,
        /// The write.
        #[serde(skip)]
        request: crate::topics::modbus::frame::Request,
    },
    /// First sample that departed from the start position.
    #[serde(rename_all = "camelCase")]
    Moving {
        /// The actuator's handle.
        actuator: ActuatorId,
        /// The caller's handle of the group command.
        caller: Caller,
        /// From the command to the first motion seen.
        issue_to_motion_ms: Millis,
    },
    /// One actuator of a group reached its target.
    #[serde(rename_all = "camelCase")]
    Completed {
        /// The actuator's handle.
        actuator: ActuatorId,
        /// The caller's handle of the group command.
        caller: Caller,
        /// The position commanded (0/1 for binary actuators).
        target: f64,
        /// From the command to the first motion seen.
        issue_to_motion_ms: Millis,
        /// From the command to its completion.
        completion_ms: Millis,
        /// Retries made before this.
        retries: u32,
        /// Whether its times are figures of motion: false when the command
        /// found the actuator already at its target (both times are 0 then).
        timed: bool,
    },
    /// Every actuator of the group reached its target: answer the caller.
    #[serde(rename_all = "camelCase")]
    GroupCompleted {
        /// The caller's handle of the group command.
        caller: Caller,
        /// From the command to the last actuator's completion.
        completion_ms: Millis,
        /// The fault lockout time: from the fault the command answered (its
        /// `fault_at`, see [`Tracker::command_after_fault`]) to this completion.
        #[serde(skip_serializing_if = "Option::is_none")]
        fault_lockout_ms: Option<Millis>,
        /// Its actuators, in the order they reached their targets.
        actuators: Vec<Reached>,
    },
    /// The group's caller waited its timeout: the group is withdrawn (as
    /// [`Tracker::withdraw`]); answer the caller with an error.
    #[serde(rename_all = "camelCase")]
    GroupTimedOut {
        /// The caller's handle of the group command.
        caller: Caller,
        /// The timeout it was given.
        timeout_ms: Millis,
        /// Its actuators not at their target yet, in the command's order.
        waiting: Vec<ActuatorId>,
        /// Its actuators that reached their targets before, in that order.
        actuators: Vec<Reached>,
    },
    /// The group failed (fail-fast): answer the caller with an error.
    #[serde(rename_all = "camelCase")]
    GroupFailed {
        /// The caller's handle of the group command.
        caller: Caller,
        /// The actuator's handle.
        actuator: ActuatorId,
        /// Which failure.
        fault: FaultKind,
        /// Retries of the failed command before it failed.
        retries: u32,
        /// The code the caller fails with (`COMMAND_FAILED`, `LOCKED_OUT`).
        code: Code,
        /// Why, in plain words (see [`describe_fault`]).
        message: String,
        /// Its actuators that reached their targets before, in that order.
        actuators: Vec<Reached>,
    },
    /// A command failed its check and was sent again.
    #[serde(rename_all = "camelCase")]
    Retry {
        /// The actuator's handle.
        actuator: ActuatorId,
        /// The caller's handle of the group command.
        caller: Caller,
        /// Which try this is (1 for the first retry).
        attempt: u32,
        /// Which failure.
        fault: FaultKind,
    },
    /// A failure that escalated, or a fault seen without a command.
    #[serde(rename_all = "camelCase")]
    Fault {
        /// The actuator's handle.
        actuator: ActuatorId,
        /// Which failure.
        fault: FaultKind,
    },
    /// The condition of an earlier fault is gone (fresh feedback, back in place, device online).
    #[serde(rename_all = "camelCase")]
    Recovered {
        /// The actuator's handle.
        actuator: ActuatorId,
        /// Which failure.
        fault: FaultKind,
    },
    /// A feedback value that changed beyond tolerance (report by exception).
    #[serde(rename_all = "camelCase")]
    Changed {
        /// The actuator's handle.
        actuator: ActuatorId,
        /// The new feedback value.
        value: f64,
        /// The sample's own timestamp against its reception, when the device stamped it.
        time_of_flight_ms: Option<i64>,
    },
    /// A device went offline or came back.
    #[serde(rename_all = "camelCase")]
    DeviceStatus {
        /// The device.
        device: DeviceId,
        /// Whether it is online now.
        online: bool,
    },
    /// Feedback showed the actuator at its lockout state: the standing order ends.
    #[serde(rename_all = "camelCase")]
    LockoutConfirmed {
        /// The actuator's handle.
        actuator: ActuatorId,
        /// Since the order was first issued.
        after_ms: Millis,
        /// How many times the lockout was published, the first included.
        sends: u32,
    },
    /// An unconfirmed lockout was published again (a `Publish` follows).
    #[serde(rename_all = "camelCase")]
    LockoutResent {
        /// The actuator's handle.
        actuator: ActuatorId,
        /// Re-sends of this order so far, this one included.
        attempt: u32,
    },
}

/// The timing series an effect adds a value to (the paper's Figs. 12-14, as
/// the host's stats name them), at most two per effect.
pub type Timings = [Option<(&'static str, Millis)>; 2];

impl Effect {
    /// The timing figures it measures: a command's issuance to motion and
    /// completion (when the actuator moved: `timed`), a lockout confirmed, a
    /// fault lockout (fault to its lockout command completed).
    pub fn timings(&self) -> Timings {
        match *self {
            Effect::Completed {
                timed: true,
                issue_to_motion_ms,
                completion_ms,
                ..
            } => [
                Some(("command/issueToMotion", issue_to_motion_ms)),
                Some(("command/completion", completion_ms)),
            ],
            Effect::LockoutConfirmed { after_ms, .. } => {
                [Some(("lockout/confirm", after_ms)), None]
            }
            Effect::GroupCompleted {
                fault_lockout_ms: Some(ms),
                ..
            } => [Some(("fault/lockout", ms)), None],
            _ => [None, None],
        }
    }

    /// Whether the host's status may read differently after it: anything but a
    /// new feedback value (report by exception) may move the counts.
    pub fn moves_status(&self) -> bool {
        !matches!(self, Effect::Changed { .. })
    }

    /// Whether a device's availability or staleness (its alarm conditions) may differ after it.
    pub fn moves_health(&self) -> bool {
        matches!(
            self,
            Effect::DeviceStatus { .. } | Effect::Fault { .. } | Effect::Recovered { .. }
        )
    }
}

/// A device as an operator sees it: online, and which of its actuators went silent.
#[derive(Clone, Debug, PartialEq)]
pub struct DeviceHealth {
    /// The device's id.
    pub device: String,
    /// Whether the device is online.
    pub online: bool,
    /// Its actuators whose feedback is stale, in plant order.
    pub stale: Vec<String>,
}

/// A device's state in one word, as an operator's screen shows it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Availability {
    /// Online, every actuator's feedback fresh.
    Online,
    /// Online, but some of its actuators went silent.
    Stale,
    /// It reported offline (status or last will).
    Offline,
}

impl DeviceHealth {
    /// Offline above all, else stale while any of its actuators is.
    pub fn state(&self) -> Availability {
        if !self.online {
            Availability::Offline
        } else if !self.stale.is_empty() {
            Availability::Stale
        } else {
            Availability::Online
        }
    }
}

impl Serialize for DeviceHealth {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let mut s = serializer.serialize_struct("DeviceHealth", 4)?;
        s.serialize_field("device", &self.device)?;
        s.serialize_field("online", &self.online)?;
        s.serialize_field("stale", &self.stale)?;
        s.serialize_field("state", &self.state())?;
        s.end()
    }
}

/// A lockout not yet confirmed by feedback.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct PendingLockout {
    /// The actuator's handle.
    pub actuator: ActuatorId,
    /// The position commanded (0/1 for binary actuators).
    pub target: f64,
    /// Since when, in ms.
    pub since_ms: Millis,
    /// How many times the lockout was published, the first included.
    pub sends: u32,
}

#[derive(Clone, Copy, Debug)]
struct LockoutOrder {
    target: f64,
    since_ms: Millis,
    sends: u32,
    last_send_ms: Millis,
}

#[derive(Clone, Debug)]
struct Command {
    caller: Caller,
    target: f64,
    /// Position when commanded (or first seen after), to tell motion from noise.
    start: Option<f64>,
    issued_ms: Millis,
    attempt_ms: Millis,
    moving_ms: Option<Millis>,
    retries: u32,
    /// Hang mode: failed every retry, left for the caller's own timeout.
    escalated: bool,
}

#[derive(Clone, Debug)]
struct ActuatorState {
    name: String,
    device: DeviceId,
    signal: Signal,
    range: Range,
    type_index: usize,
    /// Its device publishes on change only: silence is not staleness.
    on_change: bool,
    idle: Option<f64>,
    lockout: f64,
    position: Option<f64>,
    last_sample_ms: Millis,
    reported: Option<f64>,
    commanded: Option<f64>,
    /// Where it should stay while no command runs: the last target, or where it was first seen.
    resting: Option<f64>,
    /// The last command was a retained lockout: the next normal one clears it on the broker.
    retained: bool,
    command: Option<Command>,
    /// Outlives its group command until feedback confirms it.
    lockout_order: Option<LockoutOrder>,
    /// The target of its line's last lockout, until a normal command replaces it.
    locked_at: Option<f64>,
    phase: Phase,
    stale: bool,
    uncommanded: bool,
}

#[derive(Clone, Debug)]
struct Timing {
    no_motion_ms: Millis,
    completion_ms: Millis,
    stale_ms: Millis,
    retries: u32,
    escalation: Escalation,
}

#[derive(Clone, Debug)]
struct DeviceState {
    name: String,
    online: bool,
    /// A status or a sample of its actuators has come from it since the start.
    heard: bool,
    /// A publish for it found no node serving it, and was reported (see [`Tracker::unserved`]).
    unserved_told: bool,
    actuators: Vec<ActuatorId>,
}

#[derive(Clone, Debug)]
struct Group {
    issued_ms: Millis,
    remaining: usize,
    /// When the fault this command answers was raised (a lockout's), if any.
    fault_at: Option<Millis>,
    /// Its timeout, and the time it runs out.
    deadline: Option<(Millis, Millis)>,
    /// Its actuators, in the command's order.
    members: Vec<ActuatorId>,
    /// Those at their targets so far, in that order.
    reached: Vec<Reached>,
}

/// How a group command is carried out, beyond its targets.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Terms {
    /// A lockout: published retained, taking over actuators still moving,
    /// standing until feedback confirms it.
    pub lockout: bool,
    /// When the fault it answers was raised: its completion reports the
    /// fault lockout time, from the fault to every actuator in place (0 for
    /// a fault time after it).
    pub fault_at: Option<Millis>,
    /// How long its caller waits: the first [`Tracker::tick`] at or past it
    /// withdraws the group ([`Effect::GroupTimedOut`]). None or 0: no limit.
    pub timeout: Option<Millis>,
}

/// One actuator of a group at its target, as the group's outcome lists it
/// (the figures of its [`Effect::Completed`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Reached {
    /// The actuator's handle.
    pub actuator: ActuatorId,
    /// The position commanded (0/1 for binary actuators).
    pub target: f64,
    /// From the command to the first motion seen (0 when it was there already).
    pub issue_to_motion_ms: Millis,
    /// From the command to its completion (0 when it was there already).
    pub completion_ms: Millis,
    /// Retries made before it got there.
    pub retries: u32,
}

/// What a group command's caller is told of its outcome (a held msg's
/// `msg.command`), by actuator and device ids: the actuators that reached
/// their targets, and those it waited for (a timeout) or the one that failed.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Outcome {
    /// From the command to the last completion (completed only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub completion_ms: Option<Millis>,
    /// From the fault the command answered to its completion (a fault's lockout).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fault_lockout_ms: Option<Millis>,
    /// Not at their targets when it timed out, in the command's order.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub waiting: Option<Vec<String>>,
    /// The actuator that failed it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub failed: Option<Failed>,
    /// Those that reached their targets, in that order.
    pub actuators: Vec<ReachedBy>,
}

/// The actuator that failed a group command, by id.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Failed {
    /// The actuator's id.
    pub actuator: String,
    /// Its device's id.
    pub device: String,
    /// Which failure.
    pub fault: FaultKind,
    /// Retries of the command before it failed.
    pub retries: u32,
}

/// [`Reached`] by the actuator's id.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct ReachedBy {
    /// The actuator's id.
    pub actuator: String,
    /// The position commanded (0/1 for binary actuators).
    pub target: f64,
    /// From the command to the first motion seen (0 when it was there already).
    pub issue_to_motion_ms: Millis,
    /// From the command to its completion (0 when it was there already).
    pub completion_ms: Millis,
    /// Retries made before it got there.
    pub retries: u32,
}

impl Group {
    fn completed(self, caller: Caller, now: Millis) -> Effect {
        Effect::GroupCompleted {
            caller,
            completion_ms: now.saturating_sub(self.issued_ms),
            fault_lockout_ms: self.fault_at.map(|at| now.saturating_sub(at)),
            actuators: self.reached,
        }
    }
}

/// Counts for a status line.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Counts {
    /// Actuators moving towards a target.
    pub moving: usize,
    /// Actuators at their last commanded position.
    pub stopped: usize,
    /// Actuators that failed their command.
    pub faulted: usize,
    /// Lockouts that feedback has not confirmed yet.
    pub lockouts_pending: usize,
    /// Devices that reported offline.
    pub offline_devices: usize,
}

impl Counts {
    /// Adds (`add`) or removes one actuator's share: its phase, its unconfirmed lockout.
    fn tally(&mut self, phase: Phase, lockout_pending: bool, add: bool) {
        let bucket = match phase {
            Phase::Pending | Phase::Moving => Some(&mut self.moving),
            Phase::Stopped => Some(&mut self.stopped),
            Phase::Faulted => Some(&mut self.faulted),
            Phase::Idle => None,
        };
        for n in bucket
            .into_iter()
            .chain(lockout_pending.then_some(&mut self.lockouts_pending))
        {
            if add {
                *n += 1;
            } else {
                *n -= 1;
            }
        }
    }

    fn add(&mut self, other: &Counts) {
        self.moving += other.moving;
        self.stopped += other.stopped;
        self.faulted += other.faulted;
        self.lockouts_pending += other.lockouts_pending;
        self.offline_devices += other.offline_devices;
    }
}

/// The counts kept current on every change of phase or lockout order, so a
/// status line reads them without walking the plant (95,000 actuators at
/// the cloud paper's scale, read after every feedback msg).
#[derive(Clone, Debug, Default)]
struct Tally {
    total: Counts,
    per_device: Vec<Counts>,
}

impl Tally {
    /// A device went offline or came back: it counts in its own tally and the total.
    fn device_online(&mut self, device: DeviceId, online: bool) {
        for counts in [&mut self.total, &mut self.per_device[device.index()]] {
            if online {
                counts.offline_devices -= 1;
            } else {
                counts.offline_devices += 1;
            }
        }
    }

    fn change(&mut self, a: &ActuatorState, phase: Phase, lockout_pending: bool) {
        let was_pending = a.lockout_order.is_some();
        for counts in [&mut self.total, &mut self.per_device[a.device.index()]] {
            counts.tally(a.phase, was_pending, false);
            counts.tally(phase, lockout_pending, true);
        }
    }
}

impl ActuatorState {
    fn set_phase(&mut self, tally: &mut Tally, phase: Phase) {
        tally.change(self, phase, self.lockout_order.is_some());
        self.phase = phase;
    }

    fn set_lockout_order(&mut self, tally: &mut Tally, order: Option<LockoutOrder>) {
        tally.change(self, self.phase, order.is_some());
        self.lockout_order = order;
    }

    fn take_lockout_order(&mut self, tally: &mut Tally) -> Option<LockoutOrder> {
        let order = self.lockout_order;
        self.set_lockout_order(tally, None);
        order
    }
}

/// Tracks every actuator of a plant. Every method takes the current time; none reads a clock.
#[derive(Clone, Debug)]
pub struct Tracker {
    plant: Plant,
    timings: Vec<Timing>,
    actuators: Vec<ActuatorState>,
    devices: Vec<DeviceState>,
    device_by_name: HashMap<String, DeviceId>,
    /// (device, type name, io) -> actuator, for device feedback.
    slots: HashMap<(DeviceId, String, u32), ActuatorId>,
    groups: HashMap<Caller, Group>,
    /// The caller `new_caller` gave last (0: none yet).
    last_caller: Caller,
    tally: Tally,
    /// The earliest time `tick` may have work (a threshold, a lockout to send
    /// again), never later than it: made exact by `tick` and a device coming
    /// back, lowered as work is given, left early when work goes (a wake that
    /// finds nothing due makes it exact again).
    due: Option<Millis>,
    /// Publishes waiting until they can go out.
    outbox: outbox::Outbox,
}

impl Tracker {
    /// Validates the plant and starts tracking at `now` (feedback is stale `staleMs` after it).
    pub fn new(plant: PlantModel, now: Millis) -> Result<Self, PlantErrors> {
        let plant = Plant::new(plant)?;
        let type_names: Vec<&String> = plant.actuator_types.keys().collect();
        let timings = plant
            .actuator_types
            .values()
            .map(|t| Timing {
                no_motion_ms: t.no_motion_ms,
                completion_ms: t.completion_ms,
                stale_ms: t.stale_ms,
                retries: t.retries,
                escalation: t.escalation,
            })
            .collect();
        let mut devices: Vec<DeviceState> = plant
            .devices
            .iter()
            .map(|d| DeviceState {
                name: d.id.clone(),
                online: true,
                heard: false,
                unserved_told: false,
                actuators: Vec::new(),
            })
            .collect();
        let device_by_name: HashMap<String, DeviceId> = plant
            .devices
            .iter()
            .enumerate()
            .map(|(i, d)| (d.id.clone(), DeviceId(i as u32)))
            .collect();
        let plant_devices = devices.len();
        let mut actuators = Vec::with_capacity(plant.actuators.len());
        let mut slots = HashMap::new();
        for (i, a) in plant.actuators.iter().enumerate() {
            let id = ActuatorId(i as u32);
            let t = &plant.actuator_types[&a.kind];
            let range = t.range(a.tolerance);
            let device = device_by_name[&a.device];
            devices[device.index()].actuators.push(id);
            if let Some(io) = a.io {
                slots.insert((device, a.kind.clone(), io), id);
            }
            actuators.push(ActuatorState {
                name: a.id.clone(),
                device,
                signal: t.signal,
                range,
                type_index: type_names
                    .iter()
                    .position(|n| **n == a.kind)
                    .expect("validated type"),
                on_change: plant.reports_on_change(a),
                idle: a
                    .idle
                    .map(|s| s.position(t.signal, range).expect("validated idle")),
                lockout: a
                    .lockout
                    .position(t.signal, range)
                    .expect("validated lockout"),
                position: None,
                last_sample_ms: now,
                reported: None,
                commanded: None,
                resting: None,
                retained: false,
                command: None,
                lockout_order: None,
                locked_at: None,
                phase: Phase::Idle,
                stale: false,
                uncommanded: false,
            });
        }
        let mut tracker = Tracker {
            plant,
            timings,
            actuators,
            devices,
            device_by_name,
            slots,
            groups: HashMap::new(),
            last_caller: 0,
            tally: Tally {
                total: Counts::default(),
                per_device: vec![Counts::default(); plant_devices],
            },
            due: None,
            outbox: outbox::Outbox::default(),
        };
        tracker.due = tracker.exact_due();
        Ok(tracker)
    }

    /// The plant document it tracks.
    pub fn plant(&self) -> &Plant {
        &self.plant
    }

    /// The plant's MQTT contract (topics and payloads of every device).
    pub fn contract(&self) -> &Contract {
        self.plant.contract()
    }

    // ---- names ---------------------------------------------------------------

    /// The handle of the actuator `name`.
    pub fn actuator(&self, name: &str) -> Result<ActuatorId, TrackError> {
        self.plant
            .actuator(name)
            .map(|i| ActuatorId(i as u32))
            .ok_or_else(|| TrackError::UnknownActuator {
                name: name.to_owned(),
            })
    }

    /// The id of the actuator with handle `id`.
    pub fn actuator_name(&self, id: ActuatorId) -> Option<&str> {
        self.actuators.get(id.index()).map(|a| a.name.as_str())
    }

    /// The handle of the device `name`.
    pub fn device(&self, name: &str) -> Result<DeviceId, TrackError> {
        self.device_by_name
            .get(name)
            .copied()
            .ok_or_else(|| TrackError::UnknownDevice {
                name: name.to_owned(),
            })
    }

    /// The id of the device with handle `id`.
    pub fn device_name(&self, id: DeviceId) -> Option<&str> {
        self.devices.get(id.index()).map(|d| d.name.as_str())
    }

    /// The actuator a device reports as `<type>` number `io`, if the plant names one.
    pub fn slot(&self, device: DeviceId, kind: &str, io: u32) -> Option<ActuatorId> {
        // Off the hot path (feedback goes through the contract): one allocation is fine.
        self.slots.get(&(device, kind.to_owned(), io)).copied()
    }

    /// Whether the actuator is binary or analog.
    pub fn signal(&self, id: ActuatorId) -> Option<Signal> {
        self.actuators.get(id.index()).map(|a| a.signal)
    }

    /// Where the actuator is in carrying out its command.
    pub fn phase(&self, id: ActuatorId) -> Option<Phase> {
        self.actuators.get(id.index()).map(|a| a.phase)
    }

    /// What has come from the actuator and its device since the start: a
    /// command that fails with nothing ever heard is a wiring or profile problem.
    pub fn heard(&self, id: ActuatorId) -> Option<Heard> {
        let a = self.actuators.get(id.index())?;
        Some(if a.position.is_some() {
            Heard::Feedback
        } else if self.devices[a.device.index()].heard {
            Heard::DeviceOnly
        } else {
            Heard::Nothing
        })
    }

    /// Its last feedback value, if any.
    pub fn position(&self, id: ActuatorId) -> Option<f64> {
        self.actuators.get(id.index()).and_then(|a| a.position)
    }

    /// The position it was last commanded to (0/1 for binary), if any.
    pub fn commanded(&self, id: ActuatorId) -> Option<f64> {
        self.actuators.get(id.index()).and_then(|a| a.commanded)
    }

    /// Its idle state as a number (0/1 for binary), if it has one.
    pub fn idle_state(&self, id: ActuatorId) -> Option<f64> {
        self.actuators.get(id.index()).and_then(|a| a.idle)
    }

    /// Its lockout state as a number (0/1 for binary).
    pub fn lockout_state(&self, id: ActuatorId) -> Option<f64> {
        self.actuators.get(id.index()).map(|a| a.lockout)
    }

    /// How many actuators are moving, stopped and faulted, and devices offline, in O(1).
    pub fn counts(&self) -> Counts {
        debug_assert_eq!(self.tally.total, self.recount(), "tally out of step");
        self.tally.total
    }

    /// The counts of the actuators and devices among `devices` (an unknown device counts nothing), in O(devices).
    pub fn counts_on(&self, devices: impl IntoIterator<Item = DeviceId>) -> Counts {
        let mut counts = Counts::default();
        for d in devices {
            if let Some(c) = self.tally.per_device.get(d.index()) {
                counts.add(c);
            }
        }
        counts
    }

    /// The counts from scratch: what the tally must always equal.
    fn recount(&self) -> Counts {
        let mut counts = Counts::default();
        for a in &self.actuators {
            counts.tally(a.phase, a.lockout_order.is_some(), true);
        }
        counts.offline_devices = self.devices.iter().filter(|d| !d.online).count();
        counts
    }

    /// The error the caller of a group command that did not complete (failed,
    /// timed out) gets: its code and words; none for another effect.
    pub fn outcome_error(&self, effect: &Effect) -> Option<(Code, String)> {
        match effect {
            Effect::GroupFailed { code, message, .. } => Some((*code, message.clone())),
            Effect::GroupTimedOut {
                timeout_ms,
                waiting,
                ..
            } => {
                let waiting: Vec<&str> = waiting
                    .iter()
                    .map(|id| self.actuators[id.index()].name.as_str())
                    .collect();
                let message = format!(
                    "group command did not complete within {}: {} had not completed; \
                     the command was withdrawn (its actuators keep their last command)",
                    crate::text::seconds(timeout_ms.as_f64()),
                    waiting.join(", ")
                );
                Some((Code::CommandTimeout, message))
            }
            _ => None,
        }
    }

    /// The outcome of a group command in `effect` (completed, failed, timed
    /// out), by ids; none for another effect.
    pub fn outcome(&self, effect: &Effect) -> Option<Outcome> {
        let name = |id: ActuatorId| self.actuators[id.index()].name.clone();
        let by_id = |reached: &[Reached]| {
            reached
                .iter()
                .map(|r| ReachedBy {
                    actuator: name(r.actuator),
                    target: r.target,
                    issue_to_motion_ms: r.issue_to_motion_ms,
                    completion_ms: r.completion_ms,
                    retries: r.retries,
                })
                .collect()
        };
        let none = |actuators| Outcome {
            completion_ms: None,
            fault_lockout_ms: None,
            waiting: None,
            failed: None,
            actuators,
        };
        Some(match effect {
            Effect::GroupCompleted {
                completion_ms,
                fault_lockout_ms,
                actuators,
                ..
            } => Outcome {
                completion_ms: Some(*completion_ms),
                fault_lockout_ms: *fault_lockout_ms,
                ..none(by_id(actuators))
            },
            Effect::GroupTimedOut {
                waiting, actuators, ..
            } => Outcome {
                waiting: Some(waiting.iter().map(|&id| name(id)).collect()),
                ..none(by_id(actuators))
            },
            Effect::GroupFailed {
                actuator,
                fault,
                retries,
                actuators,
                ..
            } => Outcome {
                failed: Some(Failed {
                    actuator: name(*actuator),
                    device: self.plant.actuators[actuator.index()].device.clone(),
                    fault: *fault,
                    retries: *retries,
                }),
                ..none(by_id(actuators))
            },
            _ => return None,
        })
    }

    /// A publish for `device` found no node serving it: true when that is to
    /// be reported (once per device until [`Tracker::serving_changed`]).
    pub fn unserved(&mut self, device: DeviceId) -> bool {
        self.devices
            .get_mut(device.index())
            .is_some_and(|d| !std::mem::replace(&mut d.unserved_told, true))
    }

    /// The nodes serving the devices changed: a device served by none is reported again.
    pub fn serving_changed(&mut self) {
        for d in &mut self.devices {
            d.unserved_told = false;
        }
    }

    /// A publish for `device` that could not go out, `blocked`: it waits
    /// ([`outbox::Blocked::outlet`]; past `bound` one is dropped, never a
    /// lockout), or is dropped; answers what the host is to tell of it.
    pub fn not_sent(
        &mut self,
        blocked: outbox::Blocked,
        device: DeviceId,
        topic: String,
        payload: String,
        retain: bool,
        bound: usize,
    ) -> outbox::Told {
        match blocked.outlet() {
            Some(outlet) => {
                match self.keep_publish(outlet, device, topic, payload, retain, bound) {
                    outbox::Kept::Dropped { first: true } => outbox::Told::Dropped {
                        bound: outbox::bound_in_force(bound),
                    },
                    _ => outbox::Told::Nothing,
                }
            }
            None if blocked == outbox::Blocked::Unserved && self.unserved(device) => {
                outbox::Told::Unserved
            }
            None => outbox::Told::Nothing,
        }
    }

    /// Keeps a publish for `device` that cannot go out yet at `outlet`, within
    /// `bound` (0: the default); a lockout is never the one dropped (see [`outbox`]).
    pub fn keep_publish(
        &mut self,
        outlet: outbox::Outlet,
        device: DeviceId,
        topic: String,
        payload: String,
        retain: bool,
        bound: usize,
    ) -> outbox::Kept {
        let lockout = retain && self.is_lockout(device, &topic, &payload);
        let publish = outbox::Waiting {
            device,
            topic,
            payload,
            retain,
            lockout,
        };
        self.outbox.wait(outlet, publish, bound)
    }

    /// Whether `topic` and `payload` are the lockout of an actuator of `device` whose line stands locked out.
    fn is_lockout(&self, device: DeviceId, topic: &str, payload: &str) -> bool {
        let Some(d) = self.devices.get(device.index()) else {
            return false;
        };
        d.actuators.iter().any(|&id| {
            self.actuators[id.index()].locked_at.is_some_and(|target| {
                let message = self.plant.contract().command(id, target);
                message.topic == topic && message.payload == payload
            })
        })
    }

    /// What waited at `outlet` goes out, oldest first; if any was dropped,
    /// every commanded state and standing lockout is published again after
    /// them (see [`Tracker::path_restored`]).
    pub fn send_kept(&mut self, outlet: outbox::Outlet, now: Millis) -> Vec<Effect> {
        let (waiting, dropped) = self.outbox.take(outlet);
        let mut effects: Vec<Effect> = waiting
            .into_iter()
            .map(|p| Effect::Publish {
                device: p.device,
                topic: p.topic,
                payload: p.payload,
                retain: p.retain,
            })
            .collect();
        if dropped {
            effects.extend(self.path_restored(now));
        }
        effects
    }

    /// What waits at `outlet` is no longer this host's to send (a deposed leader's).
    pub fn drop_kept(&mut self, outlet: outbox::Outlet) {
        self.outbox.take(outlet);
    }

    /// How many publishes wait at `outlet`.
    pub fn kept_publishes(&self, outlet: outbox::Outlet) -> usize {
        self.outbox.len(outlet)
    }

    /// Lockouts not yet confirmed by feedback, in actuator order.
    pub fn pending_lockouts(&self) -> Vec<PendingLockout> {
        self.actuators
            .iter()
            .enumerate()
            .filter_map(|(i, a)| {
                a.lockout_order.map(|order| PendingLockout {
                    actuator: ActuatorId(i as u32),
                    target: order.target,
                    since_ms: order.since_ms,
                    sends: order.sends,
                })
            })
            .collect()
    }

    /// Every device: online or not, and its actuators whose feedback is stale.
    pub fn device_health(&self) -> Vec<DeviceHealth> {
        self.devices.iter().map(|d| self.health_of(d)).collect()
    }

    /// The ids of the devices that reported offline, in plant order.
    pub fn devices_offline(&self) -> Vec<String> {
        self.devices
            .iter()
            .filter(|d| !d.online)
            .map(|d| d.name.clone())
            .collect()
    }

    /// Why a command of actuator `id` to `target` failed with `fault` after
    /// `retries` retries, worded from the plant document; None for an unknown handle.
    pub fn describe_fault(
        &self,
        id: ActuatorId,
        fault: FaultKind,
        retries: u32,
        target: Option<f64>,
    ) -> Option<String> {
        let a = self.plant.actuators.get(id.index())?;
        let kind = self.plant.actuator_types.get(&a.kind)?;
        let profile = self
            .plant
            .devices
            .iter()
            .find(|d| d.id == a.device)
            .map_or("sugarshack", |d| d.profile.name());
        let heard = self.heard(id)?;
        Some(describe_fault(
            a,
            kind,
            fault,
            retries,
            target,
            (heard, profile),
        ))
    }

    /// One device's health ([`Tracker::device_health`]), if the handle is known.
    pub fn device_health_of(&self, id: DeviceId) -> Option<DeviceHealth> {
        self.devices.get(id.index()).map(|d| self.health_of(d))
    }

    fn health_of(&self, d: &DeviceState) -> DeviceHealth {
        DeviceHealth {
            device: d.name.clone(),
            online: d.online,
            stale: d
                .actuators
                .iter()
                .filter(|a| self.actuators[a.index()].stale)
                .map(|a| self.actuators[a.index()].name.clone())
                .collect(),
        }
    }

    /// Why line `resource` may not be cleared now, per member actuator in
    /// plant order: its device offline, its feedback stale, its lockout not
    /// confirmed, no feedback yet, or feedback away from its lockout state
    /// (the line's last lockout target, else its own lockout state).
    pub fn clear_blockers(&self, resource: &str) -> Vec<ClearBlocker> {
        let mut blockers = Vec::new();
        let mut offline: Vec<DeviceId> = Vec::new();
        for (i, spec) in self.plant.actuators.iter().enumerate() {
            if spec.resource.as_deref() != Some(resource) {
                continue;
            }
            let a = &self.actuators[i];
            let actuator = a.name.clone();
            if !self.devices[a.device.index()].online {
                if !offline.contains(&a.device) {
                    offline.push(a.device);
                    blockers.push(ClearBlocker::DeviceOffline {
                        device: self.devices[a.device.index()].name.clone(),
                    });
                }
                continue;
            }
            let expected = a.locked_at.unwrap_or(a.lockout);
            if a.stale {
                blockers.push(ClearBlocker::Stale { actuator });
            } else if let Some(order) = a.lockout_order {
                blockers.push(ClearBlocker::LockoutPending {
                    actuator,
                    sends: order.sends,
                });
            } else if let Some(position) = a.position {
                if (position - expected).abs() > a.range.tolerance {
                    blockers.push(ClearBlocker::OffLockout {
                        actuator,
                        position,
                        lockout: expected,
                    });
                }
            } else {
                blockers.push(ClearBlocker::NoFeedback { actuator });
            }
        }
        blockers
    }

    /// Reads a target for this actuator from JSON (a number for analog, true/false for binary).
    pub fn target_from_json(
        &self,
        id: ActuatorId,
        value: &serde_json::Value,
    ) -> Result<f64, TrackError> {
        let a = self.state(id)?;
        state_value(a.signal, a.range, value).map_err(|why| TrackError::InvalidTarget {
            actuator: a.name.clone(),
            reason: why,
        })
    }

    // ---- commands --------------------------------------------------------------

    /// Reads a group command such as `{"valves": {"V12": 100, "V13": 0}, "pumps": {"P1": true}}`:
    /// each key is an actuator type (or its plural), each id must be of that type.
    pub fn parse_group(
        &self,
        payload: &serde_json::Value,
    ) -> Result<Vec<(ActuatorId, f64)>, TrackError> {
        let targets = self.plant.group_targets(payload).map_err(|err| match err {
            GroupError::Invalid(reason) => TrackError::InvalidGroup { reason },
            GroupError::UnknownActuator(name) => TrackError::UnknownActuator { name },
            GroupError::InvalidTarget { actuator, reason } => {
                TrackError::InvalidTarget { actuator, reason }
            }
            GroupError::Empty => TrackError::EmptyCommand,
        })?;
        Ok(targets
            .into_iter()
            .map(|(i, target)| (ActuatorId(i as u32), target))
            .collect())
    }

    /// C2 at run time: refuses targets outside the resources `held` by the commanding operation.
    pub fn check_within(
        &self,
        targets: &[(ActuatorId, f64)],
        held: &[String],
    ) -> Result<(), TrackError> {
        for &(id, _) in targets {
            let a = &self.plant.actuators[id.index()];
            if !a.resource.as_ref().is_some_and(|r| held.contains(r)) {
                return Err(TrackError::OutsideResources {
                    actuator: a.id.clone(),
                    resource: a.resource.clone(),
                    held: held.to_vec(),
                });
            }
        }
        Ok(())
    }

    /// Issues a group command: all of it or, on any refusal, none of it.
    /// A `lockout` is published retained, so a device that reconnects applies
    /// it, and takes over actuators that are still moving; a normal command
    /// to an actuator still moving, or whose lockout is unconfirmed, is refused.
    ///
    /// A lockout also sets a standing order per actuator, kept whatever becomes
    /// of its group command until a sample shows the actuator at the target
    /// while its device is online (at once if the last sample already does).
    /// Another lockout to the same target renews it; to another target replaces it.
    pub fn command(
        &mut self,
        targets: &[(ActuatorId, f64)],
        caller: Caller,
        lockout: bool,
        now: Millis,
    ) -> Result<Vec<Effect>, TrackError> {
        let terms = Terms {
            lockout,
            ..Terms::default()
        };
        self.issue(targets, caller, terms, now)
    }

    /// [`Tracker::command`] on `terms`: a lockout or not, the fault it
    /// answers, the time its caller waits.
    pub fn issue(
        &mut self,
        targets: &[(ActuatorId, f64)],
        caller: Caller,
        terms: Terms,
        now: Millis,
    ) -> Result<Vec<Effect>, TrackError> {
        let lockout = terms.lockout;
        self.check_group(targets, caller, lockout)?;
        let mut effects = Vec::with_capacity(targets.len() + 1);
        let mut remaining = 0;
        let mut reached = Vec::new();
        for &(id, target) in targets {
            if let Some(old) = self.actuators[id.index()].command.take() {
                // Only a lockout gets here with a command active: it takes over.
                self.fail_group(&old, id, FaultKind::LockedOut, &mut effects);
            }
            let a = &mut self.actuators[id.index()];
            // A register holds its last write: nothing is retained to clear.
            if a.retained && !lockout && !self.plant.contract().modbus().is_modbus(a.device) {
                effects.push(Effect::Publish {
                    device: a.device,
                    topic: self.plant.contract().command_topic(id).to_owned(),
                    payload: String::new(),
                    retain: true,
                });
            }
            effects.push(publish(
                self.plant.contract(),
                id,
                a.device,
                target,
                lockout,
            ));
            a.commanded = Some(target);
            a.resting = Some(target);
            a.retained = lockout;
            a.uncommanded = false;
            a.locked_at = lockout.then_some(target);
            if lockout {
                let order = Some(match a.lockout_order {
                    Some(order) if order.target == target => LockoutOrder {
                        sends: order.sends.saturating_add(1),
                        last_send_ms: now,
                        ..order
                    },
                    _ => LockoutOrder {
                        target,
                        since_ms: now,
                        sends: 1,
                        last_send_ms: now,
                    },
                });
                a.set_lockout_order(&mut self.tally, order);
            }
            let at_target = a
                .position
                .is_some_and(|p| (p - target).abs() <= a.range.tolerance);
            if at_target && !a.stale && self.devices[a.device.index()].online {
                if let Some(order) = a.take_lockout_order(&mut self.tally) {
                    effects.push(Effect::LockoutConfirmed {
                        actuator: id,
                        after_ms: now.saturating_sub(order.since_ms),
                        sends: order.sends,
                    });
                }
                a.set_phase(&mut self.tally, Phase::Stopped);
                effects.push(Effect::Completed {
                    actuator: id,
                    caller,
                    target,
                    issue_to_motion_ms: Millis::ZERO,
                    completion_ms: Millis::ZERO,
                    retries: 0,
                    timed: false,
                });
                reached.push(Reached {
                    actuator: id,
                    target,
                    issue_to_motion_ms: Millis::ZERO,
                    completion_ms: Millis::ZERO,
                    retries: 0,
                });
                continue;
            }
            a.command = Some(Command {
                caller,
                target,
                start: a.position,
                issued_ms: now,
                attempt_ms: now,
                moving_ms: None,
                retries: 0,
                escalated: false,
            });
            a.set_phase(&mut self.tally, Phase::Pending);
            remaining += 1;
        }
        let group = Group {
            issued_ms: now,
            remaining,
            fault_at: terms.fault_at,
            deadline: terms
                .timeout
                .filter(|t| *t > Millis::ZERO)
                .map(|t| (t, now.saturating_add(t))),
            members: targets.iter().map(|&(id, _)| id).collect(),
            reached,
        };
        if remaining == 0 {
            effects.push(group.completed(caller, now));
        } else {
            self.groups.insert(caller, group);
        }
        for &(id, _) in targets {
            self.lower_due(id);
        }
        Ok(effects)
    }

    /// A caller for a new group command: the one after the last given (from 1,
    /// back to 1 after [`MAX_CALLER`]), skipping any whose group is still waiting.
    /// It ends: every waiting group holds an actuator no other one holds.
    pub fn new_caller(&mut self) -> Caller {
        loop {
            self.last_caller = if self.last_caller >= MAX_CALLER {
                1
            } else {
                self.last_caller + 1
            };
            if !self.groups.contains_key(&self.last_caller) {
                return self.last_caller;
            }
        }
    }

    /// Stops tracking a caller's group (its msg timed out or its node closed).
    /// The actuators keep their commanded state and become idle; an
    /// unconfirmed lockout stays standing.
    pub fn withdraw(&mut self, caller: Caller) -> bool {
        let known = self.groups.remove(&caller).is_some();
        for a in &mut self.actuators {
            if a.command.as_ref().is_some_and(|c| c.caller == caller) {
                a.command = None;
                a.set_phase(&mut self.tally, Phase::Idle);
            }
        }
        known
    }

    fn check_group(
        &self,
        targets: &[(ActuatorId, f64)],
        caller: Caller,
        lockout: bool,
    ) -> Result<(), TrackError> {
        if targets.is_empty() {
            return Err(TrackError::EmptyCommand);
        }
        if self.groups.contains_key(&caller) {
            return Err(TrackError::CallerBusy { caller });
        }
        for (i, &(id, target)) in targets.iter().enumerate() {
            let a = self.state(id)?;
            if targets[..i].iter().any(|(other, _)| *other == id) {
                return Err(TrackError::DuplicateActuator {
                    actuator: a.name.clone(),
                });
            }
            let valid = match a.signal {
                Signal::Binary => target == 0.0 || target == 1.0,
                Signal::Analog => {
                    target.is_finite() && target >= a.range.min && target <= a.range.max
                }
            };
            if !valid {
                let reason = match a.signal {
                    Signal::Binary => "must be true or false".to_owned(),
                    Signal::Analog => format!(
                        "must be within {}..{}, got {target}",
                        a.range.min, a.range.max
                    ),
                };
                return Err(TrackError::InvalidTarget {
                    actuator: a.name.clone(),
                    reason,
                });
            }
            if lockout {
                continue;
            }
            if a.lockout_order.is_some() {
                return Err(TrackError::LockoutPending {
                    actuator: a.name.clone(),
                });
            }
            if matches!(a.phase, Phase::Pending | Phase::Moving) {
                return Err(TrackError::StillMoving {
                    actuator: a.name.clone(),
                });
            }
            if !self.devices[a.device.index()].online {
                return Err(TrackError::DeviceOffline {
                    actuator: a.name.clone(),
                    device: self.devices[a.device.index()].name.clone(),
                });
            }
        }
        Ok(())
    }

    // ---- feedback --------------------------------------------------------------

    /// One feedback sample. `device_ts_ms` (the device's clock) gives the time of flight.
    /// A timestamp more than the plant's `clockSkewMs` ahead of `now` is
    /// refused and nothing of the sample applied; older ones apply in arrival order.
    pub fn feedback(
        &mut self,
        id: ActuatorId,
        value: f64,
        device_ts_ms: Option<Millis>,
        now: Millis,
    ) -> Result<Vec<Effect>, TrackError> {
        self.state(id)?;
        self.check_timestamp(id, device_ts_ms, now)?;
        let mut effects = Vec::new();
        self.sample(id, value, device_ts_ms, now, &mut effects)?;
        Ok(effects)
    }

    /// A device's batch (an actuator panel reports all its actuators together).
    /// A sample that fails is skipped and returned with its actuator; the others still count.
    /// A batch stamped too far in the future is refused whole, nothing of it applied.
    pub fn feedback_batch(
        &mut self,
        samples: &[(ActuatorId, f64)],
        device_ts_ms: Option<Millis>,
        now: Millis,
        effects: &mut Vec<Effect>,
    ) -> Result<Vec<(ActuatorId, TrackError)>, TrackError> {
        if let Some(&(first, _)) = samples.first() {
            self.check_timestamp(first, device_ts_ms, now)?;
        }
        let mut rejected = Vec::new();
        for &(id, value) in samples {
            if let Err(err) = self.sample(id, value, device_ts_ms, now, effects) {
                rejected.push((id, err));
            }
        }
        Ok(rejected)
    }

    /// A device clock ahead of ours would give a negative time of flight and
    /// could make old positions look current.
    fn check_timestamp(
        &self,
        id: ActuatorId,
        device_ts_ms: Option<Millis>,
        now: Millis,
    ) -> Result<(), TrackError> {
        let Some(ts) = device_ts_ms else {
            return Ok(());
        };
        let skew_ms = self.plant.clock_skew_ms;
        if ts <= now.saturating_add(skew_ms) {
            return Ok(());
        }
        Err(TrackError::FutureTimestamp {
            actuator: self
                .actuator_name(id)
                .map_or_else(|| format!("#{}", id.0), str::to_owned),
            ahead_ms: ts.saturating_sub(now),
            skew_ms,
        })
    }

    fn sample(
        &mut self,
        id: ActuatorId,
        value: f64,
        device_ts_ms: Option<Millis>,
        now: Millis,
        effects: &mut Vec<Effect>,
    ) -> Result<(), TrackError> {
        let a = self.state(id)?;
        let valid = match a.signal {
            Signal::Binary => value == 0.0 || value == 1.0,
            Signal::Analog => value.is_finite(),
        };
        if !valid {
            return Err(TrackError::InvalidFeedback {
                actuator: a.name.clone(),
                value,
            });
        }
        let a = &mut self.actuators[id.index()];
        let tolerance = a.range.tolerance;
        a.last_sample_ms = now;
        if a.stale {
            a.stale = false;
            // Fresh again: its feedback can go stale from now on.
            self.due = earliest(
                self.due,
                now.saturating_add(self.timings[a.type_index].stale_ms),
            );
            effects.push(Effect::Recovered {
                actuator: id,
                fault: FaultKind::Stale,
            });
            if a.phase == Phase::Faulted && a.command.is_none() {
                let phase = if a.commanded.is_some() {
                    Phase::Stopped
                } else {
                    Phase::Idle
                };
                a.set_phase(&mut self.tally, phase);
            }
        }
        if a.reported.is_none_or(|r| (value - r).abs() > tolerance) {
            a.reported = Some(value);
            let time_of_flight_ms = device_ts_ms.map(|ts| (now.as_f64() - ts.as_f64()) as i64);
            effects.push(Effect::Changed {
                actuator: id,
                value,
                time_of_flight_ms,
            });
        }
        a.position = Some(value);
        self.devices[a.device.index()].heard = true;
        if let Some(order) = a.lockout_order {
            let online = self.devices[a.device.index()].online;
            if online && (value - order.target).abs() <= tolerance {
                a.set_lockout_order(&mut self.tally, None);
                effects.push(Effect::LockoutConfirmed {
                    actuator: id,
                    after_ms: now.saturating_sub(order.since_ms),
                    sends: order.sends,
                });
            }
        }
        let Some(command) = a.command.as_mut() else {
            // No command: it must stay where it was last put (or first seen).
            let reference = *a.resting.get_or_insert(value);
            let away = (value - reference).abs() > tolerance;
            if away && !a.uncommanded {
                a.uncommanded = true;
                a.set_phase(&mut self.tally, Phase::Faulted);
                effects.push(Effect::Fault {
                    actuator: id,
                    fault: FaultKind::Uncommanded,
                });
            } else if !away && a.uncommanded {
                a.uncommanded = false;
                a.set_phase(&mut self.tally, Phase::Stopped);
                effects.push(Effect::Recovered {
                    actuator: id,
                    fault: FaultKind::Uncommanded,
                });
            }
            return Ok(());
        };
        let start = *command.start.get_or_insert(value);
        let arrived = (value - command.target).abs() <= tolerance;
        if command.moving_ms.is_none() && ((value - start).abs() > tolerance || arrived) {
            command.moving_ms = Some(now);
            effects.push(Effect::Moving {
                actuator: id,
                caller: command.caller,
                issue_to_motion_ms: now.saturating_sub(command.issued_ms),
            });
            a.set_phase(&mut self.tally, Phase::Moving);
        }
        if arrived {
            let command = a.command.take().expect("checked above");
            a.set_phase(&mut self.tally, Phase::Stopped);
            let issue_to_motion_ms = command
                .moving_ms
                .unwrap_or(now)
                .saturating_sub(command.issued_ms);
            let reached = Reached {
                actuator: id,
                target: command.target,
                issue_to_motion_ms,
                completion_ms: now.saturating_sub(command.issued_ms),
                retries: command.retries,
            };
            effects.push(Effect::Completed {
                actuator: id,
                caller: command.caller,
                target: command.target,
                issue_to_motion_ms,
                completion_ms: reached.completion_ms,
                retries: command.retries,
                timed: true,
            });
            self.complete_one(command.caller, reached, now, effects);
        }
        Ok(())
    }

    // ---- devices -----------------------------------------------------------------

    /// A device's availability (its retained status or last will). Offline fails
    /// its actuators' commands (fail-fast); back online, its actuators get their
    /// commanded state (or unconfirmed lockout) again and running commands a
    /// fresh time window.
    pub fn device_status(
        &mut self,
        device: DeviceId,
        online: bool,
        now: Millis,
    ) -> Result<Vec<Effect>, TrackError> {
        let d = self
            .devices
            .get_mut(device.index())
            .ok_or_else(|| TrackError::UnknownDevice {
                name: format!("#{}", device.0),
            })?;
        d.heard = true;
        let mut effects = Vec::new();
        if d.online == online {
            return Ok(effects);
        }
        let members = d.actuators.clone();
        self.devices[device.index()].online = online;
        self.tally.device_online(device, online);
        effects.push(Effect::DeviceStatus { device, online });
        for id in members {
            if online {
                self.republish(id, now, &mut effects);
            }
            let a = &mut self.actuators[id.index()];
            if online {
                a.last_sample_ms = now;
                if let Some(command) = a.command.as_mut() {
                    command.attempt_ms = now;
                    let phase = if command.moving_ms.is_some() {
                        Phase::Moving
                    } else {
                        Phase::Pending
                    };
                    a.set_phase(&mut self.tally, phase);
                } else if a.phase == Phase::Faulted {
                    let phase = if a.commanded.is_some() {
                        Phase::Stopped
                    } else {
                        Phase::Idle
                    };
                    a.set_phase(&mut self.tally, phase);
                }
                effects.push(Effect::Recovered {
                    actuator: id,
                    fault: FaultKind::DeviceOffline,
                });
            } else {
                a.set_phase(&mut self.tally, Phase::Faulted);
                effects.push(Effect::Fault {
                    actuator: id,
                    fault: FaultKind::DeviceOffline,
                });
                self.escalate(id, FaultKind::DeviceOffline, &mut effects);
            }
        }
        if online {
            self.due = self.exact_due();
        }
        Ok(effects)
    }

    /// The MQTT path came back after an outage (publishes in between were
    /// lost): every commanded state is published again, and running commands
    /// and feedback staleness get a fresh window, since silence meant nothing.
    pub fn path_restored(&mut self, now: Millis) -> Vec<Effect> {
        let mut effects = Vec::new();
        for index in 0..self.actuators.len() {
            let id = ActuatorId(index as u32);
            self.republish(id, now, &mut effects);
            let a = &mut self.actuators[index];
            a.last_sample_ms = now;
            if let Some(command) = a.command.as_mut() {
                command.attempt_ms = now;
            }
        }
        effects
    }

    // ---- time ----------------------------------------------------------------------

    /// Checks every threshold: no motion, target not reached (each retried,
    /// then escalated) and stale feedback (not for devices that publish on
    /// change, see [`PlantModel::reports_on_change`]); re-sends an unconfirmed lockout
    /// `completionMs` after its last send. A threshold counts as crossed once
    /// `now - start >= T`. Nothing is checked for a device known offline.
    pub fn tick(&mut self, now: Millis) -> Vec<Effect> {
        let effects = self.tick_thresholds(now);
        self.due = self.exact_due();
        effects
    }

    /// When `tick` is next needed, if ever: the next group command timeout or
    /// threshold, or earlier. A host keeps one timer on it; nothing is due
    /// before it, so a call to `tick` before it does nothing.
    pub fn next_wake(&self) -> Option<Millis> {
        earliest_of(self.next_deadline(), self.due)
    }

    /// The exact earliest time `tick` has work on an actuator (see `tick`): O(actuators).
    fn exact_due(&self) -> Option<Millis> {
        (0..self.actuators.len())
            .filter_map(|index| self.due_of(ActuatorId(index as u32)))
            .min()
    }

    /// When `tick` next has work on one actuator, if ever.
    fn due_of(&self, id: ActuatorId) -> Option<Millis> {
        let a = &self.actuators[id.index()];
        if !self.devices[a.device.index()].online {
            return None;
        }
        let timing = &self.timings[a.type_index];
        let stale =
            (!a.stale && !a.on_change).then(|| a.last_sample_ms.saturating_add(timing.stale_ms));
        let command = a.command.as_ref().filter(|c| !c.escalated).map(|c| {
            let limit = if c.moving_ms.is_none() {
                timing.no_motion_ms.min(timing.completion_ms)
            } else {
                timing.completion_ms
            };
            c.attempt_ms.saturating_add(limit)
        });
        let lockout = a
            .lockout_order
            .map(|o| o.last_send_ms.saturating_add(timing.completion_ms));
        [stale, command, lockout].into_iter().flatten().min()
    }

    /// Work was given to an actuator: `tick` is due by its time at the latest.
    fn lower_due(&mut self, id: ActuatorId) {
        if let Some(at) = self.due_of(id) {
            self.due = earliest(self.due, at);
        }
    }

    fn tick_thresholds(&mut self, now: Millis) -> Vec<Effect> {
        let mut effects = Vec::new();
        self.expire(now, &mut effects);
        for index in 0..self.actuators.len() {
            let id = ActuatorId(index as u32);
            let a = &self.actuators[index];
            if !self.devices[a.device.index()].online {
                continue;
            }
            let timing = &self.timings[a.type_index];
            // A device that publishes on change is silent while nothing moves:
            // its liveness is its status topic (last will) and the broker path.
            let silent_too_long =
                !a.on_change && now.saturating_sub(a.last_sample_ms) >= timing.stale_ms;
            if !a.stale && silent_too_long {
                let a = &mut self.actuators[index];
                a.stale = true;
                a.set_phase(&mut self.tally, Phase::Faulted);
                effects.push(Effect::Fault {
                    actuator: id,
                    fault: FaultKind::Stale,
                });
                self.escalate(id, FaultKind::Stale, &mut effects);
            } else {
                self.check_command(id, now, &mut effects);
            }
            // After the command's own retry, which counts as a send.
            let completion_ms = self.timings[self.actuators[index].type_index].completion_ms;
            let due = self.actuators[index]
                .lockout_order
                .is_some_and(|o| now.saturating_sub(o.last_send_ms) >= completion_ms);
            if due {
                self.resend_lockout(id, now, &mut effects);
            }
        }
        effects
    }

    /// When the next group command's timeout runs out, if one has a timeout:
    /// `tick` then, at the latest, to answer its caller on time.
    pub fn next_deadline(&self) -> Option<Millis> {
        self.groups
            .values()
            .filter_map(|g| g.deadline.map(|(_, at)| at))
            .min()
    }

    /// Withdraws every group whose timeout ran out, earliest first (`tick`
    /// does too; this checks nothing else, for a caller woken at a deadline).
    pub fn expire(&mut self, now: Millis, effects: &mut Vec<Effect>) {
        let mut due: Vec<(Millis, Caller)> = self
            .groups
            .iter()
            .filter_map(|(&caller, g)| {
                g.deadline
                    .filter(|(_, at)| *at <= now)
                    .map(|(_, at)| (at, caller))
            })
            .collect();
        due.sort_unstable();
        for (_, caller) in due {
            let group = self.groups.get(&caller).expect("listed above");
            let (timeout_ms, _) = group.deadline.expect("listed above");
            let waiting = group
                .members
                .iter()
                .copied()
                .filter(|id| {
                    self.actuators[id.index()]
                        .command
                        .as_ref()
                        .is_some_and(|c| c.caller == caller)
                })
                .collect();
            let actuators =
                std::mem::take(&mut self.groups.get_mut(&caller).expect("listed above").reached);
            self.withdraw(caller);
            effects.push(Effect::GroupTimedOut {
                caller,
                timeout_ms,
                waiting,
                actuators,
            });
        }
    }

    /// No motion or target not reached: retried, then escalated.
    fn check_command(&mut self, id: ActuatorId, now: Millis, effects: &mut Vec<Effect>) {
        let a = &self.actuators[id.index()];
        let timing = &self.timings[a.type_index];
        let Some(command) = &a.command else { return };
        if command.escalated {
            return;
        }
        let elapsed = now.saturating_sub(command.attempt_ms);
        let fault = if command.moving_ms.is_none() && elapsed >= timing.no_motion_ms {
            FaultKind::NoMotion
        } else if elapsed >= timing.completion_ms {
            FaultKind::NotReached
        } else {
            return;
        };
        let retries = timing.retries;
        let a = &mut self.actuators[id.index()];
        let Some(command) = a.command.as_mut() else {
            return;
        };
        if command.retries < retries {
            command.retries += 1;
            command.attempt_ms = now;
            effects.push(Effect::Retry {
                actuator: id,
                caller: command.caller,
                attempt: command.retries,
                fault,
            });
            effects.push(publish(
                self.plant.contract(),
                id,
                a.device,
                command.target,
                a.retained,
            ));
            if let Some(order) = a.lockout_order.as_mut() {
                if order.target == command.target {
                    order.sends = order.sends.saturating_add(1);
                    order.last_send_ms = now;
                }
            }
        } else {
            a.set_phase(&mut self.tally, Phase::Faulted);
            effects.push(Effect::Fault {
                actuator: id,
                fault,
            });
            self.escalate(id, fault, effects);
        }
    }

    // ---- internals -------------------------------------------------------------------

    /// Publishes the state the actuator should be in again: its unconfirmed
    /// lockout if it has one, else its last commanded state.
    fn republish(&mut self, id: ActuatorId, now: Millis, effects: &mut Vec<Effect>) {
        let a = &self.actuators[id.index()];
        if a.lockout_order.is_some() {
            self.resend_lockout(id, now, effects);
        } else if let Some(target) = a.commanded {
            effects.push(publish(
                self.plant.contract(),
                id,
                a.device,
                target,
                a.retained,
            ));
        }
    }

    fn resend_lockout(&mut self, id: ActuatorId, now: Millis, effects: &mut Vec<Effect>) {
        let a = &mut self.actuators[id.index()];
        let Some(order) = a.lockout_order.as_mut() else {
            return;
        };
        order.sends = order.sends.saturating_add(1);
        order.last_send_ms = now;
        effects.push(Effect::LockoutResent {
            actuator: id,
            attempt: order.sends - 1,
        });
        effects.push(publish(
            self.plant.contract(),
            id,
            a.device,
            order.target,
            true,
        ));
    }

    fn state(&self, id: ActuatorId) -> Result<&ActuatorState, TrackError> {
        self.actuators
            .get(id.index())
            .ok_or_else(|| TrackError::UnknownActuator {
                name: format!("#{}", id.0),
            })
    }

    /// A failure past its retries: fail-fast ends the command and its group;
    /// hang leaves it for the caller's own timeout.
    fn escalate(&mut self, id: ActuatorId, fault: FaultKind, effects: &mut Vec<Effect>) {
        let escalation = self.timings[self.actuators[id.index()].type_index].escalation;
        let a = &mut self.actuators[id.index()];
        match (escalation, a.command.as_mut()) {
            (_, None) => {}
            (Escalation::Hang, Some(command)) => command.escalated = true,
            (Escalation::FailFast, Some(_)) => {
                let command = a.command.take().expect("matched");
                self.fail_group(&command, id, fault, effects);
            }
        }
    }

    fn complete_one(
        &mut self,
        caller: Caller,
        reached: Reached,
        now: Millis,
        effects: &mut Vec<Effect>,
    ) {
        let Some(group) = self.groups.get_mut(&caller) else {
            return;
        };
        group.reached.push(reached);
        group.remaining -= 1;
        if group.remaining == 0 {
            let group = self.groups.remove(&caller).expect("present");
            effects.push(group.completed(caller, now));
        }
    }

    /// The group of `failed` (the command of `actuator`) fails once, worded
    /// with that command's retries and target; its other actuators stop being waited for.
    fn fail_group(
        &mut self,
        failed: &Command,
        actuator: ActuatorId,
        fault: FaultKind,
        effects: &mut Vec<Effect>,
    ) {
        let caller = failed.caller;
        let Some(group) = self.groups.remove(&caller) else {
            return;
        };
        let retries = failed.retries;
        let message = self
            .describe_fault(actuator, fault, retries, Some(failed.target))
            .unwrap_or_default();
        for a in &mut self.actuators {
            if a.command.as_ref().is_some_and(|c| c.caller == caller) {
                a.command = None;
                if a.phase != Phase::Faulted {
                    a.set_phase(&mut self.tally, Phase::Idle);
                }
            }
        }
        effects.push(Effect::GroupFailed {
            caller,
            actuator,
            fault,
            retries,
            code: fault.code(),
            message,
            actuators: group.reached,
        });
    }
}

/// The command of `id` to `target`, in its device's dialect: a message, or a register write.
fn publish(
    contract: &Contract,
    id: ActuatorId,
    device: DeviceId,
    target: f64,
    retain: bool,
) -> Effect {
    if let Some((device, request)) = contract.modbus().command(id, target) {
        return Effect::Write { device, request };
    }
    let message = contract.command(id, target);
    Effect::Publish {
        device,
        topic: message.topic,
        payload: message.payload,
        retain,
    }
}

#[cfg(test)]
mod tests;

/// The earlier of a time and another, if any.
fn earliest(due: Option<Millis>, at: Millis) -> Option<Millis> {
    Some(due.map_or(at, |d| d.min(at)))
}

/// The earlier of two times, either absent.
fn earliest_of(a: Option<Millis>, b: Option<Millis>) -> Option<Millis> {
    match (a, b) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
}
