//! The plant document: devices, actuators, sensors, resources, operations
//! and routines. Read once with serde into typed values (setpoints and group
//! commands cannot hold anything but booleans and finite numbers), then
//! checked once, concern by concern (see `validate`), into a [`Plant`] that
//! keeps its warnings. Every error names the entry at fault so an engineer
//! can find it in the document.

#[cfg(test)]
pub(crate) mod fixtures;
mod graph;
mod group;
mod setpoint;
mod validate;

pub use graph::{Edge, RoutineGraph, StateId};
use group::Targeting;
pub use group::{Group, GroupCommand, GroupError, GroupKeys};
pub use setpoint::Setpoint;

use std::collections::BTreeMap;
use std::fmt;
use std::ops::Deref;

use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serialize};

use crate::time::{ms, Millis};
use crate::topics::Contract;

/// The plant document: devices, actuators, sensors, lines, operations and routines.
/// Read with serde, then checked whole by [`Plant::new`] (or
/// [`PlantModel::validate`]), which lists every problem with its path.
///
/// ```
/// use sugarshack_core::plant::PlantModel;
///
/// let mut doc = serde_json::json!({
///   "actuatorTypes": { "valve": { "signal": "analog", "noMotionMs": 3000, "completionMs": 10000, "staleMs": 5000 } },
///   "devices": [{ "id": "ctrl-1", "kind": "actuator-panel" }],
///   "actuators": [{ "id": "V12", "type": "valve", "device": "ctrl-1", "io": 12, "idle": 0, "lockout": 0 }]
/// });
/// let plant: PlantModel = serde_json::from_value(doc.clone()).unwrap();
/// assert!(plant.validate().unwrap().is_empty(), "sound, and nothing looks unintended");
///
/// doc["actuators"][0]["device"] = "ctrl-9".into();
/// let plant: PlantModel = serde_json::from_value(doc).unwrap();
/// let problems = plant.validate().unwrap_err();
/// assert_eq!(problems.0[0].path, "actuators[0] (V12)");
/// assert!(problems.0[0].message.contains("ctrl-9"));
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct PlantModel {
    /// A name for people; the core does not use it.
    #[serde(default)]
    pub name: Option<String>,
    /// Keyed by type name, which is also the MQTT topic component (`<device>/<type>/<io>/command`).
    pub actuator_types: BTreeMap<String, ActuatorType>,
    /// The devices on the bus.
    pub devices: Vec<Device>,
    /// The actuators.
    #[serde(default)]
    pub actuators: Vec<Actuator>,
    /// The sensors.
    #[serde(default)]
    pub sensors: Vec<Sensor>,
    /// The shared resources (lines of piping) operations acquire at the interlock.
    #[serde(default)]
    pub resources: Vec<Resource>,
    /// The operations.
    #[serde(default)]
    pub operations: Vec<Operation>,
    /// The routines.
    #[serde(default)]
    pub routines: Vec<Routine>,
    /// How far ahead of the reception time a device's timestamp may be; a
    /// sample stamped further in the future is refused (its clock is wrong).
    #[serde(default = "default_clock_skew_ms")]
    pub clock_skew_ms: Millis,
    /// Read by the plant simulator only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub simulation: Option<serde_json::Value>,
}

/// A device clock may run this far ahead of ours before its samples are refused.
pub const DEFAULT_CLOCK_SKEW_MS: Millis = ms(5000);

fn default_clock_skew_ms() -> Millis {
    DEFAULT_CLOCK_SKEW_MS
}

/// How an actuator is commanded.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Signal {
    /// A position in `min..=max` (a valve in %).
    Analog,
    /// On or off (a pump).
    Binary,
}

/// What to do with a command whose actuator failed after every retry.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Escalation {
    /// Fail the command at once, so the operation faults and its line locks out now.
    #[default]
    FailFast,
    /// Leave the command pending until the caller's own timeout (the paper's behaviour).
    Hang,
}

