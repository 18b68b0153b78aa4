//! A broken plant document is refused with one error per problem, each naming its entry.

use serde_json::{json, Value};
use sugarshack_core::actuator::Tracker;
use sugarshack_core::plant::PlantModel;
use sugarshack_core::time::ms;

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

/// Each breakage of the base document is reported with a problem starting as expected.
fn assert_each_names_its_problem(base: fn() -> Value, cases: Vec<(Breakage, &str)>) {
    for (breaks, expected) in cases {
        let mut doc = base();
        breaks(&mut doc);
        let found = problems(doc);
        assert!(
            found.iter().any(|p| p.starts_with(expected)),
            "expected {expected:?}, got {found:?}"
        );
    }
}

fn problems(doc: Value) -> Vec<String> {
    let plant: PlantModel = serde_json::from_value(doc).expect("well-formed document");
    match plant.validate() {
        Ok(_) => vec![],
        Err(errors) => errors.0.iter().map(ToString::to_string).collect(),
    }
}

#[test]
fn a_sound_plant_validates_and_tracks() {
    assert_eq!(problems(good()), Vec::<String>::new());
    let plant: PlantModel = serde_json::from_value(good()).unwrap();
    assert!(Tracker::new(plant, ms(0)).is_ok());
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
    assert_each_names_its_problem(good, cases);
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
    doc["actuators"][1]["idle"] = json!(0);
    let plant: PlantModel = serde_json::from_value(doc).unwrap();
    let err = Tracker::new(plant, ms(0)).unwrap_err();
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

/// The sound plant with lines, operations and a routine.
fn with_operations() -> Value {
    let mut doc = good();
    doc["resources"] =
        json!([{ "id": "YEL" }, { "id": "RED", "lockout": { "pumps": { "P1": false } } }]);
    doc["actuators"][0]["resource"] = json!("YEL");
    doc["actuators"][1]["resource"] = json!("YEL");
    doc["actuators"].as_array_mut().unwrap().push(json!({ "id": "V40", "type": "valve", "device": "ctrl-1", "io": 40, "idle": 0, "lockout": 0, "resource": "RED" }));
    doc["operations"] = json!([
        { "id": "10", "description": "load truck", "priority": 20, "resources": ["YEL"], "steps": [
            { "command": { "valves": { "V12": 100 }, "pumps": { "P1": true } }, "timeoutMs": 20000 },
            { "wait": "`LT-2` < 100", "sensors": ["LT-2"], "timeoutMs": 600000 }
        ] },
        { "id": "18", "priority": 92, "resources": ["YEL", "RED"], "steps": [
            { "command": { "valves": { "V12": 100, "V40": 100 } }, "timeoutMs": 20000 }
        ] }
    ]);
    doc["routines"] = json!([
        { "id": "truck", "states": ["empty", "full", "error"], "initial": "empty", "errorState": "error", "transitions": [
            { "from": "empty", "to": "full", "operation": "10", "trigger": { "msg": "load" } },
            { "from": "full", "to": "empty", "operation": "18", "trigger": { "when": "`LT-2` > 10", "sensors": ["LT-2"], "everyMs": 5000 } }
        ] }
    ]);
    doc
}

#[test]
fn operations_and_routines_validate_and_lockouts_derive_from_members() {
    let plant: PlantModel = serde_json::from_value(with_operations()).unwrap();
    assert_eq!(plant.validate().unwrap(), vec![]);
    let lockout_of = |r| {
        plant
            .lockout_of(r)
            .map(|c| serde_json::to_value(c).unwrap())
    };
    assert_eq!(
        lockout_of("YEL"),
        Some(json!({ "valves": { "V12": 0 }, "pumps": { "P1": false } }))
    );
    assert_eq!(
        lockout_of("RED"),
        Some(json!({ "pumps": { "P1": false } })),
        "a configured lockout wins"
    );
    let config = plant.interlock_config();
    assert_eq!(
        config
            .resources
            .iter()
            .map(|r| r.name.as_str())
            .collect::<Vec<_>>(),
        vec!["YEL", "RED"]
    );
    assert_eq!(
        config.resources[0].lockout,
        json!({ "valves": { "V12": 0 }, "pumps": { "P1": false } })
    );
    assert!(sugarshack_core::interlock::Interlock::new(config).is_ok());
}

#[test]
fn the_papers_conditions_are_checked_at_deploy() {
    let cases: Vec<(Breakage, &str)> = vec![
        (
            |d| d["operations"][0]["steps"][0]["command"] = json!({ "valves": { "V40": 100 } }),
            "operations[0] (10).steps[0]: C2: commands 'V40' on resource 'RED', outside the operation's resources (YEL)",
        ),
        (|d| d["actuators"][0]["resource"] = json!(null), "operations[0] (10).steps[0]: C2: commands 'V12', which belongs to no resource"),
        (|d| d["actuators"][0]["idle"] = json!(null), "operations[0] (10).steps[0]: C3: commands 'V12', which has no idle state to return to"),
        (
            |d| {
                let second = json!({ "id": "shuttle", "states": ["a"], "initial": "a",
                    "transitions": [{ "from": "a", "to": "a", "operation": "10", "trigger": { "msg": "go" } }] });
                d["routines"].as_array_mut().unwrap().push(second);
            },
            "routines[1] (shuttle).transitions[0]: C1: operation '10' already belongs to routine 'truck'",
        ),
        (|d| d["operations"][0]["resources"] = json!(["GRN"]), "operations[0] (10): unknown resource 'GRN'"),
        (|d| d["operations"][0]["steps"][1]["sensors"] = json!(["LT-9"]), "operations[0] (10).steps[1]: unknown sensor 'LT-9'"),
        (|d| d["operations"][0]["steps"][0]["command"] = json!({ "valves": { "V99": 1 } }), "operations[0] (10).steps[0]: unknown actuator 'V99'"),
        (|d| d["operations"][0]["steps"][0]["timeoutMs"] = json!(0), "operations[0] (10).steps[0]: timeoutMs must be positive"),
        (|d| d["routines"][0]["transitions"][0]["operation"] = json!("77"), "routines[0] (truck).transitions[0]: unknown operation '77'"),
        (|d| d["routines"][0]["transitions"][1]["to"] = json!("gone"), "routines[0] (truck).transitions[1]: unknown state 'gone'"),
        (|d| d["routines"][0]["initial"] = json!("start"), "routines[0] (truck): initial 'start' is not one of its states"),
        (
            |d| d["routines"][0]["transitions"][0]["trigger"] = json!({ "msg": "reset" }),
            "routines[0] (truck).transitions[0]: the msg topic 'reset' is reserved: it sends the routine back to its initial state, so this transition could never fire; give it another topic",
        ),
        (|d| d["actuators"][2]["resource"] = json!("BLU"), "actuators[2] (V40): unknown resource 'BLU'"),
        (
            |d| {
                d["resources"].as_array_mut().unwrap().push(json!({ "id": "PUR" }));
            },
            "resources[2] (PUR): no lockout command: give it one, or actuators that belong to it",
        ),
    ];
    assert_each_names_its_problem(with_operations, cases);
}

#[test]
fn equal_priorities_are_a_warning_not_an_error() {
    let mut doc = with_operations();
    doc["operations"][1]["priority"] = json!(20);
    let plant: PlantModel = serde_json::from_value(doc).unwrap();
    let warnings = plant.validate().unwrap();
    assert_eq!(warnings.len(), 1);
    assert_eq!(
        warnings[0].to_string(),
        "operations[1] (18): priority 20 is also operation '10''s: equal priorities are granted first come, first served"
    );
}

#[test]
fn the_case_study_plant_validates() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../flows/plant.json"
    ))
    .unwrap();
    let plant: PlantModel = serde_json::from_str(&text).unwrap();
    let warnings = plant.validate().unwrap_or_else(|e| panic!("{e}"));
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!(
        plant.actuators.iter().filter(|a| a.kind == "valve").count(),
        50
    );
    assert_eq!(
        plant.actuators.iter().filter(|a| a.kind == "pump").count(),
        3
    );
}

