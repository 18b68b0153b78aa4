//! The whole MQTT contract between the palette and its devices, for every
//! device profile: which topics carry a device's availability, its actuators'
//! states and its sensors' values, how their payloads read, and which topic
//! and payload command an actuator. Both sides use it: the palette parses
//! feedback and formats commands ([`Contract::parse`], [`Contract::command`]);
//! a simulated device formats feedback and parses commands
//! ([`Contract::format_actuator`], [`Contract::parse_command`]...), so the two
//! always agree.
//!
//! Every topic a plant's devices publish is known when the contract is built,
//! so reading a message is one hash lookup plus the payload's own parse.
//!
//! ```
//! use sugarshack_core::plant::PlantModel;
//! use sugarshack_core::topics::{Contract, Incoming, Readings, Reading};
//! use sugarshack_core::time::ms;
//!
//! let plant: PlantModel = serde_json::from_str(r#"{
//!   "actuatorTypes": { "pump": { "signal": "binary",
//!     "noMotionMs": 3000, "completionMs": 6000, "staleMs": 5000 } },
//!   "devices": [{ "id": "ctrl-1", "kind": "actuator-panel", "profile": "esphome" }],
//!   "actuators": [{ "id": "P1", "type": "pump", "device": "ctrl-1", "idle": false, "lockout": false }]
//! }"#).unwrap();
//! let contract = Contract::new(&plant).unwrap();
//! let mut readings = Readings::default();
//! let seen = contract.parse("ctrl-1/switch/p1/state", b"ON", ms(0), &mut readings);
//! assert!(matches!(seen, Incoming::Samples { .. }));
//! assert!(matches!(readings.samples[..], [Reading::Actuator(_, v)] if v == 1.0));
//! let command = contract.command(sugarshack_core::actuator::ActuatorId::from_index(0), 0.0);
//! assert_eq!((command.topic.as_str(), command.payload.as_str()), ("ctrl-1/switch/p1/command", "OFF"));
//! ```

pub mod custom;
mod esphome;
pub mod modbus;
mod read;
mod shelly;
mod sugarshack;
mod tasmota;

use std::collections::HashMap;

use serde::Serialize;

use crate::actuator::{ActuatorId, DeviceId};
use crate::plant::{PlantError, PlantModel, Profile, Signal};
use crate::sensor::SensorId;
use crate::text::quote;
use crate::time::Millis;

pub(crate) use read::Read;

/// One MQTT message to publish.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Message {
    /// The MQTT topic.
    pub topic: String,
    /// The MQTT payload.
    pub payload: String,
    /// Whether the broker keeps it for later subscribers.
    pub retain: bool,
}

/// Why a message (or part of one) was not used.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Refusal {
    /// Short and stable, for counting: `bad JSON`, `bad status`, `non-numeric value`...
    pub reason: &'static str,
    /// What is wrong with it.
    pub message: String,
}

impl Refusal {
    /// A device's msg on an actuators node that does not speak for that device
    /// (see [`Contract::unserved`]): unread, and said so.
    pub fn not_served(device: &str) -> Self {
        Refusal::new(
            "device not served",
            format!(
                "device '{}' is not in this node's device list",
                quote(device)
            ),
        )
    }

    pub(crate) fn new(reason: &'static str, message: impl Into<String>) -> Self {
        Refusal {
            reason,
            message: message.into(),
        }
    }
}

/// What an incoming message is.
#[derive(Clone, Debug, PartialEq)]
pub enum Incoming {
    /// Not a topic of any device of the plant (discovery, another system's traffic).
    Foreign,
    /// A topic of a device that carries nothing the palette reads (logs,
    /// telemetry, its commands echoed back, an entity the plant does not name).
    Other {
        /// The device.
        device: DeviceId,
    },
    /// Its availability (birth message or last will).
    Status {
        /// The device.
        device: DeviceId,
        /// Whether it is online.
        online: bool,
    },
    /// Samples and refusals of parts, put in the caller's [`Readings`];
    /// `ts` is the device's time (epoch ms) when the message carried one.
    Samples {
        /// The device.
        device: DeviceId,
        /// The device's time (epoch ms), when given.
        ts: Option<Millis>,
    },
    /// Nothing in it could be used.
    Refused {
        /// The device.
        device: DeviceId,
        /// Why.
        refusal: Refusal,
    },
    /// Shaped like a sugarshack device's state topic, from a device the
    /// plant does not have (a typo in a device id, a device not added yet).
    UnknownDevice {
        /// The device id in the topic.
        name: String,
    },
}

