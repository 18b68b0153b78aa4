//! A broken plant document is refused with one error per problem, each naming its entry.

use serde_json::{json, Value};
use sugarshack_core::actuator::Tracker;
use sugarshack_core::plant::PlantModel;

fn good() -> Value {
    json!({
        "name": "test plant",
        "actuatorTypes": {
            "valve": { "signal": "analog", "unit": "%", "tolerance": 3, "noMotionMs": 4000, "completionMs": 15000, "staleMs": 5000, "retries": 1 },
            "pump": { "signal": "binary", "noMotionMs": 4000, "completionMs": 6000, "staleMs": 5000 }
        },
        "devices": [{ "id": "ctrl-1", "kind": "actuator-panel" }, { "id": "station-2", "kind": "sensor-station" }],
        "actuators": [
            { "id": "V12", "type": "valve", "device": "ctrl-1", "io": 12, "idle": 0, "lockout": 0 },
            { "id": "P1", "type": "pump", "device": "ctrl-1", "io": 1, "idle": false, "lockout": false }
        ],
        "sensors": [{ "id": "LT-2", "device": "station-2", "name": "volume", "unit": "L", "staleMs": 5000 }],
        "simulation": { "tanks": [] }
    })
}

/// A change that breaks a sound document.
type Breakage = fn(&mut Value);

fn problems(doc: Value) -> Vec<String> {
    let plant: PlantModel = serde_json::from_value(doc).expect("well-formed document");
    match plant.validate() {
        Ok(()) => vec![],
        Err(errors) => errors.0.iter().map(ToString::to_string).collect(),
    }
}

#[test]
fn a_sound_plant_validates_and_tracks() {
    assert_eq!(problems(good()), Vec::<String>::new());
    let plant: PlantModel = serde_json::from_value(good()).unwrap();
    assert!(Tracker::new(plant, 0).is_ok());
}

#[test]
fn each_problem_names_its_entry() {
    let cases: Vec<(Breakage, &str)> = vec![
        (
            |d| d["actuators"][0]["device"] = json!("ctrl-9"),
            "actuators[0] (V12): unknown device 'ctrl-9'",
        ),
        (
            |d| d["actuators"][0]["device"] = json!("station-2"),
            "actuators[0] (V12): device 'station-2' is a sensor station",
        ),
        (
            |d| d["actuators"][1]["type"] = json!("motor"),
            "actuators[1] (P1): unknown type 'motor' (known: pump, valve)",
        ),
        (
            |d| d["actuators"][1]["id"] = json!("V12"),
            "actuators[1] (V12): id 'V12' is used twice",
        ),
        (
            |d| d["actuators"][0]["idle"] = json!(120),
            "actuators[0] (V12): idle must be within 0..100, got 120",
        ),
        (
            |d| d["actuators"][1]["lockout"] = json!(0),
            "actuators[1] (P1): lockout must be true or false, got 0",
        ),
        (
            |d| d["actuators"][0]["io"] = json!(0),
            "actuators[0] (V12): io numbers start at 1",
        ),
        (
            |d| d["actuators"][0]["tolerance"] = json!(60),
            "actuators[0] (V12): tolerance must be at least 0 and less than half the range",
        ),
        (
            |d| d["actuatorTypes"]["valve"]["staleMs"] = json!(0),
            "actuatorTypes.valve: staleMs must be positive",
        ),
        (
            |d| d["actuatorTypes"]["valve"]["noMotionMs"] = json!(20000),
            "actuatorTypes.valve: noMotionMs must not exceed completionMs",
        ),
        (
            |d| d["actuatorTypes"]["pump"]["tolerance"] = json!(1),
            "actuatorTypes.pump: a binary type has no min, max or tolerance",
        ),
        (
            |d| d["devices"][1]["id"] = json!("ctrl-1"),
            "devices[1] (ctrl-1): device 'ctrl-1' is defined twice",
        ),
        (
            |d| d["devices"][0]["id"] = json!("ctrl/1"),
            "devices[0] (ctrl/1): a device id is its topic prefix",
        ),
        (
            |d| d["sensors"][0]["device"] = json!("station-7"),
            "sensors[0] (LT-2): unknown device 'station-7'",
        ),
        (
            |d| d["sensors"][0]["id"] = json!("P1"),
            "sensors[0] (P1): id 'P1' is used twice",
        ),
    ];
    for (breaks, expected) in cases {
        let mut doc = good();
        breaks(&mut doc);
        let found = problems(doc);
        assert!(
            found.iter().any(|p| p.starts_with(expected)),
            "expected {expected:?}, got {found:?}"
        );
    }
}

#[test]
fn a_slot_taken_twice_is_refused() {
    let mut doc = good();
    doc["actuators"].as_array_mut().unwrap().push(json!({ "id": "V13", "type": "valve", "device": "ctrl-1", "io": 12, "idle": 0, "lockout": 0 }));
    assert_eq!(
        problems(doc),
        vec![
            "actuators[2] (V13): ctrl-1 valve io 12 is already taken by another actuator"
                .to_string()
        ]
    );
}

#[test]
fn all_problems_are_reported_together() {
    let mut doc = good();
    doc["actuators"][0]["device"] = json!("nowhere");
    doc["actuators"][1]["idle"] = json!("off");
    let plant: PlantModel = serde_json::from_value(doc).unwrap();
    let err = Tracker::new(plant, 0).unwrap_err();
    let text = err.to_string();
    assert!(
        text.starts_with("invalid plant document (2 problems):"),
        "{text}"
    );
    assert!(text.contains("V12") && text.contains("P1"), "{text}");
}

#[test]
fn unknown_fields_are_refused_by_name() {
    let mut doc = good();
    doc["actuators"][0]["tolerence"] = json!(2);
    let err = serde_json::from_value::<PlantModel>(doc)
        .unwrap_err()
        .to_string();
    assert!(err.contains("tolerence"), "{err}");
}
