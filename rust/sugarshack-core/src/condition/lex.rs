//! Tokens as JSONata's own tokenizer cuts them (`jsonata/src/parser.js`), so
//! that a text means here what it means to JSONata: a plain name runs to the
//! next space or operator character (`LT-1` is `LT`, `-`, `1`), a backticked
//! name to the next backtick, a number is `(0|[1-9][0-9]*)(.[0-9]+)?(e[+-]?[0-9]+)?`.

use std::ops::Range;

use super::{ConditionError, SUPPORTED};
use crate::text::quote;

/// What a token is.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Tok {
    Number(f64),
    /// A name, plain or in backticks (without them).
    Name(String),
    /// `$name`: a variable, or a function when called.
    Variable(String),
    Bool(bool),
    Null,
    /// Text in quotes: JSONata's string, which a condition has no use for.
    Text,
    /// An operator or a keyword operator (`and`, `or`, `in`).
    Op(&'static str),
}

#[derive(Clone, Debug, PartialEq)]
pub(super) struct Token {
    pub(super) tok: Tok,
    /// Byte offsets in the condition's text.
    pub(super) span: Range<usize>,
}

/// JSONata's operator characters: each ends a plain name.
const OPERATOR_CHARS: &str = ".[]{}(),@#;:?+-*/%|=<>^&!~";
const TWO_CHAR: [&str; 9] = ["..", ":=", "!=", ">=", "<=", "**", "~>", "?:", "??"];
const ONE_CHAR: [&str; 26] = [
    ".", "[", "]", "{", "}", "(", ")", ",", "@", "#", ";", ":", "?", "+", "-", "*", "/", "%", "|",
    "=", "<", ">", "^", "&", "!", "~",
];

fn is_space(c: char) -> bool {
    matches!(c, ' ' | '\t' | '\n' | '\r' | '\u{b}')
}

fn ends_name(c: char) -> bool {
    is_space(c) || OPERATOR_CHARS.contains(c)
}

/// Every token of `text`, or the first thing that cannot be one.
pub(super) fn tokens(text: &str) -> Result<Vec<Token>, ConditionError> {
    let mut out = Vec::new();
    let mut at = 0;
    while let Some(token) = next(text, &mut at)? {
        out.push(token);
    }
    Ok(out)
}

fn next(text: &str, at: &mut usize) -> Result<Option<Token>, ConditionError> {
    loop {
        let rest = &text[*at..];
        let trimmed = rest.trim_start_matches(is_space);
        *at += rest.len() - trimmed.len();
        if let Some(comment) = trimmed.strip_prefix("/*") {
            let Some(end) = comment.find("*/") else {
                return Err(ConditionError::new(
                    *at..text.len(),
                    "a comment '/*' is not closed with '*/'",
                ));
            };
            *at += 2 + end + 2;
            continue;
        }
        break;
    }
    let start = *at;
    let rest = &text[start..];
    let Some(first) = rest.chars().next() else {
        return Ok(None);
    };
    let token = |tok, len: usize| Token {
        tok,
        span: start..start + len,
    };
    if let Some(op) = TWO_CHAR.iter().find(|op| rest.starts_with(**op)) {
        *at += 2;
        return Ok(Some(token(Tok::Op(op), 2)));
    }
    if let Some(op) = ONE_CHAR.iter().find(|op| rest.starts_with(**op)) {
        *at += 1;
        return Ok(Some(token(Tok::Op(op), 1)));
    }
    if first == '"' || first == '\'' {
        let len = quoted_text_len(rest, first).ok_or_else(|| {
            ConditionError::new(
                start..text.len(),
                format!("text in quotes is not closed with {first}"),
            )
        })?;
        *at += len;
        return Ok(Some(token(Tok::Text, len)));
    }
    if let Some(len) = number_len(rest) {
        let value: f64 = rest[..len].parse().unwrap_or(f64::INFINITY);
        if !value.is_finite() {
            return Err(ConditionError::new(
                start..start + len,
                format!("the number {} is too large", quote(&rest[..len])),
            ));
        }
        *at += len;
        return Ok(Some(token(Tok::Number(value), len)));
    }
    if first == '`' {
        let Some(end) = rest[1..].find('`') else {
            return Err(ConditionError::new(
                start..text.len(),
                format!(
                    "the name {} has no closing backtick",
                    quote(rest.split(is_space).next().unwrap_or(rest))
                ),
            ));
        };
        *at += end + 2;
        return Ok(Some(token(Tok::Name(rest[1..=end].to_owned()), end + 2)));
    }
    let len = rest.find(ends_name).unwrap_or(rest.len());
    *at += len;
    let word = &rest[..len];
    let tok = if let Some(name) = word.strip_prefix('$') {
        Tok::Variable(name.to_owned())
    } else {
        match word {
            "and" => Tok::Op("and"),
            "or" => Tok::Op("or"),
            "in" => Tok::Op("in"),
            "true" => Tok::Bool(true),
            "false" => Tok::Bool(false),
            "null" => Tok::Null,
            _ => {
                dashed_name(text, start, len)?;
                Tok::Name(word.to_owned())
            }
        }
    };
    Ok(Some(token(tok, len)))
}

/// A plain name followed at once by `-` and more name: JSONata reads `LT-1`
/// as `LT` minus 1, never as the sensor `LT-1`.
fn dashed_name(text: &str, start: usize, len: usize) -> Result<(), ConditionError> {
    let after = &text[start + len..];
    let Some(tail) = after.strip_prefix('-') else {
        return Ok(());
    };
    if tail.chars().next().is_none_or(ends_name) {
        return Ok(());
    }
    // The whole id as the user meant it: name characters and dashes.
    let mut end = start + len;
    while let Some(c) = text[end..].chars().next() {
        if c == '-' || !ends_name(c) {
            end += c.len_utf8();
        } else {
            break;
        }
    }
    let id = &text[start..end];
    let (head, rest) = id.split_once('-').unwrap_or((id, ""));
    Err(ConditionError::new(
        start..end,
        format!(
            "'{}' reads as {} minus {}: write a sensor id that has a dash in backticks, `{}` (to subtract, put spaces around the minus)",
            quote(id),
            quote(head),
            quote(rest),
            quote(id)
        ),
    ))
}

/// The length of JSONata's number at the start of `s`, if one is there.
fn number_len(s: &str) -> Option<usize> {
    let b = s.as_bytes();
    let digits = |from: usize| b[from..].iter().take_while(|c| c.is_ascii_digit()).count();
    let mut len = match b.first()? {
        b'0' => 1,
        b'1'..=b'9' => digits(0),
        _ => return None,
    };
    if b.get(len) == Some(&b'.') && digits(len + 1) > 0 {
        len += 1 + digits(len + 1);
    }
    if matches!(b.get(len), Some(b'e' | b'E')) {
        let sign = usize::from(matches!(b.get(len + 1), Some(b'+' | b'-')));
        let exponent = digits(len + 1 + sign);
        if exponent > 0 {
            len += 1 + sign + exponent;
        }
    }
    Some(len)
}

/// The length of a quoted text at the start of `s` (JSON escapes), if it is closed.
fn quoted_text_len(s: &str, quote_char: char) -> Option<usize> {
    let mut escaped = false;
    for (i, c) in s.char_indices().skip(1) {
        match c {
            _ if escaped => escaped = false,
            '\\' => escaped = true,
            c if c == quote_char => return Some(i + 1),
            _ => {}
        }
    }
    None
}

/// The words a refusal of unsupported syntax ends with.
pub(super) fn unsupported(what: &str) -> String {
    format!("{what} is not supported in a condition; {SUPPORTED}")
}