/// The error text of reading `doc`, as a user would give it.
fn read_error(doc: Value) -> String {
    sugarshack_core::json::from_str::<PlantModel>(&doc.to_string())
        .expect_err("the document is broken")
        .without_position()
        .to_string()
}

#[test]
fn a_document_that_cannot_be_read_names_the_entry() {
    let mut doc = with_operations();
    let actuators = doc["actuators"].as_array_mut().unwrap();
    actuators.push(json!({ "id": "V41", "device": "ctrl-1", "io": 41, "lockout": 0 }));
    assert_eq!(read_error(doc), "actuators[3]: missing field `type`");

    let cases: Vec<(Breakage, &str)> = vec![
        (
            |d| d["operations"][0]["steps"][1] = json!({ "wait": "`LT-2` < 100", "sensors": ["LT-2"] }),
            "operations[0].steps[1]: missing field `timeoutMs`",
        ),
        (
            |d| d["operations"][0]["steps"][0]["timeoutMs"] = json!("20 s"),
            "operations[0].steps[0]: timeoutMs must be a non-negative number of milliseconds; got '20 s'",
        ),
        (
            |d| d["operations"][1]["steps"][0]["timeout"] = json!(20000),
            "operations[1].steps[0].timeout: unknown field `timeout`",
        ),
        (
            |d| d["operations"][0]["steps"][0]["sensors"] = json!(["LT-2"]),
            "operations[0].steps[0]: unknown field `sensors`, expected one of `command`, `timeoutMs`, `restart`",
        ),
        (
            |d| d["operations"][0]["steps"][1] = json!({ "timeoutMs": 1000 }),
            "operations[0].steps[1]: a step needs either 'command' (a group command) or 'wait' (a condition)",
        ),
        (
            |d| d["operations"][0]["steps"][1]["command"] = json!({ "pumps": { "P1": false } }),
            "operations[0].steps[1]: a step has either 'command' or 'wait', not both",
        ),
        (
            |d| d["operations"][0]["steps"][1]["wait"] = json!(null),
            "operations[0].steps[1]: wait must be text in quotes; got null",
        ),
        (
            |d| d["operations"][0]["steps"][0] = json!("open V12"),
            "operations[0]: steps[0] must be a step: {",
        ),
        (
            |d| d["routines"][0]["transitions"][0]["trigger"] = json!({ "mgs": "load" }),
            "routines[0].transitions[0].trigger.mgs: unknown field `mgs`, expected one of `msg`, `when`, `sensors`, `everyMs`",
        ),
        (
            |d| d["routines"][0]["transitions"][1]["trigger"] = json!({ "when": "`LT-2` > 10", "sensors": ["LT-2"] }),
            "routines[0].transitions[1].trigger: missing field `everyMs`",
        ),
        (
            |d| d["routines"][0]["transitions"][0]["trigger"]["everyMs"] = json!(5000),
            "routines[0].transitions[0].trigger: unknown field `everyMs`, expected `msg`",
        ),
        (
            |d| d["routines"][0]["transitions"][0]["trigger"] = json!({}),
            "routines[0].transitions[0].trigger: a trigger needs either 'msg' (a msg topic) or 'when' (a condition)",
        ),
        (
            |d| d["actuatorTypes"]["valve"]["stale"] = json!(5000),
            "actuatorTypes.valve.stale: unknown field `stale`",
        ),
    ];
    for (breaks, expected) in cases {
        let mut doc = with_operations();
        breaks(&mut doc);
        let error = read_error(doc);
        assert!(
            error.starts_with(expected),
            "expected {expected:?}, got {error:?}"
        );
    }
}

