//! Alarms as ISA-18.2 treats them. Each abnormal condition the plant reports
//! (a faulted line, a device offline or with stale feedback, ...) is one alarm,
//! named by its kind and subject. The caller says which conditions hold now
//! ([`Alarms::observe`]); the alarm moves between
//!
//! - `normal`: not listed;
//! - `active-unacknowledged`: the condition holds, nobody has acknowledged it;
//! - `active-acknowledged`: the condition holds, a person acknowledged it;
//! - `returned-unacknowledged`: the condition is gone, nobody acknowledged it.
//!
//! An alarm leaves the list once it is both back to normal and acknowledged.
//! A person may shelve a listed alarm until a time they choose: it stays on
//! the shelf (kept even when normal) until that time or until unshelved, and
//! follows its condition meanwhile; taken off the shelf, it shows its true state.
//! A one-shot shelf also ends when the alarm's condition ends (ISA-18.2's
//! one-shot shelving, OPC UA's OneShotShelve).
//! Who acknowledged or shelved, and when, is recorded. Time is an argument.
//! A kind may have an on-delay: its condition must hold that long before it
//! is an alarm (a broker still connecting at start-up is none).

use std::collections::BTreeMap;
use std::fmt;

use serde::{Deserialize, Serialize};

use crate::actuator::{Availability, DeviceHealth};
use crate::clearance::{cut, Attribution};
use crate::code::Code;
use crate::text::quote;
use crate::time::{ms, Millis};

/// The most conditions one observation may report.
pub const MAX_CONDITIONS: usize = 10_000;
/// The most alarms kept (active, returned unacknowledged or shelved).
pub const MAX_ALARMS: usize = 2 * MAX_CONDITIONS;
/// The longest subject kept; longer ones are cut.
pub const SUBJECT_MAX_CHARS: usize = 200;
/// The longest text kept; longer ones are cut.
pub const TEXT_MAX_CHARS: usize = 500;
/// The longest a shelf may last: a shelved alarm must come back.
pub const MAX_SHELVE_MS: Millis = ms(7 * 24 * 3600 * 1000);

/// What is abnormal.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AlarmKind {
    /// A line is faulted (an operation faulted, an e-stop, a state lost at restart).
    LineFaulted,
    /// A device has gone offline (its last will, or no feedback at all).
    DeviceOffline,
    /// A device is online but some of its actuators' feedback is stale.
    DeviceStale,
    /// An actuators node has lost its broker.
    BusDisconnected,
    /// The interlock's state cannot be written to its store.
    StateNotSaved,
    /// An operation has waited longer than the interlock's warning time.
    WaitingLong,
    /// An operation has held its lines longer than the interlock's warning time.
    HeldLong,
    /// A hot standby took over: its subject is the instance now active.
    Failover,
    /// A member of the hot standby's etcd cluster does not answer.
    EtcdMemberDown,
}

/// How long a lost broker must stay lost before it is an alarm: Node-RED connects after the flows start.
pub const BUS_ON_DELAY_MS: Millis = ms(10_000);
/// How long an etcd member must stay silent before it is an alarm: one health check missed is none.
pub const ETCD_MEMBER_ON_DELAY_MS: Millis = ms(5_000);

impl AlarmKind {
    /// How long its condition must hold before it is an alarm.
    pub fn on_delay_ms(self) -> Millis {
        match self {
            Self::BusDisconnected => BUS_ON_DELAY_MS,
            Self::EtcdMemberDown => ETCD_MEMBER_ON_DELAY_MS,
            _ => Millis::ZERO,
        }
    }

    /// Every kind.
    pub const ALL: [AlarmKind; 9] = [
        Self::LineFaulted,
        Self::DeviceOffline,
        Self::DeviceStale,
        Self::BusDisconnected,
        Self::StateNotSaved,
        Self::WaitingLong,
        Self::HeldLong,
        Self::Failover,
        Self::EtcdMemberDown,
    ];

    /// Its priority as OPC UA's Severity (1 to 1000, most urgent highest):
    /// the safety state not saved first, then a line locked out, a device or
    /// the broker lost, the standby's etcd short of a member, stale feedback,
    /// a failover done, and operations waiting or holding long.
    pub fn severity(self) -> u16 {
        match self {
            Self::StateNotSaved => 900,
            Self::LineFaulted => 800,
            Self::DeviceOffline | Self::BusDisconnected => 700,
            Self::EtcdMemberDown => 600,
            Self::DeviceStale => 500,
            Self::Failover => 400,
            Self::WaitingLong | Self::HeldLong => 300,
        }
    }

