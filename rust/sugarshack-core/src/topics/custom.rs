//! The `custom` profile, for firmware none of the others speak: topic
//! templates per actuator type and for sensors (`{prefix}`, `{entity}`), a
//! path to the value in a JSON payload, a map from payload words to values,
//! and the command payload as a template (`{value}`).
//!
//! ```json
//! "custom": {
//!   "status": { "topic": "{prefix}/availability", "online": "up", "offline": "down" },
//!   "actuators": {
//!     "pump": { "state": "{prefix}/{entity}", "value": "state", "map": { "ON": 1, "OFF": 0 },
//!               "command": "{prefix}/{entity}/set", "on": "{\"state\":\"ON\"}", "off": "{\"state\":\"OFF\"}" },
//!     "valve": { "state": "{prefix}/{entity}", "value": "position", "command": "{prefix}/{entity}/set",
//!                "payload": "{\"position\":{value}}" }
//!   },
//!   "sensors": { "state": "{prefix}/{entity}", "value": "value", "ts": "time" }
//! }
//! ```

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::read::{self, Read};
use super::{
    topic_prefix_ok, ActuatorSpec, Builder, CommandRoute, FeedbackKind, Field, Form, Message,
    Route, SensorKind, SensorSpec, Stamp, Target,
};
use crate::actuator::DeviceId;
use crate::plant::{Actuator, Signal};
use crate::text::quote;
use crate::time::Millis;

/// A custom device's topics and payloads: topic templates with `{prefix}`
/// (the device's prefix) and `{entity}` (the actuator's or sensor's entity).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct CustomProfile {
    /// Its availability topic and payloads; without one, only the broker connection tells whether it is alive.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub status: Option<CustomStatus>,
    /// How each type of actuator it drives is commanded and read, by actuator type name (`valve`, `pump`).
    #[serde(default)]
    pub actuators: BTreeMap<String, CustomActuator>,
    /// How its sensor values are read.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensors: Option<CustomValue>,
}

/// How a custom device reports its availability.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct CustomStatus {
    /// The availability topic template (`{prefix}/availability`).
    pub topic: String,
    /// The payload that means online (`up`).
    pub online: String,
    /// The payload that means offline (`down`).
    pub offline: String,
}

/// Where a value is published and how it reads.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct CustomValue {
    /// The topic template it is published on (`{prefix}/{entity}`).
    pub state: String,
    /// The dotted path to the value in a JSON payload (`state.position`); without it, the whole payload is the value.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<String>,
    /// Payload words (or JSON strings) and the numbers they mean: `{"ON": 1, "OFF": 0}`.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub map: BTreeMap<String, f64>,
    /// The dotted path to the device's time (epoch ms) in a JSON payload.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ts: Option<String>,
}

/// How a custom device's actuators of one type are commanded and read: where
/// their state is published (`state`, `value`, `map`, `ts`) and how they are commanded.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct CustomActuator {
    /// How its state is read.
    #[serde(flatten)]
    pub state: CustomValue,
    /// The command topic template (`{prefix}/{entity}/set`).
    pub command: String,
    /// Analog: the command payload template, `{value}` standing for the target (default: the number alone).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub payload: Option<String>,
    /// Binary: the payload that switches it on (default `ON`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub on: Option<String>,
    /// Binary: the payload that switches it off (default `OFF`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub off: Option<String>,
}

/// A template with `{prefix}` and `{entity}` filled in, or why it cannot be.
fn expand(template: &str, prefix: &str, entity: &str) -> Result<String, String> {
    let mut out = String::new();
    let mut rest = template;
    while let Some(open) = rest.find('{') {
        out.push_str(&rest[..open]);
        let close = rest[open..]
            .find('}')
            .ok_or_else(|| format!("'{}' has a '{{' without '}}'", quote(template)))?;
        match &rest[open + 1..open + close] {
            "prefix" => out.push_str(prefix),
            "entity" => out.push_str(entity),
            other => {
                return Err(format!(
                    "'{}' has an unknown placeholder {{{}}} (known: {{prefix}}, {{entity}})",
                    quote(template),
                    quote(other)
                ))
            }
        }
        rest = &rest[open + close + 1..];
    }
    out.push_str(rest);
    if topic_prefix_ok(&out) {
        Ok(out)
    } else {
        Err(format!(
            "'{}' gives topic '{}', which has a wildcard, a space or an empty level",
            quote(template),
            quote(&out)
        ))
    }
}

fn path_of(what: &str, path: Option<&String>, at: &str, b: &mut Builder) -> Option<Vec<String>> {
    let path = path?;
    let keys = read::dotted(path);
    if keys.is_none() {
        b.error(
            at,
            format!(
                "custom {what} '{}' must be a dotted path such as \"state.position\"",
                quote(path)
            ),
        );
    }
    keys
}

pub(crate) fn status(
    c: &CustomProfile,
    prefix: &str,
    id: &str,
    path: &str,
    b: &mut Builder,
) -> (String, String, Option<String>) {
    let Some(s) = &c.status else {
        return (String::new(), String::new(), None);
    };
    match expand(&s.topic, prefix, id) {
        Ok(topic) => (s.online.clone(), s.offline.clone(), Some(topic)),
        Err(why) => {
            b.error(&format!("{path}.custom.status.topic"), why);
            (String::new(), String::new(), None)
        }
    }
}