/// A value read from a device.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reading {
    /// An actuator's position.
    Actuator(ActuatorId, f64),
    /// A sensor's value.
    Sensor(SensorId, f64),
    /// The device says the sensor has no reading (ESPHome `nan`).
    SensorUnavailable(SensorId),
}

/// Filled by [`Contract::parse`]; reused from message to message so the hot path does not allocate.
#[derive(Clone, Debug, Default)]
pub struct Readings {
    /// The values read.
    pub samples: Vec<Reading>,
    /// Parts of a message refused while the rest was read (one bad member of a batch).
    pub refusals: Vec<Refusal>,
}

impl Readings {
    fn clear(&mut self) {
        self.samples.clear();
        self.refusals.clear();
    }
}

/// A command a device received, as it understood it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command {
    /// Set the actuator to this value.
    Set(ActuatorId, f64),
    /// An empty payload: a retained command cleared from the broker.
    Cleared(ActuatorId),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Target {
    Actuator(ActuatorId),
    Sensor(SensorId),
}

/// How the device's time is read from a JSON payload.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Stamp {
    None,
    /// Epoch milliseconds under this key (this palette's `ts`, a custom path).
    EpochMs,
    /// Epoch seconds with a fraction (Shelly's NotifyStatus `params.ts`).
    EpochSeconds,
}

/// One value inside a JSON document, by its path of keys.
#[derive(Clone, Debug)]
pub(crate) struct Field {
    pub path: Vec<String>,
    pub target: Target,
    pub read: Read,
}

#[derive(Clone, Debug)]
pub(crate) enum Route {
    Status(DeviceId),
    /// This palette's `<prefix>/state` batch.
    Batch(DeviceId),
    /// This palette's `<prefix>/<type>/<io>/state` and `<prefix>/sensor/<name>/state`.
    Single(DeviceId, Target),
    /// A plain text payload (ESPHome, Tasmota `stat/<t>/POWER1`).
    Text(DeviceId, Target, Read),
    /// A JSON document carrying any number of values (Tasmota RESULT/SENSOR,
    /// Shelly status, custom paths); absent fields are not an error.
    Json {
        device: DeviceId,
        fields: Vec<Field>,
        stamp: Stamp,
        stamp_path: Vec<String>,
    },
}

impl Route {
    fn device(&self) -> DeviceId {
        match self {
            Route::Status(d) | Route::Batch(d) | Route::Single(d, _) | Route::Text(d, _, _) => *d,
            Route::Json { device, .. } => *device,
        }
    }
}

/// How a command for an actuator is written.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Form {
    /// The target as a number; `percent` maps the actuator's range onto 0..100.
    Number {
        percent: Option<(f64, f64)>,
        before: String,
        after: String,
    },
    /// One word for on, one for off.
    Words { on: String, off: String },
}

impl Form {
    /// One word for on, one for off.
    pub(crate) fn words(on: &str, off: &str) -> Form {
        Form::Words {
            on: on.into(),
            off: off.into(),
        }
    }
}

#[derive(Clone, Debug)]
pub(crate) struct CommandRoute {
    pub topic: String,
    pub form: Form,
}

#[derive(Clone, Debug)]
struct DeviceContract {
    profile: Profile,
    online: String,
    offline: String,
    status_topic: Option<String>,
}

