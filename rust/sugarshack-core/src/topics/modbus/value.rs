//! One value in a register block: its kind (a bit or a 16/32-bit number),
//! the order of the words of a 32-bit value, and the linear scaling between
//! the raw number the device holds and the engineering value the plant uses
//! (4-20 mA modules: raw 4000..20000 µA for 0..100 %).

use serde::{Deserialize, Serialize};

use super::super::Refusal;
use crate::text::quote;

/// Where a value lives on a Modbus device.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "kebab-case")]
pub enum RegisterKind {
    /// A read-write bit (FC 1 read, FC 5/15 write): a relay, a pump's run command.
    Coil,
    /// A read-only bit (FC 2): a limit switch, a run feedback.
    Discrete,
    /// A read-only 16-bit register (FC 4): an analog input.
    Input,
    /// A read-write 16-bit register (FC 3 read, FC 6/16 write): an analog output, a setpoint.
    Holding,
}

impl RegisterKind {
    /// Its name in the plant document.
    pub fn name(self) -> &'static str {
        match self {
            RegisterKind::Coil => "coil",
            RegisterKind::Discrete => "discrete",
            RegisterKind::Input => "input",
            RegisterKind::Holding => "holding",
        }
    }

    /// A bit rather than a register.
    pub fn is_bit(self) -> bool {
        matches!(self, RegisterKind::Coil | RegisterKind::Discrete)
    }

    /// The client may write it.
    pub fn is_writable(self) -> bool {
        matches!(self, RegisterKind::Coil | RegisterKind::Holding)
    }

    /// The function code that reads it.
    pub fn read_function(self) -> u8 {
        match self {
            RegisterKind::Coil => 1,
            RegisterKind::Discrete => 2,
            RegisterKind::Holding => 3,
            RegisterKind::Input => 4,
        }
    }

    /// All four, in function-code order.
    pub const ALL: [RegisterKind; 4] = [
        RegisterKind::Coil,
        RegisterKind::Discrete,
        RegisterKind::Holding,
        RegisterKind::Input,
    ];
}

/// How the words of a register are read as a number.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "kebab-case")]
pub enum ValueType {
    /// One register, unsigned (the default).
    #[default]
    U16,
    /// One register, two's complement.
    I16,
    /// Two registers, unsigned.
    U32,
    /// Two registers, two's complement.
    I32,
    /// Two registers, IEEE 754 single precision.
    F32,
}

impl ValueType {
    /// Its name in the plant document.
    pub fn name(self) -> &'static str {
        match self {
            ValueType::U16 => "u16",
            ValueType::I16 => "i16",
            ValueType::U32 => "u32",
            ValueType::I32 => "i32",
            ValueType::F32 => "f32",
        }
    }

    /// Registers it takes.
    pub fn words(self) -> u16 {
        match self {
            ValueType::U16 | ValueType::I16 => 1,
            _ => 2,
        }
    }

    /// The raw numbers it holds, for the integer types.
    pub fn bounds(self) -> (f64, f64) {
        match self {
            ValueType::U16 => (0.0, 65535.0),
            ValueType::I16 => (-32768.0, 32767.0),
            ValueType::U32 => (0.0, 4_294_967_295.0),
            ValueType::I32 => (-2_147_483_648.0, 2_147_483_647.0),
            ValueType::F32 => (-(f32::MAX as f64), f32::MAX as f64),
        }
    }

    /// The raw numbers must be whole.
    pub fn is_integer(self) -> bool {
        self != ValueType::F32
    }
}

/// Which word of a 32-bit value comes first (bytes within a word are always big-endian).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "kebab-case")]
pub enum WordOrder {
    /// The high word at the lower address (ABCD; Modicon's order, the default).
    #[default]
    HighFirst,
    /// The low word at the lower address (CDAB, "word swapped").
    LowFirst,
}

impl WordOrder {
    /// Its name in the plant document.
    pub fn name(self) -> &'static str {
        match self {
            WordOrder::HighFirst => "high-first",
            WordOrder::LowFirst => "low-first",
        }
    }
}

/// A linear map between the raw range the device holds and the engineering range.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields)]
pub struct Scale {
    /// Two raw numbers, e.g. `[4000, 20000]` (µA of a 4-20 mA loop).
    pub raw: [f64; 2],
    /// The engineering values they mean, e.g. `[0, 100]` (%).
    pub value: [f64; 2],
}

impl Scale {
    /// Why the map cannot be used both ways, if it cannot.
    pub fn problem(&self) -> Option<String> {
        let [r0, r1] = self.raw;
        let [v0, v1] = self.value;
        if ![r0, r1, v0, v1].iter().all(|x| x.is_finite()) {
            return Some("scale numbers must be finite".into());
        }
        if r0 == r1 {
            return Some(format!(
                "scale.raw [{}, {}] has no span: reading would divide by zero",
                quote(r0),
                quote(r1)
            ));
        }
        if v0 == v1 {
            return Some(format!(
                "scale.value [{}, {}] has no span: a command could not be written",
                quote(v0),
                quote(v1)
            ));
        }
        None
    }

    pub(crate) fn to_raw(self, value: f64) -> f64 {
        let [r0, r1] = self.raw;
        let [v0, v1] = self.value;
        r0 + (value - v0) * (r1 - r0) / (v1 - v0)
    }

    pub(crate) fn to_value(self, raw: f64) -> f64 {
        let [r0, r1] = self.raw;
        let [v0, v1] = self.value;
        v0 + (raw - r0) * (v1 - v0) / (r1 - r0)
    }

    fn raw_bounds(self) -> (f64, f64) {
        let [r0, r1] = self.raw;
        (r0.min(r1), r0.max(r1))
    }

