//! The outputs of one input as one compact value for the host: numbers in a
//! run of `f64` words, text in one UTF-8 buffer that the words point into,
//! and a string table of names (operations, lines) that the host mirrors, so
//! a name crosses once and is then only a number.
//!
//! A batch is a sequence of records, each a tag word and its fields:
//!
//! | tag | record | fields |
//! |---|---|---|
//! | 1 | commit | urgent (0/1) |
//! | 2 | after | |
//! | 3 | send | msg, port, set (0 nothing; 1 interlock: operation name, priority, waited ms, n, n names; 2 other: text) |
//! | 4 | emit | msg, port, text (JSON array of msgs) |
//! | 5 | complete | msg, 0 or 1 and text (JSON refusal) |
//! | 6 | other | text (JSON: `{ kind, ... }`, the [`Output`] as serde writes it) |
//! | 7 | counts | holding, queued, faulted, lost (0/1); first in its batch |
//! | 8 | name | id, text (the string table's entry `id` from now on) |
//! | 9 | names reset | (every entry is forgotten) |
//! | 10 | alarm | at ms, id text, action, from and to texts, by and reason (each 0, or 1 and text) |
//!
//! A text field is two words: its start and length in UTF-16 units of the
//! batch's text (which the host decodes once). The alternative, the whole
//! batch as one JSON text, is [`Wire::json`]: the benchmark compares both.

use std::sync::Arc;

use super::fx::FxMap;
use super::{Output, Set};

/// A name's key in the table: where its text lives.
fn key(name: &Arc<str>) -> usize {
    Arc::as_ptr(name).cast::<u8>() as usize
}

/// Record tags.
pub mod tag {
    /// `Output::Commit`.
    pub const COMMIT: f64 = 1.0;
    /// `Output::After`.
    pub const AFTER: f64 = 2.0;
    /// `Output::Send`.
    pub const SEND: f64 = 3.0;
    /// `Output::Emit`.
    pub const EMIT: f64 = 4.0;
    /// `Output::Complete`.
    pub const COMPLETE: f64 = 5.0;
    /// Any other output, as JSON text.
    pub const OTHER: f64 = 6.0;
    /// `Output::Counts`.
    pub const COUNTS: f64 = 7.0;
    /// A string table entry.
    pub const NAME: f64 = 8.0;
    /// The string table starts again.
    pub const NAMES_RESET: f64 = 9.0;
    /// `Output::Alarm` (its change in words: the host reads no JSON for it).
    pub const ALARM: f64 = 10.0;
}

/// What is set on a sent msg.
pub mod set {
    /// Nothing.
    pub const NOTHING: f64 = 0.0;
    /// `msg.interlock`.
    pub const INTERLOCK: f64 = 1.0;
    /// Anything else, as JSON text.
    pub const OTHER: f64 = 2.0;
}

/// Names kept in the table before it starts again (a flow naming a new
/// operation per msg): small enough that the table and its mirror stay in
/// cache, far more than the names a plant uses at once.
pub const NAMES_KEPT: usize = 4096;

/// An encoder of batches, with the string table the host mirrors.
#[derive(Clone, Debug, Default)]
pub struct Wire {
    words: Vec<f64>,
    text: String,
    text_units: usize,
    /// Entries by the address of the engine's shared text (kept alive here, so
    /// an address is never another text's): a name the engine keeps crosses
    /// once; the same text from another msg may get an entry of its own.
    names: FxMap<usize, (Arc<str>, u32)>,
    /// Where a JSON field is written before it joins the text (kept: no allocation per field).
    scratch: Vec<u8>,
    /// The table entries of a record's names (kept: no allocation per record).
    ids: Vec<f64>,
}

impl Wire {
    /// A new encoder with an empty string table.
    pub fn new() -> Self {
        Self::default()
    }

    /// The words of the last batch.
    pub fn words(&self) -> &[f64] {
        &self.words
    }

    /// The text of the last batch.
    pub fn text(&self) -> &str {
        &self.text
    }

