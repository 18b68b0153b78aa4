use serde::Serialize;
use sugarshack_core::actuator::outbox::{Blocked, Outlet, Told};
use sugarshack_core::actuator::{ActuatorId, DeviceId, Effect, FaultKind, Terms, TrackError};
use sugarshack_core::code::Code;
use sugarshack_core::plant::group_msg;
use sugarshack_core::plant::Signal;
use sugarshack_core::sensor::{SensorError, SensorId, SensorStore};
use sugarshack_core::topics::modbus::link::Links;
use sugarshack_core::topics::{Incoming, Reading, Readings, Refusal};
use wasm_bindgen::prelude::*;

use crate::operation::OperationRun;
use crate::payload::{self, Payload};
use crate::routine::Routine;
use crate::{from_js_bounded, js_error, plant_document, time, to_js, Bound};
use sugarshack_core::text::quote;
use sugarshack_core::time::Millis;

/// The TypeScript shapes of what this module's calls return and take
/// (`unchecked_return_type` / `unchecked_param_type` name them).
#[wasm_bindgen(typescript_custom_section)]
const TS_SHAPES: &str = r#"
/** A plant document (see the palette's plant schema), as an object or JSON text. */
export type PlantDocument = Record<string, unknown>;

/** `Tracker.counts()` and `countsOn()`. */
export interface TrackerCounts {
    moving: number;
    stopped: number;
    faulted: number;
    lockoutsPending: number;
    offlineDevices: number;
}

/** One actuator of `Tracker.actuators()`. */
export interface PlantActuator {
    handle: number;
    id: string;
    type: string;
    device: string;
    deviceHandle: number | null;
    io: number | null;
    binary: boolean;
    idle: number | null;
    lockout: number;
}

/** A lockout feedback has not confirmed yet. */
export interface PendingLockout {
    /** An actuator handle. */
    actuator: number;
    /** 0/1 for a binary actuator. */
    target: number;
    sinceMs: number;
    sends: number;
}

/** `Tracker.describeFault()`. */
export interface FaultDescription {
    code: string;
    message: string;
}

export type FaultKind =
    | "no-motion" | "not-reached" | "uncommanded" | "stale" | "device-offline" | "locked-out";

/** What a group command's caller is told (a held msg's `msg.command`), by ids. */
export interface GroupOutcome {
    completionMs?: number;
    faultLockoutMs?: number;
    waiting?: string[];
    failed?: { actuator: string; device: string; fault: FaultKind; retries: number };
    actuators: { actuator: string; target: number; issueToMotionMs: number; completionMs: number; retries: number }[];
}

/** The error a group command's caller fails with when it did not complete. */
export interface OutcomeError {
    code: string;
    message: string;
}

/** An actuator of a group command at its target, as the command's outcome lists it. */
export interface Reached {
    actuator: number;
    target: number;
    issueToMotionMs: number;
    completionMs: number;
    retries: number;
}

/** What the tracker asks JS to do (`takeEffects()`), and samples it refused. */
export type TrackerEffect =
    | { kind: "publish"; device: number; topic: string; payload: string; retain: boolean }
    | { kind: "moving"; actuator: number; caller: number; issueToMotionMs: number }
    | { kind: "completed"; actuator: number; caller: number; target: number; issueToMotionMs: number; completionMs: number; retries: number; timed: boolean }
    | { kind: "groupCompleted"; caller: number; completionMs: number; faultLockoutMs?: number; actuators: Reached[]; command: GroupOutcome }
    | { kind: "groupFailed"; caller: number; actuator: number; fault: FaultKind; retries: number; code: string; message: string; actuators: Reached[]; command: GroupOutcome; error: OutcomeError }
    | { kind: "groupTimedOut"; caller: number; timeoutMs: number; waiting: number[]; actuators: Reached[]; command: GroupOutcome; error: OutcomeError }
    | { kind: "retry"; actuator: number; caller: number; attempt: number; fault: FaultKind }
    | { kind: "fault"; actuator: number; fault: FaultKind }
    | { kind: "recovered"; actuator: number; fault: FaultKind }
    | { kind: "changed"; actuator: number; value: number; timeOfFlightMs: number | null }
    | { kind: "deviceStatus"; device: number; online: boolean }
    | { kind: "lockoutConfirmed"; actuator: number; afterMs: number; sends: number }
    | { kind: "lockoutResent"; actuator: number; attempt: number }
    | { kind: "rejected"; actuator: number; code: string; message: string }
    | { kind: "malformed"; device: string; reason: string; message: string }
    | { kind: "modbusSend"; connection: number };

/** A device as an operator sees it. */
export interface DeviceHealth {
    device: string;
    online: boolean;
    /** Actuators whose feedback went silent. */
    stale: string[];
    /** Offline above all, else stale while any actuator is. */
    state: "online" | "stale" | "offline";
}

/** A sensor as an operator sees it (`value` null before the first sample or with no reading). */
export interface SensorHealth {
    sensor: string;
    /** The plant document's unit for it. */
    unit: string | null;
    value: number | null;
    receivedMs: number | null;
    fresh: boolean;
    why: string | null;
}

/** An actuator on its line: its last commanded and reported positions (0/1 when binary). */
export interface ActuatorPosition {
    actuator: string;
    type: string;
    device: string;
    resource: string | null;
    unit: string | null;
    binary: boolean;
    commanded: number | null;
    reported: number | null;
    phase: "idle" | "pending" | "moving" | "stopped" | "faulted";
}

/** `Tracker.health()`. */
export interface PlantHealth {
    devices: DeviceHealth[];
    /** The ids of the devices offline, in plant order. */
    devicesOffline: string[];
    sensors: SensorHealth[];
    actuators: ActuatorPosition[];
    /** Lockouts feedback has not confirmed yet, by actuator id, in plant order. */
    lockoutsPending: { actuator: string; target: number; sinceMs: number; sends: number }[];
    /** The document's operations in its words. */
    operations: { id: string; description: string; resources: string[] }[];
}
"#;

fn sensor_error(err: SensorError) -> JsValue {
    js_error(err.code(), &err.to_string())
}

fn track_error(err: TrackError) -> JsValue {
    js_error(err.code(), &err.to_string())
}

/// What the tracker asks JS to do, plus feedback samples it refused.
#[derive(Serialize)]
#[serde(untagged)]
enum Output {
    /// A group command's outcome, with what its caller is told by ids (`command`).
    Outcome {
        #[serde(flatten)]
        effect: Effect,
        command: sugarshack_core::actuator::Outcome,
        /// A failure's or timeout's error: the caller fails with it.
        #[serde(skip_serializing_if = "Option::is_none")]
        error: Option<OutcomeError>,
    },
    Effect(Effect),
    #[serde(rename_all = "camelCase")]
    Rejected {
        kind: &'static str,
        actuator: u32,
        code: &'static str,
        message: String,
    },
    /// A Modbus connection has a write waiting: call `modbusNext` for it.
    #[serde(rename_all = "camelCase")]
    ModbusSend {
        kind: &'static str,
        connection: u32,
    },
    /// A device message (or part of one) that could not be used.
    #[serde(rename_all = "camelCase")]
    Malformed {
        kind: &'static str,
        /// Its id.
        device: String,
        reason: String,
        message: String,
    },
}

