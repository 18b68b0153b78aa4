//! The tracker against a reference model of one valve's life (commands,
//! lockouts standing until confirmed, samples, ticks, its device going
//! offline and back, the MQTT path restored), with time steps chosen around
//! every threshold, and batches against single samples.

use proptest::prelude::*;
use serde_json::json;
use sugarshack_core::actuator::{
    ActuatorId, Counts, DeviceId, Effect, FaultKind, Phase, Terms, Tracker,
};
use sugarshack_core::plant::PlantModel;
use sugarshack_core::time::ms;

const TOLERANCE: f64 = 2.0;
const NO_MOTION_MS: u64 = 1000;
const COMPLETION_MS: u64 = 3000;
const STALE_MS: u64 = 2500;
const RETRIES: u32 = 1;

fn plant(valves_per_device: u32, devices: u32) -> PlantModel {
    plant_reporting(valves_per_device, devices, "periodic")
}

/// `reports`: "periodic" (silence is staleness) or "on-change" (its devices publish only on change).
fn plant_reporting(valves_per_device: u32, devices: u32, reports: &str) -> PlantModel {
    let actuators: Vec<_> = (1..=devices)
        .flat_map(|d| {
            (1..=valves_per_device).map(move |io| {
                json!({ "id": format!("V{d}{io}"), "type": "valve", "device": format!("ctrl-{d}"), "io": io, "idle": 0, "lockout": 0 })
            })
        })
        .collect();
    let devices: Vec<_> = (1..=devices)
        .map(|d| json!({ "id": format!("ctrl-{d}"), "kind": "actuator-panel", "reports": reports }))
        .collect();
    serde_json::from_value(json!({
        "actuatorTypes": { "valve": { "signal": "analog", "tolerance": TOLERANCE, "noMotionMs": NO_MOTION_MS,
            "completionMs": COMPLETION_MS, "staleMs": STALE_MS, "retries": RETRIES } },
        "devices": devices,
        "actuators": actuators
    }))
    .unwrap()
}

#[derive(Clone, Debug)]
enum Step {
    /// A command to a target, its caller waiting this long (if it gives up).
    Command(f64, Option<u64>),
    /// A lockout to a target, answering a fault raised this long before (if it answers one).
    Lockout(f64, Option<u64>),
    Sample(f64),
    Tick,
    Offline,
    Online,
    PathRestored,
}

fn step() -> impl Strategy<Value = Step> {
    prop_oneof![
        2 => (prop::sample::select(vec![0.0, 50.0, 100.0]), prop::sample::select(vec![None, Some(0), Some(1500), Some(4000)]))
            .prop_map(|(target, timeout)| Step::Command(target, timeout)),
        1 => (prop::sample::select(vec![0.0, 0.0, 50.0]), prop::sample::select(vec![None, Some(0), Some(250)]))
            .prop_map(|(target, lead)| Step::Lockout(target, lead)),
        5 => prop::sample::select(vec![0.0, 1.5, 2.0, 2.5, 30.0, 50.0, 97.0, 98.0, 98.5, 100.0]).prop_map(Step::Sample),
        4 => Just(Step::Tick),
        1 => Just(Step::Offline),
        1 => Just(Step::Online),
        1 => Just(Step::PathRestored),
    ]
}

/// Time steps at and around each threshold.
fn gap() -> impl Strategy<Value = u64> {
    prop::sample::select(vec![
        0, 1, 499, 999, 1000, 1001, 1500, 2499, 2500, 2501, 2999, 3000, 3001,
    ])
}

