//! Sealed state documents: what an interlock or a pid node keeps across
//! restarts. A document says whose it is (`owner`, the node's id), what
//! configuration it was saved for (`savedFor`, a digest of what matters of
//! it) and carries a checksum of the rest, so that another node's state, a
//! damaged one or one of a version this build does not know is refused, never
//! taken for this node's. The bytes go wherever the caller keeps them (a file
//! of the user directory; a key of etcd): sealing and opening is all here.
//!
//! The checksum is `sha256:` and the hex SHA-256 of the document's compact
//! JSON without its `checksum` member, members in the order written (a
//! document pretty-printed to be read stays valid; one edited does not).
//!
//! ```
//! use sugarshack_core::sealed::{self, Kind, Refusal};
//! use sugarshack_core::time::ms;
//!
//! let text = sealed::seal(Kind::Pid, "pid-1", "sha256:00", ms(5), &vec![1, 2]).unwrap();
//! let doc = sealed::open::<Vec<u32>>(&text, Kind::Pid, "pid-1").unwrap();
//! assert_eq!(doc.state, vec![1, 2]);
//! assert!(matches!(
//!     sealed::open::<Vec<u32>>(&text, Kind::Pid, "pid-2"),
//!     Err(Refusal::NotOurs { .. })
//! ));
//! assert_eq!(
//!     sealed::open::<Vec<u32>>(&text.replace("[1,2]", "[1,3]"), Kind::Pid, "pid-1"),
//!     Err(Refusal::ChecksumMismatch)
//! );
//! ```

use std::fmt;

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use sha2::{Digest, Sha256};

use crate::json::{self, JsonError};
use crate::text::quote;
use crate::time::Millis;

/// The document version this build writes and the only one it reads.
/// Version 1 (no owner, no checksum) was never released.
pub const DOCUMENT_VERSION: u32 = 2;

/// What a document holds the state of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// An interlock's lines, queue and holds, with its routines and alarms.
    Interlock,
    /// A pid node's integral, set point and mode.
    Pid,
}

impl Kind {
    /// The `format` its documents carry.
    pub fn format(self) -> &'static str {
        match self {
            Kind::Interlock => "sugarshack-interlock-state",
            Kind::Pid => "sugarshack-pid-state",
        }
    }

    fn noun(self) -> &'static str {
        match self {
            Kind::Interlock => "an interlock",
            Kind::Pid => "a pid node",
        }
    }

    fn of_format(format: &str) -> Option<Self> {
        [Kind::Interlock, Kind::Pid]
            .into_iter()
            .find(|kind| kind.format() == format)
    }
}

/// A sealed document, as written.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Document<T> {
    /// What it is: [`Kind::format`].
    pub format: String,
    /// [`DOCUMENT_VERSION`].
    pub version: u32,
    /// The id of the node whose state it is.
    pub owner: String,
    /// The digest of the configuration it was saved under (see [`digest`]).
    pub saved_for: String,
    /// When it was sealed, in ms.
    pub saved_at_ms: Millis,
    /// The state itself.
    pub state: T,
    /// Of everything above (see the module's documentation); empty while sealing.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub checksum: String,
}