#[test]
fn steps_and_triggers_read_back_what_they_wrote() {
    let plant: PlantModel =
        sugarshack_core::json::from_str(&with_operations().to_string()).unwrap();
    let written = serde_json::to_value(&plant).unwrap();
    let given = with_operations();
    for op in 0..2 {
        assert_eq!(
            written["operations"][op]["steps"],
            given["operations"][op]["steps"]
        );
    }
    assert_eq!(written["routines"], given["routines"]);
    assert_eq!(
        serde_json::from_value::<PlantModel>(written).unwrap(),
        plant
    );
}

#[test]
fn a_null_command_is_a_bad_command_not_a_missing_one() {
    let mut doc = with_operations();
    doc["operations"][1]["steps"][0]["command"] = json!(null);
    assert_eq!(
        read_error(doc),
        "operations[1].steps[0]: command must be a group command such as {\"valves\": {\"V12\": 100}}; got null"
    );
}

#[test]
fn problems_quote_at_most_a_hundred_characters_of_what_they_were_given() {
    let long = "x".repeat(1_000_000);
    let mut doc = with_operations();
    doc["actuators"][0]["device"] = json!(long);
    doc["routines"][0]["initial"] = json!(long);
    let found = problems(doc);
    assert_eq!(found.len(), 2, "{found:?}");
    for problem in &found {
        assert!(
            problem.chars().count() < 300,
            "{} characters: {problem:.300}",
            problem.len()
        );
    }
    assert!(found
        .iter()
        .any(|p| p.starts_with("actuators[0] (V12): unknown device 'xxx")));

    let mut doc = with_operations();
    doc["operations"][0]["steps"][0]["command"] = json!({ "valves": { "V12": long } });
    let error = read_error(doc);
    assert!(error.chars().count() < 320, "{error:.320}");
    assert!(
        error.starts_with("operations[0].steps[0].command.valves: V12 must be a setpoint: true or false for a binary actuator, a finite number for an analog one; got 'xxx"),
        "{error:.320}"
    );

    let mut doc = with_operations();
    doc["actuators"][0]["id"] = json!(long);
    assert!(problems(doc).iter().all(|p| p.chars().count() < 300));

    let mut doc = good();
    doc["actuatorTypes"]["valve"][long.as_str()] = json!(1);
    let error = read_error(doc);
    assert!(
        error.chars().count() < 320,
        "{} characters",
        error.chars().count()
    );
}

