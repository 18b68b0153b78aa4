//! Time in the core: one type, [`Millis`], for every instant and duration.
//! The core reads no clock: callers hand the time in, in milliseconds.
//!
//! A `Millis` wraps an `f64` that is finite and at least 0, so the control
//! code keeps its fractions of a millisecond (round trips, Ts = 0.5 s) while
//! the arbitration code gets the total order, equality and hashing it needs.
//! Integers are exact up to 2^53 ms (about 285,000 years from 1970).
//!
//! On the wire a whole number of milliseconds is written as a JSON integer,
//! as the `u64` fields it replaces were; a fraction as a JSON float.

use std::cmp::Ordering;
use std::fmt;
use std::hash::{Hash, Hasher};

use serde::{de, Deserialize, Deserializer, Serialize, Serializer};

/// Up to here every whole number of milliseconds is exact in an `f64` (and
/// in a JS number): such values are written as JSON integers.
const EXACT_INTEGERS: f64 = 9_007_199_254_740_992.0;

/// A time instant or duration in milliseconds: finite and at least 0 by construction.
#[derive(Clone, Copy, Debug, Default)]
pub struct Millis(f64);

/// `value` whole milliseconds, usable in constants; exact up to 2^53 ms.
pub const fn ms(value: u64) -> Millis {
    Millis(value as f64)
}

impl Millis {
    /// No time at all; also the earliest instant.
    pub const ZERO: Self = Self(0.0);
    /// The largest time there is: where sums saturate.
    pub const MAX: Self = Self(f64::MAX);

    /// `value` ms, or `None` if it is NaN, infinite or negative.
    pub fn new(value: f64) -> Option<Self> {
        // `+ 0.0` turns -0.0 into 0.0, so equal values hash alike.
        (value.is_finite() && value >= 0.0).then_some(Self(value + 0.0))
    }

    /// `value` ms with its fraction dropped (a JS clock's time or a device's
    /// stamp), or `None` if it is NaN, infinite or negative.
    pub fn whole(value: f64) -> Option<Self> {
        Self::new(value.trunc())
    }

    /// `seconds` s in milliseconds, or `None` if that is not a valid [`Millis`].
    pub fn from_secs_f64(seconds: f64) -> Option<Self> {
        Self::new(seconds * 1000.0)
    }

    /// The value in milliseconds.
    pub fn as_f64(self) -> f64 {
        self.0
    }

    /// The value in seconds, for control formulas that work in seconds.
    pub fn as_secs_f64(self) -> f64 {
        self.0 / 1000.0
    }

    /// Whole milliseconds, rounded down (saturating at `u64::MAX`).
    pub fn as_u64(self) -> u64 {
        // `as` saturates: never a panic.
        self.0 as u64
    }

    /// The value as JSON, as [`Serialize`] writes it: an integer when whole.
    pub fn as_json(self) -> serde_json::Value {
        if self.is_whole() {
            serde_json::Value::from(self.0 as u64)
        } else {
            serde_json::Value::from(self.0)
        }
    }

    fn is_whole(self) -> bool {
        self.0.fract() == 0.0 && self.0 <= EXACT_INTEGERS
    }

    /// `self + other`, saturating at [`Millis::MAX`].
    pub fn saturating_add(self, other: Self) -> Self {
        Self((self.0 + other.0).min(f64::MAX))
    }

    /// `self + other`, or `None` if that leaves the finite numbers.
    pub fn checked_add(self, other: Self) -> Option<Self> {
        Self::new(self.0 + other.0)
    }

    /// `self - other`, or zero when `other` is later.
    pub fn saturating_sub(self, other: Self) -> Self {
        Self((self.0 - other.0).max(0.0))
    }

    /// `self - other`, or `None` when `other` is later.
    pub fn checked_sub(self, other: Self) -> Option<Self> {
        (self.0 >= other.0).then_some(Self(self.0 - other.0))
    }

    /// `self * factor`, or `None` if that is not a valid [`Millis`].
    pub fn mul_f64(self, factor: f64) -> Option<Self> {
        Self::new(self.0 * factor)
    }
}

impl From<u64> for Millis {
    /// Exact up to 2^53 ms; beyond, the nearest `f64`.
    fn from(value: u64) -> Self {
        Self(value as f64)
    }
}

impl From<u32> for Millis {
    fn from(value: u32) -> Self {
        Self(f64::from(value))
    }
}

impl PartialEq for Millis {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for Millis {}

impl PartialOrd for Millis {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Millis {
    fn cmp(&self, other: &Self) -> Ordering {
        self.0.total_cmp(&other.0)
    }
}

impl Hash for Millis {
    fn hash<H: Hasher>(&self, state: &mut H) {
        self.0.to_bits().hash(state);
    }
}

impl fmt::Display for Millis {
    /// The number of milliseconds, without a unit: `1500`, `0.5`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(&self.0, f)
    }
}

impl Serialize for Millis {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        if self.is_whole() {
            serializer.serialize_u64(self.0 as u64)
        } else {
            serializer.serialize_f64(self.0)
        }
    }
}