/// Why a document cannot be taken as this node's state. Each is a lost state
/// for its owner: never a first start.
#[derive(Clone, Debug, PartialEq)]
pub enum Refusal {
    /// Not JSON, or nested too deeply to read.
    Unreadable(JsonError),
    /// JSON, but not a sugarshack state document.
    NotADocument,
    /// The state of another kind of node.
    OtherKind {
        /// What it says it is.
        format: String,
    },
    /// A document version this build does not read.
    Version {
        /// The version it says, as written.
        found: String,
    },
    /// No checksum where one must be.
    NoChecksum,
    /// The content does not match its checksum: changed or damaged since it was sealed.
    ChecksumMismatch,
    /// Another node's state (a copied or restored file, two nodes swapped).
    NotOurs {
        /// The node it says it belongs to.
        owner: String,
    },
    /// Sealed, but not in the shape this build reads.
    Invalid(JsonError),
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Refusal::Unreadable(JsonError::TooDeep { limit }) => {
                write!(f, "it is nested deeper than {limit} levels")
            }
            Refusal::Unreadable(err) => write!(f, "it is not valid JSON ({err})"),
            Refusal::NotADocument => f.write_str(
                "it is not a sugarshack state document (no 'format' naming one)",
            ),
            Refusal::OtherKind { format } => match Kind::of_format(format) {
                Some(kind) => write!(f, "it is the state of {}", kind.noun()),
                None => write!(f, "it is a '{}' document, not a sugarshack state", quote(format)),
            },
            Refusal::Version { found } => write!(
                f,
                "it is document version {found}; this version reads version {DOCUMENT_VERSION} only"
            ),
            Refusal::NoChecksum => f.write_str("it carries no checksum"),
            Refusal::ChecksumMismatch => f.write_str(
                "its content does not match its checksum: it was changed or damaged after it was written",
            ),
            Refusal::NotOurs { owner } => write!(
                f,
                "it is the state of node '{}', not of this one (a copied or restored file?)",
                quote(owner)
            ),
            Refusal::Invalid(err) => write!(f, "it cannot be read: {err}"),
        }
    }
}

impl std::error::Error for Refusal {}

/// `sha256:` and the hex SHA-256 of `bytes`.
fn sha256(bytes: &[u8]) -> String {
    let hash = Sha256::digest(bytes);
    let mut text = String::with_capacity(7 + 2 * hash.len());
    text.push_str("sha256:");
    for byte in hash {
        text.push(char::from_digit(u32::from(byte >> 4), 16).unwrap_or('0'));
        text.push(char::from_digit(u32::from(byte & 15), 16).unwrap_or('0'));
    }
    text
}

/// The digest of a configuration as it is saved for: the SHA-256 of its compact JSON.
pub fn digest<T: Serialize + ?Sized>(config: &T) -> String {
    // A Serialize of plain data into a string does not fail.
    sha256(serde_json::to_string(config).unwrap_or_default().as_bytes())
}

/// The document's bytes: `state` of `owner`, saved for `saved_for` at `now`.
pub fn seal<T: Serialize>(
    kind: Kind,
    owner: &str,
    saved_for: &str,
    now: Millis,
    state: &T,
) -> Result<String, serde_json::Error> {
    let document = Document {
        format: kind.format().to_owned(),
        version: DOCUMENT_VERSION,
        owner: owner.to_owned(),
        saved_for: saved_for.to_owned(),
        saved_at_ms: now,
        state,
        checksum: String::new(),
    };
    let mut value = serde_json::to_value(&document)?;
    let checksum = sha256(serde_json::to_string(&value)?.as_bytes());
    if let Value::Object(members) = &mut value {
        members.insert("checksum".to_owned(), Value::String(checksum));
    }
    serde_json::to_string(&value)
}