/// The sound plant on ESPHome devices (entities by object id, components by default).
fn esphome() -> Value {
    let mut doc = good();
    doc["devices"] = json!([
        { "id": "ctrl-1", "kind": "actuator-panel", "profile": "esphome" },
        { "id": "station-2", "kind": "sensor-station", "profile": "esphome", "prefix": "shack/station-2" }
    ]);
    doc
}

#[test]
fn device_profiles_validate() {
    assert_eq!(problems(esphome()), Vec::<String>::new());
    let mut doc = good();
    doc["devices"] = json!([
        { "id": "ctrl-1", "kind": "actuator-panel", "profile": "tasmota" },
        { "id": "station-2", "kind": "sensor-station", "profile": "shelly-gen2" }
    ]);
    doc["actuators"][0]["entity"] = json!("Shutter1");
    doc["actuators"][1]["entity"] = json!("POWER1");
    doc["sensors"][0]["entity"] = json!("temperature:0.tC");
    assert_eq!(problems(doc), Vec::<String>::new());
}

#[test]
fn profile_problems_name_their_entry() {
    let cases: Vec<(Breakage, &str)> = vec![
        (
            |d| d["actuators"][0]["entity"] = json!("V 12"),
            "actuators[0] (V12): entity 'V 12' is not an ESPHome object id (lowercase letters, digits, '_' and '-'); the entity named 'V 12' has object id 'v_12'",
        ),
        (
            |d| d["actuators"][1]["component"] = json!("number"),
            "actuators[1] (P1): an ESPHome number cannot drive a binary actuator (analog: valve, cover or number; binary: switch, valve or cover)",
        ),
        (
            |d| {
                d["actuators"][1]["entity"] = json!("v12");
                d["actuators"][1]["component"] = json!("valve");
            },
            "actuators[1] (P1): its topic 'ctrl-1/valve/v12/state' is also actuators[0] (V12)'s",
        ),
        (
            |d| d["devices"][0]["profile"] = json!("tasmota"),
            "actuators[0] (V12): a tasmota shutter needs 'entity': \"Shutter1\" .. \"Shutter32\", got ''",
        ),
        (
            |d| d["devices"][1]["prefix"] = json!("a/+/b"),
            "devices[1] (station-2): prefix 'a/+/b' must be MQTT topic levels without '+', '#', spaces or empty levels",
        ),
        (
            |d| d["devices"][1]["prefix"] = json!("ctrl-1"),
            "devices[1] (station-2): topic prefix 'ctrl-1' is also device 'ctrl-1''s",
        ),
        (
            |d| d["sensors"][0]["updateMs"] = json!(0),
            "sensors[0] (LT-2): updateMs must be positive",
        ),
        (
            |d| d["devices"][1]["profile"] = json!("custom"),
            "devices[1] (station-2): a custom device needs 'custom': its topic templates",
        ),
        (
            |d| {
                d["devices"][1]["profile"] = json!("custom");
                d["devices"][1]["custom"] = json!({ "sensors": { "state": "{prefix}/{sensor}" } });
            },
            "sensors[0] (LT-2): custom.sensors: '{prefix}/{sensor}' has an unknown placeholder {sensor} (known: {prefix}, {entity})",
        ),
        (
            |d| d["devices"][0]["custom"] = json!({}),
            "devices[0] (ctrl-1): 'custom' is for devices with profile \"custom\"",
        ),
    ];
    assert_each_names_its_problem(esphome, cases);
}

#[test]
fn an_unknown_profile_is_refused_by_path() {
    let mut doc = good();
    doc["devices"][0]["profile"] = json!("zigbee");
    let error = read_error(doc);
    assert!(
        error.starts_with("devices[0]: profile must be one of 'sugarshack', 'esphome', 'tasmota', 'shelly-gen2', 'custom', 'modbus'; got 'zigbee'"),
        "{error}"
    );
}

