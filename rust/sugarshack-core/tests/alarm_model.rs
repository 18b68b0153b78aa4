//! ISA-18.2 alarm states against a simple reference model: each alarm is
//! (condition holds, acknowledgement owed, shelf until), listed while any of
//! the three is set; its state is read off the first two. A one-shot shelf
//! also ends when the condition does. Acknowledgements and shelves record
//! who and when; snapshots restore the same alarms.

use std::collections::BTreeMap;
use sugarshack_core::time::ms;

use proptest::prelude::*;
use sugarshack_core::alarm::{alarm_id, AlarmKind, AlarmState, Alarms, Condition, BUS_ON_DELAY_MS};
use sugarshack_core::clearance::Attribution;

const SUBJECTS: [(AlarmKind, &str); 5] = [
    (AlarmKind::LineFaulted, "YEL"),
    (AlarmKind::LineFaulted, "GRN"),
    (AlarmKind::DeviceOffline, "ctrl-1"),
    (AlarmKind::DeviceStale, "ctrl-1"),
    // With an on-delay: its condition must hold that long first.
    (AlarmKind::BusDisconnected, "bus"),
];
const PEOPLE: [&str; 2] = ["ana", "bo"];
/// Time between steps: far enough apart for an on-delay to run out now and then.
fn step_ms() -> u64 {
    BUS_ON_DELAY_MS.as_u64() / 4
}

/// An alarm as compared: id, state, shelf end, who acknowledged and when.
type Seen = (String, AlarmState, Option<u64>, Option<(String, u64)>);

#[derive(Clone, Debug)]
enum Step {
    /// The conditions that hold now, as a bit per subject.
    Observe(u8),
    Ack {
        alarm: Option<usize>,
        person: usize,
    },
    Shelve {
        alarm: usize,
        for_ms: u64,
        person: usize,
        one_shot: bool,
    },
    Unshelve {
        alarm: usize,
        person: usize,
    },
    /// Restore from a snapshot through JSON.
    Restart,
}

fn step() -> impl Strategy<Value = Step> {
    prop_oneof![
        4 => (0u8..32).prop_map(Step::Observe),
        3 => (prop::option::weighted(0.7, 0..SUBJECTS.len()), 0..PEOPLE.len())
            .prop_map(|(alarm, person)| Step::Ack { alarm, person }),
        1 => (0..SUBJECTS.len(), prop_oneof![Just(1u64), Just(200), Just(step_ms() * 3), Just(step_ms() * 20)], 0..PEOPLE.len(), any::<bool>())
            .prop_map(|(alarm, for_ms, person, one_shot)| Step::Shelve { alarm, for_ms, person, one_shot }),
        1 => (0..SUBJECTS.len(), 0..PEOPLE.len()).prop_map(|(alarm, person)| Step::Unshelve { alarm, person }),
        1 => Just(Step::Restart),
    ]
}

#[derive(Clone, Debug, Default)]
struct Entry {
    holds: bool,
    owed: bool,
    shelf_until: Option<u64>,
    one_shot: bool,
    acked_by: Option<(String, u64)>,
}

#[derive(Default)]
struct Model {
    alarms: BTreeMap<usize, Entry>,
    /// Conditions held, not yet past their on-delay: since when.
    waiting: BTreeMap<usize, u64>,
}

impl Model {
    fn tidy(&mut self, now: u64) {
        for e in self.alarms.values_mut() {
            if e.shelf_until.is_some_and(|t| t <= now) {
                e.shelf_until = None;
            }
        }
        self.alarms
            .retain(|_, e| e.holds || e.owed || e.shelf_until.is_some());
    }

    fn state(e: &Entry) -> AlarmState {
        match (e.holds, e.owed) {
            (true, true) => AlarmState::ActiveUnacked,
            (true, false) => AlarmState::ActiveAcked,
            (false, true) => AlarmState::ReturnedUnacked,
            (false, false) => AlarmState::Normal,
        }
    }
}