/// The error of a group command that did not complete (`Tracker::outcome_error`).
#[derive(Serialize)]
struct OutcomeError {
    code: &'static str,
    message: String,
}

impl Output {
    /// The core's effect it carries, if any.
    fn effect(&self) -> Option<&Effect> {
        match self {
            Output::Effect(e) | Output::Outcome { effect: e, .. } => Some(e),
            _ => None,
        }
    }
}

/// What [`Tracker::ingest`] made of a message.
#[wasm_bindgen]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ingest {
    /// Not a topic of any device of the plant, and not text that reads as a
    /// group command: someone else's traffic if it came from MQTT.
    Foreign = 0,
    /// A device topic the palette does not read (logs, telemetry, its commands echoed back).
    Other = 1,
    /// A device's availability, applied.
    Status = 2,
    /// Values applied (refused parts queued as `malformed` / `rejected` effects).
    Samples = 3,
    /// Nothing usable: a `malformed` effect is queued.
    Refused = 4,
    /// Not a topic of any device, and its text reads as a group command (or
    /// a broken one, to be refused): see `plant::group_msg::command_like`; or,
    /// in `ingestMsg*`, any msg from the flow (not MQTT) on no device's topic.
    Command = 5,
    /// A device's topic on an actuators node that does not serve that device
    /// (`ingestMsg`): unread, a `malformed` effect says so.
    Unserved = 6,
}

/// What one input did, in one JSON text (`ingestMsg`, `commandMsg`): what the
/// host needs of it without asking again. Empty parts are left out.
#[derive(Serialize, Default)]
#[serde(rename_all = "camelCase")]
struct Answer<'a> {
    #[serde(skip_serializing_if = "Option::is_none")]
    kind: Option<u8>,
    /// The device whose topic it was.
    #[serde(skip_serializing_if = "Option::is_none")]
    device: Option<u32>,
    /// The device time it carried.
    #[serde(skip_serializing_if = "Option::is_none")]
    ts: Option<f64>,
    /// The sensors it gave a value (or a "no reading").
    #[serde(skip_serializing_if = "<[u32]>::is_empty")]
    sensors: &'a [u32],
    /// Its values as `lastSamples` gives them (asked for: a journal records them); NaN is null.
    #[serde(skip_serializing_if = "<[f64]>::is_empty")]
    samples: &'a [f64],
    #[serde(skip_serializing_if = "<[Output]>::is_empty")]
    effects: &'a [Output],
    /// With effects or a command: when `tick` is next due, if ever (`nextWake`).
    #[serde(skip_serializing_if = "Option::is_none")]
    deadline: Option<f64>,
    /// With a command: the counts after it.
    #[serde(skip_serializing_if = "Option::is_none")]
    counts: Option<sugarshack_core::actuator::Counts>,
    /// With a command msg: its caller, which its outcome effects name.
    #[serde(skip_serializing_if = "Option::is_none")]
    caller: Option<u32>,
    /// With a command: whether it is a lockout.
    #[serde(skip_serializing_if = "Option::is_none")]
    lockout: Option<bool>,
    /// What its effects measure, as `[series, ms]` for the host's stats (`Effect::timings`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    timings: Vec<(&'static str, f64)>,
    /// Whether an effect may move what the status shows (anything but new values).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    status: bool,
    /// Whether an effect may move a device's availability or staleness (its alarm conditions).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    health: bool,
}

/// Device payloads larger than this are refused unread.
const MAX_PAYLOAD_BYTES: usize = 16 * 1024 * 1024;

/// MQTT's largest topic (its length is a 16-bit count).
const MAX_TOPIC_BYTES: usize = 65_535;

/// An outlet as JS names it (`"unsent"` or `"held"`).
fn outlet_named(name: &str) -> Result<Outlet, JsValue> {
    Outlet::named(name).ok_or_else(|| {
        js_error(
            Code::InvalidInput,
            &format!("no outlet {}: \"unsent\" or \"held\"", quote(name)),
        )
    })
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct ActuatorView<'a> {
    handle: u32,
    id: &'a str,
    #[serde(rename = "type")]
    kind: &'a str,
    device: &'a str,
    /// Its device's handle (see `devices`).
    device_handle: Option<u32>,
    io: Option<u32>,
    binary: bool,
    idle: Option<f64>,
    lockout: f64,
}

#[derive(serde::Serialize)]
#[serde(rename_all = "camelCase")]
struct SensorView<'a> {
    sensor: String,
    unit: Option<&'a str>,
    value: Option<f64>,
    received_ms: Option<Millis>,
    fresh: bool,
    why: Option<String>,
}

#[derive(serde::Serialize)]
#[serde(rename_all = "camelCase")]
struct HealthView<'a> {
    devices: Vec<sugarshack_core::actuator::DeviceHealth>,
    devices_offline: Vec<String>,
    sensors: Vec<SensorView<'a>>,
    actuators: Vec<PositionView<'a>>,
    lockouts_pending: Vec<LockoutView<'a>>,
    operations: Vec<OperationView<'a>>,
}

/// A lockout feedback has not confirmed yet, by the actuator's id.
#[derive(serde::Serialize)]
#[serde(rename_all = "camelCase")]
struct LockoutView<'a> {
    actuator: &'a str,
    target: f64,
    since_ms: Millis,
    sends: u32,
}

/// An operation in the document's words, so that an operator reads "load truck", not "10".
#[derive(serde::Serialize)]
struct OperationView<'a> {
    id: &'a str,
    description: &'a str,
    resources: &'a [String],
}

/// An actuator as an operator sees it on its line: where it was told to be and where it is.
#[derive(serde::Serialize)]
#[serde(rename_all = "camelCase")]
struct PositionView<'a> {
    actuator: &'a str,
    #[serde(rename = "type")]
    kind: &'a str,
    device: &'a str,
    resource: Option<&'a str>,
    unit: Option<&'a str>,
    binary: bool,
    commanded: Option<f64>,
    reported: Option<f64>,
    phase: sugarshack_core::actuator::Phase,
}

/// The plant as JS sees it: actuator tracking, live sensor values, and the
/// operations and routines of its document. Calls queue their effects;
/// `takeEffects` returns them, so a feedback batch that changes nothing costs
/// no allocation.
#[wasm_bindgen]
pub struct Tracker {
    pub(crate) core: sugarshack_core::actuator::Tracker,
    pub(crate) sensors: SensorStore,
    effects: Vec<Output>,
    scratch: Vec<Effect>,
    batch: Vec<(ActuatorId, f64)>,
    pub(crate) readings: Readings,
    /// Of the last `ingest`: its device, device time and the sensors it updated.
    pub(crate) last_device: Option<u32>,
    last_ts: Option<f64>,
    last_sensors: Vec<u32>,
    /// The last `ingest`'s readings as (0 actuator | 1 sensor, index, value) triples, for a journal.
    last_samples: Vec<f64>,
    /// Its Modbus connections (see `modbus.rs`).
    pub(crate) links: Links,
    /// Per connection: a `modbusSend` is queued since the last `takeEffects`.
    pub(crate) send_queued: Vec<bool>,
    /// The round trip of the last Modbus poll read.
    pub(crate) last_round_trip: Option<f64>,
    pub(crate) conditions: crate::condition::Conditions,
}