/// The MQTT contract of one plant, built once from its validated document.
#[derive(Clone, Debug)]
pub struct Contract {
    routes: HashMap<String, Route>,
    /// Topic prefixes (`ctrl-1`, Tasmota's `stat/ctrl-1`...) -> their device.
    prefixes: HashMap<String, DeviceId>,
    devices: Vec<DeviceContract>,
    commands: Vec<CommandRoute>,
    /// Command topic -> actuator, for the device side.
    command_topics: HashMap<String, ActuatorId>,
    /// Sugarshack batches: per device, per type name, io -> actuator.
    slots: Vec<Vec<(String, HashMap<u32, ActuatorId>)>>,
    type_names: Vec<String>,
    /// Whether any device speaks the sugarshack profile.
    sugarshack: bool,
    signals: Vec<Signal>,
    /// Per sensor: the device-side route, to format a value.
    sensor_routes: Vec<SensorFormat>,
    actuator_feedback: Vec<ActuatorFormat>,
    /// The registers of its Modbus devices and how they are polled.
    modbus: modbus::ModbusMap,
}

/// What a device publishes for one actuator (device side).
#[derive(Clone, Debug)]
pub(crate) struct ActuatorFormat {
    pub device: DeviceId,
    pub kind: FeedbackKind,
}

#[derive(Clone, Debug)]
pub(crate) enum FeedbackKind {
    Sugarshack {
        kind: String,
        io: u32,
    },
    Esphome {
        component: crate::plant::Component,
        topic: String,
        range: (f64, f64),
    },
    TasmotaPower(String),
    TasmotaShutter(String),
    ShellySwitch(String),
    ShellyCover(String, (f64, f64)),
    Custom {
        topic: String,
        path: Vec<String>,
        words: Option<(String, String)>,
    },
    /// Registers, not messages (see [`modbus::ModbusMap::image`]).
    Modbus,
}

#[derive(Clone, Debug)]
pub(crate) struct SensorFormat {
    pub device: DeviceId,
    pub kind: SensorKind,
}

#[derive(Clone, Debug)]
pub(crate) enum SensorKind {
    /// Its own topic with a plain number (ESPHome) or `{"ts","value"}` (sugarshack).
    Topic(String),
    /// A path inside a document shared by the device's sensors (Tasmota SENSOR, Shelly status).
    Shared { topic: String, path: Vec<String> },
    /// A register of a Modbus device, not a message.
    Modbus,
}

/// What building the routes of one device needs.
pub(crate) struct Builder {
    routes: HashMap<String, (Route, String)>,
    pub errors: Vec<PlantError>,
}

impl Builder {
    /// Adds a route; a topic two entries claim is an error at `path`.
    pub fn route(&mut self, topic: String, route: Route, path: &str) {
        if let Some((_, owner)) = self.routes.get(&topic) {
            if owner != path {
                self.errors.push(PlantError {
                    path: path.to_owned(),
                    message: format!("its topic '{}' is also {}'s", quote(&topic), quote(owner)),
                });
            }
            return;
        }
        self.routes.insert(topic, (route, path.to_owned()));
    }

    /// Adds a field to a JSON route shared by several entries (a Tasmota SENSOR document).
    pub fn field(
        &mut self,
        topic: String,
        device: DeviceId,
        stamp: Stamp,
        field: Field,
        path: &str,
    ) {
        let stamp_path = match stamp {
            Stamp::EpochSeconds => vec!["params".into(), "ts".into()],
            _ => vec!["ts".into()],
        };
        self.field_at(topic, device, (stamp, stamp_path), field, path);
    }

    /// As [`Builder::field`], with the timestamp at `stamp.1`.
    pub fn field_at(
        &mut self,
        topic: String,
        device: DeviceId,
        (stamp, stamp_path): (Stamp, Vec<String>),
        field: Field,
        path: &str,
    ) {
        match self.routes.get_mut(&topic) {
            Some((Route::Json { fields, .. }, _)) => {
                if fields.iter().any(|f| f.path == field.path) {
                    self.errors.push(PlantError {
                        path: path.to_owned(),
                        message: format!(
                            "'{}' in '{}' is already another entry's",
                            quote(field.path.join(".")),
                            quote(&topic)
                        ),
                    });
                } else {
                    fields.push(field);
                }
            }
            Some((_, owner)) => {
                let owner = owner.clone();
                self.errors.push(PlantError {
                    path: path.to_owned(),
                    message: format!("its topic '{}' is also {}'s", quote(&topic), quote(owner)),
                });
            }
            None => {
                self.routes.insert(
                    topic,
                    (
                        Route::Json {
                            device,
                            fields: vec![field],
                            stamp,
                            stamp_path,
                        },
                        path.to_owned(),
                    ),
                );
            }
        }
    }

