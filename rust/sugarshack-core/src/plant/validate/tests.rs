//! Each check on its own: a sound document passes it, and one breakage of
//! its concern gives the expected problem at the expected path.

use serde_json::{json, Value};

use super::*;
use crate::plant::fixtures::{yel_plant, yel_pump, yel_valve};
use crate::plant::Plant;

fn sound() -> Value {
    let mut doc = yel_plant(
        json!([yel_valve("V1", 1), yel_pump("P1", 1)]),
        json!([
            { "command": { "valves": { "V1": 100 }, "pumps": { "P1": true } }, "timeoutMs": 20000 },
            { "wait": "`LT-3` > 100", "sensors": ["LT-3"], "timeoutMs": 60000 }
        ]),
    );
    doc["routines"] = json!([{ "id": "r", "states": ["a", "b"], "initial": "a", "transitions": [
        { "from": "a", "to": "b", "operation": "10", "trigger": { "msg": "go" } }
    ] }]);
    doc
}

fn read(doc: Value) -> PlantModel {
    serde_json::from_value(doc).expect("a readable document")
}

/// The errors and warnings one check finds, each as `path: message`.
fn found(report: Report) -> (Vec<String>, Vec<String>) {
    (
        report.errors.iter().map(ToString::to_string).collect(),
        report.warnings.iter().map(ToString::to_string).collect(),
    )
}

fn with(change: impl FnOnce(&mut Value)) -> PlantModel {
    let mut doc = sound();
    change(&mut doc);
    read(doc)
}

#[test]
fn a_sound_document_passes_every_check_once_and_keeps_no_warning() {
    let plant = Plant::new(read(sound())).unwrap();
    assert!(plant.warnings().is_empty());
    assert!(plant.is_group_key("valves") && plant.is_group_key("pump"));
    assert!(!plant.is_group_key("blob"));
}

#[test]
fn a_document_may_name_its_json_schema_which_the_checks_ignore() {
    let schema = "./node_modules/node-red-contrib-sugarshack/schema/plant.schema.json";
    let mut doc = sound();
    doc["$schema"] = json!(schema);
    let plant = Plant::new(read(doc.clone())).unwrap();
    assert!(plant.warnings().is_empty());
    assert_eq!(plant.schema.as_deref(), Some(schema));
    assert_eq!(
        serde_json::to_value(plant.model()).unwrap()["$schema"],
        schema
    );
    doc["$schema"] = json!(5);
    assert!(serde_json::from_value::<PlantModel>(doc).is_err());
}

#[test]
fn actuator_types_need_positive_timings_and_a_range() {
    let plant = with(|d| {
        d["actuatorTypes"]["valve"]["staleMs"] = json!(0);
        d["actuatorTypes"]["valve"]["min"] = json!(100);
        d["actuatorTypes"]["pump"]["max"] = json!(1);
    });
    let mut report = Report::default();
    actuator_types(&plant, &mut report);
    let (errors, warnings) = found(report);
    assert_eq!(
        errors,
        vec![
            "actuatorTypes.pump: a binary type has no min, max or tolerance",
            "actuatorTypes.valve: staleMs must be positive",
            "actuatorTypes.valve: min (100) must be below max (100)",
            "actuatorTypes.valve: tolerance must be at least 0 and less than half the range, got 0",
        ]
    );
    assert!(warnings.is_empty());
}

#[test]
fn a_type_named_as_another_types_plural_is_a_warning() {
    let plant = with(|d| {
        d["actuatorTypes"]["valves"] = d["actuatorTypes"]["valve"].clone();
    });
    let mut report = Report::default();
    actuator_types(&plant, &mut report);
    assert_eq!(
        found(report),
        (
            vec![],
            vec!["actuatorTypes.valves: in a group command 'valves' is the plural of type 'valve': command these actuators under 'valvess'".to_string()]
        )
    );
    // Computed once, when the plant is made, and kept on it.
    let plant = Plant::new(plant).unwrap();
    assert_eq!(plant.warnings().len(), 1);
}