impl Tracker {
    fn actuator_id(&self, handle: u32) -> Result<ActuatorId, JsValue> {
        let id = ActuatorId::from_index(handle);
        self.core.actuator_name(id).map(|_| id).ok_or_else(|| {
            track_error(TrackError::UnknownActuator {
                name: format!("#{handle}"),
            })
        })
    }

    fn device_id(&self, handle: u32) -> Result<DeviceId, JsValue> {
        let id = DeviceId::from_index(handle);
        self.core.device_name(id).map(|_| id).ok_or_else(|| {
            track_error(TrackError::UnknownDevice {
                name: format!("#{handle}"),
            })
        })
    }

    pub(crate) fn malformed(
        &mut self,
        device: DeviceId,
        reason: impl Into<String>,
        message: String,
    ) {
        let name = self.core.device_name(device).unwrap_or_default().to_owned();
        self.malformed_named(name, reason, message);
    }

    fn malformed_named(&mut self, device: String, reason: impl Into<String>, message: String) {
        self.effects.push(Output::Malformed {
            kind: "malformed",
            device,
            reason: reason.into(),
            message,
        });
    }

    pub(crate) fn refused(&mut self, device: DeviceId, refusal: Refusal) {
        self.malformed(device, refusal.reason, refusal.message);
    }

    /// Applies what a device message carried; refusals become `malformed` effects.
    pub(crate) fn apply(&mut self, device: DeviceId, ts: Option<Millis>, now: Millis) {
        let mut readings = std::mem::take(&mut self.readings);
        for refusal in readings.refusals.drain(..) {
            self.refused(device, refusal);
        }
        self.batch.clear();
        for reading in &readings.samples {
            match *reading {
                Reading::Actuator(id, value) => {
                    self.last_samples.extend([0.0, id.index() as f64, value]);
                    self.batch.push((id, value));
                }
                Reading::Sensor(id, value) => {
                    self.last_samples.extend([1.0, id.index() as f64, value]);
                    let sampled = ts.unwrap_or(now);
                    match self.sensors.record(id, value, sampled, now) {
                        Ok(()) => self.last_sensors.push(id.index() as u32),
                        Err(err) => self.malformed(device, err.code().name(), err.to_string()),
                    }
                }
                Reading::SensorUnavailable(id) => {
                    self.last_samples.extend([1.0, id.index() as f64, f64::NAN]);
                    if self.sensors.record_unavailable(id, now).is_ok() {
                        self.last_sensors.push(id.index() as u32);
                    }
                }
            }
        }
        self.readings = readings;
        if self.batch.is_empty() {
            return;
        }
        let mut effects = std::mem::take(&mut self.scratch);
        let outcome = self.core.feedback_batch(&self.batch, ts, now, &mut effects);
        self.queue(effects.drain(..));
        self.scratch = effects;
        match outcome {
            Ok(rejected) => {
                for (id, err) in rejected {
                    self.effects.push(Output::Rejected {
                        kind: "rejected",
                        actuator: id.index() as u32,
                        code: err.code().name(),
                        message: err.to_string(),
                    });
                }
            }
            Err(err) => self.malformed(device, err.code().name(), err.to_string()),
        }
    }

    /// Before a call that reads device traffic: what the last one read is gone.
    pub(crate) fn forget_last(&mut self) {
        self.last_device = None;
        self.last_ts = None;
        self.last_round_trip = None;
        self.last_sensors.clear();
        self.last_samples.clear();
    }

    /// `answer` with the queued effects (then taken) and, if any, the next deadline, as JSON text.
    fn answer(&mut self, mut answer: Answer) -> Result<String, JsValue> {
        let mut effects = std::mem::take(&mut self.effects);
        if !effects.is_empty() || answer.lockout.is_some() {
            answer.deadline = self.next_wake();
        }
        let answer = Answer {
            status: effects
                .iter()
                .any(|o| o.effect().is_none_or(Effect::moves_status)),
            health: effects
                .iter()
                .any(|o| o.effect().is_some_and(Effect::moves_health)),
            timings: effects
                .iter()
                .filter_map(Output::effect)
                .flat_map(Effect::timings)
                .flatten()
                .map(|(series, ms)| (series, ms.as_f64()))
                .collect(),
            effects: &effects,
            ..answer
        };
        let text =
            serde_json::to_string(&answer).map_err(|e| js_error(Code::Internal, &e.to_string()));
        effects.clear();
        self.effects = effects;
        self.send_queued.fill(false);
        text
    }

    /// The answer to a device msg: what [`Tracker::ingest`] read and applied.
    fn ingested(&mut self, kind: Ingest, samples: bool) -> Result<String, JsValue> {
        let last_sensors = std::mem::take(&mut self.last_sensors);
        let last_samples = std::mem::take(&mut self.last_samples);
        let text = self.answer(Answer {
            kind: Some(kind as u8),
            device: self.last_device,
            ts: self.last_ts,
            sensors: &last_sensors,
            samples: if samples { &last_samples } else { &[] },
            ..Answer::default()
        });
        self.last_sensors = last_sensors;
        self.last_samples = last_samples;
        text
    }

    /// A device msg on a node serving `served` (device handles; every device when none):
    /// `Unserved` for another device's topic, else read as [`Tracker::ingest`] reads it.
    fn unserved(&mut self, topic: &str, served: Option<&[u32]>) -> bool {
        let Some(served) = served else { return false };
        let served: Vec<DeviceId> = served.iter().map(|&d| DeviceId::from_index(d)).collect();
        let Some(device) = self.core.contract().unserved(topic, &served) else {
            return false;
        };
        self.forget_last();
        self.last_device = Some(device.index() as u32);
        let name = self.core.device_name(device).unwrap_or_default().to_owned();
        self.refused(device, Refusal::not_served(&name));
        true
    }

    /// A device msg read by `read` (text or bytes, as it came: no copy), unless
    /// its topic is a device the node does not serve; answered by [`Tracker::ingested`].
    fn ingest_answered(
        &mut self,
        topic: &str,
        served: Option<Vec<u32>>,
        samples: bool,
        from_mqtt: Option<bool>,
        read: impl FnOnce(&mut Self) -> Result<Ingest, JsValue>,
    ) -> Result<String, JsValue> {
        let kind = match self.unserved(topic, served.as_deref()) {
            true => Ingest::Unserved,
            // Only MQTT brings someone else's traffic; from the flow it is a group command.
            false => match read(self)? {
                Ingest::Foreign if from_mqtt == Some(false) => Ingest::Command,
                kind => kind,
            },
        };
        self.ingested(kind, samples)
    }