    pub fn error(&mut self, path: &str, message: impl Into<String>) {
        self.errors.push(PlantError {
            path: path.to_owned(),
            message: message.into(),
        });
    }
}

pub(crate) fn actuator_path(i: usize, id: &str) -> String {
    format!("actuators[{i}] ({})", quote(id))
}

pub(crate) fn sensor_path(i: usize, id: &str) -> String {
    format!("sensors[{i}] ({})", quote(id))
}

pub(crate) fn device_path(i: usize, id: &str) -> String {
    format!("devices[{i}] ({})", quote(id))
}

/// A topic level or prefix a device can have: no wildcards, no empty levels.
pub(crate) fn topic_prefix_ok(prefix: &str) -> bool {
    !prefix.is_empty()
        && !prefix.contains(['+', '#'])
        && !prefix.chars().any(char::is_whitespace)
        && prefix.split('/').all(|level| !level.is_empty())
}

impl Contract {
    /// The contract of a plant; every problem (a missing entity, two entries
    /// on one topic, a bad template) is an error naming the entry.
    pub fn new(plant: &PlantModel) -> Result<Contract, Vec<PlantError>> {
        let mut b = Builder {
            routes: HashMap::new(),
            errors: Vec::new(),
        };
        let device_index: HashMap<&str, DeviceId> = plant
            .devices
            .iter()
            .enumerate()
            .map(|(i, d)| (d.id.as_str(), DeviceId::from_index(i as u32)))
            .collect();
        let mut prefixes = HashMap::new();
        let mut devices = Vec::with_capacity(plant.devices.len());
        for (i, d) in plant.devices.iter().enumerate() {
            let id = DeviceId::from_index(i as u32);
            let path = device_path(i, &d.id);
            let prefix = d.prefix();
            if d.prefix.is_some() && !topic_prefix_ok(prefix) {
                b.error(
                    &path,
                    format!("prefix '{}' must be MQTT topic levels without '+', '#', spaces or empty levels", quote(prefix)),
                );
            }
            if d.custom.is_some() && d.profile != Profile::Custom {
                b.error(&path, "'custom' is for devices with profile \"custom\"");
            }
            let (online, offline, status_topic) = match d.profile {
                Profile::Sugarshack | Profile::Esphome => (
                    "online".to_owned(),
                    "offline".to_owned(),
                    Some(format!("{prefix}/status")),
                ),
                Profile::Tasmota => (
                    "Online".to_owned(),
                    "Offline".to_owned(),
                    Some(format!("tele/{prefix}/LWT")),
                ),
                Profile::ShellyGen2 => (
                    "true".to_owned(),
                    "false".to_owned(),
                    Some(format!("{prefix}/online")),
                ),
                Profile::Custom => match &d.custom {
                    None => {
                        b.error(&path, "a custom device needs 'custom': its topic templates");
                        (String::new(), String::new(), None)
                    }
                    Some(c) => custom::status(c, prefix, &d.id, &path, &mut b),
                },
                // Polled: its liveness is its answers (see modbus::link).
                Profile::Modbus => (String::new(), String::new(), None),
            };
            let owned: Vec<String> = match d.profile {
                Profile::Tasmota => ["cmnd", "stat", "tele"]
                    .iter()
                    .map(|p| format!("{p}/{prefix}"))
                    .collect(),
                Profile::Modbus => Vec::new(),
                _ => vec![prefix.to_owned()],
            };
            for p in owned {
                if let Some(other) = prefixes.insert(p.clone(), id) {
                    b.error(
                        &path,
                        format!(
                            "topic prefix '{}' is also device '{}''s",
                            quote(&p),
                            quote(&plant.devices[other.index()].id)
                        ),
                    );
                }
            }
            if let Some(topic) = &status_topic {
                b.route(topic.clone(), Route::Status(id), &path);
            }
            devices.push(DeviceContract {
                profile: d.profile,
                online,
                offline,
                status_topic,
            });
        }

        let mut commands = Vec::with_capacity(plant.actuators.len());
        let mut signals = Vec::with_capacity(plant.actuators.len());
        let mut actuator_feedback = Vec::with_capacity(plant.actuators.len());
        let mut slots = vec![Vec::new(); plant.devices.len()];
        for (i, a) in plant.actuators.iter().enumerate() {
            let id = ActuatorId::from_index(i as u32);
            let path = actuator_path(i, &a.id);
            let (Some(&device), Some(t)) = (
                device_index.get(a.device.as_str()),
                plant.actuator_types.get(&a.kind),
            ) else {
                // Reported by the plant's own checks; placeholders keep indices aligned.
                commands.push(CommandRoute {
                    topic: String::new(),
                    form: Form::words("", ""),
                });
                signals.push(Signal::Binary);
                actuator_feedback.push(ActuatorFormat {
                    device: DeviceId::from_index(0),
                    kind: FeedbackKind::Sugarshack {
                        kind: String::new(),
                        io: 0,
                    },
                });
                continue;
            };
            let d = &plant.devices[device.index()];
            let range = t.range(a.tolerance);
            let spec = ActuatorSpec {
                id,
                device,
                prefix: d.prefix(),
                signal: t.signal,
                range: (range.min, range.max),
                path: &path,
            };
            if d.profile != Profile::Esphome && a.component.is_some() {
                b.error(&path, "'component' is for esphome devices");
            }
            let (command, feedback) = match d.profile {
                Profile::Sugarshack => {
                    let io = sugarshack::actuator(&spec, a, &mut b, &mut slots[device.index()]);
                    (
                        sugarshack::command(&spec, &a.kind, io),
                        FeedbackKind::Sugarshack {
                            kind: a.kind.clone(),
                            io,
                        },
                    )
                }
                Profile::Esphome => esphome::actuator(&spec, a, &mut b),
                Profile::Tasmota => tasmota::actuator(&spec, a, &mut b),
                Profile::ShellyGen2 => shelly::actuator(&spec, a, &mut b),
                Profile::Custom => match &d.custom {
                    Some(c) => custom::actuator(c, &spec, a, &mut b),
                    None => (
                        CommandRoute {
                            topic: String::new(),
                            form: Form::words("", ""),
                        },
                        FeedbackKind::Sugarshack {
                            kind: String::new(),
                            io: 0,
                        },
                    ),
                },
                // Written through its register (see `modbus`), not on a topic.
                Profile::Modbus => (
                    CommandRoute {
                        topic: String::new(),
                        form: Form::words("", ""),
                    },
                    FeedbackKind::Modbus,
                ),
            };
            commands.push(command);
            signals.push(t.signal);
            actuator_feedback.push(ActuatorFormat {
                device,
                kind: feedback,
            });
        }

        let mut sensor_routes = Vec::with_capacity(plant.sensors.len());
        for (i, s) in plant.sensors.iter().enumerate() {
            let id = SensorId::from_index(i as u32);
            let path = sensor_path(i, &s.id);
            let Some(&device) = device_index.get(s.device.as_str()) else {
                sensor_routes.push(SensorFormat {
                    device: DeviceId::from_index(0),
                    kind: SensorKind::Topic(String::new()),
                });
                continue;
            };
            let d = &plant.devices[device.index()];
            let spec = SensorSpec {
                id,
                device,
                prefix: d.prefix(),
                sensor: s,
                path: &path,
            };
            let kind = match d.profile {
                Profile::Sugarshack => sugarshack::sensor(&spec, &mut b),
                Profile::Esphome => esphome::sensor(&spec, &mut b),
                Profile::Tasmota => tasmota::sensor(&spec, &mut b),
                Profile::ShellyGen2 => shelly::sensor(&spec, &mut b),
                Profile::Custom => match &d.custom {
                    Some(c) => custom::sensor(c, &spec, &mut b),
                    None => SensorKind::Topic(String::new()),
                },
                Profile::Modbus => SensorKind::Modbus,
            };
            sensor_routes.push(SensorFormat { device, kind });
        }

        for (i, d) in plant.devices.iter().enumerate() {
            let id = DeviceId::from_index(i as u32);
            if d.profile == Profile::Sugarshack {
                b.route(
                    format!("{}/state", d.prefix()),
                    Route::Batch(id),
                    &device_path(i, &d.id),
                );
            }
        }

        let modbus = modbus::ModbusMap::new(plant, &device_index, &mut b);

        if !b.errors.is_empty() {
            return Err(b.errors);
        }
        let command_topics = commands
            .iter()
            .enumerate()
            .filter(|(_, c)| !c.topic.is_empty())
            .map(|(i, c)| (c.topic.clone(), ActuatorId::from_index(i as u32)))
            .collect();
        Ok(Contract {
            routes: b.routes.into_iter().map(|(t, (r, _))| (t, r)).collect(),
            prefixes,
            devices,
            commands,
            command_topics,
            slots,
            type_names: plant.actuator_types.keys().cloned().collect(),
            sugarshack: plant
                .devices
                .iter()
                .any(|d| d.profile == Profile::Sugarshack),
            signals,
            sensor_routes,
            actuator_feedback,
            modbus,
        })
    }