/// What the model and the tracker are compared on.
#[derive(Clone, Debug, PartialEq)]
enum Seen {
    Refused(&'static str),
    Publish {
        payload: String,
        retain: bool,
    },
    Moving {
        caller: u64,
        after: u64,
    },
    Completed {
        caller: u64,
        motion: u64,
        completion: u64,
        retries: u32,
        timed: bool,
    },
    GroupCompleted {
        caller: u64,
        after: u64,
        fault_lockout: Option<u64>,
    },
    GroupFailed {
        caller: u64,
        fault: FaultKind,
        retries: u32,
    },
    GroupTimedOut {
        caller: u64,
        timeout: u64,
    },
    Retry {
        caller: u64,
        attempt: u32,
        fault: FaultKind,
    },
    Fault(FaultKind),
    Recovered(FaultKind),
    Changed(f64),
    LockoutConfirmed {
        after: u64,
        sends: u32,
    },
    LockoutResent {
        attempt: u32,
    },
}

struct Cmd {
    caller: u64,
    target: f64,
    start: Option<f64>,
    issued: u64,
    attempt: u64,
    moving: Option<u64>,
    retries: u32,
    fault_at: Option<u64>,
    /// Its timeout and when it runs out.
    deadline: Option<(u64, u64)>,
}

#[derive(Clone, Copy)]
struct Order {
    target: f64,
    since: u64,
    sends: u32,
    last_send: u64,
}

fn publish(target: f64, retain: bool) -> Seen {
    Seen::Publish {
        payload: format!("{target}"),
        retain,
    }
}

/// One valve as the issue describes it.
struct Model {
    /// Its device publishes on change only: never stale, liveness from its status.
    on_change: bool,
    position: Option<f64>,
    last_sample: u64,
    stale: bool,
    resting: Option<f64>,
    uncommanded: bool,
    online: bool,
    reported: Option<f64>,
    commanded: Option<f64>,
    /// The last command was a lockout, left retained on the broker.
    retained: bool,
    cmd: Option<Cmd>,
    order: Option<Order>,
}

impl Model {
    fn new(on_change: bool) -> Self {
        Model {
            on_change,
            position: None,
            last_sample: 0,
            stale: false,
            resting: None,
            uncommanded: false,
            online: true,
            reported: None,
            commanded: None,
            retained: false,
            cmd: None,
            order: None,
        }
    }

    fn at(&self, target: f64) -> bool {
        self.position
            .is_some_and(|p| (p - target).abs() <= TOLERANCE)
    }

    /// Sets the new command, or completes it at once where the valve already is.
    fn issue(
        &mut self,
        caller: u64,
        target: f64,
        (fault_at, timeout): (Option<u64>, Option<u64>),
        now: u64,
        seen: &mut Vec<Seen>,
    ) {
        self.commanded = Some(target);
        self.resting = Some(target);
        self.uncommanded = false;
        if self.at(target) && !self.stale && self.online {
            if let Some(order) = self.order.take() {
                seen.push(Seen::LockoutConfirmed {
                    after: now - order.since,
                    sends: order.sends,
                });
            }
            seen.push(Seen::Completed {
                caller,
                motion: 0,
                completion: 0,
                retries: 0,
                timed: false,
            });
            seen.push(Seen::GroupCompleted {
                caller,
                after: 0,
                fault_lockout: fault_at.map(|at| now.saturating_sub(at)),
            });
        } else {
            self.cmd = Some(Cmd {
                caller,
                target,
                start: self.position,
                issued: now,
                attempt: now,
                moving: None,
                retries: 0,
                fault_at,
                deadline: timeout.filter(|t| *t > 0).map(|t| (t, now + t)),
            });
        }
    }

    fn resend(&mut self, now: u64, seen: &mut Vec<Seen>) {
        if let Some(order) = self.order.as_mut() {
            order.sends += 1;
            order.last_send = now;
            seen.push(Seen::LockoutResent {
                attempt: order.sends - 1,
            });
            seen.push(publish(order.target, true));
        }
    }

    fn republish(&mut self, now: u64, seen: &mut Vec<Seen>) {
        if self.order.is_some() {
            self.resend(now, seen);
        } else if let Some(target) = self.commanded {
            seen.push(publish(target, self.retained));
        }
    }