#[test]
fn a_custom_device_reads_its_templates() {
    let mut doc = good();
    doc["devices"][0] = json!({ "id": "ctrl-1", "kind": "actuator-panel", "profile": "custom", "custom": {
        "status": { "topic": "{prefix}/availability", "online": "up", "offline": "down" },
        "actuators": {
            "valve": { "state": "{prefix}/{entity}", "value": "position", "command": "{prefix}/{entity}/set", "payload": "{\"position\":{value}}" },
            "pump": { "state": "{prefix}/{entity}", "value": "state", "map": { "ON": 1, "OFF": 0 }, "command": "{prefix}/{entity}/set" }
        }
    }});
    assert_eq!(problems(doc.clone()), Vec::<String>::new());
    doc["devices"][0]["custom"]["actuators"]["valve"]["payload"] = json!("{\"position\":1}");
    assert_eq!(
        problems(doc),
        vec!["actuators[0] (V12): custom.actuators.valve.payload '{\"position\":1}' must hold {value} once".to_string()]
    );
}

#[test]
fn a_setpoint_that_is_not_true_false_or_a_finite_number_cannot_be_read() {
    let mut doc = with_operations();
    doc["actuators"][1]["idle"] = json!("off");
    assert_eq!(
        read_error(doc),
        "actuators[1]: idle must be a setpoint: true or false for a binary actuator, a finite number for an analog one; got 'off'"
    );
    let mut doc = with_operations();
    doc["operations"][0]["steps"][0]["command"]["valves"]["V12"] = json!(null);
    assert!(read_error(doc).starts_with(
        "operations[0].steps[0].command.valves: V12 must be a setpoint: true or false for a binary actuator, a finite number for an analog one; got null"
    ));
    let mut doc = with_operations();
    doc["resources"][1]["lockout"] = json!({ "pumps": ["P1"] });
    assert!(read_error(doc).starts_with(
        "resources[1].lockout: pumps must be an object of actuator ids and setpoints"
    ));
    // JSON text cannot hold NaN; a number too large for an f64 is refused where it stands.
    let text = with_operations()
        .to_string()
        .replace("\"lockout\":0", "\"lockout\":1e999");
    let err = sugarshack_core::json::from_str::<PlantModel>(&text)
        .unwrap_err()
        .without_position()
        .to_string();
    assert!(
        err.starts_with("actuators[0].lockout: number out of range"),
        "{err}"
    );
}

#[test]
fn a_setpoint_of_the_wrong_kind_for_its_actuator_is_refused_naming_the_entry() {
    let mut doc = with_operations();
    doc["operations"][1]["steps"][0]["command"] = json!({ "pumps": { "P1": 1 } });
    doc["resources"][1]["lockout"] = json!({ "valves": { "V40": true } });
    assert_eq!(
        problems(doc),
        vec![
            "resources[1] (RED).lockout: target for 'V40' must be a number within 0..100, got true",
            "operations[1] (18).steps[0]: target for 'P1' must be true or false, got 1",
        ]
    );
}

/// The operations plant with a hold command on op 10 and plant-wide defaults
/// for an operator's commands.
fn with_holds() -> Value {
    let mut doc = with_operations();
    doc["actuators"].as_array_mut().unwrap().push(json!({ "id": "V13", "type": "valve", "device": "ctrl-1", "io": 13, "lockout": 0, "resource": "YEL" }));
    doc["operationDefaults"] = json!({
        "hold": { "command": { "pumps": { "P1": false } }, "timeoutMs": 15000 },
        "restart": "rerun",
        "stop": "now"
    });
    doc["operations"][0]["hold"] = json!({ "command": { "pumps": { "P1": false }, "valves": { "V12": 0 } }, "timeoutMs": 20000 });
    doc["operations"][0]["stop"] = json!("finish-step");
    doc["operations"][0]["steps"][1]["restart"] = json!("reissue");
    doc
}

#[test]
fn hold_restart_and_stop_settings_validate_and_read_back() {
    assert_eq!(problems(with_holds()), Vec::<String>::new());
    let plant: PlantModel = sugarshack_core::json::from_str(&with_holds().to_string()).unwrap();
    let written = serde_json::to_value(&plant).unwrap();
    let given = with_holds();
    assert_eq!(written["operationDefaults"], given["operationDefaults"]);
    assert_eq!(written["operations"][0], given["operations"][0]);
}

