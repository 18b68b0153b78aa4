//! serde's refusals of a value of the wrong kind, in the words of the person
//! who wrote the value: `invalid type: string "high", expected i32` becomes
//! `priority must be a whole number, like 5; got 'high'`. One place for every
//! field of every document and msg the core reads. serde's texts are read
//! back from its `Display`s (`serde::de::Error`'s default messages,
//! `serde::de::Unexpected`, `serde_json`'s `null`), which serde keeps stable.

use serde_path_to_error::Segment;

use crate::text::quote;

/// A value that is not what its field takes.
#[derive(Debug, PartialEq)]
pub(super) struct WrongValue {
    /// What the field takes, in words.
    expected: String,
    /// What was given, as the user wrote it.
    got: String,
}

impl WrongValue {
    /// `field must be ...; got ...` (`it` at the top).
    pub(super) fn message(&self, field: Option<&str>) -> String {
        format!(
            "{} must be {}; got {}",
            quote(field.unwrap_or("it")),
            self.expected,
            self.got
        )
    }
}

/// The parent's path and the field's name: `operations[0].priority` gives
/// (`operations[0]`, `priority`), `[1].valves[1]` gives (`[1]`, `valves[1]`).
pub(super) fn field_of(segments: &[Segment]) -> (Option<String>, Option<String>) {
    let Some((last, rest)) = segments.split_last() else {
        return (None, None);
    };
    let name = |s: &Segment| match s {
        Segment::Map { key } | Segment::Enum { variant: key } => Some(key.clone()),
        _ => None,
    };
    match last {
        Segment::Seq { index } => match rest.split_last() {
            Some((before, parent)) if name(before).is_some() => (
                super::path_text(parent),
                Some(format!("{}[{index}]", name(before).unwrap_or_default())),
            ),
            _ => (super::path_text(rest), Some(format!("[{index}]"))),
        },
        other => (super::path_text(rest), name(other)),
    }
}

/// serde's refusal of a value of the wrong type or range, in words; None for any other message.
pub(super) fn wrong_value(message: &str) -> Option<WrongValue> {
    if let Some(rest) = message.strip_prefix("unknown variant `") {
        let (given, allowed) = rest.split_once("`, expected ")?;
        // serde's lists: "`a`", "`a` or `b`", "one of `a`, `b`, `c`".
        let names: Vec<String> = allowed
            .trim_start_matches("one of ")
            .split(", ")
            .flat_map(|n| n.split(" or "))
            .map(|n| format!("'{}'", n.trim_matches('`')))
            .collect();
        let expected = match names.as_slice() {
            [one] => one.clone(),
            _ => format!("one of {}", names.join(", ")),
        };
        return Some(WrongValue {
            expected,
            got: format!("'{}'", quote(given)),
        });
    }
    let (range, rest) = if let Some(rest) = message.strip_prefix("invalid type: ") {
        (false, rest)
    } else {
        (true, message.strip_prefix("invalid value: ")?)
    };
    let (unexpected, expected) = split_unexpected(rest)?;
    Some(WrongValue {
        expected: expected_in_words(expected, range),
        got: unexpected_in_words(unexpected),
    })
}

/// `string "a, b", expected u32` -> (`string "a, b"`, `u32`), quotes and all.
fn split_unexpected(text: &str) -> Option<(&str, &str)> {
    let end_of_string = text.strip_prefix("string \"").map(|inner| {
        let mut escaped = false;
        let close = inner
            .char_indices()
            .find(|&(_, c)| {
                let closing = c == '"' && !escaped;
                escaped = c == '\\' && !escaped;
                closing
            })
            .map_or(inner.len(), |(i, _)| i + 1);
        "string \"".len() + close
    });
    let at = match end_of_string {
        Some(end) => end + text.get(end..)?.find(", expected ")?,
        None => text.find(", expected ")?,
    };
    Some((&text[..at], &text[at + ", expected ".len()..]))
}

fn unexpected_in_words(unexpected: &str) -> String {
    let ticked = |prefix: &str| {
        unexpected
            .strip_prefix(prefix)
            .and_then(|v| v.strip_prefix('`'))
            .and_then(|v| v.strip_suffix('`'))
            .map(str::to_owned)
    };
    if let Some(inner) = unexpected
        .strip_prefix("string \"")
        .and_then(|s| s.strip_suffix('"'))
    {
        let text = serde_json::from_str::<String>(&format!("\"{inner}\""))
            .unwrap_or_else(|_| inner.to_owned());
        // The facade hands JS's non-finite numbers in as these texts (JSON has no word for them).
        if matches!(text.as_str(), "NaN" | "Infinity" | "-Infinity") {
            return text;
        }
        return format!("'{}'", quote(text));
    }
    for prefix in ["integer ", "floating point ", "boolean ", "character "] {
        if let Some(value) = ticked(prefix) {
            return quote(value);
        }
    }
    match unexpected {
        "null" | "unit value" => "null".into(),
        "sequence" => "a list".into(),
        "map" => "an object".into(),
        other => quote(other),
    }
}