/// What actuators of one type share: signal, range and timing.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct ActuatorType {
    /// Binary or analog.
    pub signal: Signal,
    /// The unit of its positions, for people.
    #[serde(default)]
    pub unit: Option<String>,
    /// The lowest position.
    #[serde(default)]
    pub min: Option<f64>,
    /// The highest position.
    #[serde(default)]
    pub max: Option<f64>,
    /// Feedback within this of a position counts as at that position.
    #[serde(default)]
    pub tolerance: Option<f64>,
    /// A command must show motion within this long, else it is retried.
    pub no_motion_ms: Millis,
    /// A command must reach its target within this long, else it is retried.
    pub completion_ms: Millis,
    /// Feedback older than this is stale.
    pub stale_ms: Millis,
    /// Retries before a failure escalates.
    #[serde(default)]
    pub retries: u32,
    /// What a failure after its retries does.
    #[serde(default)]
    pub escalation: Escalation,
    /// How its devices publish feedback; a device's own setting wins.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reports: Option<Reports>,
}

/// What a device carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DeviceKind {
    /// Actuators.
    ActuatorPanel,
    /// Sensors.
    SensorStation,
}

/// The MQTT dialect a device speaks (see the topics module for each one's topics).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Profile {
    /// This palette's own format (`<prefix>/<type>/<io>/state`, `<prefix>/state` batches).
    #[default]
    Sugarshack,
    /// ESPHome's MQTT format.
    Esphome,
    /// Tasmota's MQTT format.
    Tasmota,
    /// Shelly's second-generation MQTT format.
    #[serde(rename = "shelly-gen2")]
    ShellyGen2,
    /// Topic templates, a payload path and value maps given in the device's `custom`.
    Custom,
}

impl Profile {
    /// Its name in the plant document.
    pub fn name(self) -> &'static str {
        match self {
            Profile::Sugarshack => "sugarshack",
            Profile::Esphome => "esphome",
            Profile::Tasmota => "tasmota",
            Profile::ShellyGen2 => "shelly-gen2",
            Profile::Custom => "custom",
        }
    }

    /// Stock firmware publishes on change; this palette's devices about once a second.
    pub fn default_reports(self) -> Reports {
        match self {
            Profile::Sugarshack => Reports::Periodic,
            _ => Reports::OnChange,
        }
    }

    /// How often its sensors publish unless a sensor says otherwise: ESPHome's
    /// default `update_interval` (60 s), Tasmota's `TelePeriod` (300 s).
    pub fn default_sensor_update_ms(self) -> Millis {
        match self {
            Profile::Sugarshack | Profile::Custom => ms(1000),
            Profile::Esphome | Profile::ShellyGen2 => ms(60_000),
            Profile::Tasmota => ms(300_000),
        }
    }
}

/// Whether a device re-publishes its states (so silence means trouble) or only on change.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Reports {
    /// It re-publishes its states: silence means trouble.
    Periodic,
    /// It publishes only on change.
    OnChange,
}

/// The ESPHome component that drives an actuator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Component {
    /// An ESPHome valve.
    Valve,
    /// An ESPHome cover.
    Cover,
    /// An ESPHome number.
    Number,
    /// An ESPHome switch.
    Switch,
}

impl Component {
    /// Its name in the plant document.
    pub fn name(self) -> &'static str {
        match self {
            Component::Valve => "valve",
            Component::Cover => "cover",
            Component::Number => "number",
            Component::Switch => "switch",
        }
    }
}

/// A device on the bus.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Device {
    /// Its id in the plant document.
    pub id: String,
    /// What it carries.
    pub kind: DeviceKind,
    /// The MQTT format it speaks.
    #[serde(default, skip_serializing_if = "is_default")]
    pub profile: Profile,
    /// Its MQTT topic prefix (ESPHome `topic_prefix`, Tasmota `%topic%`,
    /// Shelly `topic_prefix`); the device id when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prefix: Option<String>,
    /// Overrides its actuator types' `reports` and the profile's default.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reports: Option<Reports>,
    /// The topics and payloads of a `custom` device.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub custom: Option<crate::topics::custom::CustomProfile>,
}

impl Device {
    /// Its topic prefix (its id unless set).
    pub fn prefix(&self) -> &str {
        self.prefix.as_deref().unwrap_or(&self.id)
    }
}

fn is_default<T: Default + PartialEq>(value: &T) -> bool {
    *value == T::default()
}