#[test]
fn a_hold_command_that_would_fail_when_an_operator_holds_is_refused_at_the_check() {
    let cases: Vec<(Breakage, &str)> = vec![
        (
            |d| d["operations"][0]["hold"]["command"] = json!({ "valves": { "V40": 0 } }),
            "operations[0] (10).hold: C2: commands 'V40' on resource 'RED', outside the operation's resources (YEL)",
        ),
        (
            |d| d["operations"][0]["hold"]["command"] = json!({ "valves": { "V13": 0 } }),
            "operations[0] (10).hold: C3: commands 'V13', which has no idle state to return to",
        ),
        (
            |d| d["operations"][0]["hold"]["command"] = json!({ "valves": { "V99": 0 } }),
            "operations[0] (10).hold: unknown actuator 'V99'",
        ),
        (
            |d| d["operations"][0]["hold"]["command"] = json!({ "pumps": { "P1": 50 } }),
            "operations[0] (10).hold: target for 'P1' must be true or false, got 50",
        ),
        (
            |d| d["operations"][0]["hold"]["timeoutMs"] = json!(0),
            "operations[0] (10).hold: timeoutMs must be positive",
        ),
        (
            |d| d["operationDefaults"]["hold"]["timeoutMs"] = json!(0),
            "operationDefaults.hold: timeoutMs must be positive",
        ),
        (
            |d| d["operationDefaults"]["hold"]["command"] = json!({ "valves": { "V99": 0 } }),
            "operationDefaults.hold: unknown actuator 'V99'",
        ),
        (
            |d| d["operationDefaults"]["hold"]["command"] = json!({ "valves": { "V13": 0 } }),
            "operationDefaults.hold: C3: commands 'V13', which has no idle state to return to",
        ),
        (
            |d| d["routines"][0]["transitions"][0]["trigger"] = json!({ "msg": "hold" }),
            "routines[0] (truck).transitions[0]: the msg topic 'hold' is reserved: it is an operator's hold command to the routine",
        ),
    ];
    assert_each_names_its_problem(with_holds, cases);
}

#[test]
fn hold_restart_and_stop_settings_that_cannot_be_read_name_their_path() {
    let cases: Vec<(Breakage, &str)> = vec![
        (
            |d| d["operations"][0]["steps"][1]["restart"] = json!("resume"),
            "operations[0].steps[1]: restart must be one of 'reissue', 'rerun'; got 'resume'",
        ),
        (
            |d| d["operations"][0]["steps"][0]["restart"] = json!(true),
            "operations[0].steps[0].restart: ",
        ),
        (
            |d| d["operationDefaults"]["restart"] = json!("again"),
            "operationDefaults: restart must be one of 'reissue', 'rerun'; got 'again'",
        ),
        (
            |d| d["operations"][0]["stop"] = json!("later"),
            "operations[0]: stop must be one of 'finish-step', 'now'; got 'later'",
        ),
        (
            |d| d["operationDefaults"]["stop"] = json!("finish"),
            "operationDefaults: stop must be one of 'finish-step', 'now'; got 'finish'",
        ),
        (
            |d| d["operations"][0]["hold"]["timeoutMs"] = json!(-1),
            "operations[0].hold: timeoutMs must be a non-negative number of milliseconds; got -1",
        ),
        (
            |d| {
                d["operations"][0]["hold"].as_object_mut().unwrap().remove("timeoutMs");
            },
            "operations[0].hold: missing field `timeoutMs`",
        ),
        (
            |d| {
                d["operationDefaults"]["hold"].as_object_mut().unwrap().remove("timeoutMs");
            },
            "operationDefaults.hold: missing field `timeoutMs`",
        ),
        (
            |d| d["operations"][0]["hold"]["timeout"] = json!(20000),
            "operations[0].hold.timeout: unknown field `timeout`, expected `command` or `timeoutMs`",
        ),
        (
            |d| d["operationDefaults"]["pause"] = json!({}),
            "operationDefaults.pause: unknown field `pause`, expected one of `hold`, `restart`, `stop`",
        ),
        (
            |d| d["operations"][0]["hold"] = json!({ "pumps": { "P1": false } }),
            "operations[0].hold.pumps: unknown field `pumps`, expected `command` or `timeoutMs`",
        ),
    ];
    for (breaks, expected) in cases {
        let mut doc = with_holds();
        breaks(&mut doc);
        let error = read_error(doc);
        assert!(
            error.starts_with(expected),
            "expected {expected:?}, got {error:?}"
        );
    }
}