    // ---- the palette's side --------------------------------------------------

    /// The device a topic belongs to, if any (by its exact route or its prefix).
    pub fn device_of(&self, topic: &str) -> Option<DeviceId> {
        if let Some(route) = self.routes.get(topic) {
            return Some(route.device());
        }
        topic
            .match_indices('/')
            .find_map(|(at, _)| self.prefixes.get(&topic[..at]).copied())
    }

    /// The device of `topic` when `served` does not include it: a device's msg
    /// handed to an actuators node that does not speak for that device.
    pub fn unserved(&self, topic: &str, served: &[DeviceId]) -> Option<DeviceId> {
        self.device_of(topic)
            .filter(|device| !served.contains(device))
    }

    /// Reads one incoming message. `now` tells a timestamp in seconds
    /// from one in milliseconds. Never panics, whatever the bytes.
    pub fn parse(&self, topic: &str, payload: &[u8], now: Millis, out: &mut Readings) -> Incoming {
        out.clear();
        let Some(route) = self.routes.get(topic) else {
            return match self.device_of(topic) {
                Some(device) => Incoming::Other { device },
                None => match sugarshack::unknown_device(self, topic).filter(|_| self.sugarshack) {
                    Some(name) => Incoming::UnknownDevice {
                        name: name.to_owned(),
                    },
                    None => Incoming::Foreign,
                },
            };
        };
        let device = route.device();
        let outcome = match route {
            Route::Status(device) => self.status(*device, payload),
            Route::Batch(device) => sugarshack::batch(self, *device, payload, now, out),
            Route::Single(device, target) => {
                sugarshack::single(*device, *target, self.signal_of(*target), payload, now, out)
            }
            Route::Text(device, target, read) => read::text(payload).map(|text| {
                read::one(*target, read.decode(read::Raw::Text(text)), out);
                self.samples_or_other(*device, None, out)
            }),
            Route::Json {
                device,
                fields,
                stamp,
                stamp_path,
            } => read::json_fields(*device, fields, *stamp, stamp_path, payload, now, out)
                .map(|ts| self.samples_or_other(*device, ts, out)),
        };
        match outcome {
            Ok(incoming) => incoming,
            Err(refusal) => Incoming::Refused { device, refusal },
        }
    }

