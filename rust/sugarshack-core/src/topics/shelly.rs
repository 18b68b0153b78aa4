//! The `shelly-gen2` profile: Shelly Plus/Pro MQTT with `status_ntf` on,
//! `<p>` the device's `mqtt.topic_prefix` (Shelly's API documentation, Mqtt
//! and Switch/Cover pages; the firmware is closed).
//!
//! | topic | payload |
//! |---|---|
//! | `<p>/online` | `true` / `false` (last will) |
//! | `<p>/status/switch:0` | `{"id":0, ..., "output":true, ...}` |
//! | `<p>/status/cover:0` | `{"id":0, ..., "state":"open", "current_pos":100, ...}` |
//! | `<p>/status/<component>` | a sensor's component, e.g. `temperature:0` `{"id":0,"tC":21.5}` |
//! | `<p>/events/rpc` | `NotifyStatus` `{"params":{"ts":<epoch s>,"switch:0":{"output":true}}}` |
//! | `<p>/command/switch:0` (palette -> device) | `on` / `off` |
//! | `<p>/command/cover:0` | `pos,<0..100>` |

use serde_json::json;

use super::read::{self, Read};
use super::{
    ActuatorSpec, Builder, CommandRoute, FeedbackKind, Field, Form, Message, SensorKind,
    SensorSpec, Stamp, Target,
};
use crate::actuator::DeviceId;
use crate::plant::{Actuator, Signal};
use crate::text::quote;

fn component(entity: &str, kind: &str) -> Option<u32> {
    entity.strip_prefix(kind)?.strip_prefix(':')?.parse().ok()
}

/// Where a value of a component is: the device, its prefix, the component key and the path of the value in it.
struct Place<'a> {
    device: DeviceId,
    prefix: &'a str,
    key: &'a str,
    keys: &'a [String],
}

/// A value of a component, on its status topic and in NotifyStatus notifications.
fn both(
    b: &mut Builder,
    Place {
        device,
        prefix,
        key,
        keys,
    }: Place,
    target: Target,
    read: Read,
    path: &str,
) {
    let mut status = vec![];
    status.extend_from_slice(keys);
    b.field(
        format!("{prefix}/status/{key}"),
        device,
        Stamp::None,
        Field {
            path: status,
            target,
            read: read.clone(),
        },
        path,
    );
    let mut notified = vec!["params".to_owned(), key.to_owned()];
    notified.extend_from_slice(keys);
    b.field(
        format!("{prefix}/events/rpc"),
        device,
        Stamp::EpochSeconds,
        Field {
            path: notified,
            target,
            read,
        },
        path,
    );
}

pub(crate) fn actuator(
    spec: &ActuatorSpec,
    a: &Actuator,
    b: &mut Builder,
) -> (CommandRoute, FeedbackKind) {
    let p = spec.prefix;
    let entity = a.entity.clone().unwrap_or_default();
    let own = Target::Actuator(spec.id);
    match spec.signal {
        Signal::Binary => {
            if component(&entity, "switch").is_none() {
                b.error(spec.path, format!("a shelly-gen2 switch needs 'entity': \"switch:0\", \"switch:1\"..., got '{}'", quote(&entity)));
            }
            let keys = ["output".to_owned()];
            let place = Place {
                device: spec.device,
                prefix: p,
                key: &entity,
                keys: &keys,
            };
            both(b, place, own, Read::Bool, spec.path);
            (
                CommandRoute {
                    topic: format!("{p}/command/{entity}"),
                    form: Form::words("on", "off"),
                },
                FeedbackKind::ShellySwitch(entity),
            )
        }
        Signal::Analog => {
            if component(&entity, "cover").is_none() {
                b.error(
                    spec.path,
                    format!(
                        "a shelly-gen2 cover needs 'entity': \"cover:0\", \"cover:1\"..., got '{}'",
                        quote(&entity)
                    ),
                );
            }
            let (min, max) = spec.range;
            let keys = ["current_pos".to_owned()];
            let place = Place {
                device: spec.device,
                prefix: p,
                key: &entity,
                keys: &keys,
            };
            both(b, place, own, Read::Percent(min, max), spec.path);
            (
                CommandRoute {
                    topic: format!("{p}/command/{entity}"),
                    form: Form::Number {
                        percent: Some(spec.range),
                        before: "pos,".into(),
                        after: String::new(),
                    },
                },
                FeedbackKind::ShellyCover(entity, spec.range),
            )
        }
    }
}

pub(crate) fn sensor(spec: &SensorSpec, b: &mut Builder) -> SensorKind {
    let (id, device, prefix, s, path) = spec.parts();
    let entity = s.entity();
    let parsed = entity.split_once('.').and_then(|(key, field)| {
        let keys = read::dotted(field)?;
        (key.contains(':') && !key.starts_with(':')).then(|| (key.to_owned(), keys))
    });
    let Some((key, keys)) = parsed else {
        b.error(path, format!("a shelly-gen2 sensor needs 'entity': a component and its field, such as \"temperature:0.tC\", got '{}'", quote(entity)));
        return SensorKind::Topic(String::new());
    };
    let place = Place {
        device,
        prefix,
        key: &key,
        keys: &keys,
    };
    both(b, place, Target::Sensor(id), Read::Number, path);
    SensorKind::Shared {
        topic: format!("{prefix}/status/{key}"),
        path: keys,
    }
}

/// The component status the device publishes (`status_ntf`).
pub(crate) fn format(p: &str, kind: &FeedbackKind, value: f64, out: &mut Vec<Message>) {
    let (entity, payload) = match kind {
        FeedbackKind::ShellySwitch(entity) => (
            entity,
            json!({ "id": component(entity, "switch").unwrap_or(0), "source": "MQTT", "output": value >= 0.5 }),
        ),
        FeedbackKind::ShellyCover(entity, (min, max)) => {
            let position = ((value - min) / (max - min) * 100.0)
                .round()
                .clamp(0.0, 100.0) as i64;
            let state = match position {
                0 => "closed",
                100 => "open",
                _ => "stopped",
            };
            (
                entity,
                json!({ "id": component(entity, "cover").unwrap_or(0), "source": "MQTT", "state": state,
                        "current_pos": position, "pos_control": true }),
            )
        }
        _ => return,
    };
    out.push(Message {
        topic: format!("{p}/status/{entity}"),
        payload: payload.to_string(),
        retain: false,
    });
}