    fn apply(&mut self, step: &Step, caller: u64, now: u64) -> Vec<Seen> {
        let mut seen = Vec::new();
        match *step {
            Step::Command(target, timeout) => {
                if self.order.is_some() {
                    return vec![Seen::Refused("LOCKOUT_PENDING")];
                }
                if self.cmd.is_some() {
                    return vec![Seen::Refused("STILL_MOVING")];
                }
                if !self.online {
                    return vec![Seen::Refused("DEVICE_OFFLINE")];
                }
                if self.retained {
                    seen.push(Seen::Publish {
                        payload: String::new(),
                        retain: true,
                    });
                }
                seen.push(publish(target, false));
                self.retained = false;
                self.issue(caller, target, (None, timeout), now, &mut seen);
            }
            Step::Lockout(target, lead) => {
                if let Some(old) = self.cmd.take() {
                    seen.push(Seen::GroupFailed {
                        caller: old.caller,
                        fault: FaultKind::LockedOut,
                        retries: old.retries,
                    });
                }
                seen.push(publish(target, true));
                self.retained = true;
                self.order = Some(match self.order {
                    Some(order) if order.target == target => Order {
                        sends: order.sends + 1,
                        last_send: now,
                        ..order
                    },
                    _ => Order {
                        target,
                        since: now,
                        sends: 1,
                        last_send: now,
                    },
                });
                let fault_at = lead.map(|lead| now.saturating_sub(lead));
                self.issue(caller, target, (fault_at, None), now, &mut seen);
            }
            Step::Sample(v) => {
                self.last_sample = now;
                if self.stale {
                    self.stale = false;
                    seen.push(Seen::Recovered(FaultKind::Stale));
                }
                if self.reported.is_none_or(|r| (v - r).abs() > TOLERANCE) {
                    self.reported = Some(v);
                    seen.push(Seen::Changed(v));
                }
                self.position = Some(v);
                if let Some(order) = self.order {
                    if self.online && (v - order.target).abs() <= TOLERANCE {
                        self.order = None;
                        seen.push(Seen::LockoutConfirmed {
                            after: now - order.since,
                            sends: order.sends,
                        });
                    }
                }
                match self.cmd.as_mut() {
                    None => {
                        let rest = *self.resting.get_or_insert(v);
                        let away = (v - rest).abs() > TOLERANCE;
                        if away && !self.uncommanded {
                            self.uncommanded = true;
                            seen.push(Seen::Fault(FaultKind::Uncommanded));
                        } else if !away && self.uncommanded {
                            self.uncommanded = false;
                            seen.push(Seen::Recovered(FaultKind::Uncommanded));
                        }
                    }
                    Some(cmd) => {
                        let start = *cmd.start.get_or_insert(v);
                        let arrived = (v - cmd.target).abs() <= TOLERANCE;
                        if cmd.moving.is_none() && ((v - start).abs() > TOLERANCE || arrived) {
                            cmd.moving = Some(now);
                            seen.push(Seen::Moving {
                                caller: cmd.caller,
                                after: now - cmd.issued,
                            });
                        }
                        if arrived {
                            let cmd = self.cmd.take().unwrap();
                            seen.push(Seen::Completed {
                                caller: cmd.caller,
                                motion: cmd.moving.unwrap() - cmd.issued,
                                completion: now - cmd.issued,
                                retries: cmd.retries,
                                timed: true,
                            });
                            seen.push(Seen::GroupCompleted {
                                caller: cmd.caller,
                                after: now - cmd.issued,
                                fault_lockout: cmd.fault_at.map(|at| now - at),
                            });
                        }
                    }
                }
            }
            Step::Tick => {
                // A caller that waited its timeout: the command is withdrawn, whatever the device.
                let due = self.cmd.as_ref().and_then(|c| c.deadline);
                if let Some((timeout, _)) = due.filter(|(_, at)| *at <= now) {
                    let cmd = self.cmd.take().unwrap();
                    seen.push(Seen::GroupTimedOut {
                        caller: cmd.caller,
                        timeout,
                    });
                }
                if !self.online {
                    return seen;
                }
                if !self.on_change && !self.stale && now - self.last_sample >= STALE_MS {
                    self.stale = true;
                    seen.push(Seen::Fault(FaultKind::Stale));
                    if let Some(cmd) = self.cmd.take() {
                        seen.push(Seen::GroupFailed {
                            caller: cmd.caller,
                            fault: FaultKind::Stale,
                            retries: cmd.retries,
                        });
                    }
                } else if let Some(cmd) = self.cmd.as_mut() {
                    let elapsed = now - cmd.attempt;
                    let fault = if cmd.moving.is_none() && elapsed >= NO_MOTION_MS {
                        Some(FaultKind::NoMotion)
                    } else if elapsed >= COMPLETION_MS {
                        Some(FaultKind::NotReached)
                    } else {
                        None
                    };
                    if let Some(fault) = fault {
                        if cmd.retries < RETRIES {
                            cmd.retries += 1;
                            cmd.attempt = now;
                            seen.push(Seen::Retry {
                                caller: cmd.caller,
                                attempt: cmd.retries,
                                fault,
                            });
                            seen.push(publish(cmd.target, self.retained));
                            if let Some(order) = self.order.as_mut() {
                                order.sends += 1;
                                order.last_send = now;
                            }
                        } else {
                            let cmd = self.cmd.take().unwrap();
                            seen.push(Seen::Fault(fault));
                            seen.push(Seen::GroupFailed {
                                caller: cmd.caller,
                                fault,
                                retries: cmd.retries,
                            });
                        }
                    }
                }
                if self
                    .order
                    .is_some_and(|o| now - o.last_send >= COMPLETION_MS)
                {
                    self.resend(now, &mut seen);
                }
            }
            Step::Offline => {
                if self.online {
                    self.online = false;
                    seen.push(Seen::Fault(FaultKind::DeviceOffline));
                    if let Some(cmd) = self.cmd.take() {
                        seen.push(Seen::GroupFailed {
                            caller: cmd.caller,
                            fault: FaultKind::DeviceOffline,
                            retries: cmd.retries,
                        });
                    }
                }
            }
            Step::Online => {
                if !self.online {
                    self.online = true;
                    self.republish(now, &mut seen);
                    self.last_sample = now;
                    if let Some(cmd) = self.cmd.as_mut() {
                        cmd.attempt = now;
                    }
                    seen.push(Seen::Recovered(FaultKind::DeviceOffline));
                }
            }
            Step::PathRestored => {
                self.republish(now, &mut seen);
                self.last_sample = now;
                if let Some(cmd) = self.cmd.as_mut() {
                    cmd.attempt = now;
                }
            }
        }
        seen
    }
}

fn observe(effects: Vec<Effect>) -> Vec<Seen> {
    effects
        .into_iter()
        .filter_map(|e| match e {
            Effect::Publish {
                payload, retain, ..
            } => Some(Seen::Publish { payload, retain }),
            Effect::Moving {
                caller,
                issue_to_motion_ms,
                ..
            } => Some(Seen::Moving {
                caller,
                after: issue_to_motion_ms.as_u64(),
            }),
            Effect::Completed {
                caller,
                issue_to_motion_ms,
                completion_ms,
                retries,
                timed,
                ..
            } => Some(Seen::Completed {
                caller,
                motion: issue_to_motion_ms.as_u64(),
                completion: completion_ms.as_u64(),
                retries,
                timed,
            }),
            Effect::GroupCompleted {
                caller,
                completion_ms,
                fault_lockout_ms,
                actuators,
            } => {
                let [reached] = actuators[..] else {
                    panic!("a completed group lists its one valve: {actuators:?}");
                };
                assert_eq!(
                    reached.completion_ms, completion_ms,
                    "the valve's completion is the group's"
                );
                Some(Seen::GroupCompleted {
                    caller,
                    after: completion_ms.as_u64(),
                    fault_lockout: fault_lockout_ms.map(|f| f.as_u64()),
                })
            }
            Effect::GroupFailed {
                caller,
                fault,
                retries,
                code,
                actuators,
                ..
            } => {
                assert_eq!(code, fault.code(), "a group fails with its fault's code");
                assert!(actuators.is_empty(), "its one valve never got there");
                Some(Seen::GroupFailed {
                    caller,
                    fault,
                    retries,
                })
            }
            Effect::GroupTimedOut {
                caller,
                timeout_ms,
                waiting,
                actuators,
            } => {
                assert_eq!(waiting.len(), 1, "the valve still waited for");
                assert!(actuators.is_empty(), "nothing else in its group");
                Some(Seen::GroupTimedOut {
                    caller,
                    timeout: timeout_ms.as_u64(),
                })
            }
            Effect::Retry {
                caller,
                attempt,
                fault,
                ..
            } => Some(Seen::Retry {
                caller,
                attempt,
                fault,
            }),
            Effect::Fault { fault, .. } => Some(Seen::Fault(fault)),
            Effect::Recovered { fault, .. } => Some(Seen::Recovered(fault)),
            Effect::Changed { value, .. } => Some(Seen::Changed(value)),
            Effect::LockoutConfirmed {
                after_ms, sends, ..
            } => Some(Seen::LockoutConfirmed {
                after: after_ms.as_u64(),
                sends,
            }),
            Effect::LockoutResent { attempt, .. } => Some(Seen::LockoutResent { attempt }),
            // The model's plant has no Modbus device.
            Effect::DeviceStatus { .. } | Effect::Write { .. } => None,
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1024, ..ProptestConfig::default() })]