/// An actuator of the plant.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Actuator {
    /// Its id in the plant document.
    pub id: String,
    /// Its type, a key of `actuatorTypes`.
    #[serde(rename = "type")]
    pub kind: String,
    /// The device's id.
    pub device: String,
    /// Its output number on a `sugarshack` device (`<device>/<type>/<io>/command`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub io: Option<u32>,
    /// Its entity on the device: ESPHome object id (`v101`, default: the id in
    /// ESPHome's form), Tasmota `POWER1` / `Shutter1`, Shelly `switch:0` / `cover:0`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub entity: Option<String>,
    /// ESPHome only: `valve` (analog default), `cover`, `number`, `switch` (binary default).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub component: Option<Component>,
    /// Overrides the type's tolerance.
    #[serde(default)]
    pub tolerance: Option<f64>,
    /// The resource (line) it belongs to; only operations holding it may command it (C2).
    #[serde(default)]
    pub resource: Option<String>,
    /// The state every operation returns it to (the paper's C3); required to command it in an operation.
    #[serde(default)]
    pub idle: Option<Setpoint>,
    /// The state a fault lockout commands.
    pub lockout: Setpoint,
}

/// A sensor of the plant.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Sensor {
    /// Its id in the plant document.
    pub id: String,
    /// The device's id.
    pub device: String,
    /// The datapoint name in `<device>/sensor/<name>/state`.
    pub name: String,
    /// Where the device publishes it, when not `name`: ESPHome object id,
    /// Tasmota path in `tele/<topic>/SENSOR` (`DS18B20.Temperature`), Shelly
    /// component and field (`temperature:0.tC`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub entity: Option<String>,
    /// The unit of its values, for people.
    #[serde(default)]
    pub unit: Option<String>,
    /// How often its device publishes it; `staleMs` defaults to five of these.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub update_ms: Option<Millis>,
    /// How old a value may be before it is stale; the plant's default when unset.
    #[serde(default)]
    pub stale_ms: Option<Millis>,
    /// The lowest value it reads, with `max` (a SCADA's engineering range).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min: Option<f64>,
    /// The highest value it reads, with `min`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max: Option<f64>,
}

impl Sensor {
    /// Its entity on its device.
    pub fn entity(&self) -> &str {
        self.entity.as_deref().unwrap_or(&self.name)
    }
}

/// A line the interlock arbitrates.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Resource {
    /// Its id in the plant document.
    pub id: String,
    /// The group command that isolates the line on a fault. By default every
    /// member actuator goes to its own lockout state.
    #[serde(default)]
    pub lockout: Option<GroupCommand>,
}

/// A singular operation (the paper's §III-D): acquire, steps, return to idle, release.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Operation {
    /// Its id in the plant document.
    pub id: String,
    /// What it does, for people.
    #[serde(default)]
    pub description: Option<String>,
    /// Higher is more urgent.
    pub priority: i32,
    /// The lines' names.
    pub resources: Vec<String>,
    /// Its steps, in order.
    pub steps: Vec<Step>,
}

/// Read by its key (`command` or `wait`), so that a broken step says what is
/// wrong with it rather than that it matches no kind of step.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Step {
    /// A group command, e.g. `{"valves": {"V101": 100}, "pumps": {"P1": true}}`.
    #[serde(rename_all = "camelCase")]
    Command {
        /// The group command.
        command: GroupCommand,
        /// How long it may take.
        timeout_ms: Millis,
    },
    /// Wait until a JSONata condition over the listed sensors holds.
    #[serde(rename_all = "camelCase")]
    Wait {
        /// The condition (JSONata).
        wait: String,
        /// The sensors it reads.
        sensors: Vec<String>,
        /// How long it may take.
        timeout_ms: Millis,
    },
}

/// Every field a step may have; which are required depends on its kind.
#[derive(Deserialize)]
#[serde(
    rename_all = "camelCase",
    deny_unknown_fields,
    expecting = "a step: {\"command\": {...}, \"timeoutMs\": ...} or {\"wait\": \"...\", \"sensors\": [...], \"timeoutMs\": ...}"
)]
struct StepFields {
    #[serde(default, deserialize_with = "present")]
    command: Option<GroupCommand>,
    #[serde(default, deserialize_with = "present")]
    wait: Option<String>,
    #[serde(default, deserialize_with = "present")]
    sensors: Option<Vec<String>>,
    #[serde(default, deserialize_with = "present")]
    timeout_ms: Option<Millis>,
}

