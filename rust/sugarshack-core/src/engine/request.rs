//! What a msg asks for, read by the rules the nodes used to apply in JS: the
//! operation id (msg.operation, else the node's, else msg.interlock.operation
//! for the nodes that follow an acquire), the priority (absent: 0), the
//! resources (a list or comma-separated text, trimmed), a fault's note and
//! who asks for a clear or an emergency stop (a signed-in dashboard user
//! outranks msg.by). Only shapes are read here; whether a request is allowed
//! is the interlock's to say.

use std::borrow::Cow;

use serde::{Deserialize, Serialize};

use super::output::{Param, Refusal};
use super::Fields;
use crate::code::Code;
use crate::text::js_number;
use crate::time::Millis;

/// A value as JS had it on a msg or in a node's configuration.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", content = "value", rename_all = "camelCase")]
pub enum Raw {
    /// `undefined` or `null`.
    #[default]
    Absent,
    /// A string.
    Text(String),
    /// A number (maybe not finite).
    Number(f64),
    /// `true` or `false`.
    Bool(bool),
    /// An array of strings.
    Names(Vec<String>),
    /// Anything else, as a short quote for a message (`[1,2]`, `{"a":1}`, `10n`).
    Other(String),
    /// Text longer than [`MAX_TEXT`]: the host hands its first [`HEAD`]
    /// characters and its length (UTF-16 units, as JS counts), no more.
    Long {
        /// Its first characters.
        head: String,
        /// Its whole length.
        length: usize,
    },
}

/// How much of a refused value a message quotes, in characters.
const QUOTE_MAX: usize = 100;
/// An operation id is a name a person gave; past this it is not one.
pub const MAX_OPERATION_NAME: usize = 200;
/// More names than any plant has lines, longer than any name a person gives: not a list of lines.
pub const MAX_NAMES: usize = 4096;
/// The longest resource name read.
pub const MAX_NAME: usize = 200;
/// The interlock keeps 500 characters of a note; no more than a little above that is read.
pub const MAX_NOTE: usize = 1000;
/// The core keeps 100 characters of a name; a little above that is read.
pub const MAX_BY: usize = 200;
/// The core keeps 500 characters of a reason; a little above that is read.
pub const MAX_REASON: usize = 1000;
/// The longest text a host hands whole: a list of lines as comma-separated
/// text, the longest any rule reads. Longer text crosses as [`Raw::Long`].
pub const MAX_TEXT: usize = MAX_NAMES * (MAX_NAME + 1);
/// How much of a longer text crosses: more than any rule keeps or quotes.
pub const HEAD: usize = MAX_NOTE;

impl Raw {
    /// Set: not absent, and not the empty string.
    pub fn present(&self) -> bool {
        // Matched, not compared with an empty text made (and dropped) per call: this runs several times a msg.
        match self {
            Raw::Absent => false,
            Raw::Text(text) => !text.is_empty(),
            _ => true,
        }
    }

    /// The value as a short quote: JSON for text and numbers, cut to 100 characters.
    pub fn quote(&self) -> String {
        let text = match self {
            Raw::Absent => "null".to_owned(),
            Raw::Text(text) => serde_json::to_string(text).unwrap_or_default(),
            Raw::Number(n) if n.is_finite() => js_number(*n),
            Raw::Number(_) => "null".to_owned(),
            Raw::Bool(b) => b.to_string(),
            Raw::Names(names) => serde_json::to_string(names).unwrap_or_default(),
            Raw::Other(quoted) => quoted.clone(),
            Raw::Long { head, .. } => serde_json::to_string(head).unwrap_or_default(),
        };
        clip(&text, QUOTE_MAX)
    }

    /// The text, or as much of it as crossed.
    fn text(&self) -> Option<&str> {
        match self {
            Raw::Text(text) | Raw::Long { head: text, .. } => Some(text),
            _ => None,
        }
    }

    /// The length JS gives the text.
    fn text_len(&self) -> Option<usize> {
        match self {
            Raw::Text(text) => Some(js_len(text)),
            Raw::Long { length, .. } => Some(*length),
            _ => None,
        }
    }
}