    #[test]
    fn one_valve_follows_the_reference_model(steps in prop::collection::vec((gap(), step()), 1..80), on_change in any::<bool>()) {
        let reports = if on_change { "on-change" } else { "periodic" };
        let mut tracker = Tracker::new(plant_reporting(1, 1, reports), ms(0)).unwrap();
        let valve = tracker.actuator("V11").unwrap();
        let device = tracker.device("ctrl-1").unwrap();
        let mut model = Model::new(on_change);
        let mut now = 0;
        // When the tracker last published the lockout it stands by.
        let mut lockout_sent: Option<u64> = None;
        for (caller, (gap, step)) in steps.iter().enumerate() {
            now += gap;
            let caller = caller as u64;
            let expected = model.apply(step, caller, now);
            let actual = match *step {
                Step::Command(target, _) | Step::Lockout(target, _) => {
                    let terms = match *step {
                        Step::Lockout(_, lead) => Terms { lockout: true, fault_at: lead.map(|lead| ms(now.saturating_sub(lead))), timeout: None },
                        Step::Command(_, timeout) => Terms { timeout: timeout.map(ms), ..Terms::default() },
                        _ => unreachable!(),
                    };
                    match tracker.issue(&[(valve, target)], caller, terms, ms(now)) {
                        Ok(effects) => observe(effects),
                        Err(err) => vec![Seen::Refused(err.code().name())],
                    }
                }
                Step::Sample(v) => observe(tracker.feedback(valve, v, None, ms(now)).unwrap()),
                Step::Tick => observe(tracker.tick(ms(now))),
                Step::Offline => observe(tracker.device_status(device, false, ms(now)).unwrap()),
                Step::Online => observe(tracker.device_status(device, true, ms(now)).unwrap()),
                Step::PathRestored => observe(tracker.path_restored(ms(now))),
            };
            prop_assert_eq!(&actual, &expected, "{:?} at {}", step, now);
            let deadline = model.cmd.as_ref().and_then(|c| c.deadline).map(|(_, at)| ms(at));
            prop_assert_eq!(tracker.next_deadline(), deadline, "the next deadline after {:?} at {}", step, now);
            // One timer on the next wake misses nothing: a tick any earlier has nothing to do
            // (a wake in the past is due at once).
            let wake = tracker.next_wake();
            let before = wake.map_or(now + 10_000_000, |w| w.as_u64().saturating_sub(1));
            if before >= now {
                let mut probe = tracker.clone();
                prop_assert_eq!(observe(probe.tick(ms(before))), vec![], "a tick at {} before the wake {:?}, after {:?} at {}", before, wake, step, now);
            }

            let pending: Vec<(f64, u64, u32)> = tracker
                .pending_lockouts()
                .iter()
                .map(|p| (p.target, p.since_ms.as_u64(), p.sends))
                .collect();
            let modelled: Vec<(f64, u64, u32)> = model.order.iter().map(|o| (o.target, o.since, o.sends)).collect();
            prop_assert_eq!(&pending, &modelled, "pending lockouts after {:?} at {}", step, now);
            prop_assert_eq!(tracker.counts().lockouts_pending, pending.len());

            let Some(&(target, _, _)) = pending.first() else {
                lockout_sent = None;
                continue;
            };
            let standing = Seen::Publish { payload: format!("{target}"), retain: true };
            if actual.contains(&standing) {
                lockout_sent = Some(now);
            }
            if matches!(step, Step::Tick) {
                if model.online {
                    let since = lockout_sent.map(|t| now - t);
                    prop_assert!(
                        since.is_some_and(|s| s < COMPLETION_MS),
                        "unconfirmed lockout last sent {:?} ms before the tick at {}", since, now
                    );
                } else {
                    prop_assert!(!actual.iter().any(|s| matches!(s, Seen::Publish { .. })), "sent while offline");
                }
            }
        }
    }