/// A key given as `null` is present: `"command": null` is a bad command, and
/// `"wait": null` a wrong type, not a missing key.
fn present<'de, D: Deserializer<'de>, T: Deserialize<'de>>(
    deserializer: D,
) -> Result<Option<T>, D::Error> {
    T::deserialize(deserializer).map(Some)
}

impl<'de> Deserialize<'de> for Step {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let fields = StepFields::deserialize(deserializer)?;
        match (fields.command, fields.wait) {
            (Some(command), None) => {
                if fields.sensors.is_some() {
                    return Err(D::Error::unknown_field(
                        "sensors",
                        &["command", "timeoutMs"],
                    ));
                }
                Ok(Step::Command {
                    command,
                    timeout_ms: fields
                        .timeout_ms
                        .ok_or_else(|| D::Error::missing_field("timeoutMs"))?,
                })
            }
            (None, Some(wait)) => Ok(Step::Wait {
                wait,
                sensors: fields
                    .sensors
                    .ok_or_else(|| D::Error::missing_field("sensors"))?,
                timeout_ms: fields
                    .timeout_ms
                    .ok_or_else(|| D::Error::missing_field("timeoutMs"))?,
            }),
            (Some(_), Some(_)) => Err(D::Error::custom(
                "a step has either 'command' or 'wait', not both: make them two steps",
            )),
            (None, None) => Err(D::Error::custom(
                "a step needs either 'command' (a group command) or 'wait' (a condition)",
            )),
        }
    }
}

/// A routine (the paper's §III-E): a state machine that dispatches one operation at a time.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Routine {
    /// Its id in the plant document.
    pub id: String,
    /// Its states.
    pub states: Vec<String>,
    /// The state it starts in.
    pub initial: String,
    /// Where the routine goes when its operation faults.
    #[serde(default)]
    pub error_state: Option<String>,
    /// Its transitions.
    pub transitions: Vec<Transition>,
}

/// A move between two states of a routine, running one operation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Transition {
    /// The state it leaves.
    pub from: String,
    /// The state it enters.
    pub to: String,
    /// The operation's id.
    pub operation: String,
    /// What fires it.
    pub trigger: Trigger,
}

/// Read by its key (`msg` or `when`), as a step is.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Trigger {
    /// A msg with this topic.
    Msg {
        /// The msg topic.
        msg: String,
    },
    /// A JSONata condition over the listed sensors, evaluated every `everyMs`.
    #[serde(rename_all = "camelCase")]
    When {
        /// The condition (JSONata).
        when: String,
        /// The sensors it reads.
        sensors: Vec<String>,
        /// How often it is checked, in ms.
        every_ms: Millis,
    },
}

/// Every field a trigger may have; which are required depends on its kind.
#[derive(Deserialize)]
#[serde(
    rename_all = "camelCase",
    deny_unknown_fields,
    expecting = "a trigger: {\"msg\": \"topic\"} or {\"when\": \"...\", \"sensors\": [...], \"everyMs\": ...}"
)]
struct TriggerFields {
    #[serde(default, deserialize_with = "present")]
    msg: Option<String>,
    #[serde(default, deserialize_with = "present")]
    when: Option<String>,
    #[serde(default, deserialize_with = "present")]
    sensors: Option<Vec<String>>,
    #[serde(default, deserialize_with = "present")]
    every_ms: Option<Millis>,
}

impl<'de> Deserialize<'de> for Trigger {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let fields = TriggerFields::deserialize(deserializer)?;
        match (fields.msg, fields.when) {
            (Some(msg), None) => {
                for (name, given) in [
                    ("sensors", fields.sensors.is_some()),
                    ("everyMs", fields.every_ms.is_some()),
                ] {
                    if given {
                        return Err(D::Error::unknown_field(name, &["msg"]));
                    }
                }
                Ok(Trigger::Msg { msg })
            }
            (None, Some(when)) => Ok(Trigger::When {
                when,
                sensors: fields
                    .sensors
                    .ok_or_else(|| D::Error::missing_field("sensors"))?,
                every_ms: fields
                    .every_ms
                    .ok_or_else(|| D::Error::missing_field("everyMs"))?,
            }),
            (Some(_), Some(_)) => Err(D::Error::custom(
                "a trigger has either 'msg' or 'when', not both: make them two transitions",
            )),
            (None, None) => Err(D::Error::custom(
                "a trigger needs either 'msg' (a msg topic) or 'when' (a condition)",
            )),
        }
    }
}