/// The length JS gives a string (UTF-16 units): the bounds are the ones JS checked.
fn js_len(text: &str) -> usize {
    // ASCII (most names) is one unit a byte: no pass over its characters.
    if text.is_ascii() {
        text.len()
    } else {
        text.encode_utf16().count()
    }
}

/// `text` cut to `max` characters, the last an ellipsis when cut.
fn clip(text: &str, max: usize) -> String {
    if text.chars().nth(max).is_none() {
        return text.to_owned();
    }
    let mut kept: String = text.chars().take(max - 1).collect();
    kept.push('…');
    kept
}

/// The first `max` characters of `text`.
fn keep(text: &str, max: usize) -> String {
    text.chars().take(max).collect()
}

/// Where a value came from, as a refusal names it.
#[derive(Clone, Copy, Debug)]
enum From {
    /// A msg property, by its path.
    Msg(&'static str),
    /// The node's configuration, by the catalog label that names it.
    Configured(&'static str),
}

impl From {
    fn param(self) -> Param {
        match self {
            From::Msg(path) => Param::Text(path.to_owned()),
            From::Configured(label) => Param::Label(label),
        }
    }
}

fn as_operation_name(value: &Raw, from: From) -> Result<Cow<'_, str>, Refusal> {
    if let Some(length) = value.text_len().filter(|l| *l > MAX_OPERATION_NAME) {
        return Err(Refusal::catalog(
            Code::InvalidOperation,
            "errors.operationTooLong",
            vec![
                ("from", from.param()),
                ("length", Param::Text(length.to_string())),
                ("max", Param::Text(MAX_OPERATION_NAME.to_string())),
            ],
        ));
    }
    match value {
        Raw::Number(n) if n.is_finite() => Ok(Cow::Owned(js_number(*n))),
        Raw::Text(text) => Ok(Cow::Borrowed(trimmed(text))),
        other => Err(Refusal::catalog(
            Code::InvalidOperation,
            "errors.operationNotName",
            vec![("from", from.param()), ("got", Param::Text(other.quote()))],
        )),
    }
}

/// `text.trim()`, with no pass over its characters when it starts and ends
/// with an ASCII character that is no space (most names).
pub(super) fn trimmed(text: &str) -> &str {
    let bare = |b: Option<&u8>| b.is_some_and(|b| b.is_ascii() && !char::from(*b).is_whitespace());
    let bytes = text.as_bytes();
    if bare(bytes.first()) && bare(bytes.last()) {
        text
    } else {
        text.trim()
    }
}

/// The operation id: msg.operation, else the configured one, else (for the
/// nodes that follow an acquire) msg.interlock.operation. An id that is
/// empty once trimmed names no operation.
pub fn operation_of(msg: &Raw, configured: &Raw, follow: &Raw) -> Result<String, Refusal> {
    operation_name_of(msg, configured, follow).map(Cow::into_owned)
}

/// [`operation_of`], borrowed from the fields where it can be (the per-msg
/// paths spare a copy of the name).
pub fn operation_name_of<'a>(
    msg: &'a Raw,
    configured: &'a Raw,
    follow: &'a Raw,
) -> Result<Cow<'a, str>, Refusal> {
    let name = if msg.present() {
        as_operation_name(msg, From::Msg("msg.operation"))?
    } else if configured.present() {
        as_operation_name(configured, From::Configured("configuredOperation"))?
    } else if follow.present() {
        as_operation_name(follow, From::Msg("msg.interlock.operation"))?
    } else {
        return Err(Refusal::catalog(
            Code::MissingOperation,
            "errors.operationMissing",
            Vec::new(),
        ));
    };
    if name.is_empty() {
        return Err(Refusal::catalog(
            Code::MissingOperation,
            "errors.operationRequired",
            Vec::new(),
        ));
    }
    Ok(name)
}