    /// Encodes `outputs` as the next batch (replacing the last one).
    pub fn encode(&mut self, outputs: &[Output]) {
        self.words.clear();
        self.text.clear();
        self.text_units = 0;
        // As in_wire_order, without an iterator chain per batch (this runs per msg).
        let counts = outputs.iter().rposition(|o| matches!(o, Output::Counts(_)));
        if let Some(at) = counts {
            self.record(&outputs[at]);
        }
        for (i, output) in outputs.iter().enumerate() {
            if Some(i) != counts {
                self.record(output);
            }
        }
    }

    /// The whole batch as one JSON text (the alternative to [`Wire::encode`]),
    /// in the same order.
    pub fn json(outputs: &[Output]) -> String {
        serde_json::to_string(&in_wire_order(outputs).collect::<Vec<_>>()).expect("plain data")
    }

    fn record(&mut self, output: &Output) {
        match output {
            Output::Commit { urgent } => self.push(&[tag::COMMIT, f64::from(u8::from(*urgent))]),
            Output::After => self.push(&[tag::AFTER]),
            Output::Send {
                msg,
                port,
                set: Set::Nothing,
            } => self.push(&[tag::SEND, f64::from(msg.0), f64::from(*port), set::NOTHING]),
            Output::Send {
                msg,
                port,
                set:
                    Set::Interlock {
                        operation,
                        priority,
                        resources,
                        waited_ms,
                    },
            } => {
                // Names first: the host learns them before the record that uses them.
                // Room for every name of the record, whether new or not: no pass to count the new ones.
                if self.names.len() + 1 + resources.len() > NAMES_KEPT {
                    self.names.clear();
                    self.words.push(tag::NAMES_RESET);
                }
                let operation = self.name(operation);
                let mut ids = std::mem::take(&mut self.ids);
                ids.clear();
                for r in resources.iter() {
                    ids.push(self.name(r));
                }
                self.push(&[
                    tag::SEND,
                    f64::from(msg.0),
                    f64::from(*port),
                    set::INTERLOCK,
                    operation,
                    f64::from(*priority),
                    waited_ms.as_f64(),
                    resources.len() as f64,
                ]);
                self.push(&ids);
                self.ids = ids;
            }
            Output::Counts(c) => self.push(&[
                tag::COUNTS,
                c.holding as f64,
                c.queued as f64,
                c.faulted as f64,
                f64::from(u8::from(c.lost)),
            ]),
            other => self.record_text(other),
        }
    }

    /// The records with text beyond names (rare per msg): apart, so the
    /// frequent ones above stay small.
    #[inline(never)]
    fn record_text(&mut self, output: &Output) {
        match output {
            Output::Send { msg, port, set } => {
                self.push(&[tag::SEND, f64::from(msg.0), f64::from(*port), set::OTHER]);
                self.json_field(set);
            }
            Output::Emit { msg, port, msgs } => {
                self.push(&[tag::EMIT, f64::from(msg.0), f64::from(*port)]);
                self.json_field(msgs);
            }
            Output::Complete { msg, refusal } => {
                self.push(&[tag::COMPLETE, f64::from(msg.0)]);
                match refusal {
                    None => self.words.push(0.0),
                    Some(refusal) => {
                        self.words.push(1.0);
                        self.json_field(refusal);
                    }
                }
            }
            Output::Alarm { change } => {
                self.push(&[tag::ALARM, change.at_ms.as_f64()]);
                self.text_field(&change.id);
                self.enum_field(&change.action);
                self.enum_field(&change.from);
                self.enum_field(&change.to);
                self.optional_text(change.by.as_deref());
                self.optional_text(change.reason.as_deref());
            }
            other => {
                self.words.push(tag::OTHER);
                self.json_field(other);
            }
        }
    }

    /// `name`'s table entry, announced to the host first if it is new.
    fn name(&mut self, name: &Arc<str>) -> f64 {
        if let Some((_, id)) = self.names.get(&key(name)) {
            return f64::from(*id);
        }
        let id = self.names.len() as u32;
        self.names.insert(key(name), (name.clone(), id));
        self.push(&[tag::NAME, f64::from(id)]);
        self.text_field(name);
        f64::from(id)
    }