impl<'de> Deserialize<'de> for Millis {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer.deserialize_any(MillisVisitor)
    }
}

struct MillisVisitor;

impl de::Visitor<'_> for MillisVisitor {
    type Value = Millis;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a non-negative number of milliseconds")
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Millis, E> {
        Ok(Millis::from(v))
    }

    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Millis, E> {
        u64::try_from(v)
            .map(Millis::from)
            .map_err(|_| E::invalid_value(de::Unexpected::Signed(v), &self))
    }

    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Millis, E> {
        Millis::new(v).ok_or_else(|| E::invalid_value(de::Unexpected::Float(v), &self))
    }
}

/// What the visitor above accepts: any JSON number of at least 0 (JSON has no NaN or infinity).
#[cfg(feature = "schema")]
impl schemars::JsonSchema for Millis {
    fn inline_schema() -> bool {
        true
    }

    fn schema_name() -> std::borrow::Cow<'static, str> {
        "Millis".into()
    }

    fn json_schema(_: &mut schemars::SchemaGenerator) -> schemars::Schema {
        schemars::json_schema!({ "type": "number", "minimum": 0 })
    }
}

/// A test's time in ms, known valid.
#[cfg(test)]
pub(crate) fn millis(value: f64) -> Millis {
    Millis::new(value).expect("a valid time")
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn refuses_what_is_not_a_time() {
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, -1.0, -1e-300] {
            assert_eq!(Millis::new(bad), None, "{bad}");
        }
        assert_eq!(Millis::new(-0.0), Some(Millis::ZERO));
        assert_eq!(
            Millis::from_secs_f64(0.5),
            Some(Millis::new(500.0).unwrap())
        );
        assert_eq!(Millis::from_secs_f64(f64::MAX), None);
    }

    #[test]
    fn a_whole_time_drops_its_fraction_and_refuses_what_is_not_a_time() {
        assert_eq!(Millis::whole(1500.9), Some(ms(1500)));
        assert_eq!(Millis::whole(0.4), Some(Millis::ZERO));
        for bad in [f64::NAN, f64::INFINITY, -1.0] {
            assert_eq!(Millis::whole(bad), None, "{bad}");
        }
    }

    #[test]
    fn arithmetic_stays_finite_and_non_negative() {
        assert_eq!(ms(5).saturating_sub(ms(7)), Millis::ZERO);
        assert_eq!(ms(7).saturating_sub(ms(5)), ms(2));
        assert_eq!(ms(5).checked_sub(ms(7)), None);
        assert_eq!(Millis::MAX.saturating_add(Millis::MAX), Millis::MAX);
        assert_eq!(ms(3).mul_f64(f64::MAX), None);
        assert_eq!(ms(1500).as_secs_f64(), 1.5);
        assert_eq!(Millis::new(2.9).unwrap().as_u64(), 2);
    }

    #[test]
    fn whole_milliseconds_stay_json_integers() {
        let old = r#"{"a":0,"b":1700000000123,"c":[5,null],"d":0.5}"#;
        #[derive(Serialize, Deserialize)]
        struct Saved {
            a: Millis,
            b: Millis,
            c: Vec<Option<Millis>>,
            d: Millis,
        }
        let saved: Saved = serde_json::from_str(old).unwrap();
        assert_eq!(saved.b, ms(1_700_000_000_123));
        assert_eq!(serde_json::to_string(&saved).unwrap(), old);
        // A float that is a whole number (as the control state used to write) reads the same.
        let float: Millis = serde_json::from_str("1000.0").unwrap();
        assert_eq!(serde_json::to_string(&float).unwrap(), "1000");
    }

    #[test]
    fn json_refuses_what_is_not_a_time() {
        for bad in ["-1", "-0.5", "\"5\"", "null", "1e400"] {
            assert!(serde_json::from_str::<Millis>(bad).is_err(), "{bad}");
        }
    }

    proptest! {
        #[test]
        fn order_and_equality_follow_the_numbers(a in 0.0..1e15f64, b in 0.0..1e15f64) {
            let (x, y) = (Millis::new(a).unwrap(), Millis::new(b).unwrap());
            prop_assert_eq!(x.cmp(&y), a.partial_cmp(&b).unwrap());
            prop_assert_eq!(x == y, a == b);
        }

        #[test]
        fn json_round_trips(v in prop_oneof![(0u64..1 << 53).prop_map(|n| n as f64), 0.0..1e15f64]) {
            let m = Millis::new(v).unwrap();
            let text = serde_json::to_string(&m).unwrap();
            let back = serde_json::from_str::<Millis>(&text).unwrap();
            if v.fract() == 0.0 {
                prop_assert_eq!(back, m);
                prop_assert!(!text.contains('.'));
            } else {
                // serde_json reads floats back to within an ulp, as it always did.
                prop_assert!((back.as_f64() - v).abs() <= v * 4.0 * f64::EPSILON);
                prop_assert!(text.contains('.') || text.contains('e'));
            }
        }
    }
}
