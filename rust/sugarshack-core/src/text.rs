//! Text built from input for messages. A message that repeats what it was
//! given repeats only the start of it: a refused megabyte payload must not
//! come back as a megabyte of log line.

use std::fmt::{self, Display, Write};

/// How many characters of a value a message quotes.
pub const QUOTE_CHARS: usize = 100;

const ELLIPSIS: char = '…';

/// A duration in ms, worded in seconds as the node settings are: 4000 -> "4 s", 300 -> "0.3 s".
pub fn seconds(ms: f64) -> String {
    if ms.is_finite() {
        format!("{} s", ms / 1000.0)
    } else {
        quote(ms)
    }
}

/// `value` as text, cut to [`QUOTE_CHARS`] characters with an ellipsis.
/// Quoting a quote changes nothing.
///
/// ```
/// use sugarshack_core::text::quote;
/// assert_eq!(quote("V12"), "V12");
/// let long = quote("x".repeat(1_000_000));
/// assert_eq!(long.chars().count(), 100);
/// assert!(long.ends_with('…'));
/// ```
pub fn quote(value: impl Display) -> String {
    let mut out = Clipped {
        text: String::new(),
        chars: 0,
    };
    // The writer stops the formatting with an error once it has seen enough.
    if write!(out, "{value}").is_err() {
        let keep: String = out.text.chars().take(QUOTE_CHARS - 1).collect();
        return keep + &ELLIPSIS.to_string();
    }
    out.text
}

struct Clipped {
    text: String,
    chars: usize,
}

impl Write for Clipped {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        for c in s.chars() {
            if self.chars == QUOTE_CHARS {
                return Err(fmt::Error);
            }
            self.text.push(c);
            self.chars += 1;
        }
        Ok(())
    }
}

/// `text` cut to at most `max_chars` characters by dropping its middle, for a
/// message whose end matters as much as its start (what was expected).
///
/// ```
/// use sugarshack_core::text::abridge;
/// let text = format!("invalid type: string \"{}\", expected u64", "x".repeat(5000));
/// let short = abridge(&text, 120);
/// assert!(short.chars().count() <= 120);
/// assert!(short.starts_with("invalid type: string \"xx"));
/// assert!(short.ends_with("\", expected u64"));
/// ```
pub fn abridge(text: &str, max_chars: usize) -> String {
    let count = text.chars().count();
    if count <= max_chars {
        return text.to_owned();
    }
    let kept = max_chars.saturating_sub(1);
    let tail = kept / 3;
    let head = kept - tail;
    let mut out: String = text.chars().take(head).collect();
    out.push(ELLIPSIS);
    out.extend(text.chars().skip(count - tail));
    out
}

/// A number as JavaScript writes it (`String(n)`, `JSON.stringify`): no
/// trailing `.0`, an exponent below 1e-6 and from 1e21 (`1e+21`), `0` for
/// -0; `null` for what is no finite number, as in JSON.
pub fn js_number(n: f64) -> String {
    if !n.is_finite() {
        return "null".to_owned();
    }
    if n == 0.0 {
        return "0".to_owned();
    }
    let size = n.abs();
    if (1e-6..1e21).contains(&size) {
        return format!("{n}");
    }
    let exp = format!("{n:e}");
    match exp.split_once('e') {
        Some((digits, power)) if !power.starts_with('-') => format!("{digits}e+{power}"),
        _ => exp,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_written_as_javascript_writes_them() {
        for (n, js) in [
            (100.0, "100"),
            (12.5, "12.5"),
            (-0.0, "0"),
            (0.1 + 0.2, "0.30000000000000004"),
            (1e-6, "0.000001"),
            (1.5e-7, "1.5e-7"),
            (1e21, "1e+21"),
            (-2.5e22, "-2.5e+22"),
            (123456789012345680000.0, "123456789012345680000"),
            (f64::NAN, "null"),
            (f64::INFINITY, "null"),
        ] {
            assert_eq!(js_number(n), js, "{n}");
        }
    }

    #[test]
    fn short_values_are_quoted_whole() {
        assert_eq!(quote(""), "");
        assert_eq!(quote(12.5), "12.5");
        let exactly = "é".repeat(QUOTE_CHARS);
        assert_eq!(quote(&exactly), exactly);
    }

    #[test]
    fn long_values_are_cut_to_the_limit_on_a_character_boundary() {
        let one_over = "é".repeat(QUOTE_CHARS + 1);
        let quoted = quote(&one_over);
        assert_eq!(quoted.chars().count(), QUOTE_CHARS);
        assert!(quoted.starts_with("éé") && quoted.ends_with(ELLIPSIS));
        assert_eq!(quote(&quoted), quoted, "quoting twice cuts nothing more");
    }

    #[test]
    fn large_numbers_are_cut_too() {
        // f64 Display writes every digit: 1e300 is 301 characters.
        assert_eq!(quote(1e300).chars().count(), QUOTE_CHARS);
    }

    #[test]
    fn json_values_are_cut_while_written() {
        let big = serde_json::json!({ "valves": { "V12": "x".repeat(1_000_000) } });
        let quoted = quote(&big);
        assert!(quoted.starts_with("{\"valves\":{\"V12\":\"xxx"));
        assert_eq!(quoted.chars().count(), QUOTE_CHARS);
    }

    #[test]
    fn abridge_keeps_both_ends_within_the_limit() {
        assert_eq!(abridge("short", 10), "short");
        let text: String = ('a'..='z').collect();
        let short = abridge(&text, 10);
        assert_eq!(short.chars().count(), 10);
        assert_eq!(short, "abcdef…xyz");
    }
}