    fn push(&mut self, words: &[f64]) {
        self.words.extend_from_slice(words);
    }

    fn text_field(&mut self, text: &str) {
        // Most text is ASCII (names, JSON of plain fields): one unit a byte, counted at once.
        let units = if text.is_ascii() {
            text.len()
        } else {
            text.encode_utf16().count()
        };
        self.words.push(self.text_units as f64);
        self.words.push(units as f64);
        self.text.push_str(text);
        self.text_units += units;
    }

    fn optional_text(&mut self, text: Option<&str>) {
        match text {
            None => self.words.push(0.0),
            Some(text) => {
                self.words.push(1.0);
                self.text_field(text);
            }
        }
    }

    /// A unit variant's name as serde writes it (a JSON string, without its quotes).
    fn enum_field<T: serde::Serialize>(&mut self, value: &T) {
        let mut json = std::mem::take(&mut self.scratch);
        json.clear();
        serde_json::to_writer(&mut json, value).expect("plain data");
        let text = std::str::from_utf8(&json).expect("serde_json writes UTF-8");
        self.text_field(text.trim_matches('"'));
        self.scratch = json;
    }

    fn json_field<T: serde::Serialize + ?Sized>(&mut self, value: &T) {
        let mut json = std::mem::take(&mut self.scratch);
        json.clear();
        serde_json::to_writer(&mut json, value).expect("plain data");
        self.text_field(std::str::from_utf8(&json).expect("serde_json writes UTF-8"));
        self.scratch = json;
    }
}