/// Registers where a value arrives.
fn route(
    value: &CustomValue,
    topic: String,
    device: DeviceId,
    target: Target,
    at: &str,
    b: &mut Builder,
) -> Vec<String> {
    let read = Read::Mapped(value.map.clone());
    let keys = path_of("value", value.value.as_ref(), at, b);
    let ts = path_of("ts", value.ts.as_ref(), at, b);
    if keys.is_none() && ts.is_none() {
        b.route(topic, Route::Text(device, target, read), at);
        return Vec::new();
    }
    let keys = keys.unwrap_or_default();
    let stamp = match ts {
        Some(ts) => (Stamp::EpochMs, ts),
        None => (Stamp::None, Vec::new()),
    };
    b.field_at(
        topic,
        device,
        stamp,
        Field {
            path: keys.clone(),
            target,
            read,
        },
        at,
    );
    keys
}

pub(crate) fn actuator(
    c: &CustomProfile,
    spec: &ActuatorSpec,
    a: &Actuator,
    b: &mut Builder,
) -> (CommandRoute, FeedbackKind) {
    let entity = a.entity.clone().unwrap_or_else(|| a.id.clone());
    let empty = (
        CommandRoute {
            topic: String::new(),
            form: Form::words("", ""),
        },
        FeedbackKind::Custom {
            topic: String::new(),
            path: Vec::new(),
            words: None,
        },
    );
    let Some(t) = c.actuators.get(&a.kind) else {
        b.error(
            spec.path,
            format!(
                "its device's custom profile has no templates for type '{}' (custom.actuators.{})",
                quote(&a.kind),
                quote(&a.kind)
            ),
        );
        return empty;
    };
    let (state, command) = match (
        expand(&t.state.state, spec.prefix, &entity),
        expand(&t.command, spec.prefix, &entity),
    ) {
        (Ok(s), Ok(c)) => (s, c),
        (Err(why), _) | (_, Err(why)) => {
            b.error(
                spec.path,
                format!("custom.actuators.{}: {why}", quote(&a.kind)),
            );
            return empty;
        }
    };
    let keys = route(
        &t.state,
        state.clone(),
        spec.device,
        Target::Actuator(spec.id),
        spec.path,
        b,
    );
    let form = match spec.signal {
        Signal::Binary => Form::Words {
            on: t.on.clone().unwrap_or_else(|| "ON".into()),
            off: t.off.clone().unwrap_or_else(|| "OFF".into()),
        },
        Signal::Analog => {
            let template = t.payload.clone().unwrap_or_else(|| "{value}".into());
            match template.split_once("{value}") {
                Some((before, after)) if !after.contains("{value}") => Form::Number {
                    percent: None,
                    before: before.into(),
                    after: after.into(),
                },
                _ => {
                    b.error(
                        spec.path,
                        format!(
                            "custom.actuators.{}.payload '{}' must hold {{value}} once",
                            quote(&a.kind),
                            quote(&template)
                        ),
                    );
                    return empty;
                }
            }
        }
    };
    let word = |v: f64| {
        t.state
            .map
            .iter()
            .find(|(_, m)| **m == v)
            .map(|(k, _)| k.clone())
    };
    let words = match (word(1.0), word(0.0)) {
        (Some(on), Some(off)) => Some((on, off)),
        _ => None,
    };
    (
        CommandRoute {
            topic: command,
            form,
        },
        FeedbackKind::Custom {
            topic: state,
            path: keys,
            words,
        },
    )
}

pub(crate) fn sensor(c: &CustomProfile, spec: &SensorSpec, b: &mut Builder) -> SensorKind {
    let (id, device, prefix, s, path) = spec.parts();
    let Some(v) = &c.sensors else {
        b.error(
            path,
            "its device's custom profile has no sensor template (custom.sensors)",
        );
        return SensorKind::Topic(String::new());
    };
    match expand(&v.state, prefix, s.entity()) {
        Ok(topic) => {
            let keys = route(v, topic.clone(), device, Target::Sensor(id), path, b);
            if keys.is_empty() {
                SensorKind::Topic(topic)
            } else {
                SensorKind::Shared { topic, path: keys }
            }
        }
        Err(why) => {
            b.error(path, format!("custom.sensors: {why}"));
            SensorKind::Topic(String::new())
        }
    }
}

/// What such a device publishes for an actuator.
pub(crate) fn format(
    topic: &str,
    path: &[String],
    words: Option<&(String, String)>,
    signal: Signal,
    value: f64,
    ts: Option<Millis>,
    out: &mut Vec<Message>,
) {
    let leaf = match (signal, words) {
        (Signal::Binary, Some((on, off))) => Value::String(if value >= 0.5 {
            on.clone()
        } else {
            off.clone()
        }),
        (Signal::Binary, None) => Value::Bool(value >= 0.5),
        (Signal::Analog, _) => read::json_number(value),
    };
    let payload = if path.is_empty() {
        match leaf {
            Value::String(s) => s,
            other => other.to_string(),
        }
    } else {
        let mut doc = Value::Object(Default::default());
        read::put(&mut doc, path, leaf);
        let _ = ts;
        doc.to_string()
    };
    out.push(Message {
        topic: topic.to_owned(),
        payload,
        retain: false,
    });
}

/// A sensor value on its own topic.
pub(crate) fn format_value(value: f64, _ts: Option<Millis>) -> String {
    read::format_plain(value)
}
