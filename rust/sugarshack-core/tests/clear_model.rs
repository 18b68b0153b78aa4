//! Cause-aware clear against a simple reference model: no clear is accepted
//! while a member actuator is off its lockout state, unconfirmed, unheard or
//! on an offline device, unless forced; and a line the model sees isolated
//! clears without force.

use proptest::prelude::*;
use serde_json::json;
use sugarshack_core::actuator::{ActuatorId, DeviceId, Tracker};
use sugarshack_core::clearance::{Attribution, ClearBlocker};
use sugarshack_core::interlock::{EventKind, Interlock, InterlockError, ResourceSet};
use sugarshack_core::plant::PlantModel;
use sugarshack_core::time::ms;

/// YEL: V1, V2 on ctrl-1. GRN: V3 on ctrl-2 and V4 on ctrl-1 (a device shared by two lines).
const MEMBERS: [(&str, &str, usize); 4] = [
    ("V1", "YEL", 0),
    ("V2", "YEL", 0),
    ("V3", "GRN", 1),
    ("V4", "GRN", 0),
];
const LINES: [&str; 2] = ["YEL", "GRN"];
const TOLERANCE: f64 = 2.0;

/// A clear by no one in particular that the tracker's blockers must refuse.
fn refused_clear(
    lock: &mut Interlock,
    tracker: &Tracker,
    lines: &ResourceSet,
    at_ms: u64,
) -> InterlockError {
    lock.clear_checked(
        lines,
        &Attribution::unknown(),
        |l| tracker.clear_blockers(l),
        ms(at_ms),
    )
    .unwrap_err()
}

fn plant() -> PlantModel {
    serde_json::from_value(json!({
        "actuatorTypes": { "valve": { "signal": "analog", "tolerance": TOLERANCE, "noMotionMs": 1_000_000,
            "completionMs": 1_000_000, "staleMs": 1_000_000_000u64 } },
        "devices": [{ "id": "ctrl-1", "kind": "actuator-panel" }, { "id": "ctrl-2", "kind": "actuator-panel" }],
        "resources": [{ "id": "YEL" }, { "id": "GRN" }],
        "actuators": MEMBERS.iter().enumerate().map(|(i, (id, line, device))| json!({
            "id": id, "type": "valve", "device": format!("ctrl-{}", device + 1), "io": i + 1,
            "idle": 0, "lockout": 0, "resource": line })).collect::<Vec<_>>()
    }))
    .unwrap()
}

#[derive(Clone, Debug)]
enum Step {
    Feedback {
        actuator: usize,
        value: f64,
    },
    Device {
        device: usize,
        online: bool,
    },
    /// The interlock faults the line and its lockout goes out.
    EStop {
        line: usize,
    },
    Clear {
        line: usize,
        forced: bool,
    },
}

fn step() -> impl Strategy<Value = Step> {
    prop_oneof![
        4 => (0..MEMBERS.len(), prop_oneof![Just(0.0), Just(1.5), Just(3.0), Just(50.0), Just(100.0)])
            .prop_map(|(actuator, value)| Step::Feedback { actuator, value }),
        1 => (0..2usize, any::<bool>()).prop_map(|(device, online)| Step::Device { device, online }),
        1 => (0..LINES.len()).prop_map(|line| Step::EStop { line }),
        2 => (0..LINES.len(), prop::bool::weighted(0.2)).prop_map(|(line, forced)| Step::Clear { line, forced }),
    ]
}

/// What the reference model knows of one actuator.
#[derive(Clone, Copy, Default)]
struct Seen {
    value: Option<f64>,
    /// A lockout went out and no feedback at the lockout state (device online) has come since.
    unconfirmed: bool,
}

struct Model {
    seen: [Seen; MEMBERS.len()],
    online: [bool; 2],
    faulted: [bool; 2],
}

impl Model {
    fn at_lockout(value: Option<f64>) -> bool {
        value.is_some_and(|v| v.abs() <= TOLERANCE)
    }

