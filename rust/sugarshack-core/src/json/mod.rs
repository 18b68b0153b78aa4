//! Reading JSON documents so that every problem says where it is
//! (`operations[2].steps[1]: missing field `timeoutMs``), and so that no
//! document, however deeply nested, can exhaust the stack.

use std::fmt;

use serde::de::DeserializeOwned;
use serde_path_to_error::Segment;

use crate::text::{abridge, QUOTE_CHARS};

mod words;

/// The deepest nesting read: serde_json refuses its 128th level.
pub const MAX_DEPTH: usize = 127;

/// A serde message names what it expected after the bad value: room for both.
const MESSAGE_CHARS: usize = 200;

/// Why JSON text could not be read.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum JsonError {
    /// Arrays and objects nested deeper than [`MAX_DEPTH`].
    TooDeep {
        /// The deepest nesting read.
        limit: usize,
    },
    /// Not JSON, or not the shape expected.
    Invalid {
        /// Where, as `actuators[3].io`; None at the top or when unknown.
        path: Option<String>,
        /// What is wrong, and where.
        message: String,
        /// Line and column in the text, counted from 1.
        position: Option<(usize, usize)>,
    },
}

impl JsonError {
    /// The same error without its line and column: for text the user never
    /// saw (a JS object turned into JSON on its way in).
    pub fn without_position(self) -> Self {
        match self {
            Self::Invalid { path, message, .. } => Self::Invalid {
                path,
                message,
                position: None,
            },
            other => other,
        }
    }
}

impl fmt::Display for JsonError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::TooDeep { limit } => write!(f, "nested deeper than {limit} levels"),
            Self::Invalid {
                path,
                message,
                position,
            } => {
                if let Some(path) = path {
                    write!(f, "{path}: ")?;
                }
                f.write_str(message)?;
                if let Some((line, column)) = position {
                    write!(f, " (line {line}, column {column})")?;
                }
                Ok(())
            }
        }
    }
}

impl std::error::Error for JsonError {}

/// How deeply the arrays and objects of `text` nest, counting no further
/// than `limit + 1`. Brackets inside strings do not count.
pub fn nesting_depth(text: &str, limit: usize) -> usize {
    let (mut depth, mut deepest) = (0usize, 0usize);
    let (mut in_string, mut escaped) = (false, false);
    for byte in text.bytes() {
        if in_string {
            match byte {
                _ if escaped => escaped = false,
                b'\\' => escaped = true,
                b'"' => in_string = false,
                _ => {}
            }
            continue;
        }
        match byte {
            b'"' => in_string = true,
            b'[' | b'{' => {
                depth += 1;
                deepest = deepest.max(depth);
                if deepest > limit {
                    return deepest;
                }
            }
            b']' | b'}' => depth = depth.saturating_sub(1),
            _ => {}
        }
    }
    deepest
}

/// Reads `text` as a `T`, seeing every key, with the path of the first problem.
///
/// ```
/// use sugarshack_core::json::{from_str, JsonError};
/// use sugarshack_core::plant::Device;
/// let err = from_str::<Vec<Device>>(r#"[{ "id": "ctrl-1", "kind": "actuator-panel" }, { "id": "ctrl-2" }]"#)
///     .unwrap_err();
/// assert_eq!(err.without_position().to_string(), "[1]: missing field `kind`");
/// let err = from_str::<Vec<Device>>(r#"[{ "id": "ctrl-1", "kind": "relay" }]"#).unwrap_err();
/// assert_eq!(
///     err.without_position().to_string(),
///     "[0]: kind must be one of 'actuator-panel', 'sensor-station'; got 'relay'"
/// );
/// ```
pub fn from_str<T: DeserializeOwned>(text: &str) -> Result<T, JsonError> {
    if nesting_depth(text, MAX_DEPTH) > MAX_DEPTH {
        return Err(JsonError::TooDeep { limit: MAX_DEPTH });
    }
    let mut deserializer = serde_json::Deserializer::from_str(text);
    let value = serde_path_to_error::deserialize(&mut deserializer).map_err(|err| {
        let segments: Vec<Segment> = err.path().iter().cloned().collect();
        invalid(&segments, err.into_inner())
    })?;
    deserializer.end().map_err(|err| invalid(&[], err))?;
    Ok(value)
}

/// Reads a JSON value already parsed as a `T`, with the path of the first
/// problem, worded as [`from_str`] words it.
pub fn from_value<T: DeserializeOwned>(value: &serde_json::Value) -> Result<T, JsonError> {
    serde_path_to_error::deserialize(value).map_err(|err| {
        let segments: Vec<Segment> = err.path().iter().cloned().collect();
        invalid(&segments, err.into_inner())
    })
}