#[test]
fn devices_are_defined_once_with_topic_safe_ids() {
    let plant = with(|d| {
        d["devices"][1]["id"] = json!("ctrl-1");
        d["devices"][0]["id"] = json!("ctrl 1");
    });
    let mut report = Report::default();
    devices(&plant, &mut report);
    assert_eq!(
        found(report).0,
        vec!["devices[0] (ctrl 1): a device id is its topic prefix: no spaces, '/', '+' or '#' (or give it a 'prefix')"]
    );
}

fn actuator_errors(plant: &PlantModel) -> Vec<String> {
    let mut report = Report::default();
    let devices = devices(plant, &mut report);
    actuators(plant, &devices, &mut HashSet::new(), &mut report);
    found(report).0
}

#[test]
fn an_idle_or_lockout_setpoint_of_the_wrong_kind_is_refused_naming_the_actuator() {
    let plant = with(|d| {
        d["actuators"][0]["idle"] = json!(true);
        d["actuators"][1]["lockout"] = json!(0);
    });
    assert_eq!(
        actuator_errors(&plant),
        vec![
            "actuators[0] (V1): idle must be a number within 0..100, got true",
            "actuators[1] (P1): lockout must be true or false, got 0",
        ]
    );
}

#[test]
fn an_analog_setpoint_must_lie_within_its_range() {
    let plant = with(|d| {
        d["actuatorTypes"]["valve"]["max"] = json!(50);
        d["actuators"][0]["lockout"] = json!(80);
    });
    assert_eq!(
        actuator_errors(&plant),
        vec!["actuators[0] (V1): lockout must be within 0..50, got 80"]
    );
}

#[test]
fn actuators_need_a_known_device_type_and_free_output() {
    let plant = with(|d| {
        d["actuators"][1]["type"] = json!("valve");
        d["actuators"][1]["io"] = json!(2);
        d["actuators"][1]["idle"] = json!(0);
        d["actuators"][1]["lockout"] = json!(0);
        d["actuators"][0]["device"] = json!("station-3");
    });
    assert_eq!(
        actuator_errors(&plant),
        vec!["actuators[0] (V1): device 'station-3' is a sensor station, not an actuator panel"]
    );
    let plant = with(|d| d["actuators"][1]["type"] = json!("motor"));
    assert_eq!(
        actuator_errors(&plant),
        vec!["actuators[1] (P1): unknown type 'motor' (known: pump, valve)"]
    );
}

#[test]
fn sensors_share_ids_with_actuators_and_need_positive_periods() {
    let plant = with(|d| {
        d["sensors"][0]["id"] = json!("V1");
        d["sensors"][0]["updateMs"] = json!(0);
        d["sensors"][0]["min"] = json!(10);
    });
    let mut report = Report::default();
    let devices = devices(&plant, &mut report);
    let mut ids = HashSet::new();
    actuators(&plant, &devices, &mut ids, &mut report);
    sensors(&plant, &devices, &mut ids, &mut report);
    assert_eq!(
        found(report).0,
        vec![
            "sensors[0] (V1): id 'V1' is used twice",
            "sensors[0] (V1): updateMs must be positive",
            "sensors[0] (V1): min and max go together, finite, min below max",
        ]
    );
}

fn resource_errors(plant: &PlantModel) -> Vec<String> {
    let mut report = Report::default();
    resources(plant, &Targeting::new(plant), &mut report);
    found(report).0
}

