#![cfg(target_arch = "wasm32")]

//! The control facade under Node: a PID loop's terms and fallback, the Smith
//! predictor's estimate, an RCC pair deciding over a JS state tuple, and the
//! errors a flow author sees for a broken configuration.

use js_sys::{Reflect, JSON};
use sugarshack_wasm::{validate_thresholds, IoModule, PidLoop, Rcc};
use wasm_bindgen::{JsCast, JsValue};
use wasm_bindgen_test::wasm_bindgen_test;

fn json(text: &str) -> JsValue {
    JSON::parse(text).expect("test JSON parses")
}

fn get(value: &JsValue, key: &str) -> JsValue {
    Reflect::get(value, &key.into()).unwrap()
}

fn number(value: &JsValue, key: &str) -> f64 {
    get(value, key).as_f64().unwrap_or_else(|| panic!("{key} is not a number"))
}

fn code_of(error: JsValue) -> String {
    assert!(error.is_instance_of::<js_sys::Error>());
    get(&error, "code").as_string().unwrap()
}

const PI: &str = r#"{ "pid": { "kp": 2, "tiS": 4, "outMin": 0, "outMax": 100 } }"#;

#[wasm_bindgen_test]
fn a_step_returns_every_term() {
    let mut pid = PidLoop::new(json(PI)).unwrap();
    let step = pid.step(50.0, Some(40.0), 1.0, None).unwrap();
    assert_eq!((number(&step, "p"), number(&step, "i"), number(&step, "output")), (20.0, 5.0, 25.0));
    assert_eq!(get(&step, "mode").as_string().unwrap(), "auto");
    assert_eq!(number(&step, "seen"), 40.0);
    assert!(get(&step, "deadTimeSamples").is_null());
}

