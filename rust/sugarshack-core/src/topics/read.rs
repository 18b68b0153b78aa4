//! Reading and writing the values inside payloads, shared by the profiles:
//! plain numbers, ON/OFF words, JSON documents walked by a path of keys,
//! device timestamps.

use std::collections::BTreeMap;

use serde_json::Value;

use super::{DeviceId, Field, Form, Reading, Readings, Refusal, Stamp, Target};
use crate::plant::Profile;
use crate::text::quote;
use crate::time::{ms, Millis};

/// Below this a "millisecond" timestamp is before 1973: it is in seconds.
const MIN_EPOCH_MS: f64 = 1e11;
/// Only a clock past this is an epoch clock (tests run clocks from zero).
const EPOCH_CLOCK_MS: Millis = ms(1_000_000_000_000);
/// How far from now a stamp read as seconds may be and still be taken for seconds: a year.
const SECONDS_SLACK_MS: f64 = 365.0 * 24.0 * 3600.0 * 1000.0;

#[derive(Clone, Copy, Debug)]
pub(crate) enum Raw<'a> {
    Text(&'a str),
    Json(&'a Value),
}

#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Decoded {
    Value(f64),
    /// Legal, but carries no value (ESPHome's `opening`).
    Skip,
    /// The device says it has no reading (`nan`).
    Unavailable,
    Bad(Refusal),
}

/// How a value is read.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Read {
    /// A number (text or JSON); `nan` / `None` / null mean no reading.
    Number,
    /// 0..100 mapped onto `min..max` (a valve's or cover's position).
    Percent(f64, f64),
    /// `ON` / `OFF`, any case.
    OnOff,
    /// JSON `true` / `false`.
    Bool,
    /// ESPHome valve/cover state: `open` / `closed` (a value for a binary
    /// actuator), `opening` / `closing` (no value).
    ValveWord { binary: bool },
    /// A custom value map first (text -> value), then numbers and booleans.
    Mapped(BTreeMap<String, f64>),
}

fn bad_value(what: &str, got: Raw) -> Decoded {
    Decoded::Bad(Refusal::new(
        "non-numeric value",
        format!("value must be {what}, got {}", shown(got)),
    ))
}

fn shown(raw: Raw) -> String {
    match raw {
        Raw::Text(t) => quote(t),
        Raw::Json(v) => quote(v),
    }
}

fn is_nan_word(text: &str) -> bool {
    matches!(text, "nan" | "-nan" | "NaN" | "None" | "null")
}

fn number_of(raw: Raw) -> Option<f64> {
    match raw {
        Raw::Text(t) => {
            let t = t.trim();
            // Rust also reads "inf" and "NaN": only finite decimal numbers count.
            let v: f64 = t.parse().ok()?;
            v.is_finite().then_some(v)
        }
        Raw::Json(v) => v.as_f64().filter(|v| v.is_finite()),
    }
}