    fn samples_or_other(&self, device: DeviceId, ts: Option<Millis>, out: &Readings) -> Incoming {
        if out.samples.is_empty() && out.refusals.is_empty() {
            Incoming::Other { device }
        } else {
            Incoming::Samples { device, ts }
        }
    }

    fn signal_of(&self, target: Target) -> Option<Signal> {
        match target {
            Target::Actuator(a) => self.signals.get(a.index()).copied(),
            Target::Sensor(_) => None,
        }
    }

    fn status(&self, device: DeviceId, payload: &[u8]) -> Result<Incoming, Refusal> {
        let d = &self.devices[device.index()];
        let text = std::str::from_utf8(payload).unwrap_or("");
        let text = text.trim();
        if text == d.online {
            Ok(Incoming::Status {
                device,
                online: true,
            })
        } else if text == d.offline {
            Ok(Incoming::Status {
                device,
                online: false,
            })
        } else {
            Err(Refusal::new(
                "bad status",
                format!(
                    "status must be \"{}\" or \"{}\", got {}",
                    d.online,
                    d.offline,
                    quote(String::from_utf8_lossy(payload))
                ),
            ))
        }
    }

    /// The message that commands actuator `id` to `target` (a validated target of its signal).
    pub fn command(&self, id: ActuatorId, target: f64) -> Message {
        let route = &self.commands[id.index()];
        Message {
            topic: route.topic.clone(),
            payload: read::format_command(&route.form, target),
            retain: false,
        }
    }