#[test]
fn a_configured_lockout_is_checked_like_a_command_but_may_be_empty() {
    let plant = with(|d| d["resources"][0]["lockout"] = json!({ "valves": {}, "motors": {} }));
    assert_eq!(resource_errors(&plant), Vec::<String>::new());
    let plant = with(|d| d["resources"][0]["lockout"] = json!({ "pumps": { "P1": 0 } }));
    assert_eq!(
        resource_errors(&plant),
        vec!["resources[0] (YEL).lockout: target for 'P1' must be true or false, got 0"]
    );
    let plant = with(|d| d["resources"][0]["lockout"] = json!({ "valves": { "V9": 0 } }));
    assert_eq!(
        resource_errors(&plant),
        vec!["resources[0] (YEL).lockout: unknown actuator 'V9'"]
    );
}

#[test]
fn a_resource_without_lockout_or_members_is_refused() {
    let plant = with(|d| {
        d["resources"] = json!([{ "id": "YEL" }, { "id": "RED" }, { "id": "YEL" }]);
    });
    assert_eq!(
        resource_errors(&plant),
        vec![
            "resources[1] (RED): no lockout command: give it one, or actuators that belong to it",
            "resources[2] (YEL): resource 'YEL' is defined twice",
        ]
    );
}

fn operation_report(plant: &PlantModel) -> (Vec<String>, Vec<String>) {
    let mut report = Report::default();
    operations(plant, &Targeting::new(plant), &mut report);
    found(report)
}

#[test]
fn a_step_setpoint_of_the_wrong_kind_is_refused_naming_the_step_and_actuator() {
    let plant = with(|d| {
        d["operations"][0]["steps"][0]["command"] = json!({ "pumps": { "P1": 1 } });
    });
    assert_eq!(
        operation_report(&plant).0,
        vec!["operations[0] (10).steps[0]: target for 'P1' must be true or false, got 1"]
    );
    let plant = with(|d| {
        d["operations"][0]["steps"][0]["command"] = json!({ "valves": { "V1": 101 } });
    });
    assert_eq!(
        operation_report(&plant).0,
        vec!["operations[0] (10).steps[0]: target for 'V1' must be within 0..100, got 101"]
    );
}

#[test]
fn steps_keep_c2_and_c3_and_equal_priorities_warn() {
    let plant = with(|d| {
        d["actuators"][0]["idle"] = json!(null);
        d["actuators"][1]["resource"] = json!(null);
        let mut second = d["operations"][0].clone();
        second["id"] = json!("11");
        d["operations"].as_array_mut().unwrap().push(second);
    });
    let (errors, warnings) = operation_report(&plant);
    assert_eq!(
        &errors[..2],
        [
            "operations[0] (10).steps[0]: C3: commands 'V1', which has no idle state to return to",
            "operations[0] (10).steps[0]: C2: commands 'P1', which belongs to no resource",
        ]
    );
    assert_eq!(
        warnings,
        vec!["operations[1] (11): priority 20 is also operation '10''s: equal priorities are granted first come, first served"]
    );
}

#[test]
fn an_empty_command_or_unknown_sensor_is_refused() {
    let plant = with(|d| {
        d["operations"][0]["steps"][0]["command"] = json!({});
        d["operations"][0]["steps"][1]["sensors"] = json!(["LT-9"]);
    });
    assert_eq!(
        operation_report(&plant).0,
        vec![
            "operations[0] (10).steps[0]: the group command names no actuator",
            "operations[0] (10).steps[1]: unknown sensor 'LT-9'",
            "operations[0] (10).steps[1]: condition '`LT-3` > 100': reads sensor 'LT-3', which is not listed with the condition (the sensors listed are LT-9): add it to the sensors, so that it is read fresh",
        ]
    );
}

/// The errors of the operations' checks with the wait step's condition `text`.
fn wait_errors(text: &str) -> Vec<String> {
    let plant = with(|d| d["operations"][0]["steps"][1]["wait"] = json!(text));
    operation_report(&plant).0
}

