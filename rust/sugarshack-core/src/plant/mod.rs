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
pub mod group_msg;
#[cfg(feature = "schema")]
mod schema;
mod setpoint;
mod simulation;
mod validate;

pub use graph::{Edge, RoutineGraph, StateId};
use group::Targeting;
pub use group::{Group, GroupCommand, GroupError, GroupKeys};
#[cfg(feature = "schema")]
pub use schema::schema;
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
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(
    feature = "schema",
    schemars(
        title = "sugarshack plant document",
        description = "One plant, as the palette runs it: the field devices on the MQTT bus, the actuators and sensors they carry, the lines (resources) the interlock hands out, the operations that run on them and the routines that chain operations. The plant config node holds it; the plant check names every problem with its path before a deploy."
    )
)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct PlantModel {
    /// Where an editor finds this document's JSON Schema, for completion and
    /// checks as you type: the palette ships it as
    /// `node_modules/node-red-contrib-sugarshack/schema/plant.schema.json`.
    /// The plant check ignores it.
    #[serde(rename = "$schema", default, skip_serializing_if = "Option::is_none")]
    pub schema: Option<String>,
    /// A name for people (the plant node's label); the palette does not use it otherwise.
    #[serde(default)]
    pub name: Option<String>,
    /// The kinds of actuator, by name (`valve`, `pump`): what a kind of
    /// actuator accepts and how long it may take to move. The name is also
    /// the group-command key (`valves` or `valve`) and, on this palette's own
    /// devices, a topic level (`<device>/<type>/<io>/command`).
    pub actuator_types: BTreeMap<String, ActuatorType>,
    /// The devices on the MQTT bus: actuator panels and sensor stations.
    pub devices: Vec<Device>,
    /// Every valve, pump or other actuator the palette commands and tracks.
    #[serde(default)]
    pub actuators: Vec<Actuator>,
    /// Every measurement operations and routines may wait on (levels, volumes, temperatures).
    #[serde(default)]
    pub sensors: Vec<Sensor>,
    /// The lines of piping (or any equipment) the interlock hands to one
    /// operation at a time; a fault locks its line out until a person clears it.
    #[serde(default)]
    pub resources: Vec<Resource>,
    /// The operations: each acquires its lines, runs its steps, returns its
    /// actuators to idle and releases the lines.
    #[serde(default)]
    pub operations: Vec<Operation>,
    /// The routines: state machines that start one operation at a time (a truck unloading, a wash cycle).
    #[serde(default)]
    pub routines: Vec<Routine>,
    /// What an operator's hold, restart and stop do to every operation that
    /// does not say otherwise (ISA-88 commands; see each operation's `hold`
    /// and `stop`, and each step's `restart`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub operation_defaults: Option<OperationDefaults>,
    /// How far ahead of the palette's clock a device's timestamp may be, in
    /// ms; a sample stamped further in the future is refused, since its
    /// device's clock is wrong.
    #[serde(default = "default_clock_skew_ms")]
    pub clock_skew_ms: Millis,
    /// Settings of the plant simulator (`npm start`): its tanks, the
    /// transfers between them, datapoint baselines. The palette runs
    /// without them, but checks them as the simulator reads them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[cfg_attr(feature = "schema", schemars(with = "Option<simulation::Simulation>"))]
    pub simulation: Option<serde_json::Value>,
}

/// A device clock may run this far ahead of ours before its samples are refused.
pub const DEFAULT_CLOCK_SKEW_MS: Millis = ms(5000);

fn default_clock_skew_ms() -> Millis {
    DEFAULT_CLOCK_SKEW_MS
}

/// How an actuator is commanded: to a position, or on and off.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "kebab-case")]
pub enum Signal {
    /// Set to a position between `min` and `max` (a modulating valve, 0 to 100 %).
    Analog,
    /// Switched on or off, `true` or `false` (a pump, a solenoid valve).
    Binary,
}

/// What happens when an actuator still has not moved after its retries.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "kebab-case")]
pub enum Escalation {
    /// The command fails at once: the operation faults and its line locks out now (the default).
    #[default]
    FailFast,
    /// The command stays pending until the step's own timeout runs out (the paper's behaviour).
    Hang,
}