    /// The command topic of actuator `id` (a retained lockout is cleared there).
    pub fn command_topic(&self, id: ActuatorId) -> &str {
        &self.commands[id.index()].topic
    }

    /// The profile of a device.
    pub fn profile(&self, device: DeviceId) -> Option<Profile> {
        self.devices.get(device.index()).map(|d| d.profile)
    }

    /// Its Modbus devices' registers, polling plans and connections.
    pub fn modbus(&self) -> &modbus::ModbusMap {
        &self.modbus
    }

    // ---- the device's side ---------------------------------------------------

    /// The topics a device subscribes to for its commands.
    pub fn command_topics(&self, device: DeviceId) -> Vec<String> {
        self.actuator_feedback
            .iter()
            .zip(&self.commands)
            .filter(|(f, c)| f.device == device && !c.topic.is_empty())
            .map(|(_, c)| c.topic.clone())
            .collect()
    }

    /// Reads a command as the device would: None when the topic commands no actuator of the plant.
    pub fn parse_command(&self, topic: &str, payload: &[u8]) -> Option<Result<Command, Refusal>> {
        let &id = self.command_topics.get(topic)?;
        let form = &self.commands[id.index()].form;
        Some(read::text(payload).and_then(|text| {
            if text.trim().is_empty() {
                return Ok(Command::Cleared(id));
            }
            read::parse_command(form, text).map(|v| Command::Set(id, v))
        }))
    }

    /// The device's availability message (retained; also its last will when offline).
    pub fn format_status(&self, device: DeviceId, online: bool) -> Option<Message> {
        let d = self.devices.get(device.index())?;
        Some(Message {
            topic: d.status_topic.clone()?,
            payload: if online {
                d.online.clone()
            } else {
                d.offline.clone()
            },
            retain: true,
        })
    }

    /// What a device publishes for its actuators at `values` (in the
    /// firmware's own form: one batch for sugarshack, else per entity).
    pub fn format_actuators(
        &self,
        device: DeviceId,
        values: &[(ActuatorId, f64)],
        ts: Option<Millis>,
    ) -> Vec<Message> {
        let Some(d) = self.devices.get(device.index()) else {
            return Vec::new();
        };
        if d.profile == Profile::Sugarshack {
            return sugarshack::format_batch(self, device, values, ts);
        }
        let mut out = Vec::new();
        for &(id, value) in values {
            let Some(f) = self.actuator_feedback.get(id.index()) else {
                continue;
            };
            if f.device != device {
                continue;
            }
            let signal = self.signals[id.index()];
            match &f.kind {
                FeedbackKind::Sugarshack { .. } | FeedbackKind::Modbus => {}
                FeedbackKind::Esphome {
                    component,
                    topic,
                    range,
                } => esphome::format(*component, topic, *range, signal, value, &mut out),
                FeedbackKind::TasmotaPower(_) | FeedbackKind::TasmotaShutter(_) => {
                    tasmota::format(&self.prefix_of(device), &f.kind, value, &mut out)
                }
                FeedbackKind::ShellySwitch(_) | FeedbackKind::ShellyCover(..) => {
                    shelly::format(&self.prefix_of(device), &f.kind, value, &mut out)
                }
                FeedbackKind::Custom { topic, path, words } => {
                    custom::format(topic, path, words.as_ref(), signal, value, ts, &mut out)
                }
            }
        }
        out
    }

