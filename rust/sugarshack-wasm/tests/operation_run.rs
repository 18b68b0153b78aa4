#![cfg(target_arch = "wasm32")]

//! An operation's run across the JS boundary, under Node: one run through to
//! its release, one through a fault, and the refusals of bad input.

use js_sys::{Array, JSON};
use sugarshack_wasm::operation::AbortedOperations;
use sugarshack_wasm::Tracker;
use wasm_bindgen::JsValue;
use wasm_bindgen_test::wasm_bindgen_test;

mod support;
use support::{code_of, get, json, valve_plant};

fn stringify(value: &JsValue) -> String {
    JSON::stringify(value).unwrap().into()
}

/// The only effect of an input.
fn one(effects: Result<JsValue, JsValue>) -> JsValue {
    let effects = Array::from(&effects.unwrap());
    assert_eq!(effects.length(), 1, "{}", stringify(&effects));
    effects.get(0)
}

fn plant() -> String {
    valve_plant(
        r#"
    "actuators": [
        { "id": "V1", "type": "valve", "device": "ctrl-1", "io": 1, "idle": 0, "lockout": 0, "resource": "YEL" }
    ],
    "resources": [{ "id": "YEL" }],
    "operations": [
        { "id": "10", "priority": 20, "resources": ["YEL"], "steps": [
            { "command": { "valves": { "V1": 100 } }, "timeoutMs": 9000 },
            { "wait": "`LT-3` > 10", "sensors": ["LT-3"], "timeoutMs": 60000 }
        ] }
    ]
"#,
    )
}

fn tracker() -> Tracker {
    Tracker::new(json(&plant()), 0.0).expect("plant is valid")
}

#[wasm_bindgen_test]
fn a_run_goes_from_its_request_to_its_release() {
    let mut t = tracker();
    let mut run = t.operation_run("10").unwrap();
    assert_eq!(
        (run.id(), run.state()),
        ("10".to_string(), "idle".to_string())
    );
    assert_eq!(
        stringify(&get(&run.plan().unwrap(), "steps")),
        stringify(&get(&t.operation_plan("10").unwrap(), "steps"))
    );

    let acquire = one(run.start(1000.0));
    assert_eq!(
        stringify(&acquire),
        r#"{"kind":"acquire","operation":"10","priority":20,"resources":["YEL"]}"#
    );
    assert_eq!(run.state(), "queued");

    let command = one(run.granted(1500.0));
    assert_eq!(
        stringify(&command),
        r#"{"kind":"startStep","index":0,"attempt":0,"step":{"kind":"command","command":{"valves":{"V1":100}},"timeoutMs":9000,"restart":"reissue"},"within":["YEL"],"timeoutMs":9000}"#
    );
    assert_eq!((run.state(), run.step()), ("running".to_string(), Some(0)));
    // The step and its `within` go to the tracker as they are (C2 checked there).
    let step = get(&command, "step");
    let within: Vec<String> = Array::from(&get(&command, "within"))
        .iter()
        .filter_map(|l| l.as_string())
        .collect();
    assert!(
        t.command(
            get(&step, "command"),
            1,
            false,
            1500.0,
            Some(within),
            None,
            None
        )
        .unwrap()
            > 0
    );
    assert_eq!(
        Array::from(&run.granted(1600.0).unwrap()).length(),
        0,
        "a second grant"
    );

    let wait = one(run.step_done(0.0, 2500.0));
    assert_eq!(
        stringify(&wait),
        r#"{"kind":"startStep","index":1,"attempt":1,"step":{"kind":"wait","condition":"`LT-3` > 10","sensors":["LT-3"],"timeoutMs":60000,"restart":"reissue"},"timeoutMs":60000}"#
    );
    assert_eq!(
        Array::from(&run.step_done(0.0, 2600.0).unwrap()).length(),
        0,
        "a late done"
    );
    let idle = one(run.step_done(1.0, 4500.0));
    assert_eq!(
        stringify(&get(&idle, "step")),
        r#"{"kind":"returnToIdle","command":{"valve":{"V1":0}},"timeoutMs":9000}"#
    );
    assert_eq!(
        stringify(&one(run.step_done(2.0, 5000.0))),
        r#"{"kind":"release","operation":"10"}"#
    );
    assert_eq!(run.state(), "completing");
    assert_eq!(
        stringify(&one(run.released(5100.0))),
        r#"{"kind":"finished","id":"10","queuedMs":500,"runMs":3600,"heldMs":0,"steps":[{"kind":"command","ms":1000},{"kind":"wait","ms":2000},{"kind":"returnToIdle","ms":500}]}"#
    );
    assert_eq!((run.state(), run.step()), ("complete".to_string(), None));
    assert_eq!(code_of(run.start(6000.0).unwrap_err()), "ALREADY_STARTED");
}

#[wasm_bindgen_test]
fn a_failed_step_faults_the_run_and_reports_its_lockouts() {
    let t = tracker();
    let mut run = t.operation_run("10").unwrap();
    one(run.start(0.0));
    one(run.granted(0.0));
    one(run.step_done(0.0, 100.0));
    let fault = one(run.step_failed(
        1.0,
        "CONDITION_TIMEOUT",
        "condition `LT-3` > 10 did not hold within 60 s",
        60100.0,
    ));
    assert_eq!(
        stringify(&fault),
        r#"{"kind":"fault","operation":"10","note":"step 2 (wait): condition `LT-3` > 10 did not hold within 60 s"}"#
    );
    assert_eq!(run.state(), "faulting");
    let failed = one(run.fault_applied(vec!["YEL".into()], 60200.0));
    assert_eq!(
        stringify(&failed),
        r#"{"kind":"failed","id":"10","code":"CONDITION_TIMEOUT","message":"operation '10' faulted at step 2 (wait): condition `LT-3` > 10 did not hold within 60 s; YEL locked out until cleared","step":1,"stage":"wait","lockedOut":["YEL"],"aborted":false,"state":"faulted"}"#
    );
    assert_eq!(run.state(), "faulted");
    assert_eq!(
        Array::from(&run.interrupt("closed", 60300.0).unwrap()).length(),
        0
    );
}

