#![cfg(target_arch = "wasm32")]

//! Operations, sensors and routines across the JS boundary, run under Node:
//! plans, C2 refusals, stale sensors and a routine's round trip through a snapshot.

use js_sys::{Array, JSON};
use sugarshack_wasm::operation::AbortedOperations;
use sugarshack_wasm::Tracker;
use wasm_bindgen::JsValue;
use wasm_bindgen_test::wasm_bindgen_test;

mod support;
use support::{code_of, fresh_value, get, json, message_of, valve_plant};

fn text(value: &JsValue, key: &str) -> String {
    get(value, key).as_string().unwrap_or_default()
}

fn plant() -> String {
    valve_plant(
        r#"
    "actuators": [
        { "id": "V1", "type": "valve", "device": "ctrl-1", "io": 1, "idle": 0, "lockout": 0, "resource": "YEL" },
        { "id": "V9", "type": "valve", "device": "ctrl-1", "io": 9, "idle": 0, "lockout": 0, "resource": "RED" }
    ],
    "resources": [{ "id": "YEL" }, { "id": "RED" }],
    "operations": [
        { "id": "10", "priority": 20, "resources": ["YEL"], "steps": [
            { "command": { "valves": { "V1": 100 } }, "timeoutMs": 9000 },
            { "wait": "`LT-3` > 10", "sensors": ["LT-3"], "timeoutMs": 60000 }
        ] },
        { "id": "51", "priority": 1, "resources": ["RED"], "steps": [
            { "command": { "valves": { "V9": 100 } }, "timeoutMs": 9000 }
        ] }
    ],
    "routines": [{ "id": "truck", "states": ["empty", "full", "fault"], "initial": "empty", "errorState": "fault",
        "transitions": [
            { "from": "empty", "to": "full", "operation": "10", "trigger": { "msg": "load" } },
            { "from": "full", "to": "empty", "operation": "51",
              "trigger": { "when": "`LT-3` > 10", "sensors": ["LT-3"], "everyMs": 1000 } }
        ] }]
"#,
    )
}

fn tracker() -> Tracker {
    Tracker::new(json(&plant()), 0.0).expect("plant is valid")
}

#[wasm_bindgen_test]
fn an_operation_plan_ends_with_the_return_to_idle() {
    let t = tracker();
    let plan = t.operation_plan("10").unwrap();
    let steps = Array::from(&get(&plan, "steps"));
    let kinds: Vec<String> = steps.iter().map(|s| text(&s, "kind")).collect();
    assert_eq!(kinds, ["command", "wait", "returnToIdle"]);
    assert_eq!(get(&steps.get(1), "timeoutMs").as_f64(), Some(60000.0));
    assert_eq!(
        JSON::stringify(&get(&steps.get(2), "command")).unwrap(),
        r#"{"valve":{"V1":0}}"#
    );
    assert_eq!(
        code_of(t.operation_plan("99").unwrap_err()),
        "UNKNOWN_OPERATION"
    );
}