#[wasm_bindgen_test]
fn a_nan_or_missing_measurement_outputs_the_fallback_never_nan() {
    let mut pid = PidLoop::new(json(r#"{ "pid": { "kp": 2, "tiS": 4, "outMin": 0, "outMax": 100, "fallback": 12 } }"#)).unwrap();
    pid.step(50.0, Some(40.0), 1.0, None).unwrap();
    for measurement in [Some(f64::NAN), None] {
        let step = pid.step(50.0, measurement, 1.0, None).unwrap();
        assert_eq!(number(&step, "output"), 12.0);
        assert_eq!(get(&step, "mode").as_string().unwrap(), "fallback");
    }
    assert_eq!(pid.integral(), 5.0, "the integrator is held");
}

#[wasm_bindgen_test]
fn broken_configurations_and_inputs_name_their_fault() {
    let cases = [
        (r#"{ "pid": { "kp": 2, "outMin": 10, "outMax": 0 } }"#, "min < max"),
        (r#"{ "pid": { "kp": 2, "outMin": 0, "outMax": 1, "kd": 3 } }"#, "unknown field `kd`"),
        (
            r#"{ "pid": { "kp": 2, "outMin": 0, "outMax": 1 }, "smith": { "model": { "gain": 1, "tauS": 3 }, "tsS": 0, "deadTime": { "mode": "fixed", "samples": 3 } } }"#,
            "sampling period",
        ),
    ];
    for (config, words) in cases {
        let error = PidLoop::new(json(config)).err().expect("refused");
        let message = get(&error, "message").as_string().unwrap();
        assert!(message.contains(words), "{message}");
        assert_eq!(code_of(error), "INVALID_CONFIG");
    }
    let mut pid = PidLoop::new(json(PI)).unwrap();
    assert_eq!(code_of(pid.step(50.0, Some(1.0), 0.0, None).unwrap_err()), "INVALID_INPUT");
    assert_eq!(code_of(pid.set_limits(5.0, 1.0).unwrap_err()), "INVALID_CONFIG");
    assert_eq!(code_of(validate_thresholds(vec![400.0, 300.0], 200.0).unwrap_err()), "INVALID_CONFIG");
    assert!(validate_thresholds(vec![200.0, 400.0], 200.0).is_ok());
}

#[wasm_bindgen_test]
fn the_adaptive_predictor_reports_its_delay_estimate() {
    let mut pid = PidLoop::new(json(
        r#"{ "pid": { "kp": 1, "tiS": 3, "outMin": -5, "outMax": 5 },
             "smith": { "model": { "gain": 1, "tauS": 3 }, "tsS": 0.3, "deadTime": { "mode": "adaptive", "alpha": 0.5, "h": 3 } } }"#,
    ))
    .unwrap();
    for _ in 0..50 {
        pid.observe_round_trip(1200.0).unwrap();
    }
    let estimate = pid.delay_estimate().unwrap();
    assert_eq!(number(&estimate, "deadTimeSamples"), 4.0);
    assert_eq!(number(&estimate, "meanMs"), 1200.0);
    assert_eq!(code_of(pid.observe_round_trip(f64::NAN).unwrap_err()), "INVALID_INPUT");
    let step = pid.step(1.0, Some(0.0), 0.3, None).unwrap();
    assert_eq!(number(&step, "deadTimeSamples"), 4.0);
}

#[wasm_bindgen_test]
fn an_rcc_pair_hands_over_through_the_io_module() {
    let group = r#"{ "thresholdsMs": [200, 500], "tsMs": 200, "id": "#;
    let mut primary = Rcc::new(json(&format!("{group} 1 }}"))).unwrap();
    let mut secondary = Rcc::new(json(&format!("{group} 2 }}"))).unwrap();
    let mut pid1 = PidLoop::new(json(PI)).unwrap();
    let mut pid2 = PidLoop::new(json(PI)).unwrap();
    let mut io = IoModule::new(2.0, 0.0).unwrap();

    let scan = primary.scan(&mut pid1, io.state(0.0).unwrap(), 50.0, Some(40.0), 0.2).unwrap();
    assert!(get(&scan, "engaged").as_bool().unwrap());
    io.write(1.0, number(&scan, "write"), 0.0).unwrap();
    let written = io.last_action();

    let decision = secondary.decide(io.state(100.0).unwrap()).unwrap();
    assert_eq!(get(&decision, "engaged").as_bool(), Some(false));
    assert_eq!(number(&decision, "track"), written);
    let standby = pid2.step_decided(decision, 50.0, Some(40.0), 0.2).unwrap();
    assert!(get(&standby, "write").is_null(), "a standby controller writes nothing");
    assert_eq!(number(&get(&standby, "step"), "seen"), 40.0);

    // the primary goes silent: past D_2 the secondary acts, starting from the primary's action
    let decision = secondary.decide(io.state(600.0).unwrap()).unwrap();
    let took_over = pid2.step_decided(decision, 50.0, Some(40.0), 0.2).unwrap();
    let first = number(&took_over, "write");
    assert!((first - (written + 2.0 / 4.0 * 10.0 * 0.2)).abs() < 1e-9, "one integration away from {written}: {first}");
    io.write(2.0, first, 600.0).unwrap();

    primary.poll_timed_out();
    assert!(primary.first_cycle());
    let back = primary.scan(&mut pid1, io.state(700.0).unwrap(), 50.0, Some(40.0), 0.2).unwrap();
    assert_eq!(number(&back, "write"), first, "the recovered primary re-seeds on the backup's action");

    assert_eq!(code_of(io.write(3.0, 1.0, 700.0).unwrap_err()), "UNKNOWN_CONTROLLER");
    assert_eq!(code_of(io.write(1.5, 1.0, 700.0).unwrap_err()), "UNKNOWN_CONTROLLER");
    assert_eq!(code_of(io.write(-1.0, 1.0, 700.0).unwrap_err()), "UNKNOWN_CONTROLLER");
    assert_eq!(code_of(IoModule::new(0.5, 0.0).err().unwrap()), "INVALID_CONFIG");
    assert_eq!(code_of(secondary.decide(json(r#"{ "lastAction": 1, "agesMs": [1] }"#)).unwrap_err()), "INVALID_INPUT");
    assert_eq!(code_of(Rcc::new(json(r#"{ "id": 1, "thresholdsMs": [100], "tsMs": 200 }"#)).err().unwrap()), "INVALID_CONFIG");
}
