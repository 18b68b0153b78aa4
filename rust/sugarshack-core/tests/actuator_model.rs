//! The tracker against a reference model of one valve's life (commands,
//! samples, ticks, its device going offline and back), with time steps
//! chosen around every threshold, and batches against single samples.

use proptest::prelude::*;
use serde_json::json;
use sugarshack_core::actuator::{ActuatorId, Effect, FaultKind, Tracker};
use sugarshack_core::plant::PlantModel;

const TOLERANCE: f64 = 2.0;
const NO_MOTION_MS: u64 = 1000;
const COMPLETION_MS: u64 = 3000;
const STALE_MS: u64 = 2500;
const RETRIES: u32 = 1;

fn plant(valves_per_device: u32, devices: u32) -> PlantModel {
    let actuators: Vec<_> = (1..=devices)
        .flat_map(|d| {
            (1..=valves_per_device).map(move |io| {
                json!({ "id": format!("V{d}{io}"), "type": "valve", "device": format!("ctrl-{d}"), "io": io, "idle": 0, "lockout": 0 })
            })
        })
        .collect();
    let devices: Vec<_> = (1..=devices)
        .map(|d| json!({ "id": format!("ctrl-{d}"), "kind": "actuator-panel" }))
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
    Command(f64),
    Sample(f64),
    Tick,
    Offline,
    Online,
}

fn step() -> impl Strategy<Value = Step> {
    prop_oneof![
        2 => prop::sample::select(vec![0.0, 50.0, 100.0]).prop_map(Step::Command),
        5 => prop::sample::select(vec![0.0, 1.5, 2.0, 2.5, 30.0, 50.0, 97.0, 98.0, 98.5, 100.0]).prop_map(Step::Sample),
        4 => Just(Step::Tick),
        1 => Just(Step::Offline),
        1 => Just(Step::Online),
    ]
}

/// Time steps at and around each threshold.
fn gap() -> impl Strategy<Value = u64> {
    prop::sample::select(vec![
        0, 1, 499, 999, 1000, 1001, 1500, 2499, 2500, 2501, 2999, 3000, 3001,
    ])
}

/// What the model and the tracker are compared on (publishes aside).
#[derive(Clone, Debug, PartialEq)]
enum Seen {
    Refused(&'static str),
    Moving {
        caller: u64,
        after: u64,
    },
    Completed {
        caller: u64,
        motion: u64,
        completion: u64,
        retries: u32,
    },
    GroupCompleted {
        caller: u64,
        after: u64,
    },
    GroupFailed {
        caller: u64,
        fault: FaultKind,
    },
    Retry {
        caller: u64,
        attempt: u32,
        fault: FaultKind,
    },
    Fault(FaultKind),
    Recovered(FaultKind),
    Changed(f64),
}

struct Cmd {
    caller: u64,
    target: f64,
    start: Option<f64>,
    issued: u64,
    attempt: u64,
    moving: Option<u64>,
    retries: u32,
}

/// One valve as the issue describes it.
struct Model {
    position: Option<f64>,
    last_sample: u64,
    stale: bool,
    resting: Option<f64>,
    uncommanded: bool,
    online: bool,
    reported: Option<f64>,
    cmd: Option<Cmd>,
}

impl Model {
    fn new() -> Self {
        Model {
            position: None,
            last_sample: 0,
            stale: false,
            resting: None,
            uncommanded: false,
            online: true,
            reported: None,
            cmd: None,
        }
    }