/// What every actuator of one kind shares: how it is commanded, its range,
/// and how long it may take to move before it counts as failed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct ActuatorType {
    /// `analog` (a position between `min` and `max`) or `binary` (on or off).
    pub signal: Signal,
    /// The unit of its positions, for people (`%`).
    #[serde(default)]
    pub unit: Option<String>,
    /// Analog only: the lowest position (default 0).
    #[serde(default)]
    pub min: Option<f64>,
    /// Analog only: the highest position (default 100).
    #[serde(default)]
    pub max: Option<f64>,
    /// Analog only: how close the feedback must come to the target to count
    /// as there (default 0); less than half the range. An actuator may set its own.
    #[serde(default)]
    pub tolerance: Option<f64>,
    /// Within this many ms of a command the feedback must start moving
    /// toward the target, else the command is retried (or fails).
    pub no_motion_ms: Millis,
    /// Within this many ms of a command the feedback must reach the target,
    /// else the command is retried (or fails); at least `noMotionMs`.
    pub completion_ms: Millis,
    /// Feedback older than this many ms is stale: the actuator's position is no longer known.
    pub stale_ms: Millis,
    /// How many times a command that did not move or finish is sent again before it fails.
    #[serde(default)]
    pub retries: u32,
    /// What a command that failed after its retries does: `fail-fast` (the
    /// default) faults the operation at once, `hang` waits for the step's timeout.
    #[serde(default)]
    pub escalation: Escalation,
    /// Whether its devices re-publish their states (`periodic`) or only on
    /// change (`on-change`); a device's own `reports` wins, and without
    /// either the device profile decides.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reports: Option<Reports>,
}

/// What a device carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "kebab-case")]
pub enum DeviceKind {
    /// A controller that drives actuators (valves, pumps) and reports their positions.
    ActuatorPanel,
    /// A controller that publishes sensor readings.
    SensorStation,
}

/// The MQTT dialect a device speaks: its topics and payloads.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "kebab-case")]
pub enum Profile {
    /// This palette's own devices (the default): `<prefix>/<type>/<io>/state`
    /// and `<prefix>/state` batches; actuators are addressed by `io`.
    #[default]
    Sugarshack,
    /// ESPHome's stock MQTT: actuators and sensors are addressed by `entity`
    /// (the object id), components by `component`.
    Esphome,
    /// Tasmota's stock MQTT: `POWER1`, `Shutter1`, sensor paths in `tele/<topic>/SENSOR`.
    Tasmota,
    /// Shelly's second-generation MQTT: `switch:0`, `cover:0`, `temperature:0.tC`.
    #[serde(rename = "shelly-gen2")]
    ShellyGen2,
    /// Any other firmware: topic templates, a payload path and value maps, given in the device's `custom`.
    Custom,
    /// Registers polled over Modbus TCP or RTU, described in the device's `modbus` (no MQTT).
    Modbus,
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
            Profile::Modbus => "modbus",
        }
    }

    /// Stock firmware publishes on change; this palette's devices about once a second.
    pub fn default_reports(self) -> Reports {
        match self {
            // A polled device answers every poll: silence means trouble.
            Profile::Sugarshack | Profile::Modbus => Reports::Periodic,
            _ => Reports::OnChange,
        }
    }

    /// How often its sensors publish unless a sensor says otherwise: ESPHome's
    /// default `update_interval` (60 s), Tasmota's `TelePeriod` (300 s).
    pub fn default_sensor_update_ms(self) -> Millis {
        match self {
            Profile::Sugarshack | Profile::Custom | Profile::Modbus => ms(1000),
            Profile::Esphome | Profile::ShellyGen2 => ms(60_000),
            Profile::Tasmota => ms(300_000),
        }
    }
}

/// Whether a device re-publishes its states (so silence means trouble) or only on change.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "kebab-case")]
pub enum Reports {
    /// It re-publishes its states about once a second: feedback older than `staleMs` means trouble.
    Periodic,
    /// It publishes only when a state changes: silence is normal.
    OnChange,
}