/// The priority: msg.priority, else the configured one, else 0. An integer
/// in the 32-bit range, or text that is one (higher goes first).
pub fn priority_of(msg: &Raw, configured: &Raw) -> Result<i32, Refusal> {
    let (value, from) = if msg.present() {
        (msg, From::Msg("msg.priority"))
    } else {
        (configured, From::Configured("configuredPriority"))
    };
    if !value.present() {
        return Ok(0);
    }
    let number = match value {
        Raw::Number(n) => Some(*n),
        Raw::Text(text) => integer_text(text),
        _ => None,
    };
    number
        .filter(|n| n.fract() == 0.0 && *n >= f64::from(i32::MIN) && *n <= f64::from(i32::MAX))
        .map(|n| n as i32)
        .ok_or_else(|| {
            Refusal::catalog(
                Code::InvalidPriority,
                "errors.priorityNotInteger",
                vec![("from", from.param()), ("got", Param::Text(value.quote()))],
            )
        })
}

/// Text that is a whole number, spaces around it allowed (`" -12 "`).
fn integer_text(text: &str) -> Option<f64> {
    let digits = text.trim();
    let unsigned = digits.strip_prefix(['+', '-']).unwrap_or(digits);
    if unsigned.is_empty() || !unsigned.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    digits.parse::<f64>().ok()
}

/// Names from a list or comma-separated text, trimmed, the empty ones left
/// out; `from` names where they came from when they are not names.
pub fn names_of(value: &Raw, from: Param) -> Result<Vec<String>, Refusal> {
    let names: Option<Vec<&str>> = match value {
        Raw::Text(text) if js_len(text) <= MAX_NAMES * (MAX_NAME + 1) => {
            Some(text.split(',').collect())
        }
        Raw::Names(list) if list.len() <= MAX_NAMES => {
            Some(list.iter().map(String::as_str).collect())
        }
        _ => None,
    };
    match names {
        Some(names) if names.len() <= MAX_NAMES && names.iter().all(|n| js_len(n) <= MAX_NAME) => {
            Ok(names
                .iter()
                .map(|n| n.trim())
                .filter(|n| !n.is_empty())
                .map(str::to_owned)
                .collect())
        }
        _ => Err(Refusal::catalog(
            Code::InvalidResources,
            "errors.notNames",
            vec![
                ("from", from),
                ("names", Param::Text(MAX_NAMES.to_string())),
                ("length", Param::Text(MAX_NAME.to_string())),
                ("got", Param::Text(value.quote())),
            ],
        )),
    }
}

/// Resource names from msg.resources, else the configured list (maybe empty).
pub fn resources_of(msg: &Raw, configured: &Raw) -> Result<Vec<String>, Refusal> {
    if msg.present() {
        names_of(msg, From::Msg("msg.resources").param())
    } else if configured.present() {
        names_of(configured, From::Configured("configuredResources").param())
    } else {
        Ok(Vec::new())
    }
}

/// A fault's note: a Catch node's msg.error.message, else a text payload. A
/// message that is not text never stops a fault (isolating the line comes
/// first): the note says what it was.
pub fn note_of(error_message: &Raw, payload: &Raw) -> Option<String> {
    if error_message.present() && error_message.text().is_none() {
        return Some(format!(
            "(a note that is not text: {})",
            error_message.quote()
        ));
    }
    let text = error_message
        .text()
        .filter(|t| !t.is_empty())
        .or_else(|| payload.text().filter(|t| !t.is_empty()))?;
    Some(keep(text, MAX_NOTE))
}

/// A signed-in dashboard user (msg._client.user), as read off the msg.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", default)]
pub struct SignedIn {
    /// Its username.
    pub username: Raw,
    /// Its name.
    pub name: Raw,
    /// Its email.
    pub email: Raw,
    /// Its userId.
    pub user_id: Raw,
}

impl SignedIn {
    /// No one signed in.
    pub const NONE: SignedIn = SignedIn {
        username: Raw::Absent,
        name: Raw::Absent,
        email: Raw::Absent,
        user_id: Raw::Absent,
    };

    /// A user known by its username.
    pub fn username(name: &str) -> Self {
        SignedIn {
            username: Raw::Text(name.to_owned()),
            ..SignedIn::default()
        }
    }

