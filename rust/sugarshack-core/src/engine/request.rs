//! What a msg asks for, read by the rules the nodes used to apply in JS: the
//! operation id (msg.operation, else the node's, else msg.interlock.operation
//! for the nodes that follow an acquire), the priority (absent: 0), the
//! resources (a list or comma-separated text, trimmed), a fault's note and
//! who asks for a clear or an emergency stop (a signed-in dashboard user
//! outranks msg.by). Only shapes are read here; whether a request is allowed
//! is the interlock's to say.

use serde::{Deserialize, Serialize};

use super::output::{Param, Refusal};
use crate::code::Code;
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

impl Raw {
    /// Set: not absent, and not the empty string.
    pub fn present(&self) -> bool {
        !matches!(self, Raw::Absent) && *self != Raw::Text(String::new())
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
        };
        clip(&text, QUOTE_MAX)
    }

    fn text(&self) -> Option<&str> {
        match self {
            Raw::Text(text) => Some(text),
            _ => None,
        }
    }
}

/// A number as JS's `String(n)` writes it (integers without a fraction).
pub fn js_number(n: f64) -> String {
    if n == 0.0 {
        "0".to_owned()
    } else if n.fract() == 0.0 && n.abs() < 1e21 {
        format!("{n:.0}")
    } else {
        n.to_string()
    }
}

/// The length JS gives a string (UTF-16 units): the bounds are the ones JS checked.
fn js_len(text: &str) -> usize {
    text.encode_utf16().count()
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

fn as_operation_name(value: &Raw, from: From) -> Result<String, Refusal> {
    match value {
        Raw::Number(n) if n.is_finite() => Ok(js_number(*n)),
        Raw::Text(text) if js_len(text) > MAX_OPERATION_NAME => Err(Refusal::catalog(
            Code::InvalidOperation,
            "errors.operationTooLong",
            vec![
                ("from", from.param()),
                ("length", Param::Text(js_len(text).to_string())),
                ("max", Param::Text(MAX_OPERATION_NAME.to_string())),
            ],
        )),
        Raw::Text(text) => Ok(text.trim().to_owned()),
        other => Err(Refusal::catalog(
            Code::InvalidOperation,
            "errors.operationNotName",
            vec![("from", from.param()), ("got", Param::Text(other.quote()))],
        )),
    }
}

/// The operation id: msg.operation, else the configured one, else (for the
/// nodes that follow an acquire) msg.interlock.operation. An id that is
/// empty once trimmed names no operation.
pub fn operation_of(msg: &Raw, configured: &Raw, follow: &Raw) -> Result<String, Refusal> {
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

/// Names from a list or comma-separated text, trimmed, the empty ones left out.
fn split_names(value: &Raw, from: From) -> Result<Vec<String>, Refusal> {
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
                ("from", from.param()),
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
        split_names(msg, From::Msg("msg.resources"))
    } else if configured.present() {
        split_names(configured, From::Configured("configuredResources"))
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

/// Who asks, as read off a msg.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", default)]
pub struct WhoFields {
    /// The signed-in dashboard user (msg._client.user: its username, name, email or userId).
    pub user: Raw,
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

/// The signed-in dashboard user, else msg.by (so a page cannot record a
/// clear under another name); msg.reason; msg.force.
pub fn attribution_of(fields: &WhoFields) -> Result<Who, Refusal> {
    let by = [&fields.user, &fields.by]
        .into_iter()
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
            user: text("ann"),
            by: text("bob"),
            reason: text("leak"),
            force: true,
        })
        .unwrap();
        assert_eq!(who.by.as_deref(), Some("ann"));
        assert_eq!(who.reason.as_deref(), Some("leak"));
        assert!(who.force);
        let who = attribution_of(&WhoFields {
            user: text("  "),
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
}