    /// A panel's batch gives the same effects as its samples one by one,
    /// with commands and ticks interleaved between devices' reports.
    #[test]
    fn batches_equal_single_samples(
        reports in prop::collection::vec(
            (0u32..2, prop::collection::vec((1u32..=3, prop::sample::select(vec![0.0, 1.0, 3.0, 50.0, 99.0, 100.0])), 1..4), gap(),
             prop::option::of((1u32..=3, prop::sample::select(vec![0.0, 100.0])))),
            1..40),
    ) {
        let mut single = Tracker::new(plant(3, 2), ms(0)).unwrap();
        let mut batched = single.clone();
        let id = |t: &Tracker, d: u32, io: u32| t.slot(t.device(&format!("ctrl-{}", d + 1)).unwrap(), "valve", io).unwrap();
        let mut now = 0;
        for (caller, (device, samples, gap, command)) in reports.iter().enumerate() {
            now += gap;
            if let Some((io, target)) = command {
                let a = single.command(&[(id(&single, *device, *io), *target)], caller as u64, false, ms(now));
                let b = batched.command(&[(id(&batched, *device, *io), *target)], caller as u64, false, ms(now));
                prop_assert_eq!(a, b);
            }
            let mut one_by_one = Vec::new();
            for &(io, value) in samples {
                one_by_one.extend(single.feedback(id(&single, *device, io), value, Some(ms(now)), ms(now)).unwrap());
            }
            let batch: Vec<(ActuatorId, f64)> = samples.iter().map(|&(io, v)| (id(&batched, *device, io), v)).collect();
            let mut together = Vec::new();
            prop_assert!(batched.feedback_batch(&batch, Some(ms(now)), ms(now), &mut together).unwrap().is_empty());
            prop_assert_eq!(&together, &one_by_one);
            prop_assert_eq!(single.tick(ms(now)), batched.tick(ms(now)));
        }
    }