    /// What names the user: its username, else its name, email or userId (the first that is text).
    fn names(&self) -> [&Raw; 4] {
        [&self.username, &self.name, &self.email, &self.user_id]
    }
}

/// Who asks, as read off a msg.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", default)]
pub struct WhoFields {
    /// The signed-in dashboard user (msg._client.user).
    pub user: SignedIn,
    /// msg.by.
    pub by: Raw,
    /// msg.reason.
    pub reason: Raw,
    /// msg.force === true.
    pub force: bool,
}

/// Who asks for a clear, an emergency stop or an alarm action, and why.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Who {
    /// The person, if known.
    pub by: Option<String>,
    /// Why, if said.
    pub reason: Option<String>,
    /// A clear that overrides the plant's reasons.
    pub force: bool,
}

/// The signed-in dashboard user (its username, name, email or userId),
/// else msg.by (so a page cannot record a clear under another name);
/// msg.reason; msg.force.
pub fn attribution_of(fields: &WhoFields) -> Result<Who, Refusal> {
    let by = fields
        .user
        .names()
        .into_iter()
        .chain([&fields.by])
        .find_map(|v| v.text().filter(|t| !t.trim().is_empty()));
    if fields.by.present() && fields.by.text().is_none() {
        return Err(Refusal::catalog(
            Code::InvalidInput,
            "errors.byNotName",
            vec![("got", Param::Text(fields.by.quote()))],
        ));
    }
    if fields.reason.present() && fields.reason.text().is_none() {
        return Err(Refusal::catalog(
            Code::InvalidInput,
            "errors.reasonNotText",
            vec![("got", Param::Text(fields.reason.quote()))],
        ));
    }
    Ok(Who {
        by: by.map(|b| keep(b, MAX_BY)),
        reason: fields
            .reason
            .text()
            .filter(|r| !r.is_empty())
            .map(|r| keep(r, MAX_REASON)),
        force: fields.force,
    })
}

/// What a node reads off a msg, for a host that runs no engine for it (an
/// interlock bound to a plant, an operation or routine node).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "camelCase")]
pub enum Asks {
    /// An acquire: operation, priority and resources.
    Acquire,
    /// A release, cancel or fault of an operation: the operation, else the acquire the msg follows.
    Named,
    /// An emergency stop: lines and who asks.
    Stop,
    /// A clear: who asks, and the lines (none: every faulted line, when the
    /// node clears all and the msg names none).
    #[serde(rename_all = "camelCase")]
    Clear {
        /// The node clears every faulted line unless the msg names some.
        all_faulted: bool,
        /// msg.resources is set (even to null).
        names_given: bool,
    },
    /// Who asks (an operator's command, an alarm action).
    Who,
}

/// What the node's configuration says, where the msg says nothing.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", default)]
pub struct Configured {
    /// Its operation id.
    pub operation: Raw,
    /// Its priority.
    pub priority: Raw,
    /// Its resources.
    pub resources: Raw,
}

/// What a msg asks for, as the rules above read it.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Asked {
    /// The operation id, trimmed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub operation: Option<String>,
    /// The priority (absent: 0).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub priority: Option<i32>,
    /// The lines, trimmed (a clear's none: every faulted line).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub resources: Option<Vec<String>>,
    /// Who asks.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub who: Option<Who>,
}

/// Reads what `asks` needs of a msg's `fields`, the node's `configured`
/// values where the msg gives none; the first refusal stops it.
pub fn read_request(
    asks: Asks,
    fields: &Fields,
    configured: &Configured,
) -> Result<Asked, Refusal> {
    let Fields {
        operation,
        priority,
        resources,
        follow,
        who,
        ..
    } = fields;
    let mut asked = Asked::default();
    match asks {
        Asks::Acquire => {
            asked.operation = Some(operation_of(
                operation,
                &configured.operation,
                &Raw::Absent,
            )?);
            asked.priority = Some(priority_of(priority, &configured.priority)?);
            asked.resources = Some(resources_of(resources, &configured.resources)?);
        }
        Asks::Named => {
            asked.operation = Some(operation_of(operation, &configured.operation, follow)?);
        }
        Asks::Stop => {
            asked.who = Some(attribution_of(who)?);
            asked.resources = Some(resources_of(resources, &configured.resources)?);
        }
        Asks::Clear {
            all_faulted,
            names_given,
        } => {
            if !all_faulted || names_given {
                asked.resources = Some(resources_of(resources, &configured.resources)?);
            }
            asked.who = Some(attribution_of(who)?);
        }
        Asks::Who => asked.who = Some(attribution_of(who)?),
    }
    Ok(asked)
}

