//! The state an actuator is set to (its idle and lockout states, a command's
//! target): read from JSON as `true`/`false` or a finite number, then checked
//! against the actuator's signal and range.

use std::fmt;

use serde::de::{self, Visitor};
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::{Range, Signal};
use crate::text::quote;

/// On or off for a binary actuator, a position for an analog one. An analog
/// setpoint is always finite: NaN and ±Infinity are refused when read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Setpoint {
    /// `true` or `false`.
    Binary(bool),
    /// A finite position.
    Analog(f64),
}

impl Setpoint {
    /// Reads a JSON value: a boolean, or a number (JSON numbers are finite).
    pub fn from_json(value: &serde_json::Value) -> Option<Self> {
        match value {
            serde_json::Value::Bool(on) => Some(Self::Binary(*on)),
            serde_json::Value::Number(n) => n.as_f64().and_then(Self::analog),
            _ => None,
        }
    }

    /// An analog setpoint, None when `value` is not finite.
    pub fn analog(value: f64) -> Option<Self> {
        value.is_finite().then_some(Self::Analog(value))
    }

    /// The position the tracker works with (0 or 1 when binary) if the
    /// setpoint suits `signal` and lies within `range`; else why not.
    pub fn position(self, signal: Signal, range: Range) -> Result<f64, String> {
        match (signal, self) {
            (Signal::Binary, Self::Binary(on)) => Ok(if on { 1.0 } else { 0.0 }),
            (Signal::Binary, other) => Err(wrong_setpoint(signal, range, other)),
            (Signal::Analog, Self::Analog(v)) if v >= range.min && v <= range.max => Ok(v),
            (Signal::Analog, Self::Analog(v)) => Err(format!(
                "must be within {}..{}, got {}",
                quote(range.min),
                quote(range.max),
                quote(v)
            )),
            (Signal::Analog, other) => Err(wrong_setpoint(signal, range, other)),
        }
    }
}

/// Why `got` cannot be a setpoint of this signal.
pub(crate) fn wrong_setpoint(signal: Signal, range: Range, got: impl fmt::Display) -> String {
    match signal {
        Signal::Binary => format!("must be true or false, got {}", quote(got)),
        Signal::Analog => format!(
            "must be a number within {}..{}, got {}",
            quote(range.min),
            quote(range.max),
            quote(got)
        ),
    }
}

impl fmt::Display for Setpoint {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Binary(on) => write!(f, "{on}"),
            Self::Analog(v) => write!(f, "{v}"),
        }
    }
}

/// Integers up to 2^53 are exact in an f64 and in JS.
const EXACT_INTEGER: f64 = 9_007_199_254_740_992.0;

impl Serialize for Setpoint {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        match *self {
            Self::Binary(on) => serializer.serialize_bool(on),
            // Written back as it was read: `100`, not `100.0`.
            Self::Analog(v) if v.fract() == 0.0 && v.abs() <= EXACT_INTEGER => {
                serializer.serialize_i64(v as i64)
            }
            Self::Analog(v) => serializer.serialize_f64(v),
        }
    }
}

impl<'de> Deserialize<'de> for Setpoint {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct SetpointVisitor;

        impl Visitor<'_> for SetpointVisitor {
            type Value = Setpoint;

            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a setpoint: true or false for a binary actuator, a finite number for an analog one")
            }

            fn visit_bool<E: de::Error>(self, on: bool) -> Result<Setpoint, E> {
                Ok(Setpoint::Binary(on))
            }

            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Setpoint, E> {
                Ok(Setpoint::Analog(v as f64))
            }

            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Setpoint, E> {
                Ok(Setpoint::Analog(v as f64))
            }

            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Setpoint, E> {
                Setpoint::analog(v).ok_or_else(|| {
                    E::custom(format!(
                        "a setpoint must be a finite number, got {}",
                        quote(v)
                    ))
                })
            }
        }

        deserializer.deserialize_any(SetpointVisitor)
    }
}

/// What the visitor above accepts: a boolean, or any JSON number.
#[cfg(feature = "schema")]
impl schemars::JsonSchema for Setpoint {
    fn inline_schema() -> bool {
        true
    }

    fn schema_name() -> std::borrow::Cow<'static, str> {
        "Setpoint".into()
    }

    fn json_schema(_: &mut schemars::SchemaGenerator) -> schemars::Schema {
        schemars::json_schema!({ "type": ["boolean", "number"] })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    const PERCENT: Range = Range {
        min: 0.0,
        max: 100.0,
        tolerance: 1.0,
    };
    const ON_OFF: Range = Range {
        min: 0.0,
        max: 1.0,
        tolerance: 0.5,
    };

    #[test]
    fn a_setpoint_reads_a_boolean_or_a_number_and_nothing_else() {
        let read = |v| serde_json::from_value::<Setpoint>(v);
        assert_eq!(read(json!(true)).unwrap(), Setpoint::Binary(true));
        assert_eq!(read(json!(40)).unwrap(), Setpoint::Analog(40.0));
        assert_eq!(read(json!(-2.5)).unwrap(), Setpoint::Analog(-2.5));
        for bad in [json!("open"), json!(null), json!([1]), json!({ "v": 1 })] {
            let err = read(bad.clone()).unwrap_err().to_string();
            assert!(
                err.contains("expected a setpoint: true or false"),
                "{bad}: {err}"
            );
        }
    }

    #[test]
    fn a_non_finite_setpoint_cannot_be_made() {
        assert_eq!(Setpoint::analog(f64::NAN), None);
        assert_eq!(Setpoint::analog(f64::INFINITY), None);
        assert_eq!(Setpoint::analog(3.0), Some(Setpoint::Analog(3.0)));
        // A deserializer that can carry NaN (not JSON) is refused by the visitor.
        let err = Setpoint::deserialize(
            serde::de::value::F64Deserializer::<serde::de::value::Error>::new(f64::NAN),
        )
        .unwrap_err();
        assert_eq!(
            err.to_string(),
            "a setpoint must be a finite number, got NaN"
        );
    }

    #[test]
    fn a_setpoint_must_suit_the_signal_and_range() {
        assert_eq!(
            Setpoint::Binary(true).position(Signal::Binary, ON_OFF),
            Ok(1.0)
        );
        assert_eq!(
            Setpoint::Analog(40.0).position(Signal::Analog, PERCENT),
            Ok(40.0)
        );
        assert_eq!(
            Setpoint::Analog(0.0).position(Signal::Binary, ON_OFF),
            Err("must be true or false, got 0".into())
        );
        assert_eq!(
            Setpoint::Binary(false).position(Signal::Analog, PERCENT),
            Err("must be a number within 0..100, got false".into())
        );
        assert_eq!(
            Setpoint::Analog(120.0).position(Signal::Analog, PERCENT),
            Err("must be within 0..100, got 120".into())
        );
    }

    #[test]
    fn a_setpoint_is_written_as_it_was_read() {
        for v in [json!(true), json!(100), json!(-3), json!(12.5)] {
            let setpoint: Setpoint = serde_json::from_value(v.clone()).unwrap();
            assert_eq!(serde_json::to_value(setpoint).unwrap(), v);
        }
    }
}
