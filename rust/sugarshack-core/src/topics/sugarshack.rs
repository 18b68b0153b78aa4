//! The `sugarshack` profile, this palette's own format (the default):
//!
//! | topic | payload |
//! |---|---|
//! | `<p>/status` | `online` / `offline` (retained, last will) |
//! | `<p>/state` | `{"ts": <epoch ms>, "<type>": {"<io>": <value>, ...}, ...}` |
//! | `<p>/<type>/<io>/state` | `{"ts", "value"}`, or a bare number or boolean |
//! | `<p>/sensor/<name>/state` | `{"ts", "value"}`, or a bare number |
//! | `<p>/<type>/<io>/command` (palette -> device) | a number (analog), `ON` / `OFF` (binary) |

use std::collections::HashMap;

use serde_json::{Map, Value};

use super::read::{self, epoch_ms};
use super::{
    ActuatorSpec, Builder, CommandRoute, Contract, FeedbackKind, Form, Incoming, Message, Reading,
    Readings, Refusal, Route, SensorKind, SensorSpec, Stamp, Target,
};
use crate::actuator::{ActuatorId, DeviceId};
use crate::plant::{Actuator, Signal};
use crate::text::quote;
use crate::time::Millis;

/// Registers an actuator's state topic; returns its io (0 when missing, reported).
pub(crate) fn actuator(
    spec: &ActuatorSpec,
    a: &Actuator,
    b: &mut Builder,
    slots: &mut Vec<(String, HashMap<u32, ActuatorId>)>,
) -> u32 {
    if a.entity.is_some() {
        b.error(
            spec.path,
            "'entity' is for esphome, tasmota, shelly-gen2 and custom devices; a sugarshack device uses 'io'",
        );
    }
    let Some(io) = a.io else {
        b.error(spec.path, "a sugarshack device's actuator needs 'io'");
        return 0;
    };
    // io 0 and a taken io are reported by the plant's own checks.
    let at = match slots.iter().position(|(k, _)| *k == a.kind) {
        Some(at) => at,
        None => {
            slots.push((a.kind.clone(), HashMap::new()));
            slots.len() - 1
        }
    };
    if slots[at].1.insert(io, spec.id).is_none() {
        b.route(
            format!("{}/{}/{io}/state", spec.prefix, a.kind),
            Route::Single(spec.device, Target::Actuator(spec.id)),
            spec.path,
        );
    }
    io
}

pub(crate) fn command(spec: &ActuatorSpec, kind: &str, io: u32) -> CommandRoute {
    CommandRoute {
        topic: format!("{}/{kind}/{io}/command", spec.prefix),
        form: match spec.signal {
            Signal::Analog => Form::Number {
                percent: None,
                before: String::new(),
                after: String::new(),
            },
            Signal::Binary => Form::words("ON", "OFF"),
        },
    }
}

pub(crate) fn sensor(spec: &SensorSpec, b: &mut Builder) -> SensorKind {
    let (id, device, prefix, s, path) = spec.parts();
    let topic = format!("{prefix}/sensor/{}/state", s.entity());
    b.route(
        topic.clone(),
        Route::Single(device, Target::Sensor(id)),
        path,
    );
    SensorKind::Topic(topic)
}

/// The device id of a topic shaped like a sugarshack state topic
/// (`<d>/state`, `<d>/<type>/<io>/state`, `<d>/sensor/<name>/state`); the
/// caller knows no device has it.
pub(crate) fn unknown_device<'t>(contract: &Contract, topic: &'t str) -> Option<&'t str> {
    let mut levels = topic.split('/');
    let device = levels.next().filter(|d| !d.is_empty())?;
    let rest: Vec<&str> = levels.collect();
    let shaped = match rest[..] {
        ["state"] => true,
        ["sensor", name, "state"] => !name.is_empty(),
        [kind, io, "state"] => contract.is_type(kind) && io_number(io).is_some(),
        _ => false,
    };
    shaped.then_some(device)
}

/// A sample as the tracker takes it: numbers as they are, booleans as 1/0.
fn sample(value: &Value) -> Option<f64> {
    match value {
        Value::Number(n) => n.as_f64().filter(|v| v.is_finite()),
        Value::Bool(b) => Some(if *b { 1.0 } else { 0.0 }),
        _ => None,
    }
}

/// An io number as in topics and batch keys (`"12"`).
fn io_number(key: &str) -> Option<u32> {
    let digits = key.as_bytes();
    if digits.is_empty()
        || digits.len() > 10
        || digits[0] == b'0'
        || !digits.iter().all(u8::is_ascii_digit)
    {
        return None;
    }
    key.parse().ok()
}

