use serde_json::json;

use super::*;
use crate::plant::PlantModel;
use crate::time::ms;

fn plant(error_state: bool) -> Plant {
    let mut routine = json!({
        "id": "truck",
        "states": ["empty", "full", "primed", "fault"],
        "initial": "empty",
        "transitions": [
            { "from": "empty", "to": "full", "operation": "10", "trigger": { "msg": "load" } },
            { "from": "full", "to": "primed", "operation": "11",
              "trigger": { "when": "`LT-3` > 100", "sensors": ["LT-3"], "everyMs": 1000 } },
            { "from": "full", "to": "empty", "operation": "12",
              "trigger": { "when": "`LT-3` > 500", "sensors": ["LT-3"], "everyMs": 3000 } },
            { "from": "primed", "to": "empty", "operation": "12", "trigger": { "msg": "unload" } },
            { "from": "fault", "to": "empty", "operation": "15", "trigger": { "msg": "wash" } }
        ]
    });
    if error_state {
        routine["errorState"] = json!("fault");
    }
    let op = |id: &str, priority: i32| {
        json!({ "id": id, "priority": priority, "resources": ["YEL"], "steps": [
            { "wait": "`LT-3` >= 0", "sensors": ["LT-3"], "timeoutMs": 1000 }
        ] })
    };
    let plant: PlantModel = serde_json::from_value(json!({
        "actuatorTypes": {},
        "devices": [{ "id": "ctrl-1", "kind": "actuator-panel" }, { "id": "station-3", "kind": "sensor-station" }],
        "actuators": [],
        "sensors": [{ "id": "LT-3", "device": "station-3", "name": "volume" }],
        "resources": [{ "id": "YEL", "lockout": { "valves": {} } }],
        "operations": [op("10", 20), op("11", 23), op("12", 22), op("15", 77)],
        "routines": [routine]
    }))
    .unwrap();
    Plant::new(plant).unwrap()
}

/// The truck routine after its "load" message started operation 10.
fn truck_after_load(error_state: bool) -> RoutineMachine {
    let mut r = RoutineMachine::new(&plant(error_state), "truck").unwrap();
    r.on_msg("load").unwrap();
    r
}

#[test]
fn a_msg_dispatches_one_operation_and_its_return_moves_the_state() {
    let mut r = RoutineMachine::new(&plant(true), "truck").unwrap();
    assert_eq!(r.state(), "empty");
    let d = r.on_msg("load").unwrap();
    assert_eq!(
        (d.operation.as_str(), d.from.as_str(), d.to.as_str()),
        ("10", "empty", "full")
    );
    assert_eq!(r.pending(), Some("10"));
    let busy = r.on_msg("load").unwrap_err();
    assert_eq!(busy.code(), "ROUTINE_BUSY");
    assert_eq!(busy.to_string(), "routine 'truck' is waiting for operation '10'; one operation at a time (the trigger was refused)");
    let moved = r.completed().unwrap();
    assert_eq!((moved.from.as_str(), moved.to.as_str()), ("empty", "full"));
    assert_eq!(r.state(), "full");
    assert_eq!(r.pending(), None);
    assert_eq!(r.completed().unwrap_err().code(), "NOT_PENDING");
}

#[test]
fn a_msg_without_a_transition_from_the_state_is_refused() {
    let mut r = RoutineMachine::new(&plant(true), "truck").unwrap();
    let err = r.on_msg("unload").unwrap_err();
    assert_eq!(
        err.to_string(),
        "routine 'truck' has no transition on 'unload' from state 'empty'"
    );
    assert_eq!(r.state(), "empty");
}

#[test]
fn conditions_fall_due_on_entry_then_after_a_sample_once_a_period_and_the_first_met_fires() {
    let mut r = RoutineMachine::new(&plant(true), "truck").unwrap();
    assert!(
        r.due(ms(0)).is_empty(),
        "no condition transition leaves 'empty'"
    );
    r.on_msg("load").unwrap();
    assert!(
        r.due(ms(0)).is_empty(),
        "nothing is due while an operation runs"
    );
    r.completed().unwrap();
    assert_eq!(
        r.next_deadline(),
        Some(Millis::ZERO),
        "due at once in a new state"
    );
    assert_eq!(r.due(ms(10_000)), vec![1, 2]);
    assert_eq!(
        r.next_deadline(),
        None,
        "nothing sampled: nothing to check again"
    );
    assert!(
        r.due(ms(20_000)).is_empty(),
        "no polling: unchanged values cannot hold now"
    );
    r.input_changed(1);
    r.input_changed(2);
    assert_eq!(
        r.next_deadline(),
        Some(ms(11_000)),
        "everyMs after the check"
    );
    assert!(r.due(ms(10_999)).is_empty());
    assert_eq!(r.due(ms(11_000)), vec![1]);
    assert_eq!(r.next_deadline(), Some(ms(13_000)));
    r.input_changed(1);
    assert_eq!(r.due(ms(13_000)), vec![1, 2]);
    assert_eq!(
        r.condition(2),
        Some(("`LT-3` > 500", &["LT-3".to_string()][..]))
    );
    let d = r.condition_met(2).unwrap();
    assert_eq!(d.operation, "12");
    r.input_changed(1);
    assert_eq!(
        r.next_deadline(),
        None,
        "nothing is due while an operation runs"
    );
    assert_eq!(
        r.condition_met(1),
        None,
        "one pending operation: a second met condition does not fire"
    );
    r.completed().unwrap();
    assert_eq!(r.state(), "empty");
    assert_eq!(
        r.condition_met(1),
        None,
        "a condition of a state left meanwhile does not fire"
    );
}