/// Something legal but probably unintended, reported at deploy.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PlantWarning {
    /// Where in the document, e.g. `actuators[3] (V12)`.
    pub path: String,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for PlantWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path, self.message)
    }
}

/// One problem in a plant document.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PlantError {
    /// Where: `actuators[3] (V12)`, `actuatorTypes.valve`, ...
    pub path: String,
    /// What looks unintended.
    pub message: String,
}

impl fmt::Display for PlantError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path, self.message)
    }
}

/// All problems found, one per line when displayed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PlantErrors(pub Vec<PlantError>);

impl fmt::Display for PlantErrors {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "invalid plant document ({} problem{}):",
            self.0.len(),
            if self.0.len() == 1 { "" } else { "s" }
        )?;
        for error in &self.0 {
            write!(f, "\n  {error}")?;
        }
        Ok(())
    }
}

impl std::error::Error for PlantErrors {}

/// A validated setting of one actuator, in the form the tracker uses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    /// The lowest position.
    pub min: f64,
    /// The highest position.
    pub max: f64,
    /// How close to a position counts as there.
    pub tolerance: f64,
}

impl ActuatorType {
    /// Binary actuators are tracked as 0.0 / 1.0 with a tolerance of one half.
    pub fn range(&self, override_tolerance: Option<f64>) -> Range {
        match self.signal {
            Signal::Binary => Range {
                min: 0.0,
                max: 1.0,
                tolerance: 0.5,
            },
            Signal::Analog => Range {
                min: self.min.unwrap_or(0.0),
                max: self.max.unwrap_or(100.0),
                tolerance: override_tolerance.or(self.tolerance).unwrap_or(0.0),
            },
        }
    }
}

/// Reads a command target given as JSON for this signal: true/false, or a number within the range.
pub fn state_value(signal: Signal, range: Range, value: &serde_json::Value) -> Result<f64, String> {
    Setpoint::from_json(value)
        .ok_or_else(|| setpoint::wrong_setpoint(signal, range, value))?
        .position(signal, range)
}

impl PlantModel {
    /// The group command that isolates a resource: its configured lockout, or
    /// every member actuator at its lockout state. None when it has neither.
    pub fn lockout_of(&self, resource: &str) -> Option<GroupCommand> {
        let r = self.resources.iter().find(|r| r.id == resource)?;
        if let Some(lockout) = &r.lockout {
            return Some(lockout.clone());
        }
        let mut command = GroupCommand::default();
        for a in self
            .actuators
            .iter()
            .filter(|a| a.resource.as_deref() == Some(resource))
        {
            command.set(&GroupKeys::plural(&a.kind), &a.id, a.lockout);
        }
        (!command.is_empty()).then_some(command)
    }

    /// The interlock's configuration for this plant: its resources with their lockouts.
    pub fn interlock_config(&self) -> crate::interlock::InterlockConfig {
        let mut config = crate::interlock::InterlockConfig::with_resources(
            self.resources.iter().map(|r| r.id.clone()),
        );
        for r in &mut config.resources {
            // Booleans and finite numbers under string keys: always JSON.
            r.lockout = self
                .lockout_of(&r.name)
                .and_then(|command| serde_json::to_value(command).ok())
                .unwrap_or_default();
        }
        config
    }
}

impl PlantModel {
    /// How often a sensor's device publishes it: its `updateMs`, else its profile's default.
    pub fn sensor_update_ms(&self, sensor: &Sensor) -> Millis {
        sensor.update_ms.unwrap_or_else(|| {
            self.devices
                .iter()
                .find(|d| d.id == sensor.device)
                .map_or(ms(1000), |d| d.profile.default_sensor_update_ms())
        })
    }

    /// A sensor's value is stale after its `staleMs`, else five missed updates.
    pub fn sensor_stale_ms(&self, sensor: &Sensor) -> Millis {
        sensor.stale_ms.unwrap_or_else(|| {
            self.sensor_update_ms(sensor)
                .mul_f64(5.0)
                .unwrap_or(Millis::MAX)
        })
    }

