//! Who may clear a faulted line, and when. A line is cleared by a person once
//! the plant shows it isolated: its lockout completed, every member actuator
//! confirmed at its lockout state by fresh feedback, no member device offline.
//! Anything else is a reason to refuse, and every reason is listed; a person
//! who knows better may force the clear, and the clear is recorded as forced.
//! Every clear and emergency stop records who asked and why.
//!
//! ```
//! use sugarshack_core::clearance::{Attribution, ClearBlocker};
//! use sugarshack_core::interlock::{Interlock, InterlockConfig, InterlockError};
//! use sugarshack_core::time::ms;
//!
//! let mut lock = Interlock::new(InterlockConfig::with_resources(["YEL"])).unwrap();
//! let yel = lock.resource_set(&["YEL"]).unwrap();
//! lock.fault_resources(&yel, Some("emergency stop"), ms(0)).unwrap();
//! // The plant's reasons, per line: here its panel is offline.
//! let offline = |_: &str| vec![ClearBlocker::DeviceOffline { device: "ctrl-1".into() }];
//! let ann = Attribution::new(Some("ann"), None, false);
//! let refused = lock.clear_checked(&yel, &ann, offline, ms(10)).unwrap_err();
//! assert!(matches!(refused, InterlockError::ClearRefused { .. }));
//! assert!(refused.to_string().contains("ctrl-1"), "{refused}");
//! // A person who knows better forces it: cleared, and recorded as forced.
//! let forced = Attribution::new(Some("ann"), Some("checked on site"), true);
//! lock.clear_checked(&yel, &forced, offline, ms(20)).unwrap();
//! assert!(!lock.is_faulted(lock.resource("YEL").unwrap()));
//! let cleared = lock.drain_events().pop().unwrap();
//! assert!(lock.describe(&cleared).forced);
//! ```

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::text::quote;

/// The longest name of a person kept in an event, in characters.
pub const BY_MAX_CHARS: usize = 100;
/// The longest reason kept in an event, in characters.
pub const REASON_MAX_CHARS: usize = 500;

/// Who asked for a clear or an emergency stop, why, and whether a refusal was overridden.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Attribution {
    /// The dashboard or editor user; `"unknown"` when nobody is signed in.
    pub by: String,
    /// Why, in words a person acts on.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    /// The clear overrode the reasons to refuse it.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub forced: bool,
}

/// Who did it, when nobody said.
pub const UNKNOWN_BY: &str = "unknown";

/// Who an operator's action is attributed to, as its event and journal line
/// name them: trimmed and cut, [`UNKNOWN_BY`] when nobody said.
pub fn attributed_by(by: Option<&str>) -> String {
    Attribution::new(by, None, false).by
}

impl Attribution {
    /// Bounded: a name or reason from outside is cut, an empty name reads [`UNKNOWN_BY`].
    pub fn new(by: Option<&str>, reason: Option<&str>, forced: bool) -> Self {
        let by = by
            .map(str::trim)
            .filter(|b| !b.is_empty())
            .unwrap_or(UNKNOWN_BY);
        Attribution {
            by: cut(by, BY_MAX_CHARS),
            reason: reason
                .map(str::trim)
                .filter(|r| !r.is_empty())
                .map(|r| cut(r, REASON_MAX_CHARS)),
            forced,
        }
    }

    /// Nobody signed in, no reason, not forced.
    pub fn unknown() -> Self {
        Attribution::new(None, None, false)
    }
}

/// `text` cut to `max_chars` characters, the last one an ellipsis when cut.
pub(crate) fn cut(text: &str, max_chars: usize) -> String {
    if text.chars().nth(max_chars).is_none() {
        return text.to_owned();
    }
    let mut kept: String = text.chars().take(max_chars - 1).collect();
    kept.push('\u{2026}');
    kept
}

/// Why a line may not be cleared yet.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", tag = "kind")]
pub enum ClearBlocker {
    /// The line's lockout is still a standing order for this actuator: feedback has not confirmed it.
    #[serde(rename_all = "camelCase")]
    LockoutPending {
        /// The actuator's id.
        actuator: String,
        /// How many times its lockout was published.
        sends: u32,
    },
    /// Feedback shows the actuator away from its lockout state.
    #[serde(rename_all = "camelCase")]
    OffLockout {
        /// The actuator's id.
        actuator: String,
        /// Its last feedback value.
        position: f64,
        /// Its lockout state.
        lockout: f64,
    },
    /// The actuator never reported where it is.
    #[serde(rename_all = "camelCase")]
    NoFeedback {
        /// The actuator's id.
        actuator: String,
    },
    /// Its feedback is stale: where it is now is not known.
    #[serde(rename_all = "camelCase")]
    Stale {
        /// The actuator's id.
        actuator: String,
    },
    /// A device serving the line is offline.
    #[serde(rename_all = "camelCase")]
    DeviceOffline {
        /// The device's id.
        device: String,
    },
}

