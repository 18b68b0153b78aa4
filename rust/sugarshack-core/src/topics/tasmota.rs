//! The `tasmota` profile: stock Tasmota with the default FullTopic
//! `%prefix%/%topic%/`, `<t>` the device's `%topic%`
//! (`tasmota/tasmota_xdrv_driver/xdrv_02_9_mqtt.ino`, `xdrv_27_shutter.ino`).
//!
//! | topic | payload |
//! |---|---|
//! | `tele/<t>/LWT` | `Online` / `Offline` (retained, last will) |
//! | `stat/<t>/POWER1` (`POWER` with one relay) | `ON` / `OFF` |
//! | `stat/<t>/RESULT` | `{"POWER1":"ON"}`, `{"Shutter1":{"Position":54,...}}` |
//! | `tele/<t>/STATE` | `{..., "POWER1":"ON", ...}` every TelePeriod |
//! | `tele/<t>/SENSOR` | `{"DS18B20":{"Temperature":21.5}, "Shutter1":{"Position":54,...}}` |
//! | `cmnd/<t>/POWER1` (palette -> device) | `ON` / `OFF` |
//! | `cmnd/<t>/ShutterPosition1` | `0`..`100` |
//!
//! Its `Time` is local time with second resolution, not used as a device time.

use serde_json::{json, Value};

use super::read::{self, Read};
use super::{
    ActuatorSpec, Builder, CommandRoute, FeedbackKind, Field, Form, Message, Route, SensorKind,
    SensorSpec, Stamp, Target,
};
use crate::plant::{Actuator, Signal};
use crate::text::quote;

fn numbered(entity: &str, word: &str) -> Option<u32> {
    let n = entity.strip_prefix(word)?;
    if n.is_empty() {
        return (word == "POWER").then_some(0);
    }
    n.parse().ok().filter(|n| (1..=32).contains(n))
}

pub(crate) fn actuator(
    spec: &ActuatorSpec,
    a: &Actuator,
    b: &mut Builder,
) -> (CommandRoute, FeedbackKind) {
    let t = spec.prefix;
    let entity = a.entity.clone().unwrap_or_default();
    let own = Target::Actuator(spec.id);
    let field = |path: Vec<String>, read: Read| Field {
        path,
        target: own,
        read,
    };
    match spec.signal {
        Signal::Binary => {
            if numbered(&entity, "POWER").is_none() {
                b.error(
                    spec.path,
                    format!("a tasmota relay needs 'entity': \"POWER1\" .. \"POWER32\" (\"POWER\" with one relay), got '{}'", quote(&entity)),
                );
            }
            b.route(
                format!("stat/{t}/{entity}"),
                Route::Text(spec.device, own, Read::OnOff),
                spec.path,
            );
            for topic in [format!("stat/{t}/RESULT"), format!("tele/{t}/STATE")] {
                b.field(
                    topic,
                    spec.device,
                    Stamp::None,
                    field(vec![entity.clone()], Read::OnOff),
                    spec.path,
                );
            }
            (
                CommandRoute {
                    topic: format!("cmnd/{t}/{entity}"),
                    form: Form::words("ON", "OFF"),
                },
                FeedbackKind::TasmotaPower(entity),
            )
        }
        Signal::Analog => {
            let n = numbered(&entity, "Shutter").filter(|n| *n > 0);
            if n.is_none() {
                b.error(
                    spec.path,
                    format!(
                        "a tasmota shutter needs 'entity': \"Shutter1\" .. \"Shutter32\", got '{}'",
                        quote(&entity)
                    ),
                );
            }
            let (min, max) = spec.range;
            for topic in [format!("stat/{t}/RESULT"), format!("tele/{t}/SENSOR")] {
                b.field(
                    topic,
                    spec.device,
                    Stamp::None,
                    field(
                        vec![entity.clone(), "Position".into()],
                        Read::Percent(min, max),
                    ),
                    spec.path,
                );
            }
            (
                CommandRoute {
                    topic: format!("cmnd/{t}/ShutterPosition{}", n.unwrap_or(1)),
                    form: Form::Number {
                        percent: Some(spec.range),
                        before: String::new(),
                        after: String::new(),
                    },
                },
                FeedbackKind::TasmotaShutter(entity),
            )
        }
    }
}

pub(crate) fn sensor(spec: &SensorSpec, b: &mut Builder) -> SensorKind {
    let (id, device, prefix, s, path) = spec.parts();
    let Some(keys) = read::dotted(s.entity()) else {
        b.error(path, format!("entity '{}' must be a path into tele/<topic>/SENSOR such as \"DS18B20.Temperature\"", quote(s.entity())));
        return SensorKind::Topic(String::new());
    };
    let topic = format!("tele/{prefix}/SENSOR");
    b.field(
        topic.clone(),
        device,
        Stamp::None,
        Field {
            path: keys.clone(),
            target: Target::Sensor(id),
            read: Read::Number,
        },
        path,
    );
    SensorKind::Shared { topic, path: keys }
}

/// What the firmware publishes when a relay or shutter reports.
pub(crate) fn format(t: &str, kind: &FeedbackKind, value: f64, out: &mut Vec<Message>) {
    match kind {
        FeedbackKind::TasmotaPower(entity) => {
            let word = if value >= 0.5 { "ON" } else { "OFF" };
            out.push(Message {
                topic: format!("stat/{t}/RESULT"),
                payload: json!({ entity.as_str(): word }).to_string(),
                retain: false,
            });
            out.push(Message {
                topic: format!("stat/{t}/{entity}"),
                payload: word.into(),
                retain: false,
            });
        }
        FeedbackKind::TasmotaShutter(entity) => {
            let position = Value::from(value.round().clamp(0.0, 100.0) as i64);
            out.push(Message {
                topic: format!("stat/{t}/RESULT"),
                payload: json!({ entity.as_str(): {
                    "Position": position, "Direction": 0, "Target": position, "Tilt": 0 } })
                .to_string(),
                retain: false,
            });
        }
        _ => {}
    }
}