    /// Whether an actuator's device publishes only on change: the device's
    /// `reports`, else its type's, else its profile's default.
    pub fn reports_on_change(&self, actuator: &Actuator) -> bool {
        let device = self.devices.iter().find(|d| d.id == actuator.device);
        let reports = device
            .and_then(|d| d.reports)
            .or_else(|| {
                self.actuator_types
                    .get(&actuator.kind)
                    .and_then(|t| t.reports)
            })
            .unwrap_or_else(|| device.map_or(Reports::Periodic, |d| d.profile.default_reports()));
        reports == Reports::OnChange
    }
}

impl PlantModel {
    /// Every problem in the document, or the warnings of a sound one. Each
    /// check is run once by [`Plant::new`], which keeps the warnings.
    pub fn validate(&self) -> Result<Vec<PlantWarning>, PlantErrors> {
        validate::check(self).map(|checked| checked.warnings)
    }
}

/// A plant document that passed every check: read and checked once, with
/// its warnings, the keys and ids its group commands name, and its MQTT
/// contract. Reads as the document it was made from.
///
/// ```
/// use sugarshack_core::plant::{Plant, PlantModel};
///
/// let doc = serde_json::json!({
///   "actuatorTypes": { "pump": { "signal": "binary", "noMotionMs": 2000, "completionMs": 4000, "staleMs": 3000 } },
///   "devices": [{ "id": "ctrl-1", "kind": "actuator-panel" }],
///   "actuators": [{ "id": "P1", "type": "pump", "device": "ctrl-1", "io": 1, "idle": false, "lockout": false }]
/// });
/// let plant = Plant::new(serde_json::from_value::<PlantModel>(doc).unwrap()).unwrap();
/// assert!(plant.warnings().is_empty());
/// assert_eq!(plant.group_targets(&serde_json::json!({ "pumps": { "P1": true } })), Ok(vec![(0, 1.0)]));
/// assert!(plant.group_targets(&serde_json::json!({ "pumps": { "P1": 1 } })).is_err());
/// ```
#[derive(Clone, Debug)]
pub struct Plant {
    model: PlantModel,
    warnings: Vec<PlantWarning>,
    targeting: Targeting,
    contract: Contract,
    routines: Vec<RoutineGraph>,
}

impl Plant {
    /// Checks the document once; every problem with its path when it is not sound.
    pub fn new(model: PlantModel) -> Result<Plant, PlantErrors> {
        let checked = validate::check(&model)?;
        Ok(Plant {
            model,
            warnings: checked.warnings,
            targeting: checked.targeting,
            contract: checked.contract,
            routines: checked.routines,
        })
    }

    /// Routine `id`, its states resolved.
    pub fn routine(&self, id: &str) -> Option<&RoutineGraph> {
        self.routines.iter().find(|r| r.id() == id)
    }

    /// The document as read.
    pub fn model(&self) -> &PlantModel {
        &self.model
    }

    /// What the document holds that is legal but probably unintended.
    pub fn warnings(&self) -> &[PlantWarning] {
        &self.warnings
    }

    /// The MQTT topics and payloads of its devices.
    pub fn contract(&self) -> &Contract {
        &self.contract
    }

    /// Reads a group command given at run time, such as
    /// `{"valves": {"V12": 100, "V13": 0}, "pumps": {"P1": true}}`, into
    /// (actuator index, position): each key an actuator type or its plural,
    /// each id an actuator of that type, each target one it can take.
    pub fn group_targets(
        &self,
        payload: &serde_json::Value,
    ) -> Result<Vec<(usize, f64)>, GroupError> {
        self.targeting.read(&self.model, payload)
    }

    /// The index of actuator `id` in the document's list.
    pub fn actuator(&self, id: &str) -> Option<usize> {
        self.targeting.actuator(id)
    }

    /// Whether `key` names an actuator type (or its plural), as group commands' keys do.
    pub fn is_group_key(&self, key: &str) -> bool {
        self.targeting.kind(key).is_some()
    }
}

impl Deref for Plant {
    type Target = PlantModel;

    fn deref(&self) -> &PlantModel {
        &self.model
    }
}