#[wasm_bindgen_test]
fn a_command_within_held_resources_goes_and_one_outside_them_is_refused() {
    let mut t = tracker();
    let yel = Some(vec!["YEL".to_string()]);
    assert!(
        t.command(
            json(r#"{"valves":{"V1":100}}"#),
            1,
            false,
            0.0,
            yel.clone(),
            None,
            None
        )
        .unwrap()
            > 0
    );
    let err = t
        .command(
            json(r#"{"valves":{"V9":100}}"#),
            2,
            false,
            0.0,
            yel,
            None,
            None,
        )
        .unwrap_err();
    assert_eq!(code_of(err), "OUTSIDE_RESOURCES");
    // Without `within` (a plain group command node) C2 is not the tracker's to check.
    assert!(t
        .command(
            json(r#"{"valves":{"V9":100}}"#),
            3,
            false,
            0.0,
            None,
            None,
            None
        )
        .is_ok());
}

#[wasm_bindgen_test]
fn sensors_are_read_only_while_fresh() {
    let mut t = tracker();
    let lt = t.sensor("LT-3").unwrap();
    assert_eq!(t.sensor_slot("station-3", "volume"), Some(lt));
    assert_eq!(
        fresh_value(&mut t, "LT-3", 0.0),
        Err("sensor 'LT-3' has sent no value yet".into())
    );
    assert!(t.record_sensor(lt, 12.5, Some(900.0), 1000.0).unwrap());
    assert_eq!(fresh_value(&mut t, "LT-3", 2999.0), Ok(12.5));
    assert_eq!(
        fresh_value(&mut t, "LT-3", 3000.0),
        Err("sensor 'LT-3' is stale: its last value is 2000 ms old (limit 2000 ms)".into())
    );
    assert_eq!(
        code_of(t.record_sensor(lt, f64::NAN, None, 3000.0).unwrap_err()),
        "INVALID_SENSOR_VALUE"
    );
    let c = t.condition("`LT-3` > 10", vec!["LT-3".into()]).unwrap();
    assert_eq!(
        code_of(t.check_condition(c, &[7], 0.0).unwrap_err()),
        "UNKNOWN_SENSOR"
    );
}

#[wasm_bindgen_test]
fn a_condition_is_checked_in_one_call_and_never_passes_on_old_data() {
    let mut t = tracker();
    let lt = t.sensor("LT-3").unwrap();
    let c = t.condition("`LT-3` > 10", vec!["LT-3".into()]).unwrap();
    let check = |t: &Tracker, now: f64| {
        JSON::stringify(&t.check_condition(c, &[lt], now).unwrap())
            .unwrap()
            .as_string()
            .unwrap()
    };
    assert_eq!(
        check(&t, 0.0),
        r#"{"met":false,"values":null,"reason":"sensor 'LT-3' has sent no value yet"}"#
    );
    t.record_sensor(lt, 12.5, Some(900.0), 1000.0).unwrap();
    assert_eq!(
        check(&t, 2999.0),
        r#"{"met":true,"values":{"LT-3":12.5},"reason":null}"#
    );
    let stale = check(&t, 3000.0);
    assert!(
        stale.starts_with(r#"{"met":false,"values":null,"reason":"sensor 'LT-3' is stale"#),
        "{stale}"
    );
    t.record_sensor(lt, 4.0, None, 3000.0).unwrap();
    assert_eq!(
        check(&t, 3000.0),
        r#"{"met":false,"values":{"LT-3":4},"reason":"values {\"LT-3\":4}"}"#
    );
    assert_eq!(
        code_of(t.check_condition(c, &[lt, lt], 3000.0).unwrap_err()),
        "INVALID_INPUT"
    );
}

#[wasm_bindgen_test]
fn a_condition_is_read_once_and_holds_on_the_values_given() {
    let mut t = tracker();
    let lt = vec!["LT-3".to_string()];
    let c = t.condition("`LT-3` / 2 > 10", lt.clone()).unwrap();
    assert_eq!(
        t.condition("`LT-3` / 2 > 10", lt.clone()).unwrap(),
        c,
        "read once"
    );
    let sensor = t.sensor("LT-3").unwrap();
    let check = |t: &mut Tracker, c: u32, value: f64| {
        t.record_sensor(sensor, value, None, 0.0).unwrap();
        let check = t.check_condition(c, &[sensor], 0.0).unwrap();
        (
            get(&check, "met").as_bool().unwrap(),
            text(&check, "reason"),
        )
    };
    assert_eq!(check(&mut t, c, 30.0), (true, String::new()));
    assert_eq!(
        check(&mut t, c, 3.0),
        (false, r#"values {"LT-3":3}"#.into())
    );
    let zero = t.condition("1 / (`LT-3` - 3) + 1 > 0", lt.clone()).unwrap();
    let (met, why) = check(&mut t, zero, 3.0);
    assert!(
        !met && why.contains("'1 / (`LT-3` - 3)' gives no finite number"),
        "{why}"
    );
    assert_eq!(
        code_of(t.check_condition(c, &[], 0.0).unwrap_err()),
        "INVALID_INPUT"
    );
    assert_eq!(
        code_of(t.check_condition(99, &[sensor], 0.0).unwrap_err()),
        "INVALID_CONDITION"
    );
    let err = t.condition("LT-3 > 10", lt.clone()).unwrap_err();
    assert_eq!(
        message_of(&err),
        "condition 'LT-3 > 10': 'LT-3' reads as LT minus 3: write a sensor id that has a dash in backticks, `LT-3` (to subtract, put spaces around the minus)"
    );
    assert_eq!(code_of(err), "INVALID_CONDITION");
    assert_eq!(
        code_of(t.condition("`LT-9` > 1", vec!["LT-9".into()]).unwrap_err()),
        "UNKNOWN_SENSOR"
    );
}

#[wasm_bindgen_test]
fn a_routine_dispatches_moves_and_survives_a_snapshot() {
    let t = tracker();
    let mut r = t.routine("truck").unwrap();
    assert_eq!(r.operations(), vec!["10".to_string(), "51".to_string()]);
    let d = r.on_msg("load").unwrap();
    assert_eq!(
        (text(&d, "operation"), text(&d, "to")),
        ("10".into(), "full".into())
    );
    assert_eq!(code_of(r.on_msg("load").unwrap_err()), "ROUTINE_BUSY");
    r.completed().unwrap();
    assert_eq!(
        JSON::stringify(&r.conditions().unwrap()).unwrap(),
        r#"[{"transition":1,"when":"`LT-3` > 10","sensors":["LT-3"]}]"#
    );
    // Its interlock's gate closed (a drain): nothing due, no deadline; open again, it is due.
    r.gate(false);
    assert!(r.due(5000.0).unwrap().is_empty());
    assert_eq!(r.next_deadline(), None);
    r.gate(true);
    assert_eq!(r.due(5000.0).unwrap(), vec![1]);
    assert_eq!(text(&r.condition(1).unwrap(), "when"), "`LT-3` > 10");
    assert_eq!(text(&r.condition_met(1).unwrap(), "operation"), "51");
    let snapshot = r.snapshot().unwrap();
    let mut again = t.routine("truck").unwrap();
    let moved = again.restore(snapshot, Vec::new()).unwrap();
    assert_eq!(
        (text(&moved, "to"), again.state(), again.pending()),
        ("fault".into(), "fault".to_string(), None)
    );
    assert_eq!(
        code_of(
            again
                .restore(json(r#"{"routine":"truck","state":"nope"}"#), Vec::new())
                .unwrap_err()
        ),
        "INVALID_SNAPSHOT"
    );
    assert_eq!(code_of(t.routine("silo").err().unwrap()), "UNKNOWN_ROUTINE");
}

#[wasm_bindgen_test]
fn a_routines_reset_resets_its_aborted_operations() {
    let r = tracker().routine("truck").unwrap();
    let mut aborted = AbortedOperations::new(JsValue::UNDEFINED).unwrap();
    for operation in ["51", "99"] {
        aborted
            .ended(operation, "aborted", Some("ana".into()), None, 1.0)
            .unwrap();
    }
    assert_eq!(aborted.reset_routine(&r), vec!["51".to_string()]);
    assert_eq!(
        (aborted.state("51"), aborted.state("99")),
        ("idle".to_string(), "aborted".to_string())
    );
}

#[wasm_bindgen_test]
fn the_plant_configures_an_interlock_with_derived_lockouts() {
    let resources = tracker().interlock_resources().unwrap();
    assert_eq!(
        JSON::stringify(&resources).unwrap(),
        r#"[{"name":"YEL","lockout":{"valves":{"V1":0}}},{"name":"RED","lockout":{"valves":{"V9":0}}}]"#
    );
}

#[wasm_bindgen_test]
fn plant_warnings_are_listed() {
    assert!(tracker().warnings().is_empty());
    let doubled = plant().replace(
        r#""id": "51", "priority": 1"#,
        r#""id": "51", "priority": 20"#,
    );
    let t = Tracker::new(json(&doubled), 0.0).unwrap();
    assert_eq!(t.warnings().len(), 1);
    assert!(
        t.warnings()[0].contains("priority 20 is also operation '10''s"),
        "{:?}",
        t.warnings()
    );
}