/// Reads the document `text` as the state of `owner`, a node of `kind`:
/// refused unless it says it is one, of this version, unchanged since sealed,
/// and `owner`'s.
pub fn open<T: DeserializeOwned>(
    text: &str,
    kind: Kind,
    owner: &str,
) -> Result<Document<T>, Refusal> {
    let mut value: Value = json::from_str(text).map_err(Refusal::Unreadable)?;
    let Value::Object(members) = &mut value else {
        return Err(Refusal::NotADocument);
    };
    match members.get("format") {
        Some(Value::String(format)) if format == kind.format() => {}
        Some(Value::String(format)) if !format.is_empty() => {
            return Err(Refusal::OtherKind {
                format: format.clone(),
            })
        }
        _ => return Err(Refusal::NotADocument),
    }
    match members.get("version") {
        Some(version) if version.as_u64() == Some(u64::from(DOCUMENT_VERSION)) => {}
        found => {
            return Err(Refusal::Version {
                found: found.map_or_else(|| "(none)".to_owned(), quote),
            })
        }
    }
    let Some(Value::String(checksum)) = members.shift_remove("checksum") else {
        return Err(Refusal::NoChecksum);
    };
    let canonical = serde_json::to_string(&value).map_err(|_| Refusal::NotADocument)?;
    if sha256(canonical.as_bytes()) != checksum {
        return Err(Refusal::ChecksumMismatch);
    }
    let mut document: Document<T> = json::from_value(&value).map_err(Refusal::Invalid)?;
    if document.owner != owner {
        return Err(Refusal::NotOurs {
            owner: document.owner,
        });
    }
    document.checksum = checksum;
    Ok(document)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::time::ms;

    fn sealed() -> String {
        seal(Kind::Interlock, "il", "sha256:ab", ms(7), &vec!["note"]).unwrap()
    }

    fn open_il(text: &str) -> Result<Document<Vec<String>>, Refusal> {
        open(text, Kind::Interlock, "il")
    }

    #[test]
    fn a_sealed_document_opens_for_its_owner() {
        let doc = open_il(&sealed()).unwrap();
        assert_eq!(
            (doc.owner.as_str(), doc.saved_for.as_str(), doc.saved_at_ms),
            ("il", "sha256:ab", ms(7))
        );
        assert_eq!(doc.state, vec!["note"]);
        assert!(sealed().ends_with(&format!(",\"checksum\":\"{}\"}}", doc.checksum)));
    }

    #[test]
    fn whitespace_does_not_matter_content_does() {
        let pretty =
            serde_json::to_string_pretty(&serde_json::from_str::<Value>(&sealed()).unwrap())
                .unwrap();
        assert!(open_il(&pretty).is_ok(), "pretty-printed to be read");
        assert_eq!(
            open_il(&sealed().replace("note", "nose")),
            Err(Refusal::ChecksumMismatch)
        );
        assert_eq!(
            open_il(&sealed().replace("\"savedAtMs\":7", "\"savedAtMs\":8")),
            Err(Refusal::ChecksumMismatch)
        );
    }

    #[test]
    fn every_refusal_says_why() {
        let cases: Vec<(String, &str)> = vec![
            ("{\"format\":".into(), "not valid JSON"),
            (
                format!("{}1{}", "[".repeat(200), "]".repeat(200)),
                "nested deeper",
            ),
            ("[1]".into(), "not a sugarshack state document"),
            ("{\"version\":2}".into(), "not a sugarshack state document"),
            (
                sealed().replace("sugarshack-interlock-state", "sugarshack-pid-state"),
                "the state of a pid node",
            ),
            (
                sealed().replace("\"version\":2", "\"version\":99"),
                "document version 99; this version reads version 2 only",
            ),
            (
                sealed().replace(",\"version\":2", ""),
                "document version (none)",
            ),
            (
                sealed().split(",\"checksum\"").next().unwrap().to_owned() + "}",
                "no checksum",
            ),
        ];
        for (text, why) in cases {
            let refusal = open_il(&text).unwrap_err().to_string();
            assert!(refusal.contains(why), "{refusal:?} should say {why:?}");
        }
        let other = seal(Kind::Interlock, "il-2", "sha256:ab", ms(7), &vec!["note"]).unwrap();
        assert_eq!(
            open_il(&other).unwrap_err().to_string(),
            "it is the state of node 'il-2', not of this one (a copied or restored file?)"
        );
        let shape = seal(Kind::Interlock, "il", "sha256:ab", ms(7), &7).unwrap();
        assert!(matches!(open_il(&shape), Err(Refusal::Invalid(_))));
    }

    #[test]
    fn the_digest_is_of_the_compact_json() {
        assert_eq!(
            digest(&serde_json::json!({ "lines": ["YEL"] })),
            sha256(br#"{"lines":["YEL"]}"#)
        );
        assert_eq!(
            sha256(b""),
            "sha256:e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855"
        );
    }
}