#[test]
fn conditions_are_checked_only_while_the_gate_is_open() {
    let mut r = truck_after_load(true);
    r.completed().unwrap();
    r.gate(false);
    assert_eq!(r.next_deadline(), None, "no deadline while closed");
    assert!(r.due(ms(0)).is_empty(), "nothing due while closed");
    r.input_changed(1);
    assert_eq!(r.next_deadline(), None);
    // Open again: what was due is due at once, unchecked so far.
    r.gate(true);
    assert_eq!(r.next_deadline(), Some(Millis::ZERO));
    assert_eq!(r.due(ms(1_000)), vec![1, 2]);
    // Closed between the check and its result: it does not fire, and is due again a period later.
    r.gate(false);
    assert_eq!(r.condition_met(1), None);
    assert_eq!(r.pending(), None);
    r.gate(true);
    assert_eq!(r.next_deadline(), Some(ms(2_000)));
    assert_eq!(r.due(ms(2_000)), vec![1]);
    assert_eq!(r.condition_met(1).unwrap().operation, "11");
}

#[test]
fn a_met_condition_held_back_by_a_pending_operation_is_due_again() {
    let mut r = truck_after_load(true);
    r.completed().unwrap();
    assert_eq!(r.due(ms(0)), vec![1, 2]);
    // Both hold: the first fires, the second waits for the operation.
    assert!(r.condition_met(1).is_some());
    assert_eq!(r.condition_met(2), None);
    // Refused before it ran: both are due again a period after the check.
    r.refused().unwrap();
    assert_eq!(r.next_deadline(), Some(ms(1_000)));
    assert_eq!(r.due(ms(3_000)), vec![1, 2]);
}

#[test]
fn a_fault_moves_to_the_error_state() {
    let mut r = truck_after_load(true);
    let moved = r.faulted().unwrap();
    assert_eq!((moved.to.as_str(), moved.halted), ("fault", false));
    assert_eq!(r.on_msg("wash").unwrap().operation, "15");
}

#[test]
fn without_an_error_state_a_fault_halts_until_reset() {
    let mut r = truck_after_load(false);
    let moved = r.faulted().unwrap();
    assert_eq!((moved.to.as_str(), moved.halted), ("empty", true));
    assert_eq!(r.on_msg("load").unwrap_err().code(), "ROUTINE_HALTED");
    let moved = r.reset().unwrap();
    assert_eq!(moved.to, "empty");
    assert!(r.on_msg("load").is_ok());
    assert_eq!(r.reset().unwrap_err().code(), "ROUTINE_BUSY");
}

#[test]
fn a_failed_run_moves_the_routine_as_its_end_state_says() {
    // Ended before it ran (refused, withdrawn), or no run started: refused, nothing moved.
    for ended in [None, Some(State::Refused), Some(State::Withdrawn)] {
        let mut r = truck_after_load(true);
        let failed = r.run_failed(ended).unwrap();
        assert_eq!((failed.outcome, failed.moved), (Failure::Refused, None));
        assert_eq!(r.pending(), None);
        assert_eq!(r.state(), "empty");
    }
    let mut r = truck_after_load(true);
    let failed = r.run_failed(Some(State::Faulted)).unwrap();
    assert_eq!(failed.outcome, Failure::Faulted);
    assert_eq!(failed.moved.map(|m| m.to), Some("fault".to_owned()));
    let mut r = truck_after_load(true);
    let failed = r.run_failed(Some(State::Aborted)).unwrap();
    assert_eq!(failed.outcome, Failure::Aborted);
    assert_eq!(failed.moved.map(|m| m.to), Some("empty".to_owned()));
    assert!(r.on_msg("load").is_err(), "aborted until a reset");
    assert_eq!(r.run_failed(None).unwrap_err().code(), "NOT_PENDING");
}