    /// A sugarshack device's per-actuator state message (`<p>/<type>/<io>/state`) instead of its batch.
    pub fn format_single(&self, id: ActuatorId, value: f64, ts: Option<Millis>) -> Option<Message> {
        sugarshack::format_single(self, id, value, ts)
    }

    fn prefix_of(&self, device: DeviceId) -> String {
        let topic = self.devices[device.index()]
            .status_topic
            .clone()
            .unwrap_or_default();
        match self.devices[device.index()].profile {
            Profile::Tasmota => topic
                .strip_prefix("tele/")
                .and_then(|t| t.strip_suffix("/LWT"))
                .unwrap_or_default()
                .to_owned(),
            Profile::ShellyGen2 => topic.strip_suffix("/online").unwrap_or_default().to_owned(),
            _ => topic.strip_suffix("/status").unwrap_or_default().to_owned(),
        }
    }

    /// What a device publishes for its sensors at `values` (NaN: no reading).
    pub fn format_sensors(
        &self,
        device: DeviceId,
        values: &[(SensorId, f64)],
        ts: Option<Millis>,
    ) -> Vec<Message> {
        let Some(d) = self.devices.get(device.index()) else {
            return Vec::new();
        };
        let mut shared: Vec<(String, serde_json::Value)> = Vec::new();
        let mut out = Vec::new();
        for &(id, value) in values {
            let Some(f) = self.sensor_routes.get(id.index()) else {
                continue;
            };
            if f.device != device {
                continue;
            }
            match &f.kind {
                SensorKind::Topic(topic) => out.push(Message {
                    topic: topic.clone(),
                    payload: match d.profile {
                        Profile::Sugarshack => sugarshack::format_value(value, ts),
                        Profile::Custom => custom::format_value(value, ts),
                        _ => read::format_plain(value),
                    },
                    retain: d.profile == Profile::Esphome,
                }),
                SensorKind::Shared { topic, path } => {
                    let at = match shared.iter().position(|(t, _)| t == topic) {
                        Some(at) => at,
                        None => {
                            shared.push((topic.clone(), read::document_start(d.profile, topic)));
                            shared.len() - 1
                        }
                    };
                    read::put(&mut shared[at].1, path, read::json_number(value));
                }
                SensorKind::Modbus => {}
            }
        }
        for (topic, document) in shared {
            out.push(Message {
                topic,
                payload: document.to_string(),
                retain: false,
            });
        }
        out
    }

    /// The io -> actuator map of a sugarshack device's type, if it has actuators of that type.
    pub(crate) fn slots_of(
        &self,
        device: DeviceId,
        kind: &str,
    ) -> Option<&HashMap<u32, ActuatorId>> {
        self.slots
            .get(device.index())?
            .iter()
            .find(|(name, _)| name == kind)
            .map(|(_, slots)| slots)
    }

    /// Whether `kind` is an actuator type of the plant.
    pub(crate) fn is_type(&self, kind: &str) -> bool {
        self.type_names.iter().any(|t| t == kind)
    }
}

/// What a profile's sensor builder needs to know of the sensor.
#[derive(Clone, Copy)]
pub(crate) struct SensorSpec<'a> {
    pub id: SensorId,
    pub device: DeviceId,
    pub prefix: &'a str,
    pub sensor: &'a crate::plant::Sensor,
    pub path: &'a str,
}

impl<'a> SensorSpec<'a> {
    /// Its fields, for a codec to name them.
    pub fn parts(
        &self,
    ) -> (
        SensorId,
        DeviceId,
        &'a str,
        &'a crate::plant::Sensor,
        &'a str,
    ) {
        (self.id, self.device, self.prefix, self.sensor, self.path)
    }
}

/// What a profile's actuator builder needs to know of the actuator.
pub(crate) struct ActuatorSpec<'a> {
    pub id: ActuatorId,
    pub device: DeviceId,
    pub prefix: &'a str,
    pub signal: Signal,
    pub range: (f64, f64),
    pub path: &'a str,
}

#[cfg(test)]
mod tests;