    /// Its name in alarm ids and JSON, e.g. `"line-faulted"`.
    pub fn name(self) -> &'static str {
        match self {
            Self::LineFaulted => "line-faulted",
            Self::DeviceOffline => "device-offline",
            Self::DeviceStale => "device-stale",
            Self::BusDisconnected => "bus-disconnected",
            Self::StateNotSaved => "state-not-saved",
            Self::WaitingLong => "waiting-long",
            Self::HeldLong => "held-long",
            Self::Failover => "failover",
            Self::EtcdMemberDown => "etcd-member-down",
        }
    }
}

/// Where an alarm stands, as ISA-18.2 names the states.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum AlarmState {
    /// Only a shelved alarm is kept in this state.
    #[serde(rename = "normal")]
    Normal,
    /// The condition holds; nobody has acknowledged it.
    #[serde(rename = "active-unacknowledged")]
    ActiveUnacked,
    /// The condition holds; a person acknowledged it.
    #[serde(rename = "active-acknowledged")]
    ActiveAcked,
    /// The condition is gone; nobody acknowledged it yet.
    #[serde(rename = "returned-unacknowledged")]
    ReturnedUnacked,
}

impl AlarmState {
    /// Whether its condition holds.
    pub fn is_active(self) -> bool {
        matches!(self, Self::ActiveUnacked | Self::ActiveAcked)
    }

    /// Whether it still needs a person's acknowledgement.
    pub fn is_unacked(self) -> bool {
        matches!(self, Self::ActiveUnacked | Self::ReturnedUnacked)
    }
}

/// An abnormal condition that holds now.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Condition {
    /// What is abnormal.
    pub kind: AlarmKind,
    /// What it is about: a line, a device, an operation.
    pub subject: String,
    /// One line for a person.
    #[serde(default)]
    pub text: String,
    /// Since when it holds, when the caller knows (a fault's time).
    #[serde(default)]
    pub since_ms: Option<Millis>,
}

impl Condition {
    /// The condition `kind` on `subject`, worded by [`Condition::wording`].
    pub fn new(kind: AlarmKind, subject: &str) -> Self {
        Condition {
            kind,
            subject: subject.to_owned(),
            text: Condition::wording(kind, subject),
            since_ms: None,
        }
    }

    /// The one line a condition reads as when its caller gave none: a bus
    /// or a store knows only which one it is.
    pub fn wording(kind: AlarmKind, subject: &str) -> String {
        let subject = quote(subject);
        match kind {
            AlarmKind::LineFaulted => format!("{subject} faulted"),
            AlarmKind::DeviceOffline => format!("device {subject} offline"),
            AlarmKind::DeviceStale => format!("device {subject}: stale feedback"),
            AlarmKind::BusDisconnected => format!("actuators node {subject} has lost its broker"),
            AlarmKind::StateNotSaved => {
                format!("the interlock state cannot be written to {subject}")
            }
            AlarmKind::WaitingLong => format!("operation {subject} waits long"),
            AlarmKind::HeldLong => format!("operation {subject} holds its lines long"),
            AlarmKind::Failover => format!("failover: instance {subject} took over"),
            AlarmKind::EtcdMemberDown => format!("etcd member {subject} does not answer"),
        }
    }

    /// A device's condition, if it has one: offline, else stale feedback
    /// from some of its actuators (named).
    pub fn of_device(health: &DeviceHealth) -> Option<Self> {
        match health.state() {
            Availability::Offline => {
                return Some(Condition::new(AlarmKind::DeviceOffline, &health.device))
            }
            Availability::Online => return None,
            Availability::Stale => {}
        }
        let mut condition = Condition::new(AlarmKind::DeviceStale, &health.device);
        condition.text = format!(
            "device {}: stale feedback from {}",
            quote(&health.device),
            health.stale.join(", ")
        );
        Some(condition)
    }
}

/// The conditions of a plant's devices ([`Condition::of_device`]), in plant order.
pub fn device_conditions(devices: &[DeviceHealth]) -> Vec<Condition> {
    devices.iter().filter_map(Condition::of_device).collect()
}

/// Who did something to an alarm, and when.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Stamp {
    /// Who.
    pub by: String,
    /// When, in ms since the epoch.
    pub at_ms: Millis,
    /// Why, when they said.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
}

impl Stamp {
    fn new(who: &Attribution, at_ms: Millis) -> Self {
        Stamp {
            by: who.by.clone(),
            at_ms,
            reason: who.reason.clone(),
        }
    }
}

/// A shelving: who put the alarm aside, when, and until when.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Shelf {
    /// Who.
    pub by: String,
    /// When, in ms since the epoch.
    pub at_ms: Millis,
    /// When it comes back off the shelf, in ms since the epoch.
    pub until_ms: Millis,
    /// Why, when they said.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    /// It also ends when the alarm's condition ends.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub one_shot: bool,
}