    /// The line is isolated: every member heard at its lockout state, confirmed, on an online device.
    fn isolated(&self, line: usize) -> bool {
        MEMBERS
            .iter()
            .enumerate()
            .filter(|(_, m)| m.1 == LINES[line])
            .all(|(i, m)| {
                self.online[m.2]
                    && Self::at_lockout(self.seen[i].value)
                    && !self.seen[i].unconfirmed
            })
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn no_clear_while_a_member_is_off_its_lockout_state_unless_forced(steps in prop::collection::vec(step(), 1..60)) {
        let mut tracker = Tracker::new(plant(), ms(0)).unwrap();
        let mut lock = Interlock::new(tracker.plant().interlock_config()).unwrap();
        let ids: Vec<ActuatorId> = MEMBERS.iter().map(|m| tracker.actuator(m.0).unwrap()).collect();
        let mut model = Model { seen: [Seen::default(); MEMBERS.len()], online: [true; 2], faulted: [false; 2] };
        for (t, step) in steps.into_iter().enumerate() {
            let now = t as u64 * 10;
            match step {
                Step::Feedback { actuator, value } => {
                    tracker.feedback(ids[actuator], value, None, ms(now)).unwrap();
                    let seen = &mut model.seen[actuator];
                    seen.value = Some(value);
                    if model.online[MEMBERS[actuator].2] && Model::at_lockout(Some(value)) {
                        seen.unconfirmed = false;
                    }
                }
                Step::Device { device, online } => {
                    tracker.device_status(DeviceId::from_index(device as u32), online, ms(now)).unwrap();
                    model.online[device] = online;
                }
                Step::EStop { line } => {
                    let set = lock.resource_set(&[LINES[line]]).unwrap();
                    let outcome = lock.fault_resources_by(&set, Some("e-stop"), &Attribution::new(Some("ana"), None, false), ms(now)).unwrap();
                    for lockout in outcome.lockouts {
                        let targets = tracker.parse_group(&lockout.command).unwrap();
                        tracker.command(&targets, t as u64 + 1, true, ms(now)).unwrap();
                    }
                    model.faulted[line] = true;
                    for (i, m) in MEMBERS.iter().enumerate() {
                        if m.1 == LINES[line] {
                            let confirmed = model.online[m.2] && Model::at_lockout(model.seen[i].value);
                            model.seen[i].unconfirmed = !confirmed;
                        }
                    }
                }
                Step::Clear { line, forced } => {
                    let set = lock.resource_set(&[LINES[line]]).unwrap();
                    let by = Attribution::new(Some("ana"), Some("checked on site"), forced);
                    let result = lock.clear_checked(&set, &by, |l| tracker.clear_blockers(l), ms(now));
                    let isolated = model.isolated(line);
                    match result {
                        Ok(_) => {
                            prop_assert!(model.faulted[line]);
                            prop_assert!(forced || isolated, "cleared {} off its lockout state without force", LINES[line]);
                            model.faulted[line] = false;
                            let events = lock.drain_events();
                            let record = lock.describe(events.last().unwrap());
                            prop_assert_eq!(record.kind, EventKind::Cleared);
                            prop_assert_eq!(record.by.as_deref(), Some("ana"));
                            prop_assert_eq!(record.forced, forced && !isolated);
                        }
                        Err(InterlockError::NotFaulted { resource }) => {
                            prop_assert!(!model.faulted[line]);
                            prop_assert_eq!(resource, LINES[line]);
                        }
                        Err(InterlockError::ClearRefused { lines }) => {
                            prop_assert!(model.faulted[line] && !forced && !isolated);
                            prop_assert_eq!(lines.len(), 1);
                            prop_assert!(!lines[0].reasons.is_empty());
                        }
                        Err(other) => prop_assert!(false, "unexpected refusal {other}"),
                    }
                }
            }
        }
    }
}

#[test]
fn a_refusal_lists_every_reason_of_every_line() {
    let mut tracker = Tracker::new(plant(), ms(0)).unwrap();
    let mut lock = Interlock::new(tracker.plant().interlock_config()).unwrap();
    let both = lock.resource_set(&LINES).unwrap();
    lock.fault_resources(&both, None, ms(0)).unwrap();
    let v1 = tracker.actuator("V1").unwrap();
    let v3 = tracker.actuator("V3").unwrap();
    tracker.feedback(v1, 40.0, None, ms(1)).unwrap();
    tracker.feedback(v3, 0.0, None, ms(1)).unwrap();
    tracker
        .device_status(DeviceId::from_index(1), false, ms(2))
        .unwrap();
    let err = refused_clear(&mut lock, &tracker, &both, 3);
    let InterlockError::ClearRefused { lines } = &err else {
        panic!("{err}")
    };
    assert_eq!(lines[0].line, "YEL");
    assert_eq!(
        lines[0].reasons,
        vec![
            ClearBlocker::OffLockout {
                actuator: "V1".into(),
                position: 40.0,
                lockout: 0.0
            },
            ClearBlocker::NoFeedback {
                actuator: "V2".into()
            },
        ]
    );
    assert_eq!(lines[1].line, "GRN");
    assert_eq!(
        lines[1].reasons,
        vec![
            ClearBlocker::DeviceOffline {
                device: "ctrl-2".into()
            },
            ClearBlocker::NoFeedback {
                actuator: "V4".into()
            }
        ]
    );
    assert_eq!(err.code(), "CLEAR_REFUSED");
    assert!(err.to_string().contains("device ctrl-2 offline"), "{err}");
    // Refused whole: both lines still faulted.
    assert_eq!(lock.faulted_resources().len(), 2);
    let forced = Attribution::new(Some("ana"), Some("valves checked by hand"), true);
    lock.clear_checked(&both, &forced, |l| tracker.clear_blockers(l), ms(4))
        .unwrap();
    let events = lock.drain_events();
    let record = lock.describe(events.last().unwrap());
    assert!(record.forced);
    assert_eq!(record.reason.as_deref(), Some("valves checked by hand"));
    assert!(record
        .note
        .unwrap()
        .starts_with("forced over: YEL: member actuator V1"));
}

#[test]
fn clearing_a_line_that_is_not_faulted_names_the_line() {
    let tracker = Tracker::new(plant(), ms(0)).unwrap();
    let mut lock = Interlock::new(tracker.plant().interlock_config()).unwrap();
    let yel = lock.resource_set(&["YEL"]).unwrap();
    let err = refused_clear(&mut lock, &tracker, &yel, 0);
    assert_eq!(
        err.to_string(),
        "line 'YEL' is not faulted; nothing to clear"
    );
}
