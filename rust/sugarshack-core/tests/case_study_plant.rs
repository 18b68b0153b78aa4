//! The case-study plant document (`flows/plant.json`) holds the paper's Fig. 8
//! operations exactly, every one owned by exactly one routine, and validates
//! without a warning.

use std::collections::{BTreeMap, BTreeSet};

use sugarshack_core::plant::{PlantModel, Step, Trigger};

/// Fig. 8: id, priority, description, lines ticked.
const FIG_8: [(&str, i32, &str, &[&str]); 16] = [
    ("10", 20, "load truck", &["YEL"]),
    ("11", 23, "passive prime truck", &["YEL"]),
    ("12", 22, "unload truck", &["YEL"]),
    ("20", 78, "conc flush to truck", &["YEL"]),
    ("15", 77, "truck wash", &["YEL"]),
    ("18", 92, "flit downstock", &["YEL", "RED"]),
    ("19", 91, "flit topstock", &["YEL"]),
    ("21", 101, "evap push conc", &["GRN"]),
    ("23", 99, "evap desugar", &["GRN", "RED"]),
    ("24", 100, "evap final desugar", &["GRN", "RED"]),
    ("33", 88, "desugar push to s7", &["BLU", "RED"]),
    ("41", 69, "washball push", &["PUR", "RED"]),
    ("42", 55, "washball drain", &["PUR", "RED"]),
    ("48", 97, "push to evap wash", &["PUR", "RED"]),
    ("49", 96, "push to heater tank", &["PUR", "RED"]),
    ("51", 1, "drain silo 1-6", &["RED"]),
];

fn plant() -> PlantModel {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../flows/plant.json");
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{path}: {e}"))
}

#[test]
fn the_document_validates_without_warnings() {
    let warnings = plant().validate().unwrap_or_else(|e| panic!("{e}"));
    assert!(warnings.is_empty(), "{warnings:?}");
}

#[test]
fn the_operations_are_fig_8() {
    let plant = plant();
    let ids: Vec<&str> = plant.operations.iter().map(|o| o.id.as_str()).collect();
    let expected: Vec<&str> = FIG_8.iter().map(|(id, ..)| *id).collect();
    assert_eq!(ids, expected, "the operations, in Fig. 8's order");
    for (id, priority, description, lines) in FIG_8 {
        let op = plant.operations.iter().find(|o| o.id == id).unwrap();
        assert_eq!(op.priority, priority, "priority of operation {id}");
        assert_eq!(
            op.description.as_deref(),
            Some(description),
            "description of operation {id}"
        );
        let got: BTreeSet<&str> = op.resources.iter().map(String::as_str).collect();
        let want: BTreeSet<&str> = lines.iter().copied().collect();
        assert_eq!(got, want, "lines of operation {id}");
        assert_eq!(
            op.resources.len(),
            lines.len(),
            "operation {id} lists a line twice"
        );
    }
}

/// Each operation commands an actuator of every line it acquires (a line held
/// for nothing would only block others), and waits on at least one condition.
#[test]
fn every_operation_uses_each_of_its_lines_and_waits_on_the_plant() {
    let plant = plant();
    for op in &plant.operations {
        let mut lines = BTreeSet::new();
        let mut waits = 0;
        for step in &op.steps {
            match step {
                Step::Command { command, .. } => {
                    for (_, name, _) in command.members() {
                        let a = plant.actuators.iter().find(|a| a.id == name).unwrap();
                        lines.insert(a.resource.clone().unwrap());
                    }
                }
                Step::Wait { .. } => waits += 1,
            }
        }
        let held: BTreeSet<String> = op.resources.iter().cloned().collect();
        assert_eq!(
            lines, held,
            "operation {} commands actuators of these lines",
            op.id
        );
        assert!(waits > 0, "operation {} has no condition step", op.id);
    }
}

#[test]
fn every_operation_belongs_to_exactly_one_routine() {
    let plant = plant();
    let mut owners: BTreeMap<&str, BTreeSet<&str>> = BTreeMap::new();
    for routine in &plant.routines {
        assert!(
            routine.error_state.is_some(),
            "routine {} has no error state",
            routine.id
        );
        for t in &routine.transitions {
            owners
                .entry(t.operation.as_str())
                .or_default()
                .insert(routine.id.as_str());
        }
    }
    for (id, ..) in FIG_8 {
        let routines = owners.remove(id).unwrap_or_default();
        assert_eq!(
            routines.len(),
            1,
            "operation {id} belongs to {routines:?}; it must belong to exactly one routine"
        );
    }
    assert!(
        owners.is_empty(),
        "routines run unknown operations: {owners:?}"
    );
}

/// The demo runs by itself and keeps running: condition triggers only, and from
/// every state a routine can get back to its initial state.
#[test]
fn every_routine_cycles_back_to_its_initial_state() {
    let plant = plant();
    for routine in &plant.routines {
        for t in &routine.transitions {
            assert!(
                matches!(t.trigger, Trigger::When { .. }),
                "routine {} transition {} -> {} is not a condition trigger",
                routine.id,
                t.from,
                t.to
            );
        }
        // States that reach the initial one, walking transitions backwards.
        let mut reach = BTreeSet::from([routine.initial.as_str()]);
        loop {
            let before = reach.len();
            for t in &routine.transitions {
                if reach.contains(t.to.as_str()) {
                    reach.insert(t.from.as_str());
                }
            }
            if reach.len() == before {
                break;
            }
        }
        for state in &routine.states {
            if Some(state) == routine.error_state.as_ref() {
                continue; // left by an operator's reset
            }
            assert!(
                reach.contains(state.as_str()),
                "routine {}: state {state} never leads back to {}",
                routine.id,
                routine.initial
            );
        }
    }
}

/// YEL and RED are each wanted by operations of more than one routine.
#[test]
fn yel_and_red_are_contended_between_routines() {
    let plant = plant();
    for line in ["YEL", "RED"] {
        let routines: BTreeSet<&str> = plant
            .routines
            .iter()
            .filter(|r| {
                r.transitions.iter().any(|t| {
                    plant
                        .operations
                        .iter()
                        .any(|o| o.id == t.operation && o.resources.iter().any(|x| x == line))
                })
            })
            .map(|r| r.id.as_str())
            .collect();
        assert!(routines.len() >= 2, "{line} is wanted by {routines:?} only");
    }
}