    /// Queues the core's effects; a Modbus write goes to its connection's
    /// queue instead, and JS is told once that the connection has one.
    pub(crate) fn queue(&mut self, effects: impl IntoIterator<Item = Effect>) -> u32 {
        for effect in effects {
            let Effect::Write { device, request } = effect else {
                self.effects.push(match self.core.outcome(&effect) {
                    Some(command) => Output::Outcome {
                        error: self.core.outcome_error(&effect).map(|(code, message)| {
                            OutcomeError {
                                code: code.name(),
                                message,
                            }
                        }),
                        effect,
                        command,
                    },
                    None => Output::Effect(effect),
                });
                continue;
            };
            let Some(connection) = self.links.enqueue(device, request) else {
                continue; // closed: written again when the device is back
            };
            if !std::mem::replace(&mut self.send_queued[connection], true) {
                self.effects.push(Output::ModbusSend {
                    kind: "modbusSend",
                    connection: connection as u32,
                });
            }
        }
        self.effects.len() as u32
    }
}

#[wasm_bindgen]
impl Tracker {
    /// `plant`: the plant document. Refused with every problem listed (code `INVALID_PLANT`).
    #[wasm_bindgen(constructor)]
    pub fn new(
        #[wasm_bindgen(unchecked_param_type = "PlantDocument | string")] plant: JsValue,
        now_ms: f64,
    ) -> Result<Tracker, JsValue> {
        let plant = plant_document(plant)?;
        let now = time(now_ms)?;
        let core = sugarshack_core::actuator::Tracker::new(plant, now)
            .map_err(|errors| js_error(Code::InvalidPlant, &errors.to_string()))?;
        let links = Links::new(core.contract().modbus(), now);
        Ok(Tracker {
            send_queued: vec![false; links.len()],
            links,
            last_round_trip: None,
            sensors: SensorStore::new(core.plant()),
            core,
            effects: Vec::new(),
            scratch: Vec::new(),
            batch: Vec::new(),
            readings: Readings::default(),
            last_device: None,
            last_ts: None,
            last_sensors: Vec::new(),
            last_samples: Vec::new(),
            conditions: Default::default(),
        })
    }

    /// What the plant document holds that is legal but probably unintended (duplicate priorities...).
    pub fn warnings(&self) -> Vec<String> {
        self.core
            .plant()
            .warnings()
            .iter()
            .map(ToString::to_string)
            .collect()
    }

    pub fn actuator(&self, name: &str) -> Result<u32, JsValue> {
        self.core
            .actuator(name)
            .map(|id| id.index() as u32)
            .map_err(track_error)
    }

    pub fn device(&self, name: &str) -> Result<u32, JsValue> {
        self.core
            .device(name)
            .map(|id| id.index() as u32)
            .map_err(track_error)
    }

    /// The actuator a device reports as `<type>` number `io`, if the plant names one.
    pub fn slot(&self, device: u32, kind: &str, io: u32) -> Option<u32> {
        self.core
            .slot(DeviceId::from_index(device), kind, io)
            .map(|id| id.index() as u32)
    }

    /// Every actuator: `[{ handle, id, type, device, deviceHandle, io, binary, idle, lockout }]`.
    #[wasm_bindgen(unchecked_return_type = "PlantActuator[]")]
    pub fn actuators(&self) -> Result<JsValue, JsValue> {
        let views: Vec<ActuatorView> = self
            .core
            .plant()
            .actuators
            .iter()
            .enumerate()
            .map(|(i, a)| {
                let id = ActuatorId::from_index(i as u32);
                ActuatorView {
                    handle: i as u32,
                    id: &a.id,
                    kind: &a.kind,
                    device: &a.device,
                    device_handle: self.core.device(&a.device).ok().map(|d| d.index() as u32),
                    io: a.io,
                    binary: self.core.signal(id) == Some(Signal::Binary),
                    idle: self.core.idle_state(id),
                    lockout: self.core.lockout_state(id).unwrap_or_default(),
                }
            })
            .collect();
        to_js(&views)
    }

    /// Device ids in handle order.
    pub fn devices(&self) -> Vec<String> {
        self.core
            .plant()
            .devices
            .iter()
            .map(|d| d.id.clone())
            .collect()
    }

    /// Issues a group command (`{"valves": {"V12": 100}, "pumps": {"P1": true}}`), all or
    /// nothing; returns how many effects are queued. A refusal throws and sends nothing.
    /// `within`: the resources the commanding operation holds (C2), if it is one.
    /// A normal command to an actuator whose lockout is unconfirmed throws `LOCKOUT_PENDING`.
    /// `faultAtMs`: when the fault it answers was raised; its `groupCompleted` then has `faultLockoutMs`.
    /// `timeoutMs`: how long its caller waits (`nextDeadline`, `expire`).
    // One crossing per command: each of its terms is an argument, not an object to read.
    #[allow(clippy::too_many_arguments)]
    pub fn command(
        &mut self,
        #[wasm_bindgen(unchecked_param_type = "GroupCommand | string")] payload: JsValue,
        caller: u32,
        lockout: bool,
        now_ms: f64,
        within: Option<Vec<String>>,
        fault_at_ms: Option<f64>,
        timeout_ms: Option<f64>,
    ) -> Result<u32, JsValue> {
        let now = time(now_ms)?;
        // A fault time that is no time (a msg's stray `faultAtMs`) reports no fault lockout time;
        // a timeout that is none (0, NaN) sets no limit.
        let terms = Terms {
            lockout,
            fault_at: fault_at_ms.and_then(Millis::whole),
            timeout: timeout_ms.and_then(Millis::whole),
        };
        let payload: serde_json::Value = from_js_bounded(
            payload,
            Code::InvalidGroup,
            "invalid group command",
            Bound::GroupCommand,
        )?;
        let targets = self.core.parse_group(&payload).map_err(track_error)?;
        if let Some(held) = within {
            self.core
                .check_within(&targets, &held)
                .map_err(track_error)?;
        }
        let effects = self
            .core
            .issue(&targets, u64::from(caller), terms, now)
            .map_err(track_error)?;
        Ok(self.queue(effects))
    }

    /// A group command msg in one call: read as `readGroupMsg` reads it
    /// (`msg.topic`, `msg.lockout`, `msg.interlock`, `msg.payload`), issued as
    /// `command` issues it. Answers JSON text: `{ refusal }` (as
    /// `readGroupMsg`'s) or `{ caller, lockout, effects?, deadline?, counts }`
    /// (`caller`: as `nextCaller` gives it); the command's refusal throws.
    #[wasm_bindgen(js_name = commandMsg)]
    #[allow(clippy::too_many_arguments)]
    pub fn command_msg(
        &mut self,
        #[wasm_bindgen(unchecked_param_type = "unknown")] topic: JsValue,
        #[wasm_bindgen(unchecked_param_type = "unknown")] lockout: JsValue,
        #[wasm_bindgen(unchecked_param_type = "unknown")] interlock: JsValue,
        #[wasm_bindgen(unchecked_param_type = "unknown")] payload: JsValue,
        now_ms: f64,
        fault_at_ms: Option<f64>,
        timeout_ms: Option<f64>,
    ) -> Result<String, JsValue> {
        let (read, payload) = match crate::group::read_msg(&topic, &lockout, &interlock, payload) {
            Ok(read) => read,
            Err(refusal) => {
                return Ok(
                    serde_json::json!({ "refusal": crate::group::refusal_json(&refusal) })
                        .to_string(),
                )
            }
        };
        let caller = self.next_caller();
        self.command(
            payload,
            caller,
            read.lockout,
            now_ms,
            read.within,
            fault_at_ms,
            timeout_ms,
        )?;
        let counts = self.core.counts();
        self.answer(Answer {
            caller: Some(caller),
            lockout: Some(read.lockout),
            counts: Some(counts),
            ..Answer::default()
        })
    }