fn id(i: usize) -> String {
    alarm_id(SUBJECTS[i].0, SUBJECTS[i].1)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(500))]

    #[test]
    fn alarms_follow_the_reference_model(steps in prop::collection::vec(step(), 1..80)) {
        let mut alarms = Alarms::new();
        let mut model = Model::default();
        for (t, step) in steps.into_iter().enumerate() {
            let now = t as u64 * step_ms();
            match step {
                Step::Observe(bits) => {
                    let conditions: Vec<Condition> = (0..SUBJECTS.len()).filter(|i| bits & (1 << i) != 0).map(|i| Condition {
                        kind: SUBJECTS[i].0, subject: SUBJECTS[i].1.into(), text: format!("{} {}", SUBJECTS[i].0.name(), t), since_ms: None,
                    }).collect();
                    alarms.observe(&conditions, ms(now)).unwrap();
                    model.tidy(now);
                    for (i, (kind, _)) in SUBJECTS.iter().enumerate() {
                        let mut holds = bits & (1 << i) != 0;
                        let delay = kind.on_delay_ms();
                        if !holds {
                            model.waiting.remove(&i);
                        } else if delay > ms(0) && !model.alarms.contains_key(&i) {
                            let first = *model.waiting.entry(i).or_insert(now);
                            holds = now - first >= delay.as_u64();
                            if holds {
                                model.waiting.remove(&i);
                            }
                        }
                        let entry = model.alarms.entry(i).or_default();
                        if holds && !entry.holds {
                            entry.owed = true;
                            entry.acked_by = None;
                        }
                        if !holds && entry.holds && entry.one_shot {
                            entry.shelf_until = None;
                        }
                        entry.holds = holds;
                    }
                    model.tidy(now);
                }
                Step::Ack { alarm, person } => {
                    let who = Attribution::new(Some(PEOPLE[person]), None, false);
                    let ids = alarm.map(|i| vec![id(i)]);
                    let listed_before = alarm.map(|i| model.alarms.contains_key(&i));
                    let result = alarms.acknowledge(ids.as_deref(), &who, ms(now));
                    if listed_before == Some(false) {
                        prop_assert_eq!(result.unwrap_err().code(), "UNKNOWN_ALARM");
                        continue;
                    }
                    result.unwrap();
                    model.tidy(now);
                    for (i, e) in model.alarms.iter_mut() {
                        if alarm.is_none_or(|a| a == *i) && e.owed {
                            e.owed = false;
                            e.acked_by = Some((PEOPLE[person].into(), now));
                        }
                    }
                    model.tidy(now);
                }
                Step::Shelve { alarm, for_ms, person, one_shot } => {
                    let who = Attribution::new(Some(PEOPLE[person]), None, false);
                    let result = if one_shot {
                        alarms.shelve_one_shot(&id(alarm), ms(now + for_ms), &who, ms(now))
                    } else {
                        alarms.shelve(&id(alarm), ms(now + for_ms), &who, ms(now))
                    };
                    if !model.alarms.contains_key(&alarm) {
                        prop_assert_eq!(result.unwrap_err().code(), "UNKNOWN_ALARM");
                        continue;
                    }
                    model.tidy(now);
                    match model.alarms.get_mut(&alarm) {
                        Some(e) => {
                            result.unwrap();
                            e.shelf_until = Some(now + for_ms);
                            e.one_shot = one_shot;
                            let shelf = alarms.get(&id(alarm)).unwrap().shelved.clone().unwrap();
                            prop_assert_eq!((shelf.by.as_str(), shelf.at_ms), (PEOPLE[person], ms(now)));
                        }
                        None => prop_assert!(result.is_err()),
                    }
                }
                Step::Unshelve { alarm, person } => {
                    let who = Attribution::new(Some(PEOPLE[person]), None, false);
                    let result = alarms.unshelve(&id(alarm), &who, ms(now));
                    if !model.alarms.contains_key(&alarm) {
                        prop_assert_eq!(result.unwrap_err().code(), "UNKNOWN_ALARM");
                        continue;
                    }
                    result.unwrap();
                    if let Some(e) = model.alarms.get_mut(&alarm) {
                        e.shelf_until = None;
                    }
                    model.tidy(now);
                }
                Step::Restart => {
                    let text = serde_json::to_string(&alarms.snapshot()).unwrap();
                    alarms = Alarms::restore(serde_json::from_str(&text).unwrap()).unwrap();
                    // An on-delay under way is not saved: it starts again.
                    model.waiting.clear();
                }
            }
            // The alarms as listed are the model's, state, shelf and acknowledgement alike.
            let listed: Vec<Seen> = alarms.list()
                .map(|a| (a.id.clone(), a.state, a.shelved.as_ref().map(|s| s.until_ms.as_u64()), a.acked.as_ref().map(|s| (s.by.clone(), s.at_ms.as_u64()))))
                .collect();
            let mut expected: Vec<Seen> = model.alarms.iter()
                .map(|(i, e)| (id(*i), Model::state(e), e.shelf_until, e.acked_by.clone()))
                .collect();
            expected.sort_by(|a, b| a.0.cmp(&b.0));
            prop_assert_eq!(listed, expected);
            for a in alarms.list() {
                prop_assert!(a.state != AlarmState::Normal || a.shelved.is_some(), "a normal alarm is kept only on a shelf");
            }
        }
    }
}
