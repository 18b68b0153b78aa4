//! Every timeout of an engine as a time in its deadline set: the host keeps
//! one timer, set from [`super::Engine::next_deadline`].

use std::collections::BTreeSet;

use serde::{Deserialize, Serialize};

use super::MsgId;
use crate::time::Millis;

/// What is due at a deadline.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "camelCase")]
pub enum Due {
    /// A waiting request's acquire timeout.
    AcquireTimeout {
        /// Its msg.
        msg: MsgId,
    },
}

/// Deadlines in time order.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Deadlines(BTreeSet<(Millis, Due)>);

impl Deadlines {
    /// `due` falls due at `at`.
    pub fn set(&mut self, at: Millis, due: Due) {
        self.0.insert((at, due));
    }

    /// `due` (set for `at`) is no longer awaited.
    pub fn clear(&mut self, at: Millis, due: Due) {
        self.0.remove(&(at, due));
    }

    /// The earliest deadline.
    pub fn next(&self) -> Option<Millis> {
        self.0.first().map(|(at, _)| *at)
    }

    /// Takes the earliest deadline due at `now`, if any.
    pub fn pop_due(&mut self, now: Millis) -> Option<Due> {
        match self.0.first() {
            Some((at, _)) if *at <= now => self.0.pop_first().map(|(_, due)| due),
            _ => None,
        }
    }

    /// How many are set.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Whether none is set.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}