/// The ESPHome component that drives an actuator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "kebab-case")]
pub enum Component {
    /// An ESPHome `valve` with a position (the default for an analog actuator).
    Valve,
    /// An ESPHome `cover` with a position.
    Cover,
    /// An ESPHome `number`.
    Number,
    /// An ESPHome `switch` (the default for a binary actuator).
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

/// A controller on the MQTT bus.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Device {
    /// Its id, which actuators and sensors name as their `device`; also its
    /// topic prefix unless `prefix` is given.
    pub id: String,
    /// `actuator-panel` (drives actuators) or `sensor-station` (publishes readings).
    pub kind: DeviceKind,
    /// The MQTT dialect it speaks: `sugarshack` (the default), `esphome`,
    /// `tasmota`, `shelly-gen2` or `custom`.
    #[serde(default, skip_serializing_if = "is_default")]
    pub profile: Profile,
    /// Its MQTT topic prefix when not its id (ESPHome `topic_prefix`,
    /// Tasmota `%topic%`, Shelly `topic_prefix`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prefix: Option<String>,
    /// Whether it re-publishes its states (`periodic`) or only on change
    /// (`on-change`); wins over its actuator types' `reports` and its profile's default.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reports: Option<Reports>,
    /// With profile `custom`: its topics and payloads.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub custom: Option<crate::topics::custom::CustomProfile>,
    /// The endpoint, unit and polling of a `modbus` device.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub modbus: Option<crate::topics::modbus::ModbusDevice>,
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

/// A valve, pump or other actuator the palette commands and tracks.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Actuator {
    /// Its tag (`V101`, `P1`): unique among actuators and sensors, and the
    /// name group commands and the HMI use.
    pub id: String,
    /// Its kind: a name in `actuatorTypes` (`valve`, `pump`).
    #[serde(rename = "type")]
    pub kind: String,
    /// The id of the actuator panel that drives it.
    pub device: String,
    /// On a `sugarshack` device: its output number, from 1
    /// (`<device>/<type>/<io>/command`); no two actuators of one type share it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub io: Option<u32>,
    /// Its entity on a stock-firmware device: ESPHome object id (`v101`; by
    /// default the id in ESPHome's form), Tasmota `POWER1` or `Shutter1`,
    /// Shelly `switch:0` or `cover:0`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub entity: Option<String>,
    /// ESPHome only: the component that drives it, `valve` (the default when
    /// analog), `cover`, `number` or `switch` (the default when binary).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub component: Option<Component>,
    /// Analog only: its own tolerance, in place of its type's.
    #[serde(default)]
    pub tolerance: Option<f64>,
    /// The line (a resource id) it belongs to: only an operation holding that
    /// line may command it, and a fault on the line locks it out (C2).
    #[serde(default)]
    pub resource: Option<String>,
    /// Where every operation leaves it when done (`0`, `false`): true or
    /// false when binary, a position when analog. An operation may command it
    /// only if it has one (C3).
    #[serde(default)]
    pub idle: Option<Setpoint>,
    /// Where a fault lockout of its line sends it, the safe state (`0`, `false`):
    /// true or false when binary, a position when analog.
    pub lockout: Setpoint,
    /// On a `modbus` device: the register it is commanded through and the one it reports on.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub modbus: Option<crate::topics::modbus::ModbusActuator>,
}

/// A measurement conditions can read (a level, a volume, a temperature).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Sensor {
    /// Its tag (`LT-3`): unique among actuators and sensors, and the name
    /// conditions read it by (in backticks when it has a `-`: `` `LT-3` >= 12000 ``).
    pub id: String,
    /// The id of the device that publishes it.
    pub device: String,
    /// Its datapoint on the device (`volume`), as in `<device>/sensor/<name>/state`.
    pub name: String,
    /// Where the device publishes it, when not `name`: ESPHome object id,
    /// Tasmota path in `tele/<topic>/SENSOR` (`DS18B20.Temperature`), Shelly
    /// component and field (`temperature:0.tC`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub entity: Option<String>,
    /// The unit of its values, for people (`L`, `°C`).
    #[serde(default)]
    pub unit: Option<String>,
    /// How often its device publishes it, in ms (default: the profile's,
    /// 1 s for this palette's devices, 60 s for ESPHome and Shelly, 300 s for Tasmota).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub update_ms: Option<Millis>,
    /// How old its value may be, in ms, before conditions stop trusting it
    /// (default: five times `updateMs`).
    #[serde(default)]
    pub stale_ms: Option<Millis>,
    /// The lowest value it reads, with `max` (a SCADA's engineering range).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min: Option<f64>,
    /// The highest value it reads, with `min`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max: Option<f64>,
    /// On a `modbus` device: the register it is read from.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub modbus: Option<crate::topics::modbus::ModbusRegister>,
}

impl Sensor {
    /// Its entity on its device.
    pub fn entity(&self) -> &str {
        self.entity.as_deref().unwrap_or(&self.name)
    }
}

/// A line of piping (or any equipment) the interlock hands to one operation at a time.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Resource {
    /// Its name (`YEL`), which actuators name as their `resource` and operations in their `resources`.
    pub id: String,
    /// The group command that makes the line safe on a fault, such as
    /// `{"valves": {"V101": 0}}`. Without it, every actuator of the line goes
    /// to its own `lockout` state.
    #[serde(default)]
    pub lockout: Option<GroupCommand>,
}