#[test]
fn a_restore_with_an_operation_pending_counts_it_as_faulted() {
    let p = plant(true);
    let mut r = RoutineMachine::new(&p, "truck").unwrap();
    r.on_msg("load").unwrap();
    let snapshot = r.snapshot();
    assert_eq!(
        snapshot,
        RoutineSnapshot {
            routine: "truck".into(),
            state: "empty".into(),
            pending: Some("10".into()),
            halted: false,
            ..RoutineSnapshot::default()
        }
    );
    let mut restored = RoutineMachine::new(&p, "truck").unwrap();
    let moved = restored.restore(&snapshot, &[]).unwrap();
    assert_eq!(moved.unwrap().operation.as_deref(), Some("10"));
    assert_eq!((restored.state(), restored.pending()), ("fault", None));

    let quiet = RoutineSnapshot {
        routine: "truck".into(),
        state: "primed".into(),
        pending: None,
        halted: false,
        ..RoutineSnapshot::default()
    };
    let mut restored = RoutineMachine::new(&p, "truck").unwrap();
    let moved = restored.restore(&quiet, &[]).unwrap();
    assert_eq!((restored.state(), moved), ("primed", None));
}

#[test]
fn a_snapshot_that_no_longer_fits_the_routine_is_refused() {
    let p = plant(true);
    for (snapshot, why) in [
        (
            RoutineSnapshot {
                routine: "silo".into(),
                state: "empty".into(),
                pending: None,
                halted: false,
                ..RoutineSnapshot::default()
            },
            "routine 'silo''s",
        ),
        (
            RoutineSnapshot {
                routine: "truck".into(),
                state: "gone".into(),
                pending: None,
                halted: false,
                ..RoutineSnapshot::default()
            },
            "no state 'gone'",
        ),
        (
            RoutineSnapshot {
                routine: "truck".into(),
                state: "empty".into(),
                pending: Some("12".into()),
                halted: false,
                ..RoutineSnapshot::default()
            },
            "no transition from 'empty' running '12'",
        ),
    ] {
        let mut r = RoutineMachine::new(&p, "truck").unwrap();
        r.on_msg("load").unwrap();
        let err = r.restore(&snapshot, &[]).unwrap_err();
        assert_eq!(
            (r.state(), r.pending()),
            ("empty", Some("10")),
            "a refused snapshot changes nothing"
        );
        assert_eq!(err.code(), "INVALID_SNAPSHOT");
        assert!(err.to_string().contains(why), "{err}");
    }
    assert_eq!(
        RoutineMachine::new(&p, "nope").unwrap_err().code(),
        "UNKNOWN_ROUTINE"
    );
}

#[test]
fn the_operations_of_a_routine_are_listed_once() {
    let r = RoutineMachine::new(&plant(true), "truck").unwrap();
    assert_eq!(r.operations(), vec!["10", "11", "12", "15"]);
    let conditions: Vec<usize> = r.conditions().iter().map(|c| c.0).collect();
    assert_eq!(conditions, vec![1, 2]);
}

#[test]
fn a_dispatch_refused_before_it_ran_leaves_the_state_unchanged() {
    let mut r = truck_after_load(true);
    r.refused().unwrap();
    assert_eq!((r.state(), r.pending(), r.halted()), ("empty", None, false));
    assert_eq!(r.on_msg("load").unwrap().operation, "10");
    r.completed().unwrap();
    assert!(r.refused().is_err());
    // A condition's dispatch refused is tried again a period after its check, with no new sample.
    assert_eq!(r.due(ms(1_000)), vec![1, 2]);
    assert_eq!(r.condition_met(1).unwrap().operation, "11");
    r.refused().unwrap();
    assert_eq!(r.next_deadline(), Some(ms(2_000)));
    assert_eq!(r.due(ms(2_000)), vec![1]);
}

#[test]
fn the_checked_plant_resolves_every_state_of_a_routine_once() {
    let p = plant(true);
    let graph = p.routine("truck").unwrap();
    let name = |s: StateId| graph.name(s);
    assert_eq!(name(graph.initial()), "empty");
    assert_eq!(graph.error_state().map(name), Some("fault"));
    let edges: Vec<(&str, &str, &str)> = graph
        .edges()
        .iter()
        .map(|e| (name(e.from), name(e.to), e.operation.as_str()))
        .collect();
    assert_eq!(edges[1], ("full", "primed", "11"));
    assert_eq!(edges.len(), 5);
    assert_eq!(graph.state("primed"), Some(edges_from(graph, 3)));
    assert!(p.routine("nope").is_none());
    assert_eq!(plant(false).routine("truck").unwrap().error_state(), None);
}

fn edges_from(graph: &RoutineGraph, edge: usize) -> StateId {
    graph.edges()[edge].from
}