    /// The engineering range it covers, low end first.
    pub fn value_bounds(&self) -> (f64, f64) {
        let [v0, v1] = self.value;
        (v0.min(v1), v0.max(v1))
    }
}

/// What a value read from a device is.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Read {
    /// An engineering value.
    Value(f64),
    /// The device holds NaN (a float input with no reading).
    Unavailable,
}

/// How one value is written into and read from words (or bits, one per word).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Codec {
    pub kind: RegisterKind,
    pub value_type: ValueType,
    pub order: WordOrder,
    pub scale: Option<Scale>,
    /// A binary actuator: 0 and 1 only.
    pub binary: bool,
}

impl Codec {
    /// Words (or bits) it spans.
    pub fn width(&self) -> u16 {
        if self.kind.is_bit() {
            1
        } else {
            self.value_type.words()
        }
    }

    /// The engineering values it can carry: the scale's, else the type's.
    pub fn value_bounds(&self) -> (f64, f64) {
        if self.kind.is_bit() || self.binary {
            return (0.0, 1.0);
        }
        match self.scale {
            Some(scale) => scale.value_bounds(),
            None => self.value_type.bounds(),
        }
    }

    /// The raw words for `value`, or why it cannot be written.
    pub fn encode(&self, value: f64) -> Result<Vec<u16>, Refusal> {
        if !value.is_finite() {
            return Err(Refusal::new(
                "bad value",
                format!("{} is not a number a register can hold", quote(value)),
            ));
        }
        if self.kind.is_bit() {
            return Ok(vec![u16::from(value >= 0.5)]);
        }
        let raw = match (self.binary, self.scale) {
            (true, _) => f64::from(u8::from(value >= 0.5)),
            (false, Some(s)) => s.to_raw(value),
            (false, None) => value,
        };
        let (low, high) = match self.scale {
            Some(s) => s.raw_bounds(),
            None => self.value_type.bounds(),
        };
        let slack = self.slack(low, high);
        if !(raw >= low - slack && raw <= high + slack) {
            return Err(Refusal::new(
                "out of range",
                format!(
                    "{} is raw {}, outside {}..{} of this {} register",
                    quote(value),
                    quote(raw),
                    quote(low),
                    quote(high),
                    self.value_type.name()
                ),
            ));
        }
        let (type_low, type_high) = self.value_type.bounds();
        let words = match self.value_type {
            ValueType::U16 | ValueType::I16 => {
                vec![raw.round().clamp(type_low, type_high) as i32 as u16]
            }
            ValueType::U32 | ValueType::I32 => {
                let bits = raw.round().clamp(type_low, type_high) as i64 as u32;
                self.split(bits)
            }
            ValueType::F32 => self.split((raw as f32).to_bits()),
        };
        Ok(words)
    }

    /// The words of a 32-bit pattern, in this value's word order.
    pub fn split(&self, bits: u32) -> Vec<u16> {
        let (high, low) = ((bits >> 16) as u16, bits as u16);
        match self.order {
            WordOrder::HighFirst => vec![high, low],
            WordOrder::LowFirst => vec![low, high],
        }
    }

    fn join(&self, words: &[u16]) -> u32 {
        let (high, low) = match self.order {
            WordOrder::HighFirst => (words[0], words[1]),
            WordOrder::LowFirst => (words[1], words[0]),
        };
        (u32::from(high) << 16) | u32::from(low)
    }

    /// How far past the ends of a raw range a raw number still counts as in
    /// it: half a step of an integer register (it rounds onto the end), an
    /// f32's rounding of the end.
    fn slack(&self, low: f64, high: f64) -> f64 {
        if self.value_type.is_integer() {
            0.5
        } else {
            low.abs().max(high.abs()) * f64::from(f32::EPSILON)
        }
    }

    /// The engineering value of `words` (exactly [`Codec::width`] of them), or why it is refused.
    pub fn decode(&self, words: &[u16]) -> Result<Read, Refusal> {
        if words.len() != usize::from(self.width()) {
            return Err(Refusal::new(
                "short block",
                format!(
                    "{} word(s) where a {} value needs {}",
                    words.len(),
                    self.value_type.name(),
                    self.width()
                ),
            ));
        }
        if self.kind.is_bit() {
            return match words[0] {
                0 => Ok(Read::Value(0.0)),
                _ => Ok(Read::Value(1.0)),
            };
        }
        let raw = match self.value_type {
            ValueType::U16 => f64::from(words[0]),
            ValueType::I16 => f64::from(words[0] as i16),
            ValueType::U32 => f64::from(self.join(words)),
            ValueType::I32 => f64::from(self.join(words) as i32),
            ValueType::F32 => {
                let v = f32::from_bits(self.join(words));
                if v.is_nan() {
                    return Ok(Read::Unavailable);
                }
                if v.is_infinite() {
                    return Err(Refusal::new(
                        "non-numeric value",
                        format!("the register holds {v} (an overflowed input?)"),
                    ));
                }
                f64::from(v)
            }
        };
        if self.binary {
            return match raw {
                0.0 => Ok(Read::Value(0.0)),
                1.0 => Ok(Read::Value(1.0)),
                _ => Err(Refusal::new(
                    "non-numeric value",
                    format!("a binary actuator's register must hold 0 or 1, got {raw}"),
                )),
            };
        }
        let Some(scale) = self.scale else {
            return Ok(Read::Value(raw));
        };
        let (low, high) = scale.raw_bounds();
        let slack = self.slack(low, high);
        if !(raw >= low - slack && raw <= high + slack) {
            return Err(Refusal::new(
                "out of range",
                format!(
                    "raw {} is outside the scale's {}..{} (a broken loop or an overrange input?)",
                    quote(raw),
                    quote(low),
                    quote(high)
                ),
            ));
        }
        Ok(Read::Value(scale.to_value(raw)))
    }
}