/// One listed alarm.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Alarm {
    /// `kind:subject`.
    pub id: String,
    /// What is abnormal.
    pub kind: AlarmKind,
    /// What it is about.
    pub subject: String,
    /// One line for a person.
    pub text: String,
    /// Where it stands.
    pub state: AlarmState,
    /// When its condition last began.
    pub active_since_ms: Millis,
    /// When its state last changed.
    pub changed_ms: Millis,
    /// The acknowledgement of the current activation.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub acked: Option<Stamp>,
    /// Its shelving, while shelved.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shelved: Option<Shelf>,
}

/// What moved an alarm.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AlarmAction {
    /// Its condition began or ended.
    Condition,
    /// A person acknowledged it.
    Acknowledge,
    /// A person shelved it.
    Shelve,
    /// A person took it off the shelf.
    Unshelve,
    /// Its shelf's time ran out.
    ShelfExpired,
}

/// One change of one alarm, for an event list.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct AlarmChange {
    /// The alarm's id.
    pub id: String,
    /// What moved it.
    pub action: AlarmAction,
    /// Its state before.
    pub from: AlarmState,
    /// Its state after.
    pub to: AlarmState,
    /// When, in ms since the epoch.
    pub at_ms: Millis,
    /// Who, for a person's action.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub by: Option<String>,
    /// Why, when they said.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
}

/// Why an alarm request was refused.
#[derive(Clone, Debug, PartialEq)]
pub enum AlarmError {
    /// No alarm with this id is listed.
    UnknownAlarm {
        /// The id asked for.
        id: String,
    },
    /// A shelve time that is past or too far ahead.
    InvalidShelf {
        /// What is wrong with it.
        reason: String,
    },
    /// More conditions or alarms than are kept.
    TooMany {
        /// How many there were.
        count: usize,
        /// How many are kept.
        max: usize,
    },
    /// A saved form that cannot be restored.
    InvalidSnapshot {
        /// What is wrong with it.
        reason: String,
    },
}

impl AlarmError {
    /// Its code, as Catch nodes see it.
    pub fn code(&self) -> Code {
        match self {
            Self::UnknownAlarm { .. } => Code::UnknownAlarm,
            Self::InvalidShelf { .. } => Code::InvalidShelf,
            Self::TooMany { .. } => Code::TooManyAlarms,
            Self::InvalidSnapshot { .. } => Code::InvalidSnapshot,
        }
    }
}

impl fmt::Display for AlarmError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::UnknownAlarm { id } => write!(
                f,
                "no alarm {} is listed (it may have returned to normal and been acknowledged)",
                quote(id)
            ),
            Self::InvalidShelf { reason } => write!(f, "cannot shelve: {reason}"),
            Self::TooMany { count, max } => {
                write!(f, "{count} alarms, more than the {max} kept; refused")
            }
            Self::InvalidSnapshot { reason } => write!(f, "cannot restore the alarms: {reason}"),
        }
    }
}

impl std::error::Error for AlarmError {}

/// The saved form: every kept alarm.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct AlarmsSnapshot {
    /// Every kept alarm.
    pub alarms: Vec<Alarm>,
}

/// The alarms of one interlock and its plant.
#[derive(Clone, Debug, Default)]
pub struct Alarms {
    alarms: BTreeMap<String, Alarm>,
    /// Conditions held for less than their kind's on-delay, by id: since when (not saved).
    delayed: BTreeMap<String, Millis>,
}

/// The id of the alarm for `kind` on `subject`: `kind:subject`.
pub fn alarm_id(kind: AlarmKind, subject: &str) -> String {
    format!("{}:{}", kind.name(), subject)
}

impl Alarms {
    /// No alarms.
    pub fn new() -> Self {
        Self::default()
    }

    /// Every kept alarm, by id.
    pub fn list(&self) -> impl Iterator<Item = &Alarm> {
        self.alarms.values()
    }

    /// The alarm with this id, if listed.
    pub fn get(&self, id: &str) -> Option<&Alarm> {
        self.alarms.get(id)
    }

    /// Whether a condition waits out its kind's on-delay.
    pub fn has_delayed(&self) -> bool {
        !self.delayed.is_empty()
    }

    /// When the next shelf runs out, if any alarm is shelved.
    pub fn next_expiry_ms(&self) -> Option<Millis> {
        self.alarms
            .values()
            .filter_map(|a| a.shelved.as_ref().map(|s| s.until_ms))
            .min()
    }