/// An operation (the paper's §III-D): it acquires its lines, runs its steps
/// in order, returns its actuators to idle and releases the lines.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Operation {
    /// Its id (`10`, `fill`): operation nodes and routines start it by this.
    pub id: String,
    /// What it does, for people (`fill the reverse-osmosis tank`).
    #[serde(default)]
    pub description: Option<String>,
    /// A whole number, higher is more urgent: when operations wait for the
    /// same line, the most urgent is granted first.
    pub priority: i32,
    /// The lines (resource ids) it holds while it runs; its commands may set
    /// only actuators of these lines.
    pub resources: Vec<String>,
    /// Its steps, run in order: each sets actuators (`command`) or waits for a condition (`wait`).
    pub steps: Vec<Step>,
    /// What an operator's hold does: the group command that makes it safe to
    /// pause (close the feed valve, stop the pump), on its own lines only.
    /// Held, it keeps its lines, commands nothing else, and its step's
    /// timeout stands still until a restart or an abort. Default: the plant's
    /// `operationDefaults.hold`, cut to this operation's lines; an empty
    /// command holds without commanding anything. (An abort needs no
    /// setting: its lines' lockouts go out at once, as for a fault, and it
    /// waits for a reset.)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hold: Option<HoldCommand>,
    /// What an operator's stop does with the step in progress: `finish-step`
    /// (the default) lets it end, `now` cuts it short; then every actuator
    /// goes back to idle and the lines are released. Default: the plant's
    /// `operationDefaults.stop`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stop: Option<StopRule>,
}

/// The group command an operator's hold sends, and how long it may take.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct HoldCommand {
    /// The actuators to set and their targets, grouped by type: `{"pumps": {"P1": false}, "valves": {"V101": 0}}`.
    pub command: GroupCommand,
    /// How long, in ms, they may take to get there before the operation faults.
    pub timeout_ms: Millis,
}

/// How a step goes on when a held operation restarts. Either way the
/// actuators the hold command moved first go back where the operation had
/// them, except those the step commands itself (it sends its command again).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "kebab-case")]
pub enum RestartRule {
    /// The step goes on with the time it had left: a command step sends its command again (the default).
    #[default]
    Reissue,
    /// The step runs again from its start, with its whole timeout.
    Rerun,
}

/// What an operator's stop does with the step in progress.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "kebab-case")]
pub enum StopRule {
    /// The step in progress runs to its end (the default).
    #[default]
    FinishStep,
    /// The step in progress ends at once.
    Now,
}

/// What operations do on an operator's command unless they say otherwise.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct OperationDefaults {
    /// The hold command of every operation without its own, cut to each
    /// operation's lines: `{"pumps": {"P1": false, "P2": false}}` stops
    /// whichever of these pumps an operation's lines have.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hold: Option<HoldCommand>,
    /// The restart rule of every step without its own: `reissue` (the default) or `rerun`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub restart: Option<RestartRule>,
    /// The stop rule of every operation without its own: `finish-step` (the default) or `now`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stop: Option<StopRule>,
}