impl Read {
    pub(crate) fn decode(&self, raw: Raw) -> Decoded {
        match self {
            Read::Number => {
                if let Some(v) = number_of(raw) {
                    return Decoded::Value(v);
                }
                match raw {
                    Raw::Text(t) if is_nan_word(t.trim()) => Decoded::Unavailable,
                    Raw::Json(Value::Null) => Decoded::Unavailable,
                    _ => bad_value("a number", raw),
                }
            }
            Read::Percent(min, max) => match number_of(raw) {
                Some(p) if (0.0..=100.0).contains(&p) => {
                    Decoded::Value(min + p / 100.0 * (max - min))
                }
                Some(_) => bad_value("a position within 0..100", raw),
                None if matches!(raw, Raw::Json(Value::Null)) => Decoded::Bad(Refusal::new(
                    "no position",
                    "the device reports no position (not calibrated?)",
                )),
                None => bad_value("a position within 0..100", raw),
            },
            Read::OnOff => {
                let word = match raw {
                    Raw::Text(t) => t.trim(),
                    Raw::Json(Value::String(s)) => s.trim(),
                    _ => "",
                };
                if word.eq_ignore_ascii_case("on") {
                    Decoded::Value(1.0)
                } else if word.eq_ignore_ascii_case("off") {
                    Decoded::Value(0.0)
                } else {
                    bad_value("ON or OFF", raw)
                }
            }
            Read::Bool => match raw {
                Raw::Json(Value::Bool(b)) => Decoded::Value(if *b { 1.0 } else { 0.0 }),
                _ => bad_value("true or false", raw),
            },
            Read::ValveWord { binary } => {
                let word = match raw {
                    Raw::Text(t) => t.trim(),
                    _ => "",
                };
                match (word, binary) {
                    ("open", true) => Decoded::Value(1.0),
                    ("closed", true) => Decoded::Value(0.0),
                    ("open" | "closed" | "opening" | "closing" | "unknown", _) => Decoded::Skip,
                    _ => bad_value("open, closed, opening or closing", raw),
                }
            }
            Read::Mapped(map) => {
                let key = match raw {
                    Raw::Text(t) => Some(t.trim()),
                    Raw::Json(Value::String(s)) => Some(s.as_str()),
                    _ => None,
                };
                if let Some(v) = key.and_then(|k| map.get(k)) {
                    return Decoded::Value(*v);
                }
                match raw {
                    Raw::Json(Value::Bool(b)) => Decoded::Value(if *b { 1.0 } else { 0.0 }),
                    Raw::Text(t) if t.trim() == "true" || t.trim() == "false" => {
                        Decoded::Value(if t.trim() == "true" { 1.0 } else { 0.0 })
                    }
                    Raw::Text(t) if is_nan_word(t.trim()) => Decoded::Unavailable,
                    Raw::Json(Value::Null) => Decoded::Unavailable,
                    _ => match number_of(raw) {
                        Some(v) => Decoded::Value(v),
                        None => {
                            let known: Vec<&str> = map.keys().map(String::as_str).collect();
                            if known.is_empty() {
                                bad_value("a number or a boolean", raw)
                            } else {
                                bad_value(
                                    &format!("a number or one of {}", quote(known.join(", "))),
                                    raw,
                                )
                            }
                        }
                    },
                }
            }
        }
    }
}

/// The payload as text; MQTT payloads may be any bytes.
pub(crate) fn text(payload: &[u8]) -> Result<&str, Refusal> {
    std::str::from_utf8(payload).map_err(|_| {
        Refusal::new(
            "not text",
            format!(
                "payload is not UTF-8 text: {}",
                quote(String::from_utf8_lossy(payload))
            ),
        )
    })
}

pub(crate) fn json(payload: &[u8]) -> Result<Value, Refusal> {
    serde_json::from_slice(payload).map_err(|err| {
        Refusal::new(
            "bad JSON",
            format!(
                "payload is not JSON ({err}): {}",
                quote(String::from_utf8_lossy(payload))
            ),
        )
    })
}

/// Puts one decoded value where it belongs.
pub(crate) fn one(target: Target, decoded: Decoded, out: &mut Readings) {
    match (decoded, target) {
        (Decoded::Value(v), Target::Actuator(a)) => out.samples.push(Reading::Actuator(a, v)),
        (Decoded::Value(v), Target::Sensor(s)) => out.samples.push(Reading::Sensor(s, v)),
        (Decoded::Unavailable, Target::Sensor(s)) => {
            out.samples.push(Reading::SensorUnavailable(s))
        }
        (Decoded::Unavailable, Target::Actuator(_)) => out.refusals.push(Refusal::new(
            "no reading",
            "the device reports no value (nan) for an actuator",
        )),
        (Decoded::Skip, _) => {}
        (Decoded::Bad(refusal), _) => out.refusals.push(refusal),
    }
}

/// Follows a path of keys into a document; None when any of it is absent.
pub(crate) fn at<'a>(document: &'a Value, path: &[String]) -> Option<&'a Value> {
    path.iter()
        .try_fold(document, |v, key| v.as_object()?.get(key))
}

/// A device timestamp in epoch ms: a non-negative number (others are
/// ignored, as before); one that reads as seconds is refused once the
/// clock is an epoch clock.
pub(crate) fn epoch_ms(
    value: Option<&Value>,
    stamp: Stamp,
    now: Millis,
) -> Result<Option<Millis>, Refusal> {
    let Some(ts) = value
        .and_then(Value::as_f64)
        .filter(|t| t.is_finite() && *t >= 0.0)
    else {
        return Ok(None);
    };
    let ms = match stamp {
        Stamp::None => return Ok(None),
        Stamp::EpochMs => ts,
        Stamp::EpochSeconds => ts * 1000.0,
    };
    // A stamp that is now when read as seconds was written in seconds.
    let as_seconds_ms = ms * 1000.0;
    if now >= EPOCH_CLOCK_MS
        && ms < MIN_EPOCH_MS
        && (as_seconds_ms - now.as_f64()).abs() < SECONDS_SLACK_MS
    {
        return Err(Refusal::new(
            "bad timestamp",
            format!(
                "ts must be epoch milliseconds; {} reads as seconds (multiply by 1000 on the device)",
                quote(ts)
            ),
        ));
    }
    Ok(Millis::new(ms.min(f64::MAX)))
}

