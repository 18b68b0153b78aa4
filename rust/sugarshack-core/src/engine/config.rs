//! What a node's configuration means, read once when the node is made (the
//! nodes used to read it in JS): the id it names, trimmed as typed in the
//! editor; its timeout, in seconds as typed (blank: none); a wait's sensors.
//! A value that means nothing is refused in the words of the node's editor.

use serde::Serialize;

use super::output::{Param, Refusal};
use super::request::{names_of, trimmed, Raw};
use crate::code::Code;
use crate::text::js_number;
use crate::time::Millis;

/// The longest timeout a node takes, in seconds: a year. Longer is a slip of
/// the keyboard (and past what a JS timer's milliseconds keep exactly).
pub const MAX_TIMEOUT_S: f64 = 365.0 * 24.0 * 3600.0;
/// The longest id a node names: an operation's or a routine's name a person gave.
pub const MAX_CONFIG_ID: usize = 200;

/// Whose configuration is read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ConfigOf {
    /// An operation node: the operation's id.
    Operation,
    /// A routine node: the routine's id.
    Routine,
    /// A wait node: its timeout (required) and sensors.
    Wait,
    /// An acquire node: its timeout (blank: it waits as long as it takes).
    Acquire,
    /// A group command node: its timeout (blank: none).
    GroupCommand,
}

impl ConfigOf {
    /// The node kind by its name in the host (`"groupCommand"`...).
    pub fn from_name(name: &str) -> Option<Self> {
        Some(match name {
            "operation" => ConfigOf::Operation,
            "routine" => ConfigOf::Routine,
            "wait" => ConfigOf::Wait,
            "acquire" => ConfigOf::Acquire,
            "groupCommand" => ConfigOf::GroupCommand,
            _ => return None,
        })
    }
}

/// A node's configured values, as the host read them off its properties.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ConfigFields {
    /// `operation` or `routine`.
    pub id: Raw,
    /// `timeout`, in seconds.
    pub timeout: Raw,
    /// `sensors`: a list or comma-separated text.
    pub sensors: Raw,
}

/// What a node's configuration means; only its kind's values are set.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct NodeConfig {
    /// The id it names, trimmed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub id: Option<String>,
    /// Its timeout (0: none).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub timeout_ms: Option<Millis>,
    /// The sensors it names, trimmed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sensors: Option<Vec<String>>,
}

/// Reads the configuration of a node of kind `of`.
pub fn node_config(of: ConfigOf, fields: &ConfigFields) -> Result<NodeConfig, Refusal> {
    Ok(match of {
        ConfigOf::Operation => NodeConfig {
            id: Some(config_id(&fields.id, "configuredOperation")?),
            ..NodeConfig::default()
        },
        ConfigOf::Routine => NodeConfig {
            id: Some(config_id(&fields.id, "configuredRoutine")?),
            ..NodeConfig::default()
        },
        ConfigOf::Wait => NodeConfig {
            timeout_ms: Some(timeout_of(&fields.timeout, true)?),
            sensors: Some(if fields.sensors.present() {
                names_of(&fields.sensors, Param::Label("configuredSensors"))?
            } else {
                Vec::new()
            }),
            ..NodeConfig::default()
        },
        ConfigOf::Acquire | ConfigOf::GroupCommand => NodeConfig {
            timeout_ms: Some(timeout_of(&fields.timeout, false)?),
            ..NodeConfig::default()
        },
    })
}

/// An id as typed: text trimmed (a number as JS writes it); none is refused.
fn config_id(value: &Raw, label: &'static str) -> Result<String, Refusal> {
    let id = match value {
        Raw::Absent => String::new(),
        Raw::Text(text) if text.chars().count() <= MAX_CONFIG_ID => trimmed(text).to_owned(),
        Raw::Number(n) if n.is_finite() => js_number(*n),
        Raw::Text(_) | Raw::Long { .. } => {
            return Err(Refusal::catalog(
                Code::InvalidConfig,
                "errors.idTooLong",
                vec![
                    ("from", Param::Label(label)),
                    ("max", Param::Text(MAX_CONFIG_ID.to_string())),
                ],
            ))
        }
        other => {
            return Err(Refusal::catalog(
                Code::InvalidConfig,
                "errors.idNotText",
                vec![
                    ("from", Param::Label(label)),
                    ("got", Param::Text(other.quote())),
                ],
            ))
        }
    };
    if id.is_empty() {
        return Err(Refusal::catalog(
            Code::InvalidConfig,
            "errors.idRequired",
            vec![("from", Param::Label(label))],
        ));
    }
    Ok(id)
}

/// A timeout in seconds as typed (`"20"`, `" 1.5 "`, `20`): blank is none,
/// unless `required`. Anything else (negative, not a number, past
/// [`MAX_TIMEOUT_S`]) is refused rather than read as no timeout.
fn timeout_of(value: &Raw, required: bool) -> Result<Millis, Refusal> {
    let blank = match value {
        Raw::Absent => true,
        Raw::Text(text) => text.trim().is_empty(),
        _ => false,
    };
    let seconds = if blank {
        Some(0.0)
    } else {
        match value {
            Raw::Number(n) => Some(*n),
            Raw::Text(text) => seconds_text(text),
            _ => None,
        }
    };
    let Some(seconds) = seconds.filter(|s| (0.0..=MAX_TIMEOUT_S).contains(s)) else {
        return Err(Refusal::catalog(
            Code::InvalidConfig,
            "errors.timeoutNotSeconds",
            vec![
                ("from", Param::Label("configuredTimeout")),
                ("max", Param::Text(js_number(MAX_TIMEOUT_S))),
                ("got", Param::Text(value.quote())),
            ],
        ));
    };
    if required && seconds == 0.0 {
        return Err(Refusal::catalog(
            Code::InvalidConfig,
            "errors.timeoutRequired",
            Vec::new(),
        ));
    }
    // In range, so finite and not negative: never None.
    Ok(Millis::from_secs_f64(seconds).unwrap_or(Millis::ZERO))
}