fn invalid(segments: &[Segment], err: serde_json::Error) -> JsonError {
    let position = (err.line() > 0).then(|| (err.line(), err.column()));
    let text = err.to_string();
    let message = match position {
        Some((line, column)) => text
            .strip_suffix(&format!(" at line {line} column {column}"))
            .unwrap_or(&text),
        None => &text,
    };
    let (path, message) = match words::wrong_value(message) {
        // A value of the wrong kind: named by its field, under its parent's
        // path; what was given comes last, already cut to a quote.
        Some(wrong) => {
            let (parent, field) = words::field_of(segments);
            (parent, wrong.message(field.as_deref()))
        }
        None => (path_text(segments), abridge(message, MESSAGE_CHARS)),
    };
    JsonError::Invalid {
        path: path.map(|p| abridge(&p, QUOTE_CHARS)),
        message,
        position,
    }
}

/// `operations[2].steps[1]`, or None at the top.
fn path_text(segments: &[Segment]) -> Option<String> {
    let mut out = String::new();
    for segment in segments {
        match segment {
            Segment::Seq { index } => out.push_str(&format!("[{index}]")),
            Segment::Map { key } | Segment::Enum { variant: key } => {
                if !out.is_empty() {
                    out.push('.');
                }
                out.push_str(key);
            }
            Segment::Unknown => {
                if !out.is_empty() {
                    out.push('.');
                }
                out.push('?');
            }
        }
    }
    (!out.is_empty() && out != "?").then_some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    fn nested(levels: usize) -> String {
        "[".repeat(levels) + &"]".repeat(levels)
    }

    #[test]
    fn nesting_is_counted_outside_strings_only() {
        assert_eq!(nesting_depth("[]", 10), 1);
        assert_eq!(nesting_depth(r#"{"a": [1, {"b": "[[[{"}]}"#, 10), 3);
        assert_eq!(nesting_depth(r#"["\"[[", "\\", [[]]]"#, 10), 3);
        assert_eq!(
            nesting_depth(&nested(1_000_000), 127),
            128,
            "stops counting past the limit"
        );
    }

    #[test]
    fn the_depth_limit_is_serde_jsons_own() {
        assert!(serde_json::from_str::<serde_json::Value>(&nested(MAX_DEPTH)).is_ok());
        assert!(serde_json::from_str::<serde_json::Value>(&nested(MAX_DEPTH + 1)).is_err());
        assert!(from_str::<serde_json::Value>(&nested(MAX_DEPTH)).is_ok());
        assert_eq!(
            from_str::<serde_json::Value>(&nested(MAX_DEPTH + 1)),
            Err(JsonError::TooDeep { limit: MAX_DEPTH })
        );
        assert_eq!(
            from_str::<serde_json::Value>(&nested(100_000))
                .unwrap_err()
                .to_string(),
            "nested deeper than 127 levels"
        );
    }

    #[derive(Debug, Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Line {
        name: String,
        valves: Vec<u32>,
    }

    #[test]
    fn errors_name_their_path_and_position() {
        let err = from_str::<Vec<Line>>("[{\"name\": \"YEL\", \"valves\": []},\n {\"name\": \"RED\", \"valves\": [1, \"two\"]}]")
            .unwrap_err();
        assert_eq!(
            err.to_string(),
            "[1]: valves[1] must be a whole number from 0 up, like 5; got 'two' (line 2, column 36)"
        );
        assert_eq!(
            err.without_position().to_string(),
            "[1]: valves[1] must be a whole number from 0 up, like 5; got 'two'"
        );
        let typo = from_str::<Line>(r#"{"name": "YEL", "valvs": []}"#).unwrap_err();
        assert!(
            typo.to_string().starts_with("valvs: unknown field `valvs`"),
            "{typo}"
        );
        let top = from_str::<Line>("12").unwrap_err().without_position();
        assert_eq!(
            top.to_string(),
            "it must be an object in braces, {...}; got 12"
        );
    }

    #[test]
    fn trailing_text_and_bad_syntax_are_refused() {
        assert!(from_str::<Vec<u32>>("[1] [2]")
            .unwrap_err()
            .to_string()
            .contains("trailing characters"));
        assert!(from_str::<Vec<u32>>("[1,").is_err());
        assert!(from_str::<Vec<u32>>("").is_err());
    }

    #[test]
    fn huge_values_in_messages_are_abridged() {
        let text = format!(
            r#"{{"name": "YEL", "valves": ["{}"]}}"#,
            "x".repeat(1_000_000)
        );
        let err = from_str::<Line>(&text)
            .unwrap_err()
            .without_position()
            .to_string();
        assert!(err.len() < 300, "{} characters", err.len());
        assert!(
            err.starts_with("valves[0] must be a whole number from 0 up, like 5; got 'xxx"),
            "{err}"
        );
        assert!(err.ends_with("x…'"), "{err}");
        let key = format!(r#"{{"{}": 1}}"#, "k".repeat(1_000_000));
        let err = from_str::<Line>(&key)
            .unwrap_err()
            .without_position()
            .to_string();
        assert!(err.len() < 320, "{} characters", err.len());
    }
}