pub(crate) fn batch(
    contract: &Contract,
    device: DeviceId,
    payload: &[u8],
    now: Millis,
    out: &mut Readings,
) -> Result<Incoming, Refusal> {
    let document = read::json(payload)?;
    let Value::Object(groups) = &document else {
        return Err(Refusal::new(
            "not an object",
            format!(
                "a state batch must be a JSON object, got {}",
                quote(&document)
            ),
        ));
    };
    let ts = epoch_ms(groups.get("ts"), Stamp::EpochMs, now)?;
    let mut known = 0;
    for (kind, members) in groups {
        if kind == "ts" || !contract.is_type(kind) {
            continue; // other fields a device may add
        }
        known += 1;
        let Value::Object(members) = members else {
            out.refusals.push(Refusal::new(
                "bad group",
                format!(
                    "'{}' must map io numbers to values, got {}",
                    quote(kind),
                    quote(members)
                ),
            ));
            continue;
        };
        let Some(slots) = contract.slots_of(device, kind) else {
            continue;
        };
        for (key, value) in members {
            let Some(&id) = io_number(key).and_then(|io| slots.get(&io)) else {
                continue; // a slot the plant does not name
            };
            match sample(value) {
                Some(v) => out.samples.push(Reading::Actuator(id, v)),
                None => out.refusals.push(Refusal::new(
                    "non-numeric value",
                    format!(
                        "{} {}: value must be a number or a boolean, got {}",
                        quote(kind),
                        quote(key),
                        quote(value)
                    ),
                )),
            }
        }
    }
    if known == 0 {
        let keys: Vec<&str> = groups.keys().map(String::as_str).collect();
        return Err(Refusal::new(
            "no known type",
            format!(
                "a state batch needs at least one of {}, got keys {}",
                contract.type_names.join(", "),
                quote(keys.join(", "))
            ),
        ));
    }
    Ok(Incoming::Samples { device, ts })
}

/// `{"ts", "value"}` or a bare number or boolean.
pub(crate) fn single(
    device: DeviceId,
    target: Target,
    _signal: Option<Signal>,
    payload: &[u8],
    now: Millis,
    out: &mut Readings,
) -> Result<Incoming, Refusal> {
    let document = read::json(payload)?;
    let (value, ts) = match &document {
        Value::Object(fields) => (
            fields.get("value").unwrap_or(&Value::Null),
            epoch_ms(fields.get("ts"), Stamp::EpochMs, now)?,
        ),
        other => (other, None),
    };
    let Some(v) = sample(value) else {
        return Err(Refusal::new(
            "non-numeric value",
            format!("value must be a number or a boolean, got {}", quote(value)),
        ));
    };
    out.samples.push(match target {
        Target::Actuator(a) => Reading::Actuator(a, v),
        Target::Sensor(s) => Reading::Sensor(s, v),
    });
    Ok(Incoming::Samples { device, ts })
}

fn value_of(signal: Signal, value: f64) -> Value {
    match signal {
        Signal::Binary => Value::Bool(value >= 0.5),
        Signal::Analog => read::json_number(value),
    }
}

/// The device's batch: `{"ts", "valve": {"1": 37}, "pump": {"1": true}}`.
pub(crate) fn format_batch(
    contract: &Contract,
    device: DeviceId,
    values: &[(ActuatorId, f64)],
    ts: Option<Millis>,
) -> Vec<Message> {
    let mut document = Map::new();
    if let Some(ts) = ts {
        document.insert("ts".into(), ts.as_json());
    }
    for &(id, value) in values {
        let Some(f) = contract.actuator_feedback.get(id.index()) else {
            continue;
        };
        let FeedbackKind::Sugarshack { kind, io } = &f.kind else {
            continue;
        };
        if f.device != device {
            continue;
        }
        let group = document
            .entry(kind.clone())
            .or_insert_with(|| Value::Object(Map::new()));
        if let Value::Object(group) = group {
            group.insert(
                io.to_string(),
                value_of(contract.signals[id.index()], value),
            );
        }
    }
    let prefix = contract.prefix_of(device);
    vec![Message {
        topic: format!("{prefix}/state"),
        payload: Value::Object(document).to_string(),
        retain: false,
    }]
}

/// One actuator on its own topic: `<p>/<type>/<io>/state` `{"ts", "value"}`.
pub(crate) fn format_single(
    contract: &Contract,
    id: ActuatorId,
    value: f64,
    ts: Option<Millis>,
) -> Option<Message> {
    let f = contract.actuator_feedback.get(id.index())?;
    let FeedbackKind::Sugarshack { kind, io } = &f.kind else {
        return None;
    };
    let mut document = Map::new();
    if let Some(ts) = ts {
        document.insert("ts".into(), ts.as_json());
    }
    document.insert(
        "value".into(),
        value_of(contract.signals[id.index()], value),
    );
    Some(Message {
        topic: format!("{}/{kind}/{io}/state", contract.prefix_of(f.device)),
        payload: Value::Object(document).to_string(),
        retain: false,
    })
}

/// A sensor's `{"ts", "value"}`.
pub(crate) fn format_value(value: f64, ts: Option<Millis>) -> String {
    let mut document = Map::new();
    if let Some(ts) = ts {
        document.insert("ts".into(), ts.as_json());
    }
    document.insert("value".into(), read::json_number(value));
    Value::Object(document).to_string()
}