/// Text that is a decimal number of seconds (`"20"`, `"1.5"`, `"2e3"`), spaces around it allowed.
fn seconds_text(text: &str) -> Option<f64> {
    let number = text.trim();
    // Rust also reads "inf" and "NaN": no number of seconds.
    let decimal = number
        .bytes()
        .all(|b| b.is_ascii_digit() || matches!(b, b'.' | b'e' | b'E' | b'+' | b'-'));
    decimal.then(|| number.parse::<f64>().ok()).flatten()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::Text;

    fn text(value: &str) -> Raw {
        Raw::Text(value.to_owned())
    }

    fn timeout(of: ConfigOf, value: Raw) -> Result<Millis, Refusal> {
        let fields = ConfigFields {
            timeout: value,
            ..ConfigFields::default()
        };
        node_config(of, &fields).map(|c| c.timeout_ms.unwrap())
    }

    fn key(refusal: Refusal) -> &'static str {
        refusal.key().unwrap()
    }

    /// The values the editor saves mean what they meant: seconds, blank for none.
    #[test]
    fn a_timeout_is_seconds_as_typed_blank_for_none() {
        let of = ConfigOf::Acquire;
        assert_eq!(timeout(of, text("20")), Ok(Millis::new(20_000.0).unwrap()));
        assert_eq!(
            timeout(of, text(" 1.5 ")),
            Ok(Millis::new(1_500.0).unwrap())
        );
        assert_eq!(
            timeout(of, Raw::Number(3.0)),
            Ok(Millis::new(3_000.0).unwrap())
        );
        assert_eq!(timeout(of, text("")), Ok(Millis::ZERO));
        assert_eq!(timeout(of, text("  ")), Ok(Millis::ZERO));
        assert_eq!(timeout(of, Raw::Absent), Ok(Millis::ZERO));
        assert_eq!(timeout(of, text("0")), Ok(Millis::ZERO));
        let year = Millis::from_secs_f64(MAX_TIMEOUT_S).unwrap();
        assert_eq!(
            timeout(ConfigOf::GroupCommand, Raw::Number(MAX_TIMEOUT_S)),
            Ok(year)
        );
    }

    /// Not a number of seconds: refused in words, never read as "no timeout".
    #[test]
    fn a_timeout_that_is_no_number_of_seconds_is_refused() {
        for bad in [
            text("-5"),
            Raw::Number(-1.0),
            text("abc"),
            text("NaN"),
            text("inf"),
            text("Infinity"),
            Raw::Other("Infinity".to_owned()),
            text("1e400"),
            Raw::Number(MAX_TIMEOUT_S + 1.0),
            Raw::Bool(true),
        ] {
            let refusal = timeout(ConfigOf::Acquire, bad.clone()).unwrap_err();
            assert_eq!(refusal.code, Code::InvalidConfig, "{bad:?}");
            assert_eq!(key(refusal.clone()), "errors.timeoutNotSeconds");
            let Text::Catalog { params, .. } = &refusal.text else {
                panic!("{bad:?}")
            };
            assert_eq!(params[2], ("got", Param::Text(bad.quote())));
        }
    }

    /// A wait without a timeout would wait for ever: it needs one.
    #[test]
    fn a_wait_needs_a_timeout_and_reads_its_sensors() {
        for none in [text(""), Raw::Absent, text("0")] {
            assert_eq!(
                key(timeout(ConfigOf::Wait, none).unwrap_err()),
                "errors.timeoutRequired"
            );
        }
        let fields = ConfigFields {
            timeout: text("60"),
            sensors: text(" LT-1 , ,LT-2 "),
            ..ConfigFields::default()
        };
        let config = node_config(ConfigOf::Wait, &fields).unwrap();
        assert_eq!(config.timeout_ms, Millis::new(60_000.0));
        assert_eq!(
            config.sensors,
            Some(vec!["LT-1".to_owned(), "LT-2".to_owned()])
        );
        let none = ConfigFields {
            timeout: text("60"),
            ..ConfigFields::default()
        };
        assert_eq!(
            node_config(ConfigOf::Wait, &none).unwrap().sensors,
            Some(Vec::new())
        );
    }

    /// An id is trimmed as typed; none, or one that is no name, is refused.
    #[test]
    fn an_id_is_trimmed_and_required() {
        let id = |of, value| {
            let fields = ConfigFields {
                id: value,
                ..ConfigFields::default()
            };
            node_config(of, &fields).map(|c| c.id.unwrap())
        };
        assert_eq!(
            id(ConfigOf::Operation, text("  fill ")),
            Ok("fill".to_owned())
        );
        assert_eq!(id(ConfigOf::Routine, text("boil\t")), Ok("boil".to_owned()));
        assert_eq!(
            id(ConfigOf::Operation, Raw::Number(7.0)),
            Ok("7".to_owned())
        );
        for none in [text("   "), Raw::Absent] {
            assert_eq!(
                key(id(ConfigOf::Operation, none).unwrap_err()),
                "errors.idRequired"
            );
        }
        assert_eq!(
            key(id(ConfigOf::Routine, text(&"r".repeat(MAX_CONFIG_ID + 1))).unwrap_err()),
            "errors.idTooLong"
        );
        assert_eq!(
            key(id(ConfigOf::Operation, Raw::Bool(true)).unwrap_err()),
            "errors.idNotText"
        );
    }
}
