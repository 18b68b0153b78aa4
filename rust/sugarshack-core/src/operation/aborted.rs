//! The operations of an interlock whose last run ended aborted. ISA-88's
//! aborted state is left only by a reset: a run ends, but its operation stays
//! aborted, across restarts (saved with the interlock's state), until a person
//! resets it; until then every start of it is refused.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::RunError;
use crate::clearance::Attribution;
use crate::procedure::{Command, State, OPERATION};
use crate::time::Millis;

/// Who aborted an operation, why, and when.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct AbortRecord {
    /// When its run ended aborted.
    pub since_ms: Millis,
    /// Who aborted it, and why.
    pub by: Attribution,
}

/// The aborted operations, by id.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct AbortedOperations(BTreeMap<String, AbortRecord>);

impl AbortedOperations {
    /// None is aborted.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// Every aborted operation, by id.
    pub fn iter(&self) -> impl Iterator<Item = (&str, &AbortRecord)> {
        self.0.iter().map(|(id, record)| (id.as_str(), record))
    }

    /// Operation `id`'s state between runs: aborted, or idle.
    pub fn state(&self, id: &str) -> State {
        if self.0.contains_key(id) {
            State::Aborted
        } else {
            State::Idle
        }
    }

    /// Whether a new run of `id` may start: refused while it is aborted.
    pub fn check_start(&self, id: &str) -> Result<(), RunError> {
        OPERATION.check(id, self.state(id), Command::Start)?;
        Ok(())
    }

    /// A run of `id` ended in `state`: an abort stands until a reset.
    pub fn ended(&mut self, id: &str, state: State, by: &Attribution, now: Millis) {
        if state == State::Aborted {
            self.0.insert(
                id.to_owned(),
                AbortRecord {
                    since_ms: now,
                    by: by.clone(),
                },
            );
        }
    }

    /// A person's reset of `id`: refused unless it is aborted.
    pub fn reset(&mut self, id: &str) -> Result<AbortRecord, RunError> {
        OPERATION.check(id, self.state(id), Command::Reset)?;
        Ok(self.0.remove(id).expect("checked aborted"))
    }

    /// A routine's reset: those of its `operations` aborted (each waits
    /// for a reset after an abort) are reset with it. Their ids, in order.
    pub fn reset_routine(&mut self, operations: &[&str]) -> Vec<String> {
        operations
            .iter()
            .filter(|id| self.0.remove(**id).is_some())
            .map(|id| (*id).to_owned())
            .collect()
    }

    /// A person's `command` to `id` while no run of it exists: a reset of
    /// an aborted one is taken (its state after: idle); any other command is
    /// refused with the table's words.
    pub fn command(&mut self, id: &str, command: Command) -> Result<State, RunError> {
        let next = OPERATION.check(id, self.state(id), command)?;
        if command == Command::Reset {
            self.0.remove(id);
        }
        Ok(next)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::code::Code;
    use crate::time::ms;

    #[test]
    fn an_aborted_operation_starts_again_only_after_a_reset() {
        let mut aborted = AbortedOperations::default();
        let who = Attribution::new(Some("ana"), Some("gasket"), false);
        assert!(aborted.check_start("10").is_ok());
        assert_eq!(
            aborted.reset("10").unwrap_err().code(),
            Code::CommandRefused
        );
        aborted.ended("10", State::Complete, &who, ms(1));
        assert!(aborted.is_empty());
        aborted.ended("10", State::Aborted, &who, ms(2));
        let refused = aborted.check_start("10").unwrap_err();
        assert_eq!(refused.code(), Code::OperationAborted);
        assert_eq!(
            refused.to_string(),
            "start refused: operation '10' is aborted; an aborted operation starts again only after a reset"
        );
        let hold = aborted.command("10", Command::Hold).unwrap_err();
        assert_eq!(hold.code(), Code::CommandRefused);
        assert_eq!(
            hold.to_string(),
            "hold refused: operation '10' is aborted; it was aborted: only a reset applies"
        );
        assert_eq!(aborted.reset("10").unwrap().by.by, "ana");
        aborted.ended("10", State::Aborted, &who, ms(3));
        assert_eq!(aborted.command("10", Command::Reset), Ok(State::Idle));
        assert!(aborted.is_empty());
        assert!(aborted.check_start("10").is_ok());
        let json = serde_json::to_value(&aborted).unwrap();
        assert_eq!(json, serde_json::json!({}));
    }

    #[test]
    fn a_routines_reset_resets_its_aborted_operations_and_no_others() {
        let mut aborted = AbortedOperations::default();
        let who = Attribution::new(Some("ana"), None, false);
        aborted.ended("12", State::Aborted, &who, ms(1));
        aborted.ended("10", State::Aborted, &who, ms(2));
        aborted.ended("99", State::Aborted, &who, ms(3));
        assert_eq!(aborted.reset_routine(&["10", "12", "15"]), ["10", "12"]);
        assert_eq!(aborted.state("10"), State::Idle);
        assert_eq!(aborted.state("12"), State::Idle);
        assert_eq!(aborted.state("99"), State::Aborted, "not the routine's");
        assert!(aborted.reset_routine(&["10", "12", "15"]).is_empty());
    }
}
