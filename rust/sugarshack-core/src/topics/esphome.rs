//! The `esphome` profile: stock ESPHome MQTT (`esphome/components/mqtt/`),
//! `<p>` its `mqtt.topic_prefix`, `<oid>` an entity's object id.
//!
//! | topic | payload |
//! |---|---|
//! | `<p>/status` | `online` / `offline` (birth, last will; retained) |
//! | `<p>/valve/<oid>/position/state` (also `cover`) | `0`..`100` |
//! | `<p>/valve/<oid>/state` (also `cover`) | `open` / `closed` / `opening` / `closing` |
//! | `<p>/switch/<oid>/state` | `ON` / `OFF` |
//! | `<p>/number/<oid>/state` | a number (`37.000000`) |
//! | `<p>/sensor/<oid>/state` | a number (`12.3`), `nan` when the sensor fails |
//! | `<p>/binary_sensor/<oid>/state` | `ON` / `OFF` |
//! | `<p>/valve/<oid>/position/command` (palette -> device) | `0`..`100` |
//! | `<p>/valve/<oid>/command` (a binary valve) | `OPEN` / `CLOSE` |
//! | `<p>/switch/<oid>/command` | `ON` / `OFF` |
//! | `<p>/number/<oid>/command` | a number |
//!
//! States are published on change only (a switch deduplicates), without a timestamp.

use super::read::Read;
use super::{
    ActuatorSpec, Builder, CommandRoute, FeedbackKind, Form, Message, Route, SensorKind,
    SensorSpec, Target,
};
use crate::plant::{Actuator, Component, Signal};
use crate::text::quote;

/// ESPHome's object id of an entity name: snake case, then anything but
/// `[a-z0-9_-]` becomes `_` (`esphome/core/entity_base.cpp`).
pub fn object_id(name: &str) -> String {
    name.chars()
        .map(|c| {
            let c = if c == ' ' {
                '_'
            } else {
                c.to_ascii_lowercase()
            };
            if c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_' || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

fn check_object_id(entity: &str, path: &str, b: &mut Builder) {
    if entity.is_empty() || object_id(entity) != entity {
        b.error(
            path,
            format!(
                "entity '{}' is not an ESPHome object id (lowercase letters, digits, '_' and '-'); the entity named '{}' has object id '{}'",
                quote(entity),
                quote(entity),
                quote(object_id(entity))
            ),
        );
    }
}

pub(crate) fn actuator(
    spec: &ActuatorSpec,
    a: &Actuator,
    b: &mut Builder,
) -> (CommandRoute, FeedbackKind) {
    let entity = a.entity.clone().unwrap_or_else(|| object_id(&a.id));
    check_object_id(&entity, spec.path, b);
    let binary = spec.signal == Signal::Binary;
    let component = a.component.unwrap_or(if binary {
        Component::Switch
    } else {
        Component::Valve
    });
    let fits = match component {
        Component::Valve | Component::Cover => true,
        Component::Number => !binary,
        Component::Switch => binary,
    };
    if !fits {
        b.error(
            spec.path,
            format!(
                "an ESPHome {} cannot drive a {} actuator (analog: valve, cover or number; binary: switch, valve or cover)",
                component.name(),
                if binary { "binary" } else { "analog" }
            ),
        );
    }
    let base = format!("{}/{}/{entity}", spec.prefix, component.name());
    let own = |read| Route::Text(spec.device, Target::Actuator(spec.id), read);
    let (min, max) = spec.range;
    let command = match (component, binary) {
        (Component::Valve | Component::Cover, false) => {
            b.route(
                format!("{base}/position/state"),
                own(Read::Percent(min, max)),
                spec.path,
            );
            b.route(
                format!("{base}/state"),
                own(Read::ValveWord { binary: false }),
                spec.path,
            );
            CommandRoute {
                topic: format!("{base}/position/command"),
                form: Form::Number {
                    percent: Some((min, max)),
                    before: String::new(),
                    after: String::new(),
                },
            }
        }
        (Component::Valve | Component::Cover, true) => {
            b.route(
                format!("{base}/state"),
                own(Read::ValveWord { binary: true }),
                spec.path,
            );
            CommandRoute {
                topic: format!("{base}/command"),
                form: Form::words("OPEN", "CLOSE"),
            }
        }
        (Component::Number, _) => {
            b.route(format!("{base}/state"), own(Read::Number), spec.path);
            CommandRoute {
                topic: format!("{base}/command"),
                form: Form::Number {
                    percent: None,
                    before: String::new(),
                    after: String::new(),
                },
            }
        }
        (Component::Switch, _) => {
            b.route(format!("{base}/state"), own(Read::OnOff), spec.path);
            CommandRoute {
                topic: format!("{base}/command"),
                form: Form::words("ON", "OFF"),
            }
        }
    };
    (
        command,
        FeedbackKind::Esphome {
            component,
            topic: base,
            range: spec.range,
        },
    )
}

pub(crate) fn sensor(spec: &SensorSpec, b: &mut Builder) -> SensorKind {
    let (id, device, prefix, s, path) = spec.parts();
    let entity = s.entity.clone().unwrap_or_else(|| object_id(&s.name));
    check_object_id(&entity, path, b);
    let topic = format!("{prefix}/sensor/{entity}/state");
    b.route(
        topic.clone(),
        Route::Text(device, Target::Sensor(id), Read::Number),
        path,
    );
    b.route(
        format!("{prefix}/binary_sensor/{entity}/state"),
        Route::Text(device, Target::Sensor(id), Read::OnOff),
        path,
    );
    SensorKind::Topic(topic)
}

/// What the firmware publishes for an actuator at `value` (retained, as ESPHome does).
pub(crate) fn format(
    component: Component,
    base: &str,
    (min, max): (f64, f64),
    signal: Signal,
    value: f64,
    out: &mut Vec<Message>,
) {
    let mut publish = |topic: String, payload: String| {
        out.push(Message {
            topic,
            payload,
            retain: true,
        })
    };
    let on = value >= 0.5;
    match (component, signal) {
        (Component::Valve | Component::Cover, Signal::Analog) => {
            // mqtt_valve.cpp: roundf(position * 100), no decimals; then the state word.
            let percent = ((value - min) / (max - min) * 100.0)
                .round()
                .clamp(0.0, 100.0);
            publish(format!("{base}/position/state"), format!("{percent}"));
            let word = if percent == 0.0 { "closed" } else { "open" };
            publish(format!("{base}/state"), word.into());
        }
        (Component::Valve | Component::Cover, Signal::Binary) => {
            publish(
                format!("{base}/state"),
                if on { "open" } else { "closed" }.into(),
            );
        }
        // mqtt_number.cpp: printf("%f").
        (Component::Number, _) => publish(format!("{base}/state"), format!("{value:.6}")),
        (Component::Switch, _) => publish(
            format!("{base}/state"),
            if on { "ON" } else { "OFF" }.into(),
        ),
    }
}