impl fmt::Display for ClearBlocker {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::LockoutPending { actuator, sends } => write!(
                f,
                "lockout not completed: {} not confirmed in its lockout state (sent {sends} time{})",
                quote(actuator),
                if *sends == 1 { "" } else { "s" }
            ),
            Self::OffLockout {
                actuator,
                position,
                lockout,
            } => write!(
                f,
                "member actuator {} not in its lockout state (reads {position}, lockout {lockout})",
                quote(actuator)
            ),
            Self::NoFeedback { actuator } => write!(
                f,
                "member actuator {} has not reported its position",
                quote(actuator)
            ),
            Self::Stale { actuator } => write!(
                f,
                "member actuator {} has stale feedback",
                quote(actuator)
            ),
            Self::DeviceOffline { device } => write!(f, "device {} offline", quote(device)),
        }
    }
}

/// The reasons that keep one line from being cleared.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct LineBlockers {
    /// The line's name.
    pub line: String,
    /// Every reason it cannot be cleared yet.
    pub reasons: Vec<ClearBlocker>,
}

impl fmt::Display for LineBlockers {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: ", quote(&self.line))?;
        for (i, reason) in self.reasons.iter().enumerate() {
            if i > 0 {
                f.write_str("; ")?;
            }
            write!(f, "{reason}")?;
        }
        Ok(())
    }
}

/// `reasons` as a person's page lists them: each reason with its words (`text`).
pub fn worded_reasons<S: serde::Serializer>(
    reasons: &[ClearBlocker],
    serializer: S,
) -> Result<S::Ok, S::Error> {
    use serde::ser::{Error, SerializeSeq};
    let mut seq = serializer.serialize_seq(Some(reasons.len()))?;
    for reason in reasons {
        let mut value = serde_json::to_value(reason).map_err(S::Error::custom)?;
        if let Some(map) = value.as_object_mut() {
            map.insert("text".into(), reason.to_string().into());
        }
        seq.serialize_element(&value)?;
    }
    seq.end()
}

/// A refused clear's `lines` as a Catch node gets them: each line's reasons
/// and their words (`texts`, in the same order).
pub fn worded_lines<S: serde::Serializer>(
    lines: &[LineBlockers],
    serializer: S,
) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeSeq;
    let mut seq = serializer.serialize_seq(Some(lines.len()))?;
    for l in lines {
        let texts: Vec<String> = l.reasons.iter().map(ToString::to_string).collect();
        seq.serialize_element(&serde_json::json!({
            "line": l.line,
            "reasons": l.reasons,
            "texts": texts,
        }))?;
    }
    seq.end()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn attribution_is_bounded_and_defaults_to_unknown() {
        let a = Attribution::new(Some("  "), Some(""), false);
        assert_eq!(a.by, "unknown");
        assert_eq!(a.reason, None);
        let long = Attribution::new(Some(&"p".repeat(10_000)), Some(&"r".repeat(10_000)), true);
        assert_eq!(long.by.chars().count(), BY_MAX_CHARS);
        assert_eq!(long.reason.unwrap().chars().count(), REASON_MAX_CHARS);
        assert!(long.forced);
    }

    /// What an operator's action answers as its `by` is what its event names.
    #[test]
    fn an_action_is_attributed_as_its_event_names_it() {
        assert_eq!(attributed_by(None), UNKNOWN_BY);
        assert_eq!(attributed_by(Some(" \t")), UNKNOWN_BY);
        assert_eq!(attributed_by(Some(" ana ")), "ana");
        let long = "p".repeat(10_000);
        assert_eq!(
            attributed_by(Some(&long)),
            Attribution::new(Some(&long), None, false).by
        );
    }

    #[test]
    fn blockers_read_as_reasons() {
        let line = LineBlockers {
            line: "YEL".into(),
            reasons: vec![
                ClearBlocker::DeviceOffline {
                    device: "ctrl-1".into(),
                },
                ClearBlocker::OffLockout {
                    actuator: "V101".into(),
                    position: 40.0,
                    lockout: 0.0,
                },
            ],
        };
        assert_eq!(
            line.to_string(),
            "YEL: device ctrl-1 offline; member actuator V101 not in its lockout state (reads 40, lockout 0)"
        );
    }

    #[test]
    fn reasons_cross_with_their_words() {
        let reasons = vec![ClearBlocker::DeviceOffline {
            device: "ctrl-1".into(),
        }];
        let mut out = Vec::new();
        worded_reasons(&reasons, &mut serde_json::Serializer::new(&mut out)).unwrap();
        let read: serde_json::Value = serde_json::from_slice(&out).unwrap();
        assert_eq!(
            read,
            serde_json::json!([{ "kind": "deviceOffline", "device": "ctrl-1", "text": "device ctrl-1 offline" }])
        );
        let lines = vec![LineBlockers {
            line: "YEL".into(),
            reasons,
        }];
        let mut out = Vec::new();
        worded_lines(&lines, &mut serde_json::Serializer::new(&mut out)).unwrap();
        let read: serde_json::Value = serde_json::from_slice(&out).unwrap();
        assert_eq!(read[0]["line"], "YEL");
        assert_eq!(read[0]["reasons"][0]["device"], "ctrl-1");
        assert_eq!(
            read[0]["texts"],
            serde_json::json!(["device ctrl-1 offline"])
        );
    }
}