    /// A caller for the next `command`: a positive integer no group command
    /// still waiting has (see the core's `Tracker::new_caller`).
    #[wasm_bindgen(js_name = nextCaller)]
    pub fn next_caller(&mut self) -> u32 {
        // The core gives callers within u32 (MAX_CALLER).
        self.core.new_caller() as u32
    }

    /// Stops waiting for a caller's group (its msg timed out, or its node closed);
    /// an unconfirmed lockout stays standing.
    pub fn withdraw(&mut self, caller: u32) -> bool {
        self.core.withdraw(u64::from(caller))
    }

    /// One sample; `ts` is the device's timestamp (ms), if it sent one. A `ts`
    /// more than the plant's `clockSkewMs` ahead of `nowMs` throws `FUTURE_TIMESTAMP`.
    pub fn feedback(
        &mut self,
        actuator: u32,
        value: f64,
        ts: Option<f64>,
        now_ms: f64,
    ) -> Result<u32, JsValue> {
        let id = self.actuator_id(actuator)?;
        let effects = self
            .core
            .feedback(id, value, ts.and_then(Millis::whole), time(now_ms)?)
            .map_err(track_error)?;
        Ok(self.queue(effects))
    }

    /// A device batch as parallel arrays of actuator handles and values. Refused
    /// samples are queued as `{ kind: "rejected", actuator, code, message }`.
    /// A batch stamped too far in the future throws `FUTURE_TIMESTAMP`, nothing applied.
    #[wasm_bindgen(js_name = feedbackBatch)]
    pub fn feedback_batch(
        &mut self,
        actuators: &[u32],
        values: &[f64],
        ts: Option<f64>,
        now_ms: f64,
    ) -> Result<u32, JsValue> {
        let now = time(now_ms)?;
        if actuators.len() != values.len() {
            return Err(js_error(
                Code::InvalidFeedback,
                "a batch needs as many values as actuators",
            ));
        }
        self.batch.clear();
        for (&handle, &value) in actuators.iter().zip(values) {
            self.batch.push((self.actuator_id(handle)?, value));
        }
        let mut effects = std::mem::take(&mut self.scratch);
        let outcome =
            self.core
                .feedback_batch(&self.batch, ts.and_then(Millis::whole), now, &mut effects);
        self.queue(effects.drain(..));
        self.scratch = effects;
        for (id, err) in outcome.map_err(track_error)? {
            self.effects.push(Output::Rejected {
                kind: "rejected",
                actuator: id.index() as u32,
                code: err.code().name(),
                message: err.to_string(),
            });
        }
        Ok(self.effects.len() as u32)
    }

    /// Reads and applies one MQTT message by the plant's device profiles:
    /// availability, actuator states and sensor values of any device. What
    /// it could not use is queued as `{ kind: "malformed", device, reason,
    /// message }` (or `rejected` for a value the actuator cannot have); it
    /// throws only on a bad `nowMs`. Feedback's hot path: no serde.
    /// A lockout topic is a `Command`, unread; so is text on no device's
    /// topic that reads as one.
    pub fn ingest(&mut self, topic: &str, payload: &str, now_ms: f64) -> Result<Ingest, JsValue> {
        let kind = self.ingest_bytes(topic, payload.as_bytes(), now_ms)?;
        Ok(match kind {
            Ingest::Foreign if self.core.plant().command_like(payload) => Ingest::Command,
            kind => kind,
        })
    }

    /// [`Tracker::ingest`] for a payload as bytes (an MQTT Buffer): on no
    /// device's topic, bytes are never taken for a group command.
    #[wasm_bindgen(js_name = ingestBytes)]
    pub fn ingest_bytes(
        &mut self,
        topic: &str,
        payload: &[u8],
        now_ms: f64,
    ) -> Result<Ingest, JsValue> {
        self.ingest_sized(topic, Ok(payload), now_ms)
    }

    /// [`Tracker::ingest_bytes`] of bytes, or of a payload over the bound left
    /// in JS (`Err`: at least its size in bytes).
    fn ingest_sized(
        &mut self,
        topic: &str,
        payload: Result<&[u8], usize>,
        now_ms: f64,
    ) -> Result<Ingest, JsValue> {
        let now = time(now_ms)?;
        self.forget_last();
        if group_msg::is_lockout_topic(topic) {
            return Ok(Ingest::Command);
        }
        let payload = match payload {
            Ok(bytes) if bytes.len() <= MAX_PAYLOAD_BYTES => bytes,
            over => return Ok(self.too_large(topic, over.map_or_else(|size| size, <[u8]>::len))),
        };
        let contract = self.core.contract();
        let mut readings = std::mem::take(&mut self.readings);
        let incoming = contract.parse(topic, payload, now, &mut readings);
        self.readings = readings;
        Ok(match incoming {
            Incoming::Foreign => Ingest::Foreign,
            Incoming::Other { device } => {
                self.last_device = Some(device.index() as u32);
                Ingest::Other
            }
            Incoming::Status { device, online } => {
                self.last_device = Some(device.index() as u32);
                let effects = self
                    .core
                    .device_status(device, online, now)
                    .map_err(track_error)?;
                self.queue(effects);
                Ingest::Status
            }
            Incoming::Samples { device, ts } => {
                self.last_device = Some(device.index() as u32);
                self.last_ts = ts.map(Millis::as_f64);
                self.apply(device, ts, now);
                Ingest::Samples
            }
            Incoming::Refused { device, refusal } => {
                self.last_device = Some(device.index() as u32);
                self.refused(device, refusal);
                Ingest::Refused
            }
            Incoming::UnknownDevice { name } => {
                let message = format!("device '{}' is not in the plant document", quote(&name));
                self.malformed_named(quote(&name), "unknown device", message);
                Ingest::Refused
            }
        })
    }

    /// A payload over the bound (`size`: at least its bytes), refused unread.
    fn too_large(&mut self, topic: &str, size: usize) -> Ingest {
        let Some(device) = self.core.contract().device_of(topic) else {
            return Ingest::Foreign;
        };
        self.last_device = Some(device.index() as u32);
        self.malformed(
            device,
            "too large",
            format!(
                "payload of {size} bytes is over the {} MiB a device message may have",
                MAX_PAYLOAD_BYTES >> 20
            ),
        );
        Ingest::Refused
    }