#[wasm_bindgen_test]
fn bad_input_is_refused_before_it_changes_anything() {
    let t = tracker();
    assert_eq!(
        code_of(t.operation_run("99").err().unwrap()),
        "UNKNOWN_OPERATION"
    );
    let mut run = t.operation_run("10").unwrap();
    assert_eq!(code_of(run.start(f64::NAN).unwrap_err()), "INVALID_TIME");
    assert_eq!(code_of(run.start(1e300).unwrap_err()), "INVALID_TIME");
    assert_eq!(run.state(), "idle");
    one(run.start(0.0));
    one(run.granted(0.0));
    for index in [f64::NAN, -1.0, 0.5, f64::INFINITY] {
        assert_eq!(
            code_of(run.step_done(index, 1.0).unwrap_err()),
            "INVALID_STEP"
        );
    }
    assert_eq!(run.step(), Some(0));
}

#[wasm_bindgen_test]
fn an_interrupted_queued_run_is_withdrawn() {
    let t = tracker();
    let mut run = t.operation_run("10").unwrap();
    one(run.start(0.0));
    assert_eq!(
        stringify(&one(run.interrupt("its node closed", 10.0))),
        r#"{"kind":"withdraw","operation":"10"}"#
    );
    assert_eq!(run.state(), "withdrawing");
    let failed = one(run.withdrawn(20.0));
    assert_eq!(
        stringify(&failed),
        r#"{"kind":"failed","id":"10","code":"ABORTED","message":"operation '10' was withdrawn from the queue (its node closed)","step":null,"stage":"acquire","lockedOut":[],"aborted":true,"state":"withdrawn"}"#
    );
    assert_eq!(run.state(), "withdrawn");
}

#[wasm_bindgen_test]
fn an_operators_commands_cross_with_their_refusals_coded() {
    let t = tracker();
    let mut run = t.operation_run("10").unwrap();
    one(run.start(0.0));
    one(run.granted(0.0));
    one(run.step_done(0.0, 100.0));
    assert_eq!(
        stringify(&run.commands().into()),
        r#"["hold","stop","abort"]"#
    );
    let refused = run
        .command("restart", Some("ana".into()), None, 200.0)
        .unwrap_err();
    assert_eq!(code_of(refused.clone()), "COMMAND_REFUSED");
    assert_eq!(
        stringify(&get(&refused, "message")),
        r#""restart refused: operation '10' is running; restart is for a held operation: hold it first""#
    );
    assert_eq!(
        code_of(run.command("pause", None, None, 200.0).unwrap_err()),
        "INVALID_INPUT"
    );
    // No hold command in this plant: held at once, commanding nothing.
    let held = run
        .command("hold", Some("ana".into()), Some("gasket".into()), 1100.0)
        .unwrap();
    assert_eq!(
        stringify(&held),
        r#"[{"kind":"cancelStep","index":1,"attempt":1},{"kind":"entered","state":"held","step":1}]"#
    );
    assert_eq!(run.state(), "held");
    let saved = run.snapshot(JsValue::UNDEFINED).unwrap();
    assert_eq!(stringify(&get(&saved, "usedMs")), "1000");
    // Back on the same plan after a restart: held, with nothing to do.
    let restored = t.restore_run(saved.clone()).unwrap();
    assert_eq!(stringify(&get(&restored, "effects")), "[]");
    let restart = run.command("restart", None, None, 5000.0).unwrap();
    assert_eq!(
        stringify(&Array::from(&restart).get(2)),
        r#"{"kind":"startStep","index":1,"attempt":2,"step":{"kind":"wait","condition":"`LT-3` > 10","sensors":["LT-3"],"timeoutMs":60000,"restart":"reissue"},"timeoutMs":59000}"#
    );
    // The wait's attempt cancelled by the hold answers late: ignored; the reissued one's moves it on.
    assert_eq!(
        Array::from(&run.step_done(1.0, 5100.0).unwrap()).length(),
        0
    );
    assert_eq!(run.step(), Some(1));
    assert_eq!(
        Array::from(&run.step_done(2.0, 5200.0).unwrap()).length(),
        1
    );
    assert_eq!(run.step(), Some(2));
    assert_eq!(
        code_of(t.restore_run(json(r#"{ "operation": "10" }"#)).unwrap_err()),
        "INVALID_SNAPSHOT"
    );

    let mut aborted = AbortedOperations::new(JsValue::UNDEFINED).unwrap();
    aborted
        .ended("10", "aborted", Some("ana".into()), None, 9.0)
        .unwrap();
    assert_eq!(
        code_of(aborted.check_start("10").unwrap_err()),
        "OPERATION_ABORTED"
    );
    let again = AbortedOperations::new(aborted.snapshot().unwrap()).unwrap();
    assert_eq!(again.state("10"), "aborted");
    aborted.reset("10").unwrap();
    assert_eq!(code_of(aborted.reset("10").unwrap_err()), "COMMAND_REFUSED");
    assert!(aborted.check_start("10").is_ok());
}