/// The longest alarm id read (`kind:subject`).
pub const MAX_ALARM_ID: usize = 300;
/// The most alarm ids one acknowledgement names.
pub const MAX_ALARM_IDS: usize = 20_000;

/// An alarm's id, as the state lists it (`kind:subject`).
pub fn alarm_id_of(id: &Raw) -> Result<String, Refusal> {
    match id {
        Raw::Text(text) if !text.is_empty() && js_len(text) <= MAX_ALARM_ID => Ok(text.clone()),
        other => Err(Refusal::catalog(
            Code::InvalidInput,
            "errors.alarmIdInvalid",
            vec![("got", Param::Text(keep(&other.quote(), QUOTE_MAX)))],
        )),
    }
}

/// Alarm ids to acknowledge; none: every unacknowledged alarm.
pub fn alarm_ids_of(ids: &Raw) -> Result<Option<Vec<String>>, Refusal> {
    match ids {
        Raw::Absent => Ok(None),
        Raw::Names(list) if list.len() <= MAX_ALARM_IDS => list
            .iter()
            .map(|id| alarm_id_of(&Raw::Text(id.clone())))
            .collect::<Result<Vec<_>, _>>()
            .map(Some),
        _ => Err(Refusal::catalog(
            Code::InvalidInput,
            "errors.alarmIdsInvalid",
            vec![("max", Param::Text(MAX_ALARM_IDS.to_string()))],
        )),
    }
}

/// Until when a shelf lasts: `until_ms` (epoch ms), else `for_ms` (> 0) from now.
pub fn shelf_end_of(until_ms: &Raw, for_ms: &Raw, now: Millis) -> Result<Millis, Refusal> {
    match (until_ms, for_ms) {
        (Raw::Number(until), _) if until.is_finite() => {
            Ok(Millis::new(*until).unwrap_or(Millis::ZERO))
        }
        (_, Raw::Number(span)) if span.is_finite() && *span > 0.0 => Millis::new(*span)
            .map(|span| now.saturating_add(span))
            .ok_or_else(shelf_unbounded),
        _ => Err(shelf_unbounded()),
    }
}

