#![cfg(target_arch = "wasm32")]

//! A runtime's life as the JS reads it, run under Node.

use js_sys::{Array, Reflect};
use sugarshack_wasm::{life_step, life_view};
use wasm_bindgen::JsValue;
use wasm_bindgen_test::wasm_bindgen_test;

fn field(view: &JsValue, key: &str) -> JsValue {
    Reflect::get(view, &key.into()).unwrap()
}

fn stage(view: &JsValue) -> String {
    field(view, "stage").as_string().unwrap()
}

fn admit(view: &JsValue) -> Vec<String> {
    Array::from(&field(view, "admit"))
        .iter()
        .map(|a| a.as_string().unwrap())
        .collect()
}

#[wasm_bindgen_test]
fn a_runtime_parks_then_takes_then_holds_new_work_back_while_a_drain_goes_on() {
    let starting = life_view("starting").unwrap();
    assert_eq!(field(&starting, "state").as_string().unwrap(), "starting");
    assert!(field(&starting, "waits").as_bool().unwrap());
    assert_eq!(admit(&starting)[0], "park");
    let running = life_step(&stage(&starting), "started").unwrap();
    assert_eq!(admit(&running)[0], "take");
    let draining = life_step(&stage(&running), "drain-begin").unwrap();
    assert_eq!(stage(&draining), "draining");
    assert!(field(&draining, "draining").as_bool().unwrap());
    // Index: urgent 1 | passive 2 | standby 4.
    assert_eq!(&admit(&draining)[..2], ["park", "take"]);
    assert_eq!(admit(&draining)[4], "standby");
    let failed = life_step(&stage(&draining), "fail").unwrap();
    assert_eq!(stage(&failed), "failed-held");
    assert!(admit(&failed).iter().all(|a| a == "refuse"));
    let stopped = life_step(&stage(&failed), "shutdown").unwrap();
    assert!(field(&stopped, "stopped").as_bool().unwrap());
    assert!(admit(&stopped).iter().all(|a| a == "complete"));
}

#[wasm_bindgen_test]
fn an_unknown_stage_or_step_is_refused() {
    for err in [
        life_step("running", "go").err().unwrap(),
        life_step("gone", "started").err().unwrap(),
        life_view("ready").err().unwrap(),
    ] {
        let code = Reflect::get(&err, &"code".into()).unwrap();
        assert_eq!(code.as_string().unwrap(), "INVALID_INPUT");
    }
}