    /// The conditions that hold at `now` (every other one does not): alarms
    /// activate, return to normal, and shelves past their time run out.
    /// Refused whole, nothing changed, past [`MAX_CONDITIONS`] or [`MAX_ALARMS`].
    pub fn observe(
        &mut self,
        conditions: &[Condition],
        now: Millis,
    ) -> Result<Vec<AlarmChange>, AlarmError> {
        if conditions.len() > MAX_CONDITIONS {
            return Err(AlarmError::TooMany {
                count: conditions.len(),
                max: MAX_CONDITIONS,
            });
        }
        let mut holding: BTreeMap<String, &Condition> = BTreeMap::new();
        for c in conditions {
            let subject = cut(&c.subject, SUBJECT_MAX_CHARS);
            holding.entry(alarm_id(c.kind, &subject)).or_insert(c);
        }
        let kept = self.alarms.len()
            + holding
                .keys()
                .filter(|id| !self.alarms.contains_key(*id))
                .count();
        if kept > MAX_ALARMS {
            return Err(AlarmError::TooMany {
                count: kept,
                max: MAX_ALARMS,
            });
        }
        let mut changes = self.expire(now);
        let ids: Vec<String> = self.alarms.keys().cloned().collect();
        for id in ids {
            if holding.contains_key(&id) {
                continue;
            }
            let alarm = self.alarms.get_mut(&id).expect("listed");
            let to = match alarm.state {
                AlarmState::ActiveUnacked => AlarmState::ReturnedUnacked,
                AlarmState::ActiveAcked => AlarmState::Normal,
                _ => continue,
            };
            let one_shot = alarm.shelved.as_ref().is_some_and(|s| s.one_shot);
            changes.push(self.shift(&id, to, AlarmAction::Condition, None, now));
            if one_shot {
                changes.extend(self.take_off_shelf(&id, AlarmAction::ShelfExpired, None, now));
            }
        }
        self.delayed.retain(|id, _| holding.contains_key(id));
        for (id, c) in holding {
            let text = if c.text.is_empty() {
                Condition::wording(c.kind, &c.subject)
            } else {
                c.text.clone()
            };
            let text = cut(&text, TEXT_MAX_CHARS);
            let mut since = c.since_ms.filter(|&t| t <= now).unwrap_or(now);
            if !self.alarms.contains_key(&id) && c.kind.on_delay_ms() > Millis::ZERO {
                let first = *self.delayed.entry(id.clone()).or_insert(since);
                if now.saturating_sub(first) < c.kind.on_delay_ms() {
                    continue;
                }
                self.delayed.remove(&id);
                since = first;
            }
            match self.alarms.get_mut(&id) {
                Some(alarm) if alarm.state.is_active() => alarm.text = text,
                Some(alarm) => {
                    alarm.text = text;
                    alarm.acked = None;
                    alarm.active_since_ms = now;
                    changes.push(self.shift(
                        &id,
                        AlarmState::ActiveUnacked,
                        AlarmAction::Condition,
                        None,
                        now,
                    ));
                }
                None => {
                    let subject = cut(&c.subject, SUBJECT_MAX_CHARS);
                    self.alarms.insert(
                        id.clone(),
                        Alarm {
                            id: id.clone(),
                            kind: c.kind,
                            subject,
                            text,
                            state: AlarmState::ActiveUnacked,
                            active_since_ms: since,
                            changed_ms: now,
                            acked: None,
                            shelved: None,
                        },
                    );
                    changes.push(AlarmChange {
                        id,
                        action: AlarmAction::Condition,
                        from: AlarmState::Normal,
                        to: AlarmState::ActiveUnacked,
                        at_ms: now,
                        by: None,
                        reason: None,
                    });
                }
            }
        }
        Ok(changes)
    }

    /// Acknowledges the named alarms, or every unacknowledged one when `ids`
    /// is `None`. Acknowledging an acknowledged alarm changes nothing; an id
    /// not listed refuses the whole request.
    pub fn acknowledge(
        &mut self,
        ids: Option<&[String]>,
        who: &Attribution,
        now: Millis,
    ) -> Result<Vec<AlarmChange>, AlarmError> {
        if let Some(ids) = ids {
            self.require(ids)?;
        }
        let mut changes = self.expire(now);
        let targets: Vec<String> = match ids {
            Some(ids) => ids.to_vec(),
            None => self.alarms.keys().cloned().collect(),
        };
        for id in targets {
            let Some(alarm) = self.alarms.get_mut(&id) else {
                continue; // named twice and gone after the first
            };
            let to = match alarm.state {
                AlarmState::ActiveUnacked => AlarmState::ActiveAcked,
                AlarmState::ReturnedUnacked => AlarmState::Normal,
                _ => continue,
            };
            alarm.acked = Some(Stamp::new(who, now));
            changes.push(self.shift(&id, to, AlarmAction::Acknowledge, Some(who), now));
        }
        Ok(changes)
    }