/// A batch's outputs as either wire carries them: its last counts first (the
/// host shows them at once, before any effect), then the rest in order.
fn in_wire_order(outputs: &[Output]) -> impl Iterator<Item = &Output> {
    let counts = outputs.iter().rposition(|o| matches!(o, Output::Counts(_)));
    counts.map(|at| &outputs[at]).into_iter().chain(
        outputs
            .iter()
            .enumerate()
            .filter(move |(i, _)| Some(*i) != counts)
            .map(|(_, o)| o),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::{Counts, MsgId};
    use crate::time::ms;

    fn grant(msg: u32, op: &str) -> Output {
        grant_of(
            msg,
            Arc::from(op),
            vec![Arc::from("YEL"), Arc::from("RÉD")].into(),
        )
    }

    fn grant_of(msg: u32, operation: Arc<str>, resources: Arc<[Arc<str>]>) -> Output {
        Output::Send {
            msg: MsgId(msg),
            port: 0,
            set: Set::Interlock {
                operation,
                priority: 20,
                resources,
                waited_ms: ms(40),
            },
        }
    }

    #[test]
    fn a_name_crosses_once_then_only_its_number() {
        let mut wire = Wire::new();
        let op: Arc<str> = Arc::from("10");
        let lines: Arc<[Arc<str>]> = vec![Arc::from("YEL"), Arc::from("RÉD")].into();
        wire.encode(&[
            Output::Commit { urgent: false },
            grant_of(7, op.clone(), lines.clone()),
        ]);
        assert_eq!(
            wire.words(),
            [
                tag::COMMIT,
                0.0,
                tag::NAME,
                0.0,
                0.0,
                2.0,
                tag::NAME,
                1.0,
                2.0,
                3.0,
                tag::NAME,
                2.0,
                5.0,
                3.0,
                tag::SEND,
                7.0,
                0.0,
                set::INTERLOCK,
                0.0,
                20.0,
                40.0,
                2.0,
                1.0,
                2.0,
            ]
        );
        assert_eq!(wire.text(), "10YELRÉD");
        wire.encode(&[grant_of(8, op.clone(), lines.clone())]);
        assert_eq!(
            wire.words(),
            [
                tag::SEND,
                8.0,
                0.0,
                set::INTERLOCK,
                0.0,
                20.0,
                40.0,
                2.0,
                1.0,
                2.0
            ]
        );
        assert_eq!(wire.text(), "");
        // The same text the engine holds elsewhere gets an entry of its own (still right, and bounded).
        wire.encode(&[grant_of(9, Arc::from("10"), lines)]);
        assert_eq!(&wire.words()[..2], [tag::NAME, 3.0]);
        assert_eq!(wire.text(), "10");
    }

    #[test]
    fn other_outputs_cross_as_json_text_in_utf16_units() {
        let mut wire = Wire::new();
        let counts = Output::Counts(Counts {
            holding: 1,
            queued: 2,
            faulted: 3,
            lost: true,
        });
        let log = Output::Log {
            level: crate::engine::Level::Warn,
            text: Box::new(crate::engine::Text::Plain {
                text: "é😀".into()
            }),
        };
        wire.encode(&[counts, log.clone()]);
        let json = serde_json::to_string(&log).unwrap();
        assert_eq!(
            wire.words(),
            [
                tag::COUNTS,
                1.0,
                2.0,
                3.0,
                1.0,
                tag::OTHER,
                0.0,
                json.encode_utf16().count() as f64,
            ]
        );
        assert_eq!(wire.text(), json);
        assert_eq!(Wire::json(std::slice::from_ref(&log)), format!("[{json}]"));
    }

    #[test]
    fn an_alarm_change_crosses_in_words_and_its_texts() {
        use crate::alarm::{AlarmAction, AlarmChange, AlarmState};
        let change = |by: Option<&str>| Output::Alarm {
            change: Box::new(AlarmChange {
                id: "line-faulted:RÉD".into(),
                action: AlarmAction::ShelfExpired,
                from: AlarmState::ActiveUnacked,
                to: AlarmState::Normal,
                at_ms: ms(1500),
                by: by.map(str::to_owned),
                reason: None,
            }),
        };
        let mut wire = Wire::new();
        wire.encode(&[change(None)]);
        let id = "line-faulted:RÉD".encode_utf16().count() as f64;
        let words = [
            tag::ALARM,
            1500.0,
            0.0,
            id,
            id,
            13.0,
            id + 13.0,
            21.0,
            id + 34.0,
            6.0,
        ];
        assert_eq!(wire.words(), [&words[..], &[0.0, 0.0]].concat());
        assert_eq!(
            wire.text(),
            "line-faulted:RÉDshelf-expiredactive-unacknowledgednormal"
        );
        wire.encode(&[change(Some("ann"))]);
        assert_eq!(wire.words()[10..], [1.0, id + 40.0, 3.0, 0.0]);
        assert!(wire.text().ends_with("normalann"));
    }

    #[test]
    fn both_wires_carry_the_last_counts_first_then_the_rest_in_order() {
        let counts = |faulted| {
            Output::Counts(Counts {
                faulted,
                ..Counts::default()
            })
        };
        let batch = [
            counts(1),
            Output::Commit { urgent: true },
            counts(2),
            Output::After,
        ];
        let mut wire = Wire::new();
        wire.encode(&batch);
        assert_eq!(
            wire.words(),
            [
                tag::COUNTS,
                0.0,
                0.0,
                2.0,
                0.0,
                tag::COUNTS,
                0.0,
                0.0,
                1.0,
                0.0,
                tag::COMMIT,
                1.0,
                tag::AFTER
            ]
        );
        let order = [&batch[2], &batch[0], &batch[1], &batch[3]];
        assert_eq!(Wire::json(&batch), serde_json::to_string(&order).unwrap());
    }

    #[test]
    fn the_table_starts_again_past_its_bound_and_names_a_record_uses_again() {
        let mut wire = Wire::new();
        let mut i = 0;
        loop {
            wire.encode(&[grant(1, &format!("op{i}"))]);
            i += 1;
            if wire.words()[0] == tag::NAMES_RESET {
                break;
            }
            assert!(i <= NAMES_KEPT, "never started again");
        }
        let names: Vec<f64> = wire
            .words()
            .chunks(1)
            .zip(wire.words().iter().skip(1))
            .filter(|(w, _)| w[0] == tag::NAME)
            .map(|(_, id)| *id)
            .collect();
        assert_eq!(names, [0.0, 1.0, 2.0], "the operation and both lines, anew");
        assert!(wire.text().starts_with(&format!("op{}", i - 1)));
    }
}