fn expected_in_words(expected: &str, range: bool) -> String {
    let whole = |min: &str, max: &str| {
        if range {
            format!("a whole number from {min} to {max}")
        } else if min == "0" {
            "a whole number from 0 up, like 5".into()
        } else {
            "a whole number, like 5".into()
        }
    };
    match expected {
        "i8" => whole("-128", "127"),
        "i16" => whole("-32768", "32767"),
        "i32" => whole("-2147483648", "2147483647"),
        "i64" | "i128" | "isize" => whole("-9223372036854775808", "9223372036854775807"),
        "u8" => whole("0", "255"),
        "u16" => whole("0", "65535"),
        "u32" => whole("0", "4294967295"),
        "u64" | "u128" | "usize" => whole("0", "18446744073709551615"),
        "f32" | "f64" => "a number, like 2.5".into(),
        "a boolean" => "true or false".into(),
        "a string" => "text in quotes".into(),
        "a character" => "one character in quotes".into(),
        "a sequence" => "a list in brackets, [...]".into(),
        "a map" => "an object in braces, {...}".into(),
        "unit" => "null".into(),
        other if other.starts_with("struct ") => "an object in braces, {...}".into(),
        other => other.to_owned(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn words(message: &str, field: &str) -> String {
        wrong_value(message)
            .unwrap_or_else(|| panic!("{message}"))
            .message(Some(field))
    }

    #[test]
    fn every_kind_of_wrong_value_is_worded() {
        for (serde, field, expected) in [
            (
                "invalid type: string \"high\", expected i32",
                "priority",
                "priority must be a whole number, like 5; got 'high'",
            ),
            (
                "invalid value: integer `5000000000`, expected i32",
                "priority",
                "priority must be a whole number from -2147483648 to 2147483647; got 5000000000",
            ),
            (
                "invalid value: integer `-1`, expected u32",
                "io",
                "io must be a whole number from 0 to 4294967295; got -1",
            ),
            (
                "invalid type: floating point `1.5`, expected u32",
                "io",
                "io must be a whole number from 0 up, like 5; got 1.5",
            ),
            (
                "invalid type: string \"NaN\", expected f64",
                "fallback",
                "fallback must be a number, like 2.5; got NaN",
            ),
            (
                "invalid type: integer `1`, expected a boolean",
                "retain",
                "retain must be true or false; got 1",
            ),
            (
                "invalid type: boolean `true`, expected a string",
                "id",
                "id must be text in quotes; got true",
            ),
            (
                "invalid type: null, expected a string",
                "wait",
                "wait must be text in quotes; got null",
            ),
            (
                "invalid type: map, expected a sequence",
                "steps",
                "steps must be a list in brackets, [...]; got an object",
            ),
            (
                "invalid type: sequence, expected struct Device",
                "[0]",
                "[0] must be an object in braces, {...}; got a list",
            ),
            (
                "invalid type: string \"20 s\", expected a non-negative number of milliseconds",
                "timeoutMs",
                "timeoutMs must be a non-negative number of milliseconds; got '20 s'",
            ),
            (
                "invalid type: string \"a, expected \\\"b\\\"\", expected u32",
                "io",
                "io must be a whole number from 0 up, like 5; got 'a, expected \"b\"'",
            ),
            (
                "unknown variant `zigbee`, expected one of `sugarshack`, `esphome`",
                "profile",
                "profile must be one of 'sugarshack', 'esphome'; got 'zigbee'",
            ),
            (
                "unknown variant `x`, expected `only`",
                "kind",
                "kind must be 'only'; got 'x'",
            ),
            (
                "unknown variant `x`, expected `a` or `b`",
                "kind",
                "kind must be one of 'a', 'b'; got 'x'",
            ),
        ] {
            assert_eq!(words(serde, field), expected);
        }
        assert_eq!(wrong_value("missing field `timeoutMs`"), None);
        assert_eq!(
            wrong_value("unknown field `valvs`, expected `name` or `valves`"),
            None
        );
        assert_eq!(wrong_value("a step needs either 'command' or 'wait'"), None);
    }
}