    /// Shelves a listed alarm until `until_ms` (later than `now`, at most
    /// [`MAX_SHELVE_MS`] ahead); shelving a shelved alarm sets its new time.
    pub fn shelve(
        &mut self,
        id: &str,
        until_ms: Millis,
        who: &Attribution,
        now: Millis,
    ) -> Result<Vec<AlarmChange>, AlarmError> {
        self.put_on_shelf(id, until_ms, false, who, now)
    }

    /// Shelves a listed alarm as [`Alarms::shelve`] does, and until its
    /// condition next ends (one-shot shelving), whichever comes first.
    pub fn shelve_one_shot(
        &mut self,
        id: &str,
        until_ms: Millis,
        who: &Attribution,
        now: Millis,
    ) -> Result<Vec<AlarmChange>, AlarmError> {
        self.put_on_shelf(id, until_ms, true, who, now)
    }

    fn put_on_shelf(
        &mut self,
        id: &str,
        until_ms: Millis,
        one_shot: bool,
        who: &Attribution,
        now: Millis,
    ) -> Result<Vec<AlarmChange>, AlarmError> {
        self.require(&[id.to_owned()])?;
        if until_ms <= now {
            return Err(AlarmError::InvalidShelf {
                reason: format!("the shelf must end after now ({now} ms), got {until_ms} ms"),
            });
        }
        if until_ms.saturating_sub(now) > MAX_SHELVE_MS {
            return Err(AlarmError::InvalidShelf {
                reason: format!(
                    "a shelf lasts at most {} h, asked for {} h",
                    hours(MAX_SHELVE_MS),
                    hours(until_ms.saturating_sub(now))
                ),
            });
        }
        let mut changes = self.expire(now);
        let Some(alarm) = self.alarms.get_mut(id) else {
            // Its shelf just ran out and it was normal: nothing to shelve now.
            return Err(AlarmError::UnknownAlarm { id: id.to_owned() });
        };
        alarm.shelved = Some(Shelf {
            by: who.by.clone(),
            at_ms: now,
            until_ms,
            reason: who.reason.clone(),
            one_shot,
        });
        let state = alarm.state;
        changes.push(AlarmChange {
            id: id.to_owned(),
            action: AlarmAction::Shelve,
            from: state,
            to: state,
            at_ms: now,
            by: Some(who.by.clone()),
            reason: who.reason.clone(),
        });
        Ok(changes)
    }

    /// Takes a listed alarm off its shelf (nothing changes if it was not shelved).
    pub fn unshelve(
        &mut self,
        id: &str,
        who: &Attribution,
        now: Millis,
    ) -> Result<Vec<AlarmChange>, AlarmError> {
        self.require(&[id.to_owned()])?;
        let mut changes = self.expire(now);
        if let Some(change) = self.take_off_shelf(id, AlarmAction::Unshelve, Some(who), now) {
            changes.push(change);
        }
        Ok(changes)
    }

    /// The saved form.
    pub fn snapshot(&self) -> AlarmsSnapshot {
        AlarmsSnapshot {
            alarms: self.alarms.values().cloned().collect(),
        }
    }

    /// The alarms as saved, checked: bounded, ids matching kind and subject,
    /// a normal alarm only on a shelf.
    pub fn restore(snapshot: AlarmsSnapshot) -> Result<Self, AlarmError> {
        let invalid = |reason: String| AlarmError::InvalidSnapshot { reason };
        if snapshot.alarms.len() > MAX_ALARMS {
            return Err(invalid(format!(
                "{} alarms, more than {MAX_ALARMS}",
                snapshot.alarms.len()
            )));
        }
        let mut alarms = BTreeMap::new();
        for alarm in snapshot.alarms {
            if alarm.id != alarm_id(alarm.kind, &alarm.subject) {
                return Err(invalid(format!(
                    "alarm {} does not match its kind and subject",
                    quote(&alarm.id)
                )));
            }
            if alarm.subject.chars().count() > SUBJECT_MAX_CHARS
                || alarm.text.chars().count() > TEXT_MAX_CHARS
            {
                return Err(invalid(format!(
                    "alarm {} has a subject or text too long",
                    quote(&alarm.id)
                )));
            }
            if alarm.state == AlarmState::Normal && alarm.shelved.is_none() {
                return Err(invalid(format!(
                    "alarm {} is normal and not shelved",
                    quote(&alarm.id)
                )));
            }
            if alarms.insert(alarm.id.clone(), alarm).is_some() {
                return Err(invalid("an alarm is listed twice".into()));
            }
        }
        Ok(Alarms {
            alarms,
            delayed: BTreeMap::new(),
        })
    }

    fn require(&self, ids: &[String]) -> Result<(), AlarmError> {
        match ids.iter().find(|id| !self.alarms.contains_key(*id)) {
            Some(id) => Err(AlarmError::UnknownAlarm { id: id.clone() }),
            None => Ok(()),
        }
    }