    /// The counts a status line reads in O(1), kept current on every change,
    /// against counting each actuator's phase and lockout order afresh:
    /// group commands over devices, lockouts taking over, samples, ticks,
    /// devices going offline and back (counted too), withdrawals.
    #[test]
    fn counts_equal_a_fresh_count(
        steps in prop::collection::vec(
            (gap(), 0u32..7, prop::collection::vec((0u32..3, 1u32..=3), 1..4), prop::sample::select(vec![0.0, 2.5, 50.0, 100.0])),
            1..60),
    ) {
        let mut t = Tracker::new(plant(3, 3), ms(0)).unwrap();
        let devices: Vec<DeviceId> = (0..3).map(DeviceId::from_index).collect();
        let mut now = 0;
        for (caller, (gap, kind, members, value)) in steps.iter().enumerate() {
            now += gap;
            let ids: Vec<ActuatorId> = members.iter().map(|&(d, io)| t.slot(devices[d as usize], "valve", io).unwrap()).collect();
            let targets: Vec<(ActuatorId, f64)> = ids.iter().map(|&id| (id, *value)).collect();
            match kind {
                0 => drop(t.command(&targets, caller as u64, false, ms(now))),
                1 => drop(t.command(&targets, caller as u64, true, ms(now))),
                2 => drop(t.feedback(ids[0], *value, None, ms(now))),
                3 => drop(t.feedback_batch(&targets, None, ms(now), &mut Vec::new())),
                4 => drop(t.tick(ms(now))),
                5 => drop(t.device_status(devices[members[0].0 as usize], *value < 50.0, ms(now))),
                _ => drop(t.withdraw(caller.saturating_sub(members.len()) as u64)),
            }
            let fresh = |on: &[DeviceId]| {
                let mut c = Counts::default();
                for i in 0..9 {
                    let id = ActuatorId::from_index(i);
                    if !on.iter().any(|&d| t.slot(d, "valve", i % 3 + 1) == Some(id)) {
                        continue;
                    }
                    match t.phase(id).unwrap() {
                        Phase::Pending | Phase::Moving => c.moving += 1,
                        Phase::Stopped => c.stopped += 1,
                        Phase::Faulted => c.faulted += 1,
                        Phase::Idle => {}
                    }
                    if t.pending_lockouts().iter().any(|p| p.actuator == id) {
                        c.lockouts_pending += 1;
                    }
                }
                let health = t.device_health();
                c.offline_devices = on.iter().filter(|d| !health[d.index()].online).count();
                c
            };
            prop_assert_eq!(t.counts(), fresh(&devices), "after step {} at {}", caller, now);
            for d in 0..3 {
                prop_assert_eq!(t.counts_on([devices[d]]), fresh(&devices[d..=d]));
            }
            prop_assert_eq!(t.counts_on([devices[0], devices[2]]), fresh(&[devices[0], devices[2]]));
        }
    }
}