    fn apply(&mut self, step: &Step, caller: u64, now: u64) -> Vec<Seen> {
        let mut seen = Vec::new();
        match *step {
            Step::Command(target) => {
                if self.cmd.is_some() {
                    return vec![Seen::Refused("STILL_MOVING")];
                }
                if !self.online {
                    return vec![Seen::Refused("DEVICE_OFFLINE")];
                }
                self.resting = Some(target);
                self.uncommanded = false;
                if self
                    .position
                    .is_some_and(|p| (p - target).abs() <= TOLERANCE)
                    && !self.stale
                {
                    seen.push(Seen::Completed {
                        caller,
                        motion: 0,
                        completion: 0,
                        retries: 0,
                    });
                    seen.push(Seen::GroupCompleted { caller, after: 0 });
                } else {
                    self.cmd = Some(Cmd {
                        caller,
                        target,
                        start: self.position,
                        issued: now,
                        attempt: now,
                        moving: None,
                        retries: 0,
                    });
                }
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
                            });
                            seen.push(Seen::GroupCompleted {
                                caller: cmd.caller,
                                after: now - cmd.issued,
                            });
                        }
                    }
                }
            }
            Step::Tick => {
                if !self.online {
                    return seen;
                }
                if !self.stale && now - self.last_sample >= STALE_MS {
                    self.stale = true;
                    seen.push(Seen::Fault(FaultKind::Stale));
                    if let Some(cmd) = self.cmd.take() {
                        seen.push(Seen::GroupFailed {
                            caller: cmd.caller,
                            fault: FaultKind::Stale,
                        });
                    }
                    return seen;
                }
                let Some(cmd) = self.cmd.as_mut() else {
                    return seen;
                };
                let elapsed = now - cmd.attempt;
                let fault = if cmd.moving.is_none() && elapsed >= NO_MOTION_MS {
                    FaultKind::NoMotion
                } else if elapsed >= COMPLETION_MS {
                    FaultKind::NotReached
                } else {
                    return seen;
                };
                if cmd.retries < RETRIES {
                    cmd.retries += 1;
                    cmd.attempt = now;
                    seen.push(Seen::Retry {
                        caller: cmd.caller,
                        attempt: cmd.retries,
                        fault,
                    });
                } else {
                    let cmd = self.cmd.take().unwrap();
                    seen.push(Seen::Fault(fault));
                    seen.push(Seen::GroupFailed {
                        caller: cmd.caller,
                        fault,
                    });
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
                        });
                    }
                }
            }
            Step::Online => {
                if !self.online {
                    self.online = true;
                    self.last_sample = now;
                    seen.push(Seen::Recovered(FaultKind::DeviceOffline));
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
            Effect::Moving {
                caller,
                issue_to_motion_ms,
                ..
            } => Some(Seen::Moving {
                caller,
                after: issue_to_motion_ms,
            }),
            Effect::Completed {
                caller,
                issue_to_motion_ms,
                completion_ms,
                retries,
                ..
            } => Some(Seen::Completed {
                caller,
                motion: issue_to_motion_ms,
                completion: completion_ms,
                retries,
            }),
            Effect::GroupCompleted {
                caller,
                completion_ms,
            } => Some(Seen::GroupCompleted {
                caller,
                after: completion_ms,
            }),
            Effect::GroupFailed { caller, fault, .. } => Some(Seen::GroupFailed { caller, fault }),
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
            Effect::Publish { .. } | Effect::DeviceStatus { .. } => None,
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1024, ..ProptestConfig::default() })]

    #[test]
    fn one_valve_follows_the_reference_model(steps in prop::collection::vec((gap(), step()), 1..60)) {
        let mut tracker = Tracker::new(plant(1, 1), 0).unwrap();
        let valve = tracker.actuator("V11").unwrap();
        let device = tracker.device("ctrl-1").unwrap();
        let mut model = Model::new();
        let mut now = 0;
        for (caller, (gap, step)) in steps.iter().enumerate() {
            now += gap;
            let caller = caller as u64;
            let expected = model.apply(step, caller, now);
            let actual = match *step {
                Step::Command(target) => match tracker.command(&[(valve, target)], caller, false, now) {
                    Ok(effects) => observe(effects),
                    Err(err) => vec![Seen::Refused(err.code())],
                },
                Step::Sample(v) => observe(tracker.feedback(valve, v, None, now).unwrap()),
                Step::Tick => observe(tracker.tick(now)),
                Step::Offline => observe(tracker.device_status(device, false, now).unwrap()),
                Step::Online => observe(tracker.device_status(device, true, now).unwrap()),
            };
            prop_assert_eq!(&actual, &expected, "{:?} at {}", step, now);
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
        let mut single = Tracker::new(plant(3, 2), 0).unwrap();
        let mut batched = single.clone();
        let id = |t: &Tracker, d: u32, io: u32| t.slot(t.device(&format!("ctrl-{}", d + 1)).unwrap(), "valve", io).unwrap();
        let mut now = 0;
        for (caller, (device, samples, gap, command)) in reports.iter().enumerate() {
            now += gap;
            if let Some((io, target)) = command {
                let a = single.command(&[(id(&single, *device, *io), *target)], caller as u64, false, now);
                let b = batched.command(&[(id(&batched, *device, *io), *target)], caller as u64, false, now);
                prop_assert_eq!(a, b);
            }
            let mut one_by_one = Vec::new();
            for &(io, value) in samples {
                one_by_one.extend(single.feedback(id(&single, *device, io), value, Some(now), now).unwrap());
            }
            let batch: Vec<(ActuatorId, f64)> = samples.iter().map(|&(io, v)| (id(&batched, *device, io), v)).collect();
            let mut together = Vec::new();
            prop_assert!(batched.feedback_batch(&batch, Some(now), now, &mut together).is_empty());
            prop_assert_eq!(&together, &one_by_one);
            prop_assert_eq!(single.tick(now), batched.tick(now));
        }
    }
}
