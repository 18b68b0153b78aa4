//! The plant document: devices, actuators and sensors (later resources,
//! operations and routines), and its validation. Every error names the
//! entry at fault so an engineer can find it in the document.

use std::collections::{BTreeMap, HashMap, HashSet};
use std::fmt;

use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct PlantModel {
    #[serde(default)]
    pub name: Option<String>,
    /// Keyed by type name, which is also the MQTT topic component (`<device>/<type>/<io>/command`).
    pub actuator_types: BTreeMap<String, ActuatorType>,
    pub devices: Vec<Device>,
    #[serde(default)]
    pub actuators: Vec<Actuator>,
    #[serde(default)]
    pub sensors: Vec<Sensor>,
    /// Read by the plant simulator only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub simulation: Option<serde_json::Value>,
}

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

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct ActuatorType {
    pub signal: Signal,
    #[serde(default)]
    pub unit: Option<String>,
    #[serde(default)]
    pub min: Option<f64>,
    #[serde(default)]
    pub max: Option<f64>,
    /// Feedback within this of a position counts as at that position.
    #[serde(default)]
    pub tolerance: Option<f64>,
    /// A command must show motion within this long, else it is retried.
    pub no_motion_ms: u64,
    /// A command must reach its target within this long, else it is retried.
    pub completion_ms: u64,
    /// Feedback older than this is stale.
    pub stale_ms: u64,
    /// Retries before a failure escalates.
    #[serde(default)]
    pub retries: u32,
    #[serde(default)]
    pub escalation: Escalation,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DeviceKind {
    ActuatorPanel,
    SensorStation,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Device {
    /// Also the device's MQTT topic prefix.
    pub id: String,
    pub kind: DeviceKind,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Actuator {
    pub id: String,
    #[serde(rename = "type")]
    pub kind: String,
    pub device: String,
    pub io: u32,
    /// Overrides the type's tolerance.
    #[serde(default)]
    pub tolerance: Option<f64>,
    /// The state every operation returns it to (the paper's C3).
    pub idle: serde_json::Value,
    /// The state a fault lockout commands.
    pub lockout: serde_json::Value,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Sensor {
    pub id: String,
    pub device: String,
    /// The datapoint name in `<device>/sensor/<name>/state`.
    pub name: String,
    #[serde(default)]
    pub unit: Option<String>,
    #[serde(default)]
    pub stale_ms: Option<u64>,
}

/// One problem in a plant document.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PlantError {
    /// Where: `actuators[3] (V12)`, `actuatorTypes.valve`, ...
    pub path: String,
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
    pub min: f64,
    pub max: f64,
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

/// Reads a state value (idle, lockout, or a command target) for this signal.
pub fn state_value(signal: Signal, range: Range, value: &serde_json::Value) -> Result<f64, String> {
    match (signal, value) {
        (Signal::Binary, serde_json::Value::Bool(on)) => Ok(if *on { 1.0 } else { 0.0 }),
        (Signal::Binary, other) => Err(format!("must be true or false, got {other}")),
        (Signal::Analog, serde_json::Value::Number(n)) => {
            let v = n.as_f64().unwrap_or(f64::NAN);
            if v.is_finite() && v >= range.min && v <= range.max {
                Ok(v)
            } else {
                Err(format!(
                    "must be within {}..{}, got {v}",
                    range.min, range.max
                ))
            }
        }
        (Signal::Analog, other) => Err(format!(
            "must be a number within {}..{}, got {other}",
            range.min, range.max
        )),
    }
}

fn topic_safe(name: &str) -> bool {
    !name.is_empty() && !name.contains(['/', '+', '#']) && !name.chars().any(char::is_whitespace)
}

impl PlantModel {
    /// Every problem in the document, or none.
    pub fn validate(&self) -> Result<(), PlantErrors> {
        let mut errors = Vec::new();
        let mut push = |path: String, message: String| errors.push(PlantError { path, message });

        for (name, t) in &self.actuator_types {
            let path = format!("actuatorTypes.{name}");
            if !topic_safe(name) {
                push(
                    path.clone(),
                    "a type name is a topic component: no spaces, '/', '+' or '#'".into(),
                );
            }
            for (field, value) in [
                ("noMotionMs", t.no_motion_ms),
                ("completionMs", t.completion_ms),
                ("staleMs", t.stale_ms),
            ] {
                if value == 0 {
                    push(path.clone(), format!("{field} must be positive"));
                }
            }
            if t.no_motion_ms > t.completion_ms {
                push(
                    path.clone(),
                    "noMotionMs must not exceed completionMs".into(),
                );
            }
            if t.signal == Signal::Analog {
                let r = t.range(None);
                if !(r.min.is_finite() && r.max.is_finite() && r.min < r.max) {
                    push(
                        path.clone(),
                        format!("min ({}) must be below max ({})", r.min, r.max),
                    );
                }
                if !(r.tolerance >= 0.0 && r.tolerance < (r.max - r.min) / 2.0) {
                    push(
                        path.clone(),
                        format!(
                            "tolerance must be at least 0 and less than half the range, got {}",
                            r.tolerance
                        ),
                    );
                }
            } else if t.min.is_some() || t.max.is_some() || t.tolerance.is_some() {
                push(
                    path.clone(),
                    "a binary type has no min, max or tolerance".into(),
                );
            }
        }

        let mut devices = HashMap::new();
        for (i, d) in self.devices.iter().enumerate() {
            let path = format!("devices[{i}] ({})", d.id);
            if !topic_safe(&d.id) {
                push(
                    path.clone(),
                    "a device id is its topic prefix: no spaces, '/', '+' or '#'".into(),
                );
            }
            if devices.insert(d.id.as_str(), d.kind).is_some() {
                push(path, format!("device '{}' is defined twice", d.id));
            }
        }

        let mut ids = HashSet::new();
        let mut slots = HashSet::new();
        for (i, a) in self.actuators.iter().enumerate() {
            let path = format!("actuators[{i}] ({})", a.id);
            if a.id.trim().is_empty() {
                push(path.clone(), "an actuator needs an id".into());
            }
            if !ids.insert(a.id.as_str()) {
                push(path.clone(), format!("id '{}' is used twice", a.id));
            }
            match devices.get(a.device.as_str()) {
                None => push(path.clone(), format!("unknown device '{}'", a.device)),
                Some(DeviceKind::SensorStation) => push(
                    path.clone(),
                    format!(
                        "device '{}' is a sensor station, not an actuator panel",
                        a.device
                    ),
                ),
                Some(DeviceKind::ActuatorPanel) => {}
            }
            if a.io == 0 {
                push(path.clone(), "io numbers start at 1".into());
            }
            if !slots.insert((a.device.as_str(), a.kind.as_str(), a.io)) {
                push(
                    path.clone(),
                    format!(
                        "{} {} io {} is already taken by another actuator",
                        a.device, a.kind, a.io
                    ),
                );
            }
            let Some(t) = self.actuator_types.get(&a.kind) else {
                let known: Vec<&str> = self.actuator_types.keys().map(String::as_str).collect();
                push(
                    path,
                    format!("unknown type '{}' (known: {})", a.kind, known.join(", ")),
                );
                continue;
            };
            if t.signal == Signal::Binary && a.tolerance.is_some() {
                push(path.clone(), "a binary actuator has no tolerance".into());
            }
            let range = t.range(a.tolerance);
            if let Some(tol) = a.tolerance {
                if !(tol >= 0.0 && tol < (range.max - range.min) / 2.0) {
                    push(
                        path.clone(),
                        format!(
                            "tolerance must be at least 0 and less than half the range, got {tol}"
                        ),
                    );
                }
            }
            for (field, value) in [("idle", &a.idle), ("lockout", &a.lockout)] {
                if let Err(why) = state_value(t.signal, range, value) {
                    push(path.clone(), format!("{field} {why}"));
                }
            }
        }

        for (i, s) in self.sensors.iter().enumerate() {
            let path = format!("sensors[{i}] ({})", s.id);
            if !ids.insert(s.id.as_str()) {
                push(path.clone(), format!("id '{}' is used twice", s.id));
            }
            if !devices.contains_key(s.device.as_str()) {
                push(path.clone(), format!("unknown device '{}'", s.device));
            }
            if !topic_safe(&s.name) {
                push(
                    path.clone(),
                    "a datapoint name is a topic component: no spaces, '/', '+' or '#'".into(),
                );
            }
            if s.stale_ms == Some(0) {
                push(path, "staleMs must be positive".into());
            }
        }

        if errors.is_empty() {
            Ok(())
        } else {
            Err(PlantErrors(errors))
        }
    }
}
