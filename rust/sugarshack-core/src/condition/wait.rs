//! Waits on conditions (a wait node's msg, an operation's wait step): each
//! ends when its condition holds on fresh values, or times out at its
//! deadline saying why it last did not hold. The host checks the condition
//! when its sensors sample and reports each check here; it keeps one timer at
//! [`Waits::next_deadline`] and calls [`Waits::expire`] then.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt;

use super::MAX_CHARS;
use crate::code::Code;
use crate::text::{abridge, js_number};
use crate::time::Millis;

/// The code of a wait that ran out of time.
pub const TIMEOUT_CODE: Code = Code::ConditionTimeout;

/// More msgs waiting at once than a plant's flows hold: refused rather than kept.
pub const MAX_WAITS: usize = 100_000;

/// A wait refused: [`MAX_WAITS`] are in progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TooManyWaits;

impl TooManyWaits {
    /// The code a Catch node sees.
    pub fn code(self) -> Code {
        Code::QueueFull
    }
}

impl fmt::Display for TooManyWaits {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "more than {MAX_WAITS} msgs wait on conditions of one plant; refused"
        )
    }
}

/// A wait, by the number [`Waits::start`] gave it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct WaitId(pub u32);

/// A wait that ran out of time: why its condition last did not hold (none
/// when it was never checked).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TimedOut {
    /// The wait.
    pub wait: WaitId,
    /// Why it last did not hold.
    pub reason: Option<String>,
    /// What a person reads: its condition, its timeout and why it last did not hold.
    pub message: String,
}

/// The words of a wait on `condition` that did not hold within `timeout`,
/// last failing for `reason` (none: never checked).
pub fn timeout_message(condition: &str, timeout: Millis, reason: Option<&str>) -> String {
    format!(
        "condition {condition} did not hold within {} s (last check: {})",
        js_number(timeout.as_f64() / 1000.0),
        reason.unwrap_or("it was never checked")
    )
}

/// What a check of a wait's condition did to it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Checked {
    /// It held in time: the wait is over.
    Met,
    /// It did not hold: the wait goes on.
    Waiting,
    /// Checked after its deadline (the timer came late): it timed out, held or not.
    TimedOut(TimedOut),
    /// No such wait (it ended before).
    Unknown,
}

#[derive(Clone, Debug)]
struct Wait {
    deadline: Millis,
    reason: Option<String>,
    condition: String,
    timeout: Millis,
}

impl Wait {
    fn timed_out(self, wait: WaitId) -> TimedOut {
        TimedOut {
            wait,
            message: timeout_message(&self.condition, self.timeout, self.reason.as_deref()),
            reason: self.reason,
        }
    }
}

/// The waits in progress and their deadlines.
#[derive(Clone, Debug, Default)]
pub struct Waits {
    waits: BTreeMap<WaitId, Wait>,
    deadlines: BTreeSet<(Millis, WaitId)>,
    next: u32,
}

impl Waits {
    /// A wait of `timeout` from `now` on `condition` (its text); its deadline is `now + timeout`.
    pub fn start(
        &mut self,
        condition: &str,
        timeout: Millis,
        now: Millis,
    ) -> Result<WaitId, TooManyWaits> {
        self.until(condition, timeout, now.saturating_add(timeout))
    }

    /// A wait of `timeout` on `condition` until `deadline` (one carried over
    /// from a core that is gone). Its text is kept to [`MAX_CHARS`], for the
    /// words of its timeout; refused past [`MAX_WAITS`] in progress.
    pub fn until(
        &mut self,
        condition: &str,
        timeout: Millis,
        deadline: Millis,
    ) -> Result<WaitId, TooManyWaits> {
        if self.waits.len() >= MAX_WAITS {
            return Err(TooManyWaits);
        }
        let id = WaitId(self.next);
        self.next = self.next.wrapping_add(1);
        self.waits.insert(
            id,
            Wait {
                deadline,
                reason: None,
                condition: abridge(condition, MAX_CHARS),
                timeout,
            },
        );
        self.deadlines.insert((deadline, id));
        Ok(id)
    }

    /// When `wait` times out, if it is in progress.
    pub fn deadline(&self, wait: WaitId) -> Option<Millis> {
        self.waits.get(&wait).map(|w| w.deadline)
    }

    /// Its condition was checked at `now`: held (`reason` none) or not, and why.
    /// Holding at its deadline still counts; after it, the wait timed out.
    pub fn checked(&mut self, wait: WaitId, reason: Option<String>, now: Millis) -> Checked {
        let Some(w) = self.waits.get_mut(&wait) else {
            return Checked::Unknown;
        };
        if now > w.deadline {
            let timed_out = self.end(wait).map(|w| w.timed_out(wait));
            return timed_out.map_or(Checked::Unknown, Checked::TimedOut);
        }
        match reason {
            None => {
                self.end(wait);
                Checked::Met
            }
            Some(reason) => {
                w.reason = Some(reason);
                Checked::Waiting
            }
        }
    }

    /// Ends `wait` unmet (its msg was cancelled); false when it had ended.
    pub fn cancel(&mut self, wait: WaitId) -> bool {
        self.end(wait).is_some()
    }

    fn end(&mut self, wait: WaitId) -> Option<Wait> {
        let w = self.waits.remove(&wait)?;
        self.deadlines.remove(&(w.deadline, wait));
        Some(w)
    }

    /// The earliest deadline of a wait in progress.
    pub fn next_deadline(&self) -> Option<Millis> {
        self.deadlines.first().map(|(at, _)| *at)
    }

    /// The waits whose deadline is reached at `now`, earliest first; they end.
    /// (A check that held before this call, at the deadline itself, counted.)
    pub fn expire(&mut self, now: Millis) -> Vec<TimedOut> {
        let mut out = Vec::new();
        while let Some(&(at, wait)) = self.deadlines.first() {
            if at > now {
                break;
            }
            if let Some(w) = self.end(wait) {
                out.push(w.timed_out(wait));
            }
        }
        out
    }

    /// How many are in progress.
    pub fn len(&self) -> usize {
        self.waits.len()
    }

    /// Whether none is in progress.
    pub fn is_empty(&self) -> bool {
        self.waits.is_empty()
    }
}

#[cfg(test)]
mod tests;
