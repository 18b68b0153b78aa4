#![cfg(target_arch = "wasm32")]

//! Alarms at the JS boundary: conditions in as plain data, acknowledgement
//! and shelf attributed, a snapshot restored, bad input refused with a code.

use js_sys::{Array, JSON};
use sugarshack_wasm::Alarms;
use wasm_bindgen::JsValue;
use wasm_bindgen_test::wasm_bindgen_test;

mod support;
use support::get;

fn code(err: JsValue) -> String {
    get(&err, "code").as_string().unwrap()
}

fn yel_faulted() -> JsValue {
    JSON::parse(
        r#"[{ "kind": "line-faulted", "subject": "YEL", "text": "e-stop by ana", "sinceMs": 5 }]"#,
    )
    .unwrap()
}

#[wasm_bindgen_test]
fn an_alarm_is_acknowledged_by_a_person_and_survives_a_snapshot() {
    let mut alarms = Alarms::new();
    let changes = Array::from(&alarms.observe(yel_faulted(), 10.0).unwrap());
    assert_eq!(
        get(&changes.get(0), "to").as_string().unwrap(),
        "active-unacknowledged"
    );
    alarms
        .acknowledge(
            Some(vec!["line-faulted:YEL".into()]),
            Some("ana".into()),
            None,
            20.0,
        )
        .unwrap();
    let restored = Alarms::restore(alarms.snapshot().unwrap()).unwrap();
    let listed = Array::from(&restored.list().unwrap());
    assert_eq!(listed.length(), 1);
    let alarm = listed.get(0);
    assert_eq!(
        get(&alarm, "state").as_string().unwrap(),
        "active-acknowledged"
    );
    assert_eq!(get(&alarm, "activeSinceMs").as_f64(), Some(5.0));
    assert_eq!(get(&get(&alarm, "acked"), "by").as_string().unwrap(), "ana");
    assert_eq!(get(&get(&alarm, "acked"), "atMs").as_f64(), Some(20.0));
}

#[wasm_bindgen_test]
fn a_shelf_has_an_end_and_bad_input_is_refused_with_a_code() {
    let mut alarms = Alarms::new();
    alarms.observe(yel_faulted(), 10.0).unwrap();
    assert_eq!(
        code(
            alarms
                .shelve("line-faulted:YEL", f64::NAN, None, None, 10.0)
                .unwrap_err()
        ),
        "INVALID_TIME"
    );
    assert_eq!(
        code(
            alarms
                .shelve("line-faulted:YEL", 5.0, None, None, 10.0)
                .unwrap_err()
        ),
        "INVALID_SHELF"
    );
    assert_eq!(
        code(alarms.shelve("nope", 50.0, None, None, 10.0).unwrap_err()),
        "UNKNOWN_ALARM"
    );
    alarms
        .shelve(
            "line-faulted:YEL",
            50.0,
            Some(" ".into()),
            Some("valve on the bench".into()),
            10.0,
        )
        .unwrap();
    assert_eq!(alarms.next_expiry_ms(), Some(50.0));
    let shelf = get(&Array::from(&alarms.list().unwrap()).get(0), "shelved");
    assert_eq!(get(&shelf, "by").as_string().unwrap(), "unknown");
    assert_eq!(
        get(&shelf, "reason").as_string().unwrap(),
        "valve on the bench"
    );
    let bad =
        JSON::parse(r#"[{ "kind": "line-faulted", "subject": "YEL", "colour": "red" }]"#).unwrap();
    assert_eq!(
        code(alarms.observe(bad, 11.0).unwrap_err()),
        "INVALID_INPUT"
    );
    assert_eq!(
        code(
            alarms
                .observe(JsValue::from_str("[{\"kind\":\"x\"}]"), 11.0)
                .unwrap_err()
        ),
        "INVALID_INPUT"
    );
    assert_eq!(
        code(
            Alarms::restore(JSON::parse(r#"{ "alarms": 3 }"#).unwrap())
                .err()
                .unwrap()
        ),
        "INVALID_SNAPSHOT"
    );
    let changes = Array::from(&alarms.observe(Array::new().into(), 60.0).unwrap());
    let actions: Vec<String> = changes
        .iter()
        .map(|c| get(&c, "action").as_string().unwrap())
        .collect();
    assert_eq!(actions, ["shelf-expired", "condition"]);
}
