//! A msg as a group command, by the rules the nodes applied in JS: whether a
//! msg on no device's topic carries one, whether it is a lockout (its topic
//! `lockout/<line>`, or `msg.lockout = true`), how much text its payload may
//! be, and which lines its msg holds (C2). What the command may do is the
//! plant's and the tracker's to say.

use std::fmt;

use serde::de::{IgnoredAny, MapAccess, Visitor};
use serde::Deserializer as _;

use crate::code::Code;
use crate::engine::{Param, Raw, Refusal, MAX_NAME, MAX_NAMES};

/// Topics of lockout group commands start so.
pub const LOCKOUT_PREFIX: &str = "lockout/";

/// Longer JSON text than any group command: refused before it is parsed.
pub const MAX_GROUP_TEXT: usize = 64 * 1024;

/// A payload on no device's topic is a group command if one of its first
/// this many keys is a group command's (an actuator type or its plural).
pub const KEYS_LOOKED_AT: usize = 100;

/// The topic of a line's lockout msg: a group command node reads `lockout/` as a lockout.
pub fn lockout_topic(line: &str) -> String {
    format!("{LOCKOUT_PREFIX}{line}")
}

/// A lockout: flagged with `msg.lockout = true`, or on a lockout topic (a
/// fault node's second output), whatever its line is called.
pub fn is_lockout(topic: Option<&str>, flag: &Raw) -> bool {
    *flag == Raw::Bool(true) || topic.is_some_and(is_lockout_topic)
}

/// A fault node's lockout topic (`lockout/<line>`), whatever the line is called.
pub fn is_lockout_topic(topic: &str) -> bool {
    topic.starts_with(LOCKOUT_PREFIX)
}

/// Whether a payload (JSON text) on a topic of no device is meant as a group
/// command: an object with a group command key among its first
/// [`KEYS_LOOKED_AT`], or text that opens as JSON and is not an object
/// without one (an array, broken JSON: so that a broken command is refused,
/// not ignored). Any other text is someone else's traffic.
pub fn command_like(text: &str, is_group_key: impl Fn(&str) -> bool) -> bool {
    let text = text.trim_start_matches(is_js_space);
    if text.starts_with('[') {
        return true;
    }
    if !text.starts_with('{') {
        return false;
    }
    let mut deserializer = serde_json::Deserializer::from_str(text);
    let keyed = deserializer.deserialize_map(GroupKeyed(&is_group_key));
    // Broken JSON (or nested past serde's limit): refused as a command.
    keyed
        .and_then(|keyed| deserializer.end().map(|()| keyed))
        .unwrap_or(true)
}

/// What JS's `trimStart` takes off: Unicode white space and the byte order mark.
fn is_js_space(c: char) -> bool {
    c.is_whitespace() || c == '\u{feff}'
}

/// Reads an object's keys (its values skipped unread) for a group command key.
struct GroupKeyed<'k, F>(&'k F);

impl<'de, F: Fn(&str) -> bool> Visitor<'de> for GroupKeyed<'_, F> {
    type Value = bool;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("an object")
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<bool, A::Error> {
        let mut keyed = false;
        let mut seen = 0;
        while let Some(key) = map.next_key::<KeyText>()? {
            if seen < KEYS_LOOKED_AT && !keyed {
                keyed = (self.0)(&key.0);
            }
            seen += 1;
            map.next_value::<IgnoredAny>()?;
        }
        Ok(keyed)
    }
}

/// A key, borrowed when it has no escapes.
struct KeyText(String);

impl<'de> serde::Deserialize<'de> for KeyText {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let key: std::borrow::Cow<'de, str> = serde::Deserialize::deserialize(deserializer)?;
        Ok(KeyText(key.into_owned()))
    }
}

/// The size of a payload given as text (in the UTF-16 units JS counts) or
/// as bytes (a Buffer): over [`MAX_GROUP_TEXT`], it is refused unread.
pub fn check_group_text(length: usize) -> Result<(), Refusal> {
    if length <= MAX_GROUP_TEXT {
        return Ok(());
    }
    Err(Refusal::catalog(
        Code::InputTooLarge,
        "errors.groupTooLarge",
        vec![
            ("length", Param::Text(length.to_string())),
            ("max", Param::Text(MAX_GROUP_TEXT.to_string())),
        ],
    ))
}

/// A payload given as text that JSON could not read, with the parser's words.
pub fn not_json(message: &str) -> Refusal {
    Refusal::catalog(
        Code::InvalidGroup,
        "errors.groupNotJson",
        vec![("message", Param::Text(clip(message, MESSAGE_CHARS)))],
    )
}

/// The parser's words are kept to this many characters.
const MESSAGE_CHARS: usize = 200;

/// msg.interlock as the host found it.
#[derive(Clone, Debug, PartialEq)]
pub enum Interlock {
    /// Not set: the msg came from no acquire node, and holds nothing to keep within.
    Unset,
    /// An object: its `resources`, as read.
    Holds(Raw),
    /// Anything else (or an object without `resources`), quoted for the refusal.
    Other(String),
}

/// The lines an acquire node granted the msg (msg.interlock.resources): a
/// group command it carries may only command actuators on them (C2). None
/// when the msg carries no msg.interlock; anything but a list of names there
/// is refused, never taken as "no restriction".
pub fn held_lines(interlock: &Interlock) -> Result<Option<Vec<String>>, Refusal> {
    let got = match interlock {
        Interlock::Unset => return Ok(None),
        Interlock::Holds(Raw::Names(names))
            if names.len() <= MAX_NAMES && names.iter().all(|n| js_len(n) <= MAX_NAME) =>
        {
            return Ok(Some(names.clone()))
        }
        Interlock::Holds(held) => held.quote(),
        Interlock::Other(quoted) => quoted.clone(),
    };
    Err(Refusal::catalog(
        Code::InvalidResources,
        "errors.heldNotListed",
        vec![("got", Param::Text(got))],
    ))
}

/// What a group command msg is, read off the msg before its command is issued.
#[derive(Clone, Debug, PartialEq)]
pub struct GroupMsg {
    /// A lockout: a standing order, issued even while a deploy drains, and
    /// not kept within the lines its msg holds.
    pub lockout: bool,
    /// The lines its command must keep within (C2), if its msg holds any.
    pub within: Option<Vec<String>>,
}

/// Reads a group command msg: its topic, msg.lockout and msg.interlock.
pub fn read_group_msg(
    topic: Option<&str>,
    flag: &Raw,
    interlock: &Interlock,
) -> Result<GroupMsg, Refusal> {
    let lockout = is_lockout(topic, flag);
    // A lockout isolates a faulted line whatever the msg holds.
    let within = if lockout {
        None
    } else {
        held_lines(interlock)?
    };
    Ok(GroupMsg { lockout, within })
}

/// The length JS gives a string (UTF-16 units): the bounds are the ones JS checked.
fn js_len(text: &str) -> usize {
    text.encode_utf16().count()
}

fn clip(text: &str, max: usize) -> String {
    match text.char_indices().nth(max) {
        Some((at, _)) => format!("{}…", &text[..at]),
        None => text.to_owned(),
    }
}

#[cfg(test)]
mod tests;