fn shelf_unbounded() -> Refusal {
    Refusal::catalog(Code::InvalidShelf, "errors.shelfUnbounded", Vec::new())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn text(s: &str) -> Raw {
        Raw::Text(s.to_owned())
    }

    fn refusal_key(r: Result<impl std::fmt::Debug, Refusal>) -> (Code, &'static str) {
        let refusal = r.expect_err("refused");
        (refusal.code, refusal.key().expect("a catalog text"))
    }

    #[test]
    fn an_operation_name_is_trimmed_of_any_space_ascii_or_not() {
        for (given, name) in [
            ("a", "a"),
            ("load truck", "load truck"),
            ("\u{b}a\u{c}", "a"),
            ("\u{a0}a", "a"),
            ("a\u{3000}", "a"),
            ("éa é", "éa é"),
            ("\t", ""),
        ] {
            assert_eq!(
                operation_of(&text(given), &Raw::Absent, &Raw::Absent)
                    .ok()
                    .as_deref(),
                (!name.is_empty()).then_some(name),
                "{given:?}"
            );
        }
    }

    #[test]
    fn the_operation_comes_from_the_msg_then_the_node_then_the_acquire_it_follows() {
        let none = Raw::Absent;
        assert_eq!(
            operation_of(&text(" 12 "), &text("10"), &text("9")).unwrap(),
            "12"
        );
        assert_eq!(
            operation_of(&text(""), &text("10"), &text("9")).unwrap(),
            "10"
        );
        assert_eq!(operation_of(&none, &none, &text("9")).unwrap(), "9");
        assert_eq!(
            operation_of(&Raw::Number(12.0), &none, &none).unwrap(),
            "12"
        );
        assert_eq!(
            operation_of(&Raw::Number(1.5), &none, &none).unwrap(),
            "1.5"
        );
        assert_eq!(
            refusal_key(operation_of(&none, &none, &none)),
            (Code::MissingOperation, "errors.operationMissing")
        );
        assert_eq!(
            refusal_key(operation_of(&text("   "), &none, &none)),
            (Code::MissingOperation, "errors.operationRequired")
        );
        assert_eq!(
            refusal_key(operation_of(&text(&"x".repeat(201)), &none, &none)),
            (Code::InvalidOperation, "errors.operationTooLong")
        );
        assert_eq!(
            refusal_key(operation_of(&Raw::Bool(true), &none, &none)),
            (Code::InvalidOperation, "errors.operationNotName")
        );
        assert_eq!(
            refusal_key(operation_of(&Raw::Number(f64::NAN), &none, &none)),
            (Code::InvalidOperation, "errors.operationNotName")
        );
    }

    #[test]
    fn priorities_default_to_zero_and_read_integer_text() {
        let none = Raw::Absent;
        assert_eq!(priority_of(&none, &none).unwrap(), 0);
        assert_eq!(priority_of(&none, &text("")).unwrap(), 0);
        assert_eq!(priority_of(&none, &text(" -12 ")).unwrap(), -12);
        assert_eq!(priority_of(&text("+7"), &text("1")).unwrap(), 7);
        assert_eq!(priority_of(&Raw::Number(20.0), &none).unwrap(), 20);
        for bad in [
            text("urgent"),
            text("1.5"),
            Raw::Number(1.5),
            Raw::Number(2_147_483_648.0),
            Raw::Bool(true),
            text("+"),
        ] {
            let refusal = priority_of(&bad, &none).expect_err("refused");
            assert_eq!(refusal.code, Code::InvalidPriority, "{bad:?}");
        }
        let refusal = priority_of(&none, &text("urgent")).unwrap_err();
        assert_eq!(
            refusal.params(),
            vec![
                ("from", Param::Label("configuredPriority")),
                ("got", Param::Text("\"urgent\"".into()))
            ]
        );
    }

    #[test]
    fn resources_are_split_trimmed_and_bounded() {
        let none = Raw::Absent;
        assert_eq!(
            resources_of(&text(" YEL , RED,"), &none).unwrap(),
            ["YEL", "RED"]
        );
        assert_eq!(resources_of(&none, &text("GRN")).unwrap(), ["GRN"]);
        assert_eq!(resources_of(&none, &none).unwrap(), Vec::<String>::new());
        assert_eq!(
            resources_of(&Raw::Names(vec!["A".into(), " B".into()]), &none).unwrap(),
            ["A", "B"]
        );
        for bad in [
            Raw::Number(1.0),
            Raw::Names(vec!["x".repeat(201)]),
            Raw::Names(vec!["a".into(); 4097]),
            Raw::Other("[1]".into()),
        ] {
            assert_eq!(
                refusal_key(resources_of(&bad, &none)),
                (Code::InvalidResources, "errors.notNames")
            );
        }
    }

    #[test]
    fn a_note_is_the_error_message_else_a_text_payload() {
        assert_eq!(note_of(&text("dry"), &text("p")).as_deref(), Some("dry"));
        assert_eq!(note_of(&Raw::Absent, &text("p")).as_deref(), Some("p"));
        assert_eq!(note_of(&Raw::Absent, &Raw::Number(1.0)), None);
        assert_eq!(
            note_of(&Raw::Number(3.0), &Raw::Absent).as_deref(),
            Some("(a note that is not text: 3)")
        );
        assert_eq!(
            note_of(&text(&"n".repeat(2000)), &Raw::Absent)
                .unwrap()
                .len(),
            1000
        );
    }

    #[test]
    fn alarm_requests_name_ids_and_bounded_shelves() {
        let now = Millis::new(1000.0).unwrap();
        assert_eq!(
            alarm_id_of(&text("line-faulted:YEL")).unwrap(),
            "line-faulted:YEL"
        );
        assert_eq!(
            refusal_key(alarm_id_of(&text(""))),
            (Code::InvalidInput, "errors.alarmIdInvalid")
        );
        assert_eq!(alarm_ids_of(&Raw::Absent).unwrap(), None);
        assert_eq!(
            refusal_key(alarm_ids_of(&text("a"))),
            (Code::InvalidInput, "errors.alarmIdsInvalid")
        );
        assert_eq!(
            shelf_end_of(&Raw::Number(5000.0), &Raw::Absent, now).unwrap(),
            Millis::new(5000.0).unwrap()
        );
        assert_eq!(
            shelf_end_of(&Raw::Absent, &Raw::Number(60.0), now).unwrap(),
            Millis::new(1060.0).unwrap()
        );
        assert_eq!(
            refusal_key(shelf_end_of(&Raw::Absent, &Raw::Number(0.0), now)),
            (Code::InvalidShelf, "errors.shelfUnbounded")
        );
    }

    #[test]
    fn a_signed_in_user_outranks_msg_by() {
        let who = attribution_of(&WhoFields {
            user: SignedIn::username("ann"),
            by: text("bob"),
            reason: text("leak"),
            force: true,
        })
        .unwrap();
        assert_eq!(who.by.as_deref(), Some("ann"));
        assert_eq!(who.reason.as_deref(), Some("leak"));
        assert!(who.force);
        let who = attribution_of(&WhoFields {
            user: SignedIn::username("  "),
            by: text("bob"),
            ..WhoFields::default()
        })
        .unwrap();
        assert_eq!(who.by.as_deref(), Some("bob"));
        assert_eq!(
            attribution_of(&WhoFields::default()).unwrap(),
            Who::default()
        );
        assert_eq!(
            refusal_key(attribution_of(&WhoFields {
                by: Raw::Number(1.0),
                ..WhoFields::default()
            })),
            (Code::InvalidInput, "errors.byNotName")
        );
        assert_eq!(
            refusal_key(attribution_of(&WhoFields {
                reason: Raw::Bool(false),
                ..WhoFields::default()
            })),
            (Code::InvalidInput, "errors.reasonNotText")
        );
    }

    #[test]
    fn a_signed_in_user_is_named_by_username_then_name_email_or_user_id() {
        let by = |user: SignedIn| {
            attribution_of(&WhoFields {
                user,
                by: text("bob"),
                ..WhoFields::default()
            })
            .unwrap()
            .by
        };
        let user = SignedIn {
            username: Raw::Number(7.0),
            name: text(" "),
            email: text("ann@shack"),
            user_id: text("u1"),
        };
        assert_eq!(by(user).as_deref(), Some("ann@shack"));
        let user = SignedIn {
            user_id: text("u1"),
            ..SignedIn::default()
        };
        assert_eq!(by(user).as_deref(), Some("u1"));
        // No name that is text: msg.by.
        let user = SignedIn {
            username: Raw::Bool(true),
            ..SignedIn::default()
        };
        assert_eq!(by(user).as_deref(), Some("bob"));
        // Names and reasons are kept to their bounds, even past what crosses whole.
        let who = attribution_of(&WhoFields {
            by: Raw::Long {
                head: "b".repeat(HEAD),
                length: MAX_TEXT + 5,
            },
            reason: text(&"r".repeat(1500)),
            ..WhoFields::default()
        })
        .unwrap();
        assert_eq!(who.by.map(|b| b.len()), Some(MAX_BY));
        assert_eq!(who.reason.map(|r| r.len()), Some(MAX_REASON));
    }

    #[test]
    fn text_too_long_to_cross_is_refused_with_its_whole_length() {
        let long = Raw::Long {
            head: "o".repeat(HEAD),
            length: 1_000_000,
        };
        let refusal = operation_of(&long, &Raw::Absent, &Raw::Absent).unwrap_err();
        assert_eq!(refusal.key(), Some("errors.operationTooLong"));
        assert_eq!(
            refusal.params()[1],
            ("length", Param::Text("1000000".into()))
        );
        assert_eq!(long.quote().chars().count(), QUOTE_MAX);
        assert_eq!(
            refusal_key(priority_of(&long, &Raw::Absent)),
            (Code::InvalidPriority, "errors.priorityNotInteger")
        );
        assert_eq!(
            refusal_key(resources_of(&long, &Raw::Absent)),
            (Code::InvalidResources, "errors.notNames")
        );
    }

    #[test]
    fn names_name_where_they_came_from() {
        assert_eq!(
            names_of(&text(" a ,b"), Param::Text("sensors".into())).unwrap(),
            ["a", "b"]
        );
        let refusal = names_of(&Raw::Number(1.0), Param::Text("sensors".into())).unwrap_err();
        assert_eq!(refusal.params()[0], ("from", Param::Text("sensors".into())));
    }

    fn fields(operation: Raw, priority: Raw, resources: Raw) -> Fields {
        Fields {
            operation,
            priority,
            resources,
            ..Fields::default()
        }
    }

    #[test]
    fn a_request_is_read_as_its_node_asks() {
        let configured = Configured {
            operation: text(" 10 "),
            priority: text("5"),
            resources: text("YEL, RED"),
        };
        // An acquire: the node's values trimmed where the msg has none, the msg's first.
        let asked = read_request(Asks::Acquire, &Fields::default(), &configured).unwrap();
        assert_eq!(asked.operation.as_deref(), Some("10"));
        assert_eq!(asked.priority, Some(5));
        assert_eq!(asked.resources, Some(vec!["YEL".into(), "RED".into()]));
        let msg = fields(text("12"), Raw::Number(-3.0), text("GRN"));
        let asked = read_request(Asks::Acquire, &msg, &Configured::default()).unwrap();
        assert_eq!(
            (asked.operation.as_deref(), asked.priority),
            (Some("12"), Some(-3))
        );
        // No priority anywhere: 0.
        let asked = read_request(Asks::Acquire, &msg_op("1"), &Configured::default()).unwrap();
        assert_eq!(asked.priority, Some(0));
        // A release follows the acquire; an acquire never does.
        let follow = Fields {
            follow: text(" 9 "),
            ..Fields::default()
        };
        let asked = read_request(Asks::Named, &follow, &Configured::default()).unwrap();
        assert_eq!(asked.operation.as_deref(), Some("9"));
        assert_eq!(
            refusal_key(read_request(Asks::Acquire, &follow, &Configured::default())),
            (Code::MissingOperation, "errors.operationMissing")
        );
        // A clear of every faulted line names none unless the msg does.
        let clear = |names_given| Asks::Clear {
            all_faulted: true,
            names_given,
        };
        let asked = read_request(clear(false), &Fields::default(), &configured).unwrap();
        assert_eq!(asked.resources, None);
        assert_eq!(asked.who, Some(Who::default()));
        let asked = read_request(clear(true), &Fields::default(), &configured).unwrap();
        assert_eq!(asked.resources, Some(vec!["YEL".into(), "RED".into()]));
        // Who asks: the signed-in user first.
        let who = Fields {
            who: WhoFields {
                user: SignedIn::username("ann"),
                by: text("bob"),
                ..WhoFields::default()
            },
            ..Fields::default()
        };
        let asked = read_request(Asks::Who, &who, &Configured::default()).unwrap();
        assert_eq!(asked.who.and_then(|w| w.by).as_deref(), Some("ann"));
        let asked = read_request(Asks::Stop, &who, &configured).unwrap();
        assert_eq!(asked.resources.map(|r| r.len()), Some(2));
    }

    fn msg_op(operation: &str) -> Fields {
        fields(text(operation), Raw::Absent, Raw::Absent)
    }
}