#[test]
fn a_wait_that_could_never_hold_is_refused_at_the_check() {
    assert_eq!(
        wait_errors("LT-3 >= 50"),
        vec!["operations[0] (10).steps[1]: condition 'LT-3 >= 50': 'LT-3' reads as LT minus 3: write a sensor id that has a dash in backticks, `LT-3` (to subtract, put spaces around the minus)"]
    );
    assert_eq!(
        wait_errors("`LT3` >= 50"),
        vec!["operations[0] (10).steps[1]: condition '`LT3` >= 50': '`LT3`' is not a sensor of the plant; the sensors listed are LT-3 (did you mean `LT-3`?)"]
    );
    assert_eq!(
        wait_errors("`LT-3` + 50"),
        vec!["operations[0] (10).steps[1]: condition '`LT-3` + 50': the condition gives a number, not true or false: compare it, as in `LT-3` + 50 >= 50"]
    );
    assert_eq!(
        wait_errors("  "),
        vec!["operations[0] (10).steps[1]: condition '  ': the condition is empty"]
    );
    assert!(wait_errors("`LT-3` & 'x'")[0]
        .contains("'&' (joining text) is not supported in a condition"));
}

#[test]
fn a_routine_condition_is_checked_as_a_wait_is() {
    let plant = with(|d| {
        d["routines"][0]["transitions"][0]["trigger"] =
            json!({ "when": "LT-3 < 10", "sensors": ["LT-3"], "everyMs": 1000 });
    });
    assert_eq!(
        routine_errors(&plant),
        vec!["routines[0] (r).transitions[0]: condition 'LT-3 < 10': 'LT-3' reads as LT minus 3: write a sensor id that has a dash in backticks, `LT-3` (to subtract, put spaces around the minus)"]
    );
}

#[test]
fn a_listed_sensor_the_condition_does_not_read_is_a_warning() {
    let plant = with(|d| {
        d["sensors"]
            .as_array_mut()
            .unwrap()
            .push(json!({ "id": "FT-3", "device": "station-3", "name": "flow" }));
        d["operations"][0]["steps"][1]["sensors"] = json!(["LT-3", "FT-3"]);
    });
    let (errors, warnings) = operation_report(&plant);
    assert!(errors.is_empty(), "{errors:?}");
    assert_eq!(
        warnings,
        vec!["operations[0] (10).steps[1]: lists sensor 'FT-3', which the condition does not read: the condition holds only while it is fresh too"]
    );
}

fn routine_errors(plant: &PlantModel) -> Vec<String> {
    let mut report = Report::default();
    let known = operations(plant, &Targeting::new(plant), &mut report);
    let mut report = Report::default();
    routines(plant, &known, &mut report);
    found(report).0
}

#[test]
fn routines_need_known_states_and_operations_and_triggers_that_can_fire() {
    let plant = with(|d| {
        d["routines"][0]["transitions"][0]["trigger"] = json!({ "msg": "reset" });
        d["routines"][0]["initial"] = json!("z");
    });
    let errors = routine_errors(&plant);
    assert_eq!(errors.len(), 2, "{errors:?}");
    assert_eq!(
        errors[0],
        "routines[0] (r): initial 'z' is not one of its states"
    );
    assert!(
        errors[1].starts_with("routines[0] (r).transitions[0]: the msg topic 'reset' is reserved")
    );
    let plant = with(|d| d["routines"][0]["transitions"][0]["operation"] = json!("77"));
    assert_eq!(
        routine_errors(&plant),
        vec!["routines[0] (r).transitions[0]: unknown operation '77'"]
    );
}

#[test]
fn check_reports_every_concern_together_in_document_order() {
    let plant = with(|d| {
        d["actuators"][1]["lockout"] = json!(3);
        d["operations"][0]["steps"][1]["timeoutMs"] = json!(0);
    });
    let errors = check(&plant).unwrap_err();
    assert_eq!(
        errors.0.iter().map(ToString::to_string).collect::<Vec<_>>(),
        vec![
            "actuators[1] (P1): lockout must be true or false, got 3",
            "operations[0] (10).steps[1]: timeoutMs must be positive",
        ]
    );
}