    /// Shelves whose time has come.
    fn expire(&mut self, now: Millis) -> Vec<AlarmChange> {
        let due: Vec<String> = self
            .alarms
            .values()
            .filter(|a| a.shelved.as_ref().is_some_and(|s| s.until_ms <= now))
            .map(|a| a.id.clone())
            .collect();
        due.iter()
            .filter_map(|id| self.take_off_shelf(id, AlarmAction::ShelfExpired, None, now))
            .collect()
    }

    fn take_off_shelf(
        &mut self,
        id: &str,
        action: AlarmAction,
        who: Option<&Attribution>,
        now: Millis,
    ) -> Option<AlarmChange> {
        let alarm = self.alarms.get_mut(id)?;
        alarm.shelved.take()?;
        let state = alarm.state;
        if state == AlarmState::Normal {
            self.alarms.remove(id);
        }
        Some(AlarmChange {
            id: id.to_owned(),
            action,
            from: state,
            to: state,
            at_ms: now,
            by: who.map(|w| w.by.clone()),
            reason: who.and_then(|w| w.reason.clone()),
        })
    }

    /// Moves alarm `id` to `to`; a normal alarm off the shelf leaves the list.
    fn shift(
        &mut self,
        id: &str,
        to: AlarmState,
        action: AlarmAction,
        who: Option<&Attribution>,
        now: Millis,
    ) -> AlarmChange {
        let alarm = self.alarms.get_mut(id).expect("listed");
        let from = alarm.state;
        alarm.state = to;
        alarm.changed_ms = now;
        if to == AlarmState::Normal && alarm.shelved.is_none() {
            self.alarms.remove(id);
        }
        AlarmChange {
            id: id.to_owned(),
            action,
            from,
            to,
            at_ms: now,
            by: who.map(|w| w.by.clone()),
            reason: who.and_then(|w| w.reason.clone()),
        }
    }
}