    /// One device msg in one call: `ingest` (text) and what it did, as JSON
    /// text `{ kind, device?, ts?, sensors?, samples?, effects?, status?, health?, deadline? }`
    /// (see `Answer`). `served`: the devices of the actuators node it came to
    /// (all when none); `samples`: whether to list the values read; `fromMqtt`:
    /// whether it came from `mqtt in` (false: from the flow, so on no device's
    /// topic it is a group command, `Command`; unknown: told as `Foreign`).
    #[wasm_bindgen(js_name = ingestMsg)]
    pub fn ingest_msg(
        &mut self,
        topic: &str,
        payload: &str,
        now_ms: f64,
        served: Option<Vec<u32>>,
        samples: bool,
        from_mqtt: Option<bool>,
    ) -> Result<String, JsValue> {
        self.ingest_answered(topic, served, samples, from_mqtt, |t| {
            t.ingest(topic, payload, now_ms)
        })
    }

    /// [`Tracker::ingest_msg`] for a payload as bytes (`ingestBytes`).
    #[wasm_bindgen(js_name = ingestMsgBytes)]
    pub fn ingest_msg_bytes(
        &mut self,
        topic: &str,
        payload: &[u8],
        now_ms: f64,
        served: Option<Vec<u32>>,
        samples: bool,
        from_mqtt: Option<bool>,
    ) -> Result<String, JsValue> {
        self.ingest_answered(topic, served, samples, from_mqtt, |t| {
            t.ingest_bytes(topic, payload, now_ms)
        })
    }

    /// [`Tracker::ingest_msg`] for a payload as Node-RED handed it over: text,
    /// bytes (a Buffer), or a value (what `mqtt in` auto-detect parsed from
    /// JSON), which is read as JSON text; see `payload`. Never throws for the
    /// payload, whatever it is.
    #[wasm_bindgen(js_name = ingestMsgValue)]
    pub fn ingest_msg_value(
        &mut self,
        topic: &str,
        #[wasm_bindgen(unchecked_param_type = "unknown")] payload: JsValue,
        now_ms: f64,
        served: Option<Vec<u32>>,
        samples: bool,
        from_mqtt: Option<bool>,
    ) -> Result<String, JsValue> {
        match payload::read(&payload, MAX_PAYLOAD_BYTES) {
            Payload::Text(text) => {
                self.ingest_msg(topic, &text, now_ms, served, samples, from_mqtt)
            }
            Payload::Bytes(bytes) => {
                self.ingest_msg_bytes(topic, &bytes, now_ms, served, samples, from_mqtt)
            }
            Payload::TooLarge(size) => {
                self.ingest_answered(topic, served, samples, from_mqtt, |t| {
                    t.ingest_sized(topic, Err(size), now_ms)
                })
            }
        }
    }

    /// The device of the last `ingest`, if its topic was a device's.
    #[wasm_bindgen(js_name = lastDevice)]
    pub fn last_device(&self) -> Option<u32> {
        self.last_device
    }

    /// The device time (epoch ms) the last `ingest` carried, if any.
    #[wasm_bindgen(js_name = lastTs)]
    pub fn last_ts(&self) -> Option<f64> {
        self.last_ts
    }

    /// The sensors the last `ingest` gave a value (or a "no reading").
    #[wasm_bindgen(js_name = lastSensors)]
    pub fn last_sensors(&self) -> Vec<u32> {
        self.last_sensors.clone()
    }

    /// The values the last `ingest` read, as flat triples: 0 (actuator) or 1
    /// (sensor), its handle, the value (NaN for a sensor's "no reading").
    #[wasm_bindgen(js_name = lastSamples)]
    pub fn last_samples(&self) -> Vec<f64> {
        self.last_samples.clone()
    }

    /// How many effects are queued (`takeEffects` returns them).
    pub fn queued(&self) -> u32 {
        self.effects.len() as u32
    }

    /// The device a topic belongs to under the plant's profiles, if any.
    #[wasm_bindgen(js_name = topicDevice)]
    pub fn topic_device(&self, topic: &str) -> Option<u32> {
        self.core
            .contract()
            .device_of(topic)
            .map(|d| d.index() as u32)
    }

    /// Whether `key` can start a group command (`valves`, `pump`...): a msg
    /// on a foreign topic with such a key is a command, else someone else's traffic.
    #[wasm_bindgen(js_name = isGroupKey)]
    pub fn is_group_key(&self, key: &str) -> bool {
        self.core.plant().is_group_key(key)
    }

    /// The topic of a line's lockout msg (`lockout/<line>`), which a group command node reads as a lockout.
    #[wasm_bindgen(js_name = lockoutTopic)]
    pub fn lockout_topic(&self, line: &str) -> String {
        group_msg::lockout_topic(line)
    }

    /// A device's availability (its retained status or last will).
    #[wasm_bindgen(js_name = deviceStatus)]
    pub fn device_status(
        &mut self,
        device: u32,
        online: bool,
        now_ms: f64,
    ) -> Result<u32, JsValue> {
        let id = self.device_id(device)?;
        let effects = self
            .core
            .device_status(id, online, time(now_ms)?)
            .map_err(track_error)?;
        Ok(self.queue(effects))
    }

    /// The MQTT connection is back: every commanded state is published again
    /// and running commands get a fresh window; returns how many effects are queued.
    #[wasm_bindgen(js_name = pathRestored)]
    pub fn path_restored(&mut self, now_ms: f64) -> Result<u32, JsValue> {
        let effects = self.core.path_restored(time(now_ms)?);
        Ok(self.queue(effects))
    }

    /// Checks every threshold; returns how many effects are queued.
    pub fn tick(&mut self, now_ms: f64) -> Result<u32, JsValue> {
        let effects = self.core.tick(time(now_ms)?);
        Ok(self.queue(effects))
    }

    /// Withdraws the group commands whose timeout ran out (`groupTimedOut`),
    /// and nothing else; returns how many effects are queued.
    pub fn expire(&mut self, now_ms: f64) -> Result<u32, JsValue> {
        let mut effects = Vec::new();
        self.core.expire(time(now_ms)?, &mut effects);
        Ok(self.queue(effects))
    }

    /// When the next group command's or wait's timeout runs out (epoch ms), if
    /// any: call `expire` and `expireWaits` then.
    #[wasm_bindgen(js_name = nextDeadline)]
    pub fn next_deadline(&self) -> Option<f64> {
        let waits = self.conditions.waits.next_deadline();
        self.core
            .next_deadline()
            .into_iter()
            .chain(waits)
            .min()
            .map(Millis::as_f64)
    }

    /// When `tick` (and `expireWaits`) is next due (epoch ms: a group command
    /// timeout, a threshold or a wait's timeout), if ever: a host keeps one
    /// timer on it. A tick before it does nothing.
    #[wasm_bindgen(js_name = nextWake)]
    pub fn next_wake(&self) -> Option<f64> {
        let waits = self.conditions.waits.next_deadline();
        self.core
            .next_wake()
            .into_iter()
            .chain(waits)
            .min()
            .map(Millis::as_f64)
    }

    /// The queued effects, oldest first, as plain objects with a `kind`.
    #[wasm_bindgen(js_name = takeEffects, unchecked_return_type = "TrackerEffect[]")]
    pub fn take_effects(&mut self) -> Result<JsValue, JsValue> {
        let out = to_js(&self.effects);
        self.effects.clear();
        self.send_queued.fill(false);
        out
    }