/// One step of an operation: set actuators, or wait for a condition.
// Read by its key (`command` or `wait`), so that a broken step says what is
// wrong with it rather than that it matches no kind of step.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "schema", schemars(deny_unknown_fields))]
#[serde(untagged)]
pub enum Step {
    /// Set actuators and wait until their feedback confirms it, e.g.
    /// `{"command": {"valves": {"V101": 100}, "pumps": {"P1": true}}, "timeoutMs": 20000}`.
    #[serde(rename_all = "camelCase")]
    Command {
        /// The actuators to set and their targets, grouped by type: `{"valves": {"V101": 100}, "pumps": {"P1": true}}`.
        command: GroupCommand,
        /// How long, in ms, the actuators may take to get there before the operation faults.
        timeout_ms: Millis,
        /// How it goes on when its operation restarts after a hold: `reissue`
        /// (its command again, with the time it had left) or `rerun` (again
        /// from its start). Default: the plant's `operationDefaults.restart`, else `reissue`.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        restart: Option<RestartRule>,
    },
    /// Wait until a condition on sensor values holds, e.g.
    /// ``{"wait": "`LT-3` >= 12000", "sensors": ["LT-3"], "timeoutMs": 600000}``.
    #[serde(rename_all = "camelCase")]
    Wait {
        // Text in the document, whatever the core reads it into.
        #[cfg_attr(feature = "schema", schemars(with = "String"))]
        /// The condition, a JSONata expression over the listed sensors' values
        /// that gives true or false: `` `LT-3` >= 12000 `` (a sensor id with a
        /// `-` goes in backticks).
        wait: String,
        /// The ids of the sensors the condition reads.
        sensors: Vec<String>,
        /// How long, in ms, the condition may take to hold before the operation faults.
        timeout_ms: Millis,
        /// How it goes on when its operation restarts after a hold: `reissue`
        /// (waiting on with the time it had left) or `rerun` (waiting again
        /// with its whole timeout). Default: the plant's
        /// `operationDefaults.restart`, else `reissue`.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        restart: Option<RestartRule>,
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
    #[serde(default, deserialize_with = "present")]
    restart: Option<RestartRule>,
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
                        &["command", "timeoutMs", "restart"],
                    ));
                }
                Ok(Step::Command {
                    command,
                    timeout_ms: fields
                        .timeout_ms
                        .ok_or_else(|| D::Error::missing_field("timeoutMs"))?,
                    restart: fields.restart,
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
                restart: fields.restart,
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

/// A routine (the paper's §III-E): a state machine that starts one
/// operation at a time, moving from state to state as its operations complete.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Routine {
    /// Its id (`truck`): the routine node runs it by this.
    pub id: String,
    /// The names of its states (`idle`, `unloading`, `washing`).
    pub states: Vec<String>,
    /// The state it starts in, and returns to on a `reset` msg.
    pub initial: String,
    /// The state it goes to when one of its operations faults; without one it halts until a `reset` msg.
    #[serde(default)]
    pub error_state: Option<String>,
    /// Its moves between states; of those that can fire, the first listed wins.
    pub transitions: Vec<Transition>,
}

/// A move between two states of a routine: when its trigger fires in state
/// `from`, the routine runs the operation and, once it completes, enters `to`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Transition {
    /// The state it leaves.
    pub from: String,
    /// The state it enters once its operation completes.
    pub to: String,
    /// The id of the operation it runs; an operation belongs to one routine only (C1).
    pub operation: String,
    /// What fires it: a msg topic (`{"msg": "truck-arrived"}`) or a condition on sensors (`when`).
    pub trigger: Trigger,
}

/// What fires a transition: a msg topic, or a condition on sensor values.
// Read by its key (`msg` or `when`), as a step is.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "schema", schemars(deny_unknown_fields))]
#[serde(untagged)]
pub enum Trigger {
    /// A msg with this topic sent to the routine node, e.g. `{"msg": "truck-arrived"}`.
    Msg {
        /// The msg topic that fires it (any but `reset`, which sends the routine back to its initial state).
        msg: String,
    },
    /// A condition on sensor values, checked on entering the state and then
    /// as its sensors sample, at most once per `everyMs`, e.g.
    /// ``{"when": "`LT-3` >= 12000", "sensors": ["LT-3"], "everyMs": 1000}``.
    #[serde(rename_all = "camelCase")]
    When {
        // Text in the document, whatever the core reads it into.
        #[cfg_attr(feature = "schema", schemars(with = "String"))]
        /// The condition, a JSONata expression over the listed sensors' values
        /// that gives true or false: `` `LT-3` >= 12000 `` (a sensor id with a
        /// `-` goes in backticks).
        when: String,
        /// The ids of the sensors the condition reads.
        sensors: Vec<String>,
        /// The least time between two checks of the condition, in ms (it is
        /// checked again only once its sensors sampled).
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
    /// How often a sensor's device publishes it: its `updateMs`, else its
    /// Modbus device's polling period, else its profile's default.
    pub fn sensor_update_ms(&self, sensor: &Sensor) -> Millis {
        sensor.update_ms.unwrap_or_else(|| {
            self.devices
                .iter()
                .find(|d| d.id == sensor.device)
                .map_or(ms(1000), |d| {
                    d.modbus
                        .as_ref()
                        .and_then(|m| m.poll_ms)
                        .unwrap_or_else(|| d.profile.default_sensor_update_ms())
                })
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

    /// Whether JSON text on a topic of no device is meant as a group command
    /// (see [`group_msg::command_like`]): else it is someone else's traffic.
    pub fn command_like(&self, text: &str) -> bool {
        group_msg::command_like(text, |key| self.is_group_key(key))
    }
}

impl Deref for Plant {
    type Target = PlantModel;

    fn deref(&self) -> &PlantModel {
        &self.model
    }
}