pub(crate) fn json_fields(
    _device: DeviceId,
    fields: &[Field],
    stamp: Stamp,
    stamp_path: &[String],
    payload: &[u8],
    now: Millis,
    out: &mut Readings,
) -> Result<Option<Millis>, Refusal> {
    let document = json(payload)?;
    if !document.is_object() {
        return Err(Refusal::new(
            "not an object",
            format!("payload must be a JSON object, got {}", quote(&document)),
        ));
    }
    let ts = epoch_ms(at(&document, stamp_path), stamp, now)?;
    for field in fields {
        if let Some(value) = at(&document, &field.path) {
            one(field.target, field.read.decode(Raw::Json(value)), out);
        }
    }
    Ok(ts)
}

/// A number as a device writes it: shortest exact form, `nan` for no reading.
pub(crate) fn format_plain(value: f64) -> String {
    if value.is_finite() {
        format!("{value}")
    } else {
        "nan".to_owned()
    }
}

pub(crate) fn json_number(value: f64) -> Value {
    serde_json::Number::from_f64(value).map_or(Value::Null, Value::Number)
}

pub(crate) fn format_command(form: &Form, target: f64) -> String {
    match form {
        Form::Number {
            percent,
            before,
            after,
        } => {
            let v = match percent {
                Some((min, max)) => (target - min) / (max - min) * 100.0,
                None => target,
            };
            format!("{before}{}{after}", format_plain(v))
        }
        Form::Words { on, off } => {
            if target >= 0.5 {
                on.clone()
            } else {
                off.clone()
            }
        }
    }
}

/// A command as the device reads it.
pub(crate) fn parse_command(form: &Form, text: &str) -> Result<f64, Refusal> {
    let text = text.trim();
    match form {
        Form::Number {
            percent,
            before,
            after,
        } => {
            let number = text
                .strip_prefix(before.as_str())
                .and_then(|t| t.strip_suffix(after.as_str()))
                .and_then(|t| number_of(Raw::Text(t)))
                .ok_or_else(|| {
                    Refusal::new(
                        "bad command",
                        format!("expected {before}<number>{after}, got {}", quote(text)),
                    )
                })?;
            Ok(match percent {
                Some((min, max)) => min + number.clamp(0.0, 100.0) / 100.0 * (max - min),
                None => number,
            })
        }
        Form::Words { on, off } => {
            if text.eq_ignore_ascii_case(on) {
                Ok(1.0)
            } else if text.eq_ignore_ascii_case(off) {
                Ok(0.0)
            } else {
                Err(Refusal::new(
                    "bad command",
                    format!("expected {on} or {off}, got {}", quote(text)),
                ))
            }
        }
    }
}

/// The fixed part of a document shared by several sensors.
pub(crate) fn document_start(profile: Profile, topic: &str) -> Value {
    let mut doc = serde_json::Map::new();
    if profile == Profile::ShellyGen2 {
        // `<prefix>/status/temperature:0` carries `"id": 0`.
        let id = topic
            .rsplit(':')
            .next()
            .and_then(|n| n.parse::<u64>().ok())
            .unwrap_or(0);
        doc.insert("id".into(), Value::from(id));
    }
    Value::Object(doc)
}

/// Sets `value` at `path`, making the objects on the way.
pub(crate) fn put(document: &mut Value, path: &[String], value: Value) {
    let Some((last, parents)) = path.split_last() else {
        return;
    };
    let mut here = document;
    for key in parents {
        if !here.get(key).is_some_and(Value::is_object) {
            if let Some(map) = here.as_object_mut() {
                map.insert(key.clone(), Value::Object(Default::default()));
            }
        }
        match here.get_mut(key) {
            Some(next) => here = next,
            None => return,
        }
    }
    if let Some(map) = here.as_object_mut() {
        map.insert(last.clone(), value);
    }
}

/// A dotted path (`DS18B20.Temperature`) as keys; None when a key is empty.
pub(crate) fn dotted(path: &str) -> Option<Vec<String>> {
    let keys: Vec<String> = path.split('.').map(str::to_owned).collect();
    keys.iter().all(|k| !k.is_empty()).then_some(keys)
}