    /// The queued effects as [`Tracker::ingestMsg`] answers them (with the
    /// next deadline when there are any), in one JSON text.
    #[wasm_bindgen(js_name = takeAnswer, unchecked_return_type = "string")]
    pub fn take_answer(&mut self) -> Result<String, JsValue> {
        self.answer(Answer::default())
    }

    /// The actuators nodes serving the devices changed: an unserved device is reported again.
    #[wasm_bindgen(js_name = servingChanged)]
    pub fn serving_changed(&mut self) {
        self.core.serving_changed();
    }

    /// A publish (as a `publish` effect gave it) that could not go out, and
    /// why (`blocked`: the cluster role of an instance that may not act,
    /// `"deploying"` when no actuators node serves its device during a
    /// deploy, else `"unserved"`): the core keeps it (a suspended leader's as
    /// `"held"`, a deploy's as `"unsent"`) within `bound` (Node-RED's
    /// `nodeMessageBufferMaxLength`; 0: 10000), dropping one past it but never
    /// a lockout, or drops it (see `sugarshack_core::actuator::outbox`).
    /// Returns what to tell: the bound in force at the first drop since the
    /// publishes last went out, -1 when no actuators node serves the device
    /// (once per device until `servingChanged`), else 0.
    #[wasm_bindgen(js_name = notSent)]
    pub fn not_sent(
        &mut self,
        blocked: &str,
        device: u32,
        topic: String,
        payload: String,
        retain: bool,
        bound: f64,
    ) -> Result<f64, JsValue> {
        let blocked = Blocked::named(blocked).ok_or_else(|| {
            js_error(
                Code::InvalidInput,
                &format!("no reason a publish is not sent: {}", quote(blocked)),
            )
        })?;
        let device = self.device_id(device)?;
        if topic.len() > MAX_TOPIC_BYTES || payload.len() > MAX_PAYLOAD_BYTES {
            return Err(js_error(
                Code::InputTooLarge,
                "a publish's topic or payload is larger than any the plant makes",
            ));
        }
        if !(bound.is_finite() && (0.0..=f64::from(u32::MAX)).contains(&bound)) {
            return Err(js_error(
                Code::InvalidInput,
                &format!("a publish bound must be a count, got {}", quote(bound)),
            ));
        }
        let told = self
            .core
            .not_sent(blocked, device, topic, payload, retain, bound as usize);
        Ok(match told {
            Told::Dropped { bound } => bound as f64,
            Told::Unserved => -1.0,
            Told::Nothing => 0.0,
        })
    }

    /// What waited at `outlet` goes out: its publishes are queued, oldest
    /// first, then (if the core dropped any) every commanded state and
    /// standing lockout again; returns how many effects are queued.
    #[wasm_bindgen(js_name = sendKept)]
    pub fn send_kept(&mut self, outlet: &str, now_ms: f64) -> Result<u32, JsValue> {
        let outlet = outlet_named(outlet)?;
        let effects = self.core.send_kept(outlet, time(now_ms)?);
        Ok(self.queue(effects))
    }

    /// What waits at `outlet` is dropped unsent (a deposed leader's).
    #[wasm_bindgen(js_name = dropKept)]
    pub fn drop_kept(&mut self, outlet: &str) -> Result<(), JsValue> {
        self.core.drop_kept(outlet_named(outlet)?);
        Ok(())
    }

    /// How many publishes wait at `outlet`.
    #[wasm_bindgen(js_name = keptPublishes)]
    pub fn kept_publishes(&self, outlet: &str) -> Result<u32, JsValue> {
        Ok(self.core.kept_publishes(outlet_named(outlet)?) as u32)
    }

    /// `{ moving, stopped, faulted, lockoutsPending }`.
    #[wasm_bindgen(unchecked_return_type = "TrackerCounts")]
    pub fn counts(&self) -> Result<JsValue, JsValue> {
        to_js(&self.core.counts())
    }

    /// The same counts for the actuators on `devices` (device handles; an unknown one counts nothing).
    #[wasm_bindgen(js_name = countsOn, unchecked_return_type = "TrackerCounts")]
    pub fn counts_on(&self, devices: &[u32]) -> Result<JsValue, JsValue> {
        let devices = devices.iter().map(|&d| DeviceId::from_index(d));
        to_js(&self.core.counts_on(devices))
    }

    /// Lockouts feedback has not confirmed yet: `[{ actuator, target, sinceMs, sends }]`
    /// (`actuator` a handle, `target` a number, 0/1 for binary), in handle order.
    #[wasm_bindgen(js_name = pendingLockouts, unchecked_return_type = "PendingLockout[]")]
    pub fn pending_lockouts(&self) -> Result<JsValue, JsValue> {
        to_js(&self.core.pending_lockouts())
    }

    /// `idle`, `pending`, `moving`, `stopped` or `faulted`.
    pub fn phase(&self, actuator: u32) -> Result<String, JsValue> {
        let phase = self
            .core
            .phase(self.actuator_id(actuator)?)
            .expect("checked handle");
        Ok(serde_json::to_value(phase)
            .ok()
            .and_then(|v| v.as_str().map(str::to_owned))
            .unwrap_or_default())
    }

    pub fn position(&self, actuator: u32) -> Option<f64> {
        self.core.position(ActuatorId::from_index(actuator))
    }

    /// Where it was last commanded to (0/1 for binary), if ever.
    pub fn target(&self, actuator: u32) -> Option<f64> {
        self.core.commanded(ActuatorId::from_index(actuator))
    }

    /// One device as an operator sees it (`health()`'s entry for it).
    #[wasm_bindgen(js_name = deviceHealth, unchecked_return_type = "DeviceHealth")]
    pub fn device_health(&self, device: u32) -> Result<JsValue, JsValue> {
        let health = self
            .core
            .device_health_of(DeviceId::from_index(device))
            .ok_or_else(|| {
                js_error(
                    Code::UnknownDevice,
                    &format!("no device with handle {device}"),
                )
            })?;
        to_js(&health)
    }

    /// Why a group command failed on `actuator`: `{ code, message }`, worded
    /// by the core from the plant document. `fault` is the effect's fault name;
    /// `target` what the command asked for (a number or a boolean), if known.
    #[wasm_bindgen(js_name = describeFault, unchecked_return_type = "FaultDescription")]
    pub fn describe_fault(
        &self,
        actuator: u32,
        fault: &str,
        retries: u32,
        #[wasm_bindgen(unchecked_param_type = "number | boolean | null | undefined")]
        target: JsValue,
    ) -> Result<JsValue, JsValue> {
        let id = self.actuator_id(actuator)?;
        let kind = FaultKind::from_name(fault).ok_or_else(|| {
            js_error(
                Code::InvalidInput,
                &format!("unknown fault '{}'", quote(fault)),
            )
        })?;
        let target = target
            .as_f64()
            .or_else(|| target.as_bool().map(|on| if on { 1.0 } else { 0.0 }));
        let message = self
            .core
            .describe_fault(id, kind, retries, target)
            .ok_or_else(|| js_error(Code::Internal, "the actuator has no type"))?;
        to_js(&serde_json::json!({ "code": kind.code(), "message": message }))
    }

