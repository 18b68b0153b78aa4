#![cfg(target_arch = "wasm32")]

//! Cause-aware clear at the JS boundary: refused with every reason on the
//! error (`lines`), accepted once the plant shows the line isolated, forced
//! and attributed in its event.

use js_sys::{Array, Reflect, JSON};
use sugarshack_wasm::{Interlock, Tracker};
use wasm_bindgen_test::wasm_bindgen_test;

mod support;
use support::get;

const PLANT: &str = r#"{
    "actuatorTypes": {
        "valve": { "signal": "analog", "tolerance": 2, "noMotionMs": 1000, "completionMs": 5000, "staleMs": 60000 }
    },
    "devices": [{ "id": "ctrl-1", "kind": "actuator-panel" }],
    "resources": [{ "id": "YEL" }],
    "actuators": [
        { "id": "V1", "type": "valve", "device": "ctrl-1", "io": 1, "idle": 0, "lockout": 0, "resource": "YEL" }
    ]
}"#;

fn setup() -> (Tracker, Interlock, f64) {
    let plant = Tracker::new(JSON::parse(PLANT).unwrap(), 0.0).unwrap();
    let mut lock = Interlock::new(
        plant
            .interlock_resources()
            .map(|resources| {
                let config = js_sys::Object::new();
                Reflect::set(&config, &"resources".into(), &resources).unwrap();
                config.into()
            })
            .unwrap(),
    )
    .unwrap();
    let yel = lock.resource_set(vec!["YEL".into()]).unwrap();
    lock.fault_resources(
        yel,
        Some("e-stop".into()),
        Some("ana".into()),
        Some("test".into()),
        0.0,
    )
    .unwrap();
    (plant, lock, yel)
}

#[wasm_bindgen_test]
fn a_refused_clear_carries_every_reason_and_a_forced_one_is_recorded() {
    let (mut plant, mut lock, yel) = setup();
    let v1 = plant.actuator("V1").unwrap();
    plant.feedback(v1, 40.0, None, 1.0).unwrap();
    plant.device_status(0, false, 2.0).unwrap();
    let err = lock
        .clear_against(yel, &plant, Some("ana".into()), None, false, 3.0)
        .unwrap_err();
    assert_eq!(get(&err, "code").as_string().unwrap(), "CLEAR_REFUSED");
    let lines = Array::from(&get(&err, "lines"));
    assert_eq!(lines.length(), 1);
    let reasons = Array::from(&get(&lines.get(0), "reasons"));
    assert_eq!(
        get(&reasons.get(0), "kind").as_string().unwrap(),
        "deviceOffline"
    );
    assert_eq!(
        get(&reasons.get(0), "device").as_string().unwrap(),
        "ctrl-1"
    );

    plant.device_status(0, true, 4.0).unwrap();
    plant.feedback(v1, 0.5, None, 5.0).unwrap();
    let reasons = get(
        &Array::from(&lock.clear_blockers(yel, &plant).unwrap()).get(0),
        "reasons",
    );
    assert_eq!(Array::from(&reasons).length(), 0);
    lock.clear_against(
        yel,
        &plant,
        Some("ana".into()),
        Some("valves checked".into()),
        true,
        6.0,
    )
    .unwrap();
    let events = Array::from(&lock.drain_events().unwrap());
    let stop = events
        .iter()
        .find(|e| get(e, "kind").as_string().as_deref() == Some("resource-faulted"))
        .unwrap();
    assert_eq!(get(&stop, "by").as_string().unwrap(), "ana");
    let cleared = events
        .iter()
        .find(|e| get(e, "kind").as_string().as_deref() == Some("cleared"))
        .unwrap();
    assert_eq!(get(&cleared, "by").as_string().unwrap(), "ana");
    assert_eq!(
        get(&cleared, "reason").as_string().unwrap(),
        "valves checked"
    );
    // Nothing was left to override: an ordinary clear.
    assert!(get(&cleared, "forced").is_undefined());
}

#[wasm_bindgen_test]
fn a_clear_over_reasons_is_recorded_as_forced() {
    let (plant, mut lock, yel) = setup();
    lock.clear_against(yel, &plant, None, None, true, 3.0)
        .unwrap();
    let events = Array::from(&lock.drain_events().unwrap());
    let cleared = events
        .iter()
        .find(|e| get(e, "kind").as_string().as_deref() == Some("cleared"))
        .unwrap();
    assert_eq!(get(&cleared, "forced").as_bool(), Some(true));
    assert_eq!(get(&cleared, "by").as_string().unwrap(), "unknown");
    assert!(get(&cleared, "note")
        .as_string()
        .unwrap()
        .contains("V1 has not reported"));
}
