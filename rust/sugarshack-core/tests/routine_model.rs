//! The routine machine and the sensor store against simple reference models:
//! random trigger / return / fault / reset / restart / sample sequences (a
//! condition is due on entering its state, then only after its sensors
//! sampled, at most once per period, and the machine's next deadline says
//! when; nothing is due while the interlock's gate is closed, and a met
//! condition held back is due again), and random samples and reads around
//! the staleness limit.

use proptest::prelude::*;
use serde_json::json;
use sugarshack_core::plant::{Plant, PlantModel};
use sugarshack_core::routine::{RoutineMachine, RoutineSnapshot};
use sugarshack_core::sensor::SensorStore;
use sugarshack_core::time::ms;

const STATES: [&str; 4] = ["a", "b", "c", "err"];
const TOPICS: [&str; 3] = ["go", "back", "other"];

/// Transitions as (from, to, operation, trigger): a msg topic, or a condition period in ms.
#[derive(Clone, Debug)]
enum Trig {
    Msg(&'static str),
    Every(u64),
}

fn transitions() -> impl Strategy<Value = Vec<(usize, usize, usize, Trig)>> {
    let trig = prop_oneof![
        prop::sample::select(TOPICS.to_vec()).prop_map(Trig::Msg),
        prop::sample::select(vec![1000u64, 2500]).prop_map(Trig::Every),
    ];
    prop::collection::vec((0..3usize, 0..4usize, 0..4usize, trig), 1..8)
}

fn plant(transitions: &[(usize, usize, usize, Trig)], error_state: bool) -> Plant {
    let ts: Vec<_> = transitions
        .iter()
        .map(|(from, to, op, trig)| {
            let trigger = match trig {
                Trig::Msg(topic) => json!({ "msg": topic }),
                Trig::Every(ms) => json!({ "when": "`S` > 0", "sensors": ["S"], "everyMs": ms }),
            };
            json!({ "from": STATES[*from], "to": STATES[*to], "operation": format!("op{op}"), "trigger": trigger })
        })
        .collect();
    let mut routine = json!({ "id": "r", "states": STATES, "initial": "a", "transitions": ts });
    if error_state {
        routine["errorState"] = json!("err");
    }
    let ops: Vec<_> = (0..4)
        .map(|i| {
            json!({ "id": format!("op{i}"), "priority": i, "resources": ["L"],
            "steps": [{ "wait": "true", "sensors": [], "timeoutMs": 1 }] })
        })
        .collect();
    let plant: PlantModel = serde_json::from_value(json!({
        "actuatorTypes": {}, "devices": [{ "id": "st", "kind": "sensor-station" }],
        "sensors": [{ "id": "S", "device": "st", "name": "s" }],
        "resources": [{ "id": "L", "lockout": { "valves": {} } }],
        "operations": ops, "routines": [routine]
    }))
    .unwrap();
    Plant::new(plant).unwrap()
}

#[derive(Clone, Debug)]
enum Event {
    Msg(&'static str),
    /// Evaluate what is due after `gap` ms; the conditions listed by position hold.
    Check {
        gap: u64,
        met: Vec<bool>,
    },
    /// A sensor of the condition of the transition at this position (modulo their count) sampled.
    Sample(usize),
    Complete,
    /// The dispatched operation was refused before it ran.
    Refuse,
    Fault,
    Reset,
    Restart,
    /// The interlock's gate opened (true) or closed.
    Gate(bool),
}

fn event() -> impl Strategy<Value = Event> {
    prop_oneof![
        3 => prop::sample::select(TOPICS.to_vec()).prop_map(Event::Msg),
        3 => (prop::sample::select(vec![0u64, 999, 1000, 1500, 2500]), prop::collection::vec(any::<bool>(), 4))
            .prop_map(|(gap, met)| Event::Check { gap, met }),
        3 => (0..8usize).prop_map(Event::Sample),
        3 => Just(Event::Complete),
        1 => Just(Event::Refuse),
        1 => Just(Event::Fault),
        1 => Just(Event::Reset),
        1 => Just(Event::Restart),
        2 => any::<bool>().prop_map(Event::Gate),
    ]
}

/// The reference: Alg. 3 read literally, with one pending operation.
struct Model {
    ts: Vec<(usize, usize, usize, Trig)>,
    error_state: bool,
    state: usize,
    pending: Option<usize>,
    halted: bool,
    checked: Vec<Option<u64>>,
    changed: Vec<bool>,
    gate_closed: bool,
}

impl Model {
    fn enter(&mut self, state: usize) {
        self.state = state;
        self.checked = vec![None; self.ts.len()];
        self.changed = vec![false; self.ts.len()];
    }
    /// When a condition is next due: at once unchecked, a period after its check once sampled.
    fn next_deadline(&self) -> Option<u64> {
        if self.pending.is_some() || self.halted || self.gate_closed {
            return None;
        }
        self.ts
            .iter()
            .enumerate()
            .filter_map(|(i, (from, _, _, trig))| match (trig, self.checked[i]) {
                (Trig::Every(_), _) if *from != self.state => None,
                (Trig::Every(_), None) => Some(0),
                (Trig::Every(every), Some(at)) => self.changed[i].then_some(at + every),
                (Trig::Msg(_), _) => None,
            })
            .min()
    }
    fn fault(&mut self) -> bool {
        let Some(t) = self.pending.take() else {
            return false;
        };
        if self.error_state {
            self.enter(3);
        } else {
            self.halted = true;
            self.state = self.ts[t].0;
        }
        true
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn routine_matches_the_reference(ts in transitions(), error_state in any::<bool>(), events in prop::collection::vec(event(), 1..60)) {
        let plant = plant(&ts, error_state);
        let mut r = RoutineMachine::new(&plant, "r").unwrap();
        let mut m = Model { checked: vec![None; ts.len()], changed: vec![false; ts.len()], ts: ts.clone(), error_state, state: 0, pending: None, halted: false, gate_closed: false };
        let mut now = 0u64;
        let mut dispatched = 0usize;
        let mut returned = 0usize;
        for e in events {
            match e {
                Event::Msg(topic) => {
                    let expected = if m.pending.is_some() || m.halted { None } else {
                        m.ts.iter().position(|(from, _, _, trig)| *from == m.state && matches!(trig, Trig::Msg(t) if *t == topic))
                    };
                    match (r.on_msg(topic), expected) {
                        (Ok(d), Some(t)) => {
                            prop_assert_eq!(d.transition, t);
                            m.pending = Some(t);
                            dispatched += 1;
                        }
                        (Err(err), None) => {
                            let code = if m.pending.is_some() { "ROUTINE_BUSY" } else if m.halted { "ROUTINE_HALTED" } else { "NO_TRANSITION" };
                            prop_assert_eq!(err.code(), code);
                        }
                        (got, want) => prop_assert!(false, "msg {}: got {:?}, expected transition {:?}", topic, got, want),
                    }
                }
                Event::Check { gap, met } => {
                    now += gap;
                    let mut expected = Vec::new();
                    if m.pending.is_none() && !m.halted && !m.gate_closed {
                        for (i, (from, _, _, trig)) in m.ts.iter().enumerate() {
                            if let Trig::Every(every) = trig {
                                if *from == m.state && m.checked[i].is_none_or(|at| m.changed[i] && now - at >= *every) {
                                    m.checked[i] = Some(now);
                                    m.changed[i] = false;
                                    expected.push(i);
                                }
                            }
                        }
                    }
                    let due = r.due(ms(now));
                    prop_assert_eq!(&due, &expected);
                    for (k, t) in due.into_iter().enumerate() {
                        if !met[k % met.len()] { continue; }
                        let fires = m.pending.is_none() && !m.halted && m.ts[t].0 == m.state;
                        let got = r.condition_met(t);
                        prop_assert_eq!(got.is_some(), fires);
                        if fires {
                            m.pending = Some(t);
                            dispatched += 1;
                        } else if m.ts[t].0 == m.state {
                            // Held back (another fired first): due again a period after its check.
                            m.changed[t] = true;
                        }
                    }
                }
                Event::Sample(k) => {
                    let t = k % m.ts.len();
                    r.input_changed(t);
                    m.changed[t] = true;
                }
                Event::Complete => match (r.completed(), m.pending.take()) {
                    (Ok(moved), Some(t)) => {
                        prop_assert_eq!(moved.to.as_str(), STATES[m.ts[t].1]);
                        let to = m.ts[t].1;
                        m.enter(to);
                        returned += 1;
                    }
                    (Err(err), None) => prop_assert_eq!(err.code(), "NOT_PENDING"),
                    (got, want) => prop_assert!(false, "complete: got {:?}, model pending {:?}", got, want),
                },
                Event::Refuse => {
                    let had = m.pending.take();
                    prop_assert_eq!(r.refused().is_ok(), had.is_some());
                    if let Some(t) = had {
                        // Tried again: due a period after the check that fired it.
                        m.changed[t] = true;
                        returned += 1;
                    }
                }
                Event::Fault => {
                    let had = m.pending.is_some();
                    prop_assert_eq!(r.faulted().is_ok(), had);
                    if m.fault() { returned += 1; }
                }
                Event::Reset => {
                    let ok = m.pending.is_none();
                    prop_assert_eq!(r.reset().is_ok(), ok);
                    if ok {
                        m.halted = false;
                        m.enter(0);
                    }
                }
                Event::Gate(open) => {
                    r.gate(open);
                    m.gate_closed = !open;
                }
                Event::Restart => {
                    let snapshot: RoutineSnapshot = serde_json::from_value(serde_json::to_value(r.snapshot().clone()).unwrap()).unwrap();
                    r = RoutineMachine::new(&plant, "r").unwrap();
                    let moved = r.restore(&snapshot, &[]).unwrap();
                    prop_assert_eq!(moved.is_some(), m.pending.is_some());
                    if m.fault() { returned += 1; }
                    m.checked = vec![None; m.ts.len()];
                    m.changed = vec![false; m.ts.len()];
                    // A new machine starts open: its host says when the gate is closed.
                    m.gate_closed = false;
                }
            }
            prop_assert_eq!(r.state(), STATES[m.state]);
            let pending = m.pending.map(|t| format!("op{}", m.ts[t].2));
            prop_assert_eq!(r.pending(), pending.as_deref());
            prop_assert_eq!(r.halted(), m.halted);
            prop_assert_eq!(r.next_deadline(), m.next_deadline().map(ms));
            // At most one operation pending at any time.
            prop_assert!(dispatched - returned <= 1);
        }
    }

    #[test]
    fn sensor_store_matches_the_reference(samples in prop::collection::vec((0..2usize, -5.0f64..5.0, -3000i64..1500, 0u64..2500, any::<bool>()), 1..80)) {
        let plant: PlantModel = serde_json::from_value(json!({
            "actuatorTypes": {}, "devices": [{ "id": "st", "kind": "sensor-station" }],
            "sensors": [{ "id": "A", "device": "st", "name": "a", "staleMs": 2000 }, { "id": "B", "device": "st", "name": "b", "staleMs": 1000 }],
            "clockSkewMs": 1000
        })).unwrap();
        let mut store = SensorStore::new(&plant);
        let ids = [store.sensor("A").unwrap(), store.sensor("B").unwrap()];
        let limits = [2000u64, 1000];
        // Reference: (value, received) of the last sample received whose
        // device timestamp is at most 1000 ms ahead of its reception.
        let mut model: [Option<(f64, u64)>; 2] = [None, None];
        let mut now = 0u64;
        for (sensor, value, ts_offset, gap, read_both) in samples {
            now += gap;
            let sampled = now.saturating_add_signed(ts_offset);
            let recorded = store.record(ids[sensor], value, ms(sampled), ms(now));
            let plausible = sampled <= now + 1000;
            prop_assert_eq!(recorded.is_ok(), plausible, "{:?}", recorded);
            if let Err(err) = recorded { prop_assert_eq!(err.code(), "FUTURE_TIMESTAMP"); }
            if plausible { model[sensor] = Some((value, now)); }
            let later = now + gap;
            let fresh = |k: usize| model[k].filter(|(_, at)| later - at < limits[k]).map(|(v, _)| v);
            for (k, &id) in ids.iter().enumerate() {
                prop_assert_eq!(store.fresh(id, ms(later)).ok(), fresh(k));
            }
            let read = store.read(if read_both { &ids[..] } else { &ids[sensor..=sensor] }, ms(later));
            let expected: Option<Vec<f64>> = if read_both { fresh(0).zip(fresh(1)).map(|(a, b)| vec![a, b]) } else { fresh(sensor).map(|v| vec![v]) };
            prop_assert_eq!(read.ok(), expected);
        }
    }
}