    // ---- operations and routines -------------------------------------------

    /// The plan of an operation: `{ id, priority, resources, steps: [{ kind, ... }] }`,
    /// its last step returning every commanded actuator to idle.
    #[wasm_bindgen(js_name = operationPlan, unchecked_return_type = "OperationPlan")]
    pub fn operation_plan(&self, id: &str) -> Result<JsValue, JsValue> {
        let plan = self.core.plant().operation_plan(id).ok_or_else(|| {
            js_error(
                Code::UnknownOperation,
                &format!(
                    "unknown operation '{}': it is not in the plant document",
                    quote(id)
                ),
            )
        })?;
        to_js(&plan)
    }

    /// `[{ name, lockout }]`: the plant's resources as an interlock configures them.
    #[wasm_bindgen(js_name = interlockResources, unchecked_return_type = "ResourceConfig[]")]
    pub fn interlock_resources(&self) -> Result<JsValue, JsValue> {
        to_js(&self.core.plant().interlock_config().resources)
    }

    /// A run of operation `id` of this plant, not started.
    #[wasm_bindgen(js_name = operationRun)]
    pub fn operation_run(&self, id: &str) -> Result<OperationRun, JsValue> {
        OperationRun::of(self.core.plant(), id)
    }

    /// A run saved held, back on this plant's plan of it: `{ run, effects }`;
    /// refused (`INVALID_SNAPSHOT`) when the plan changed since.
    #[wasm_bindgen(js_name = restoreRun, unchecked_return_type = "RestoredRun")]
    pub fn restore_run(
        &self,
        #[wasm_bindgen(unchecked_param_type = "RunSnapshot")] snapshot: JsValue,
    ) -> Result<JsValue, JsValue> {
        OperationRun::restore(self.core.plant(), snapshot)
    }

    /// Routine `id` of this plant, in its initial state.
    pub fn routine(&self, id: &str) -> Result<Routine, JsValue> {
        Routine::of(self.core.plant(), id)
    }

    // ---- sensors ---------------------------------------------------------------

    pub fn sensor(&self, name: &str) -> Result<u32, JsValue> {
        self.sensors
            .sensor(name)
            .map(|id| id.index() as u32)
            .map_err(sensor_error)
    }

    /// Sensor ids in handle order.
    pub fn sensors(&self) -> Vec<String> {
        (0..self.sensors.len())
            .map(|i| self.sensors.name(SensorId::from_index(i as u32)).to_owned())
            .collect()
    }

    /// The sensor a device publishes as datapoint `name`, if the plant names one.
    #[wasm_bindgen(js_name = sensorSlot)]
    pub fn sensor_slot(&self, device: &str, name: &str) -> Option<u32> {
        self.sensors.slot(device, name).map(|id| id.index() as u32)
    }

    pub(crate) fn sensor_id(&self, handle: u32) -> Result<SensorId, JsValue> {
        if (handle as usize) < self.sensors.len() {
            Ok(SensorId::from_index(handle))
        } else {
            Err(sensor_error(SensorError::UnknownSensor {
                name: format!("#{handle}"),
            }))
        }
    }

    /// Keeps a sample in place of the last one received (`ts`: the device's
    /// timestamp, else the reception time): true. Throws `FUTURE_TIMESTAMP`,
    /// keeping nothing, when `ts` is further ahead of `now` than the plant's
    /// `clockSkewMs`.
    #[wasm_bindgen(js_name = recordSensor)]
    pub fn record_sensor(
        &mut self,
        sensor: u32,
        value: f64,
        ts: Option<f64>,
        now_ms: f64,
    ) -> Result<bool, JsValue> {
        let now = time(now_ms)?;
        let id = self.sensor_id(sensor)?;
        self.sensors
            .record(id, value, ts.and_then(Millis::whole).unwrap_or(now), now)
            .map_err(sensor_error)?;
        Ok(true)
    }

    /// What an operator reads of the plant now: `{ devices: [{ device, online,
    /// stale: [actuator] }], sensors: [{ sensor, unit, value, receivedMs, fresh,
    /// why }], actuators: [{ actuator, type, device, resource, unit, binary,
    /// commanded, reported, phase }], lockoutsPending, operations }` (`value`
    /// null before the first sample or when the device reports none).
    #[wasm_bindgen(unchecked_return_type = "PlantHealth")]
    pub fn health(&self, now_ms: f64) -> Result<JsValue, JsValue> {
        let now = time(now_ms)?;
        let plant = self.core.plant();
        let sensors: Vec<SensorView> = (0..self.sensors.len() as u32)
            .map(|i| {
                let id = sugarshack_core::sensor::SensorId::from_index(i);
                let sample = self.sensors.sample(id);
                let fresh = self.sensors.fresh(id, now);
                SensorView {
                    sensor: self.sensors.name(id).to_owned(),
                    unit: plant.sensors[i as usize].unit.as_deref(),
                    value: sample.map(|s| s.value).filter(|v| v.is_finite()),
                    received_ms: sample.map(|s| s.received_ms),
                    fresh: fresh.is_ok(),
                    why: fresh.err().map(|e| e.to_string()),
                }
            })
            .collect();
        let actuators = plant
            .actuators
            .iter()
            .enumerate()
            .map(|(i, a)| {
                let id = ActuatorId::from_index(i as u32);
                PositionView {
                    actuator: &a.id,
                    kind: &a.kind,
                    device: &a.device,
                    resource: a.resource.as_deref(),
                    unit: plant
                        .actuator_types
                        .get(&a.kind)
                        .and_then(|t| t.unit.as_deref()),
                    binary: self.core.signal(id) == Some(Signal::Binary),
                    commanded: self.core.commanded(id),
                    reported: self.core.position(id),
                    phase: self.core.phase(id).expect("an actuator of the plant"),
                }
            })
            .collect();
        let lockouts_pending = self
            .core
            .pending_lockouts()
            .into_iter()
            .map(|o| LockoutView {
                actuator: &plant.actuators[o.actuator.index()].id,
                target: o.target,
                since_ms: o.since_ms,
                sends: o.sends,
            })
            .collect();
        let operations = plant
            .operations
            .iter()
            .map(|o| OperationView {
                id: &o.id,
                description: o.description.as_deref().unwrap_or_default(),
                resources: &o.resources,
            })
            .collect();
        to_js(&HealthView {
            devices: self.core.device_health(),
            devices_offline: self.core.devices_offline(),
            sensors,
            actuators,
            lockouts_pending,
            operations,
        })
    }

    /// The alarm conditions of the plant's devices (offline, stale feedback),
    /// worded by the core: `[{ kind, subject, text, sinceMs }]`.
    #[wasm_bindgen(js_name = alarmConditions, unchecked_return_type = "AlarmCondition[]")]
    pub fn alarm_conditions(&self) -> Result<JsValue, JsValue> {
        to_js(&sugarshack_core::alarm::device_conditions(
            &self.core.device_health(),
        ))
    }
}