/// Whole hours in `duration`, rounded down.
fn hours(duration: Millis) -> f64 {
    (duration.as_f64() / 3_600_000.0).floor()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn faulted(line: &str) -> Condition {
        Condition {
            kind: AlarmKind::LineFaulted,
            subject: line.into(),
            text: format!("{line} faulted"),
            since_ms: Some(ms(5)),
        }
    }

    #[test]
    fn an_alarm_goes_round_the_isa_18_2_states() {
        let mut alarms = Alarms::new();
        let ana = Attribution::new(Some("ana"), Some("seen"), false);
        alarms.observe(&[faulted("YEL")], ms(10)).unwrap();
        let a = alarms.get("line-faulted:YEL").unwrap();
        assert_eq!(
            (a.state, a.active_since_ms),
            (AlarmState::ActiveUnacked, ms(5))
        );
        alarms.acknowledge(None, &ana, ms(20)).unwrap();
        let a = alarms.get("line-faulted:YEL").unwrap();
        assert_eq!(a.state, AlarmState::ActiveAcked);
        assert_eq!(
            a.acked,
            Some(Stamp {
                by: "ana".into(),
                at_ms: ms(20),
                reason: Some("seen".into())
            })
        );
        let changes = alarms.observe(&[], ms(30)).unwrap();
        assert_eq!(changes[0].to, AlarmState::Normal);
        assert!(
            alarms.get("line-faulted:YEL").is_none(),
            "normal and acknowledged: gone"
        );
        alarms.observe(&[faulted("YEL")], ms(40)).unwrap();
        alarms.observe(&[], ms(50)).unwrap();
        assert_eq!(
            alarms.get("line-faulted:YEL").unwrap().state,
            AlarmState::ReturnedUnacked
        );
        let changes = alarms
            .acknowledge(Some(&["line-faulted:YEL".into()]), &ana, ms(60))
            .unwrap();
        assert_eq!(
            (changes[0].from, changes[0].to),
            (AlarmState::ReturnedUnacked, AlarmState::Normal)
        );
        assert_eq!(alarms.list().count(), 0);
    }

    #[test]
    fn a_shelf_keeps_the_alarm_until_its_time_then_shows_its_true_state() {
        let mut alarms = Alarms::new();
        let bo = Attribution::new(Some("bo"), None, false);
        alarms.observe(&[faulted("RED")], ms(0)).unwrap();
        let id = "line-faulted:RED";
        assert_eq!(
            alarms.shelve(id, ms(0), &bo, ms(0)).unwrap_err().code(),
            "INVALID_SHELF"
        );
        assert_eq!(
            alarms
                .shelve(id, MAX_SHELVE_MS.saturating_add(ms(1)), &bo, ms(0))
                .unwrap_err()
                .code(),
            "INVALID_SHELF"
        );
        alarms.shelve(id, ms(1000), &bo, ms(0)).unwrap();
        alarms.observe(&[], ms(100)).unwrap();
        alarms.acknowledge(None, &bo, ms(200)).unwrap();
        assert_eq!(
            alarms.get(id).unwrap().state,
            AlarmState::Normal,
            "kept on its shelf"
        );
        alarms.observe(&[faulted("RED")], ms(300)).unwrap();
        assert_eq!(alarms.next_expiry_ms(), Some(ms(1000)));
        let changes = alarms.observe(&[faulted("RED")], ms(1000)).unwrap();
        assert_eq!(changes[0].action, AlarmAction::ShelfExpired);
        let a = alarms.get(id).unwrap();
        assert_eq!(
            (a.state, a.shelved.is_none()),
            (AlarmState::ActiveUnacked, true)
        );
        assert_eq!(
            alarms.unshelve("nope", &bo, ms(1001)).unwrap_err().code(),
            "UNKNOWN_ALARM"
        );
    }

    #[test]
    fn every_kind_has_a_severity_in_opc_ua_range_and_is_listed_once() {
        let names: std::collections::BTreeSet<&str> =
            AlarmKind::ALL.iter().map(|k| k.name()).collect();
        assert_eq!(names.len(), AlarmKind::ALL.len());
        for kind in AlarmKind::ALL {
            assert!((1..=1000).contains(&kind.severity()), "{kind:?}");
            let back: AlarmKind = serde_json::from_value(serde_json::json!(kind.name())).unwrap();
            assert_eq!(back, kind);
        }
        assert!(AlarmKind::StateNotSaved.severity() > AlarmKind::WaitingLong.severity());
    }

    #[test]
    fn a_one_shot_shelf_ends_with_the_condition_or_its_time() {
        let mut alarms = Alarms::new();
        let bo = Attribution::new(Some("bo"), None, false);
        let id = "line-faulted:RED";
        alarms.observe(&[faulted("RED")], ms(0)).unwrap();
        alarms.shelve_one_shot(id, ms(1000), &bo, ms(10)).unwrap();
        assert!(alarms.get(id).unwrap().shelved.as_ref().unwrap().one_shot);
        alarms.observe(&[faulted("RED")], ms(20)).unwrap();
        assert!(
            alarms.get(id).unwrap().shelved.is_some(),
            "still active: still shelved"
        );
        let changes = alarms.observe(&[], ms(30)).unwrap();
        let actions: Vec<AlarmAction> = changes.iter().map(|c| c.action).collect();
        assert_eq!(actions, [AlarmAction::Condition, AlarmAction::ShelfExpired]);
        let a = alarms.get(id).unwrap();
        assert_eq!(
            (a.state, a.shelved.is_none()),
            (AlarmState::ReturnedUnacked, true)
        );
        // Shelved while returned: it waits for the next end of its condition.
        alarms.shelve_one_shot(id, ms(1000), &bo, ms(40)).unwrap();
        alarms.observe(&[faulted("RED")], ms(50)).unwrap();
        assert!(alarms.get(id).unwrap().shelved.is_some());
        let changes = alarms.observe(&[faulted("RED")], ms(1000)).unwrap();
        assert_eq!(
            changes[0].action,
            AlarmAction::ShelfExpired,
            "its time ran out first"
        );
    }

    /// `condition` observed from 0 until just before `on_delay`: no alarm yet.
    fn quiet_until_on_delay(
        alarms: &mut Alarms,
        condition: &Condition,
        on_delay: Millis,
        why: &str,
    ) {
        let held = std::slice::from_ref(condition);
        alarms.observe(held, ms(0)).unwrap();
        alarms
            .observe(held, on_delay.saturating_sub(ms(1)))
            .unwrap();
        assert_eq!(alarms.list().count(), 0, "{why}");
    }

    #[test]
    fn a_lost_broker_is_an_alarm_only_once_lost_for_its_on_delay() {
        let mut alarms = Alarms::new();
        let lost = Condition {
            kind: AlarmKind::BusDisconnected,
            subject: "all devices".into(),
            text: "lost".into(),
            since_ms: None,
        };
        quiet_until_on_delay(&mut alarms, &lost, BUS_ON_DELAY_MS, "still connecting");
        alarms.observe(&[], BUS_ON_DELAY_MS).unwrap();
        alarms
            .observe(
                std::slice::from_ref(&lost),
                BUS_ON_DELAY_MS.saturating_add(ms(1)),
            )
            .unwrap();
        assert_eq!(alarms.list().count(), 0, "the delay starts again");
        alarms
            .observe(
                std::slice::from_ref(&lost),
                ms(2 * BUS_ON_DELAY_MS.as_u64() + 1),
            )
            .unwrap();
        let a = alarms.get("bus-disconnected:all devices").unwrap();
        assert_eq!(
            (a.state, a.active_since_ms),
            (
                AlarmState::ActiveUnacked,
                BUS_ON_DELAY_MS.saturating_add(ms(1))
            )
        );
    }

    #[test]
    fn too_many_conditions_are_refused_whole() {
        let mut alarms = Alarms::new();
        let many: Vec<Condition> = (0..=MAX_CONDITIONS)
            .map(|i| faulted(&i.to_string()))
            .collect();
        assert_eq!(
            alarms.observe(&many, ms(0)).unwrap_err().code(),
            "TOO_MANY_ALARMS"
        );
        assert_eq!(alarms.list().count(), 0);
    }

    #[test]
    fn a_snapshot_restores_and_a_bad_one_is_refused() {
        let mut alarms = Alarms::new();
        alarms.observe(&[faulted("YEL")], ms(10)).unwrap();
        alarms
            .acknowledge(None, &Attribution::new(Some("ana"), None, false), ms(11))
            .unwrap();
        let text = serde_json::to_string(&alarms.snapshot()).unwrap();
        let back = Alarms::restore(serde_json::from_str(&text).unwrap()).unwrap();
        assert_eq!(back.snapshot(), alarms.snapshot());
        let mut bad = alarms.snapshot();
        bad.alarms[0].id = "device-offline:YEL".into();
        assert_eq!(Alarms::restore(bad).unwrap_err().code(), "INVALID_SNAPSHOT");
    }

    #[test]
    fn devices_buses_and_stores_are_worded_here_not_by_the_caller() {
        let health = |device: &str, online: bool, stale: &[&str]| DeviceHealth {
            device: device.into(),
            online,
            stale: stale.iter().map(|s| s.to_string()).collect(),
        };
        let conditions = device_conditions(&[
            health("ctrl-1", false, &["V101"]),
            health("ctrl-2", true, &[]),
            health("ctrl-3", true, &["V301", "P3"]),
        ]);
        let texts: Vec<(AlarmKind, &str)> = conditions
            .iter()
            .map(|c| (c.kind, c.text.as_str()))
            .collect();
        assert_eq!(
            texts,
            [
                (AlarmKind::DeviceOffline, "device ctrl-1 offline"),
                (
                    AlarmKind::DeviceStale,
                    "device ctrl-3: stale feedback from V301, P3"
                ),
            ]
        );
        // A condition handed over without text is worded by its kind and subject.
        let mut alarms = Alarms::new();
        let bare = |kind, subject: &str| Condition {
            kind,
            subject: subject.into(),
            text: String::new(),
            since_ms: None,
        };
        alarms
            .observe(&[bare(AlarmKind::StateNotSaved, "/data/sugarshack")], ms(0))
            .unwrap();
        assert_eq!(
            alarms.get("state-not-saved:/data/sugarshack").unwrap().text,
            "the interlock state cannot be written to /data/sugarshack"
        );
        assert_eq!(
            Condition::new(AlarmKind::BusDisconnected, "plant bus").text,
            "actuators node plant bus has lost its broker"
        );
    }

    #[test]
    fn a_failover_seen_once_stays_listed_until_a_person_acknowledges_it() {
        let mut alarms = Alarms::new();
        let took_over = Condition::new(AlarmKind::Failover, "edge-b");
        assert_eq!(took_over.text, "failover: instance edge-b took over");
        alarms.observe(&[took_over], ms(0)).unwrap();
        alarms.observe(&[], ms(1_000)).unwrap();
        let a = alarms.get("failover:edge-b").unwrap();
        assert_eq!(
            a.state,
            AlarmState::ReturnedUnacked,
            "the takeover is over, nobody has seen it"
        );
        let bo = Attribution::new(Some("bo"), None, false);
        alarms
            .acknowledge(Some(&["failover:edge-b".to_owned()]), &bo, ms(2_000))
            .unwrap();
        assert_eq!(alarms.list().count(), 0);
    }

    #[test]
    fn an_etcd_member_is_down_only_once_silent_for_its_on_delay() {
        let mut alarms = Alarms::new();
        let down = Condition::new(AlarmKind::EtcdMemberDown, "http://10.0.0.5:2379");
        quiet_until_on_delay(
            &mut alarms,
            &down,
            ETCD_MEMBER_ON_DELAY_MS,
            "one health check missed",
        );
        alarms
            .observe(std::slice::from_ref(&down), ETCD_MEMBER_ON_DELAY_MS)
            .unwrap();
        let a = alarms.get("etcd-member-down:http://10.0.0.5:2379").unwrap();
        assert_eq!(a.text, "etcd member http://10.0.0.5:2379 does not answer");
    }
}
