#![cfg(target_arch = "wasm32")]

//! The control facade under Node: a PID loop's terms and fallback, the Smith
//! predictor's estimate, an RCC pair deciding over a JS state tuple, and the
//! errors a flow author sees for a broken configuration.

use sugarshack_wasm::{pid_defaults, validate_thresholds, IoModule, PidLoop, PidStation, Rcc};
use wasm_bindgen::JsValue;
use wasm_bindgen_test::wasm_bindgen_test;

mod support;
use support::{code_of, get, json};

fn number(value: &JsValue, key: &str) -> f64 {
    get(value, key)
        .as_f64()
        .unwrap_or_else(|| panic!("{key} is not a number"))
}

/// A JS number.
fn n(x: f64) -> JsValue {
    JsValue::from_f64(x)
}

const NONE: JsValue = JsValue::UNDEFINED;

const PI: &str = r#"{ "pid": { "kp": 2, "tiS": 4, "outMin": 0, "outMax": 100 } }"#;

#[wasm_bindgen_test]
fn a_step_returns_every_term() {
    let mut pid = PidLoop::new(json(PI)).unwrap();
    let step = pid.step(n(50.0), n(40.0), n(1.0), NONE).unwrap();
    assert_eq!(
        (
            number(&step, "p"),
            number(&step, "i"),
            number(&step, "output")
        ),
        (20.0, 5.0, 25.0)
    );
    assert_eq!(get(&step, "mode").as_string().unwrap(), "auto");
    assert_eq!(number(&step, "seen"), 40.0);
    assert!(get(&step, "deadTimeSamples").is_null());
}

#[wasm_bindgen_test]
fn a_nan_or_missing_measurement_outputs_the_fallback_never_nan() {
    let mut pid = PidLoop::new(json(
        r#"{ "pid": { "kp": 2, "tiS": 4, "outMin": 0, "outMax": 100, "fallback": 12 } }"#,
    ))
    .unwrap();
    pid.step(n(50.0), n(40.0), n(1.0), NONE).unwrap();
    for measurement in [Some(f64::NAN), None] {
        let step = pid
            .step(n(50.0), measurement.map_or(NONE, n), n(1.0), NONE)
            .unwrap();
        assert_eq!(number(&step, "output"), 12.0);
        assert_eq!(get(&step, "mode").as_string().unwrap(), "fallback");
    }
    assert_eq!(pid.integral(), 5.0, "the integrator is held");
}

#[wasm_bindgen_test]
fn broken_configurations_and_inputs_name_their_fault() {
    let cases = [
        (
            r#"{ "pid": { "kp": 2, "outMin": 10, "outMax": 0 } }"#,
            "min < max",
        ),
        (
            r#"{ "pid": { "kp": 2, "outMin": 0, "outMax": 1, "kd": 3 } }"#,
            "unknown field `kd`",
        ),
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
    assert_eq!(
        code_of(pid.step(n(50.0), n(1.0), n(0.0), NONE).unwrap_err()),
        "INVALID_INPUT"
    );
    assert_eq!(
        code_of(pid.set_limits(n(5.0), n(1.0)).unwrap_err()),
        "INVALID_CONFIG"
    );
    assert_eq!(
        code_of(validate_thresholds(vec![400.0, 300.0], n(200.0)).unwrap_err()),
        "INVALID_CONFIG"
    );
    assert!(validate_thresholds(vec![200.0, 400.0], n(200.0)).is_ok());
}

#[wasm_bindgen_test]
fn the_adaptive_predictor_reports_its_delay_estimate() {
    let mut pid = PidLoop::new(json(
        r#"{ "pid": { "kp": 1, "tiS": 3, "outMin": -5, "outMax": 5 },
             "smith": { "model": { "gain": 1, "tauS": 3 }, "tsS": 0.3, "deadTime": { "mode": "adaptive", "alpha": 0.5, "h": 3 } } }"#,
    ))
    .unwrap();
    for _ in 0..50 {
        pid.observe_round_trip(n(1200.0)).unwrap();
    }
    let estimate = pid.delay_estimate().unwrap();
    assert_eq!(number(&estimate, "deadTimeSamples"), 4.0);
    assert_eq!(number(&estimate, "meanMs"), 1200.0);
    assert_eq!(
        code_of(pid.observe_round_trip(n(f64::NAN)).unwrap_err()),
        "INVALID_INPUT"
    );
    let step = pid.step(n(1.0), n(0.0), n(0.3), NONE).unwrap();
    assert_eq!(number(&step, "deadTimeSamples"), 4.0);
}

#[wasm_bindgen_test]
fn an_rcc_pair_hands_over_through_the_io_module() {
    let group = r#"{ "thresholdsMs": [200, 500], "tsMs": 200, "id": "#;
    let mut primary = Rcc::new(json(&format!("{group} 1 }}"))).unwrap();
    let mut secondary = Rcc::new(json(&format!("{group} 2 }}"))).unwrap();
    let mut pid1 = PidLoop::new(json(PI)).unwrap();
    let mut pid2 = PidLoop::new(json(PI)).unwrap();
    let mut io = IoModule::new(n(2.0), n(0.0)).unwrap();

    let scan = primary
        .scan(
            &mut pid1,
            io.state(n(0.0)).unwrap(),
            n(50.0),
            n(40.0),
            n(0.2),
        )
        .unwrap();
    assert!(get(&scan, "engaged").as_bool().unwrap());
    io.write(n(1.0), n(number(&scan, "write")), n(0.0)).unwrap();
    let written = io.last_action();

    let decision = secondary.decide(io.state(n(100.0)).unwrap(), NONE).unwrap();
    assert_eq!(get(&decision, "engaged").as_bool(), Some(false));
    assert_eq!(number(&decision, "track"), written);
    let standby = pid2
        .step_decided(decision, n(50.0), n(40.0), n(0.2))
        .unwrap();
    assert!(
        get(&standby, "write").is_null(),
        "a standby controller writes nothing"
    );
    assert_eq!(number(&get(&standby, "step"), "seen"), 40.0);

    // the primary goes silent: past D_2 the secondary acts, starting from the primary's action
    let decision = secondary.decide(io.state(n(600.0)).unwrap(), NONE).unwrap();
    let took_over = pid2
        .step_decided(decision, n(50.0), n(40.0), n(0.2))
        .unwrap();
    let first = number(&took_over, "write");
    assert!(
        (first - (written + 2.0 / 4.0 * 10.0 * 0.2)).abs() < 1e-9,
        "one integration away from {written}: {first}"
    );
    io.write(n(2.0), n(first), n(600.0)).unwrap();

    primary.poll_timed_out();
    assert!(primary.first_cycle());
    let back = primary
        .scan(
            &mut pid1,
            io.state(n(700.0)).unwrap(),
            n(50.0),
            n(40.0),
            n(0.2),
        )
        .unwrap();
    assert_eq!(
        number(&back, "write"),
        first,
        "the recovered primary re-seeds on the backup's action"
    );

    assert_eq!(
        code_of(io.write(n(3.0), n(1.0), n(700.0)).unwrap_err()),
        "UNKNOWN_CONTROLLER"
    );
    assert_eq!(
        code_of(io.write(n(1.5), n(1.0), n(700.0)).unwrap_err()),
        "UNKNOWN_CONTROLLER"
    );
    assert_eq!(
        code_of(io.write(n(-1.0), n(1.0), n(700.0)).unwrap_err()),
        "UNKNOWN_CONTROLLER"
    );
    assert_eq!(
        code_of(IoModule::new(n(0.5), n(0.0)).err().unwrap()),
        "INVALID_CONFIG"
    );
    assert_eq!(
        code_of(
            secondary
                .decide(json(r#"{ "lastAction": 1, "agesMs": [1] }"#), NONE)
                .unwrap_err()
        ),
        "INVALID_INPUT"
    );
    assert_eq!(
        code_of(
            Rcc::new(json(r#"{ "id": 1, "thresholdsMs": [100], "tsMs": 200 }"#))
                .err()
                .unwrap()
        ),
        "INVALID_CONFIG"
    );
}

#[wasm_bindgen_test]
fn null_strings_and_booleans_are_refused_not_coerced() {
    let mut pid = PidLoop::new(json(PI)).unwrap();
    let before = pid.config().unwrap();
    for bad in [JsValue::NULL, JsValue::from_str("5"), JsValue::TRUE] {
        let error = pid.set_tunings(bad.clone(), n(4.0), n(0.0)).unwrap_err();
        assert!(get(&error, "message")
            .as_string()
            .unwrap()
            .starts_with("kp must be a number, got"));
        assert_eq!(code_of(error), "INVALID_INPUT");
        assert_eq!(
            code_of(pid.step(bad.clone(), n(40.0), n(1.0), NONE).unwrap_err()),
            "INVALID_INPUT"
        );
        assert_eq!(
            code_of(
                pid.step(n(50.0), JsValue::from_str("40"), n(1.0), NONE)
                    .unwrap_err()
            ),
            "INVALID_INPUT"
        );
        assert_eq!(
            code_of(pid.set_integral(bad.clone()).unwrap_err()),
            "INVALID_INPUT"
        );
    }
    assert_eq!(
        number(&pid.config().unwrap(), "kp"),
        number(&before, "kp"),
        "kp is not 0"
    );
    assert_eq!(pid.integral(), 0.0);
    // non-finite numbers reach the core, which refuses them with its code
    assert_eq!(
        code_of(
            pid.set_tunings(n(f64::INFINITY), n(4.0), n(0.0))
                .unwrap_err()
        ),
        "INVALID_CONFIG"
    );
    assert_eq!(
        code_of(pid.set_integral(n(f64::NAN)).unwrap_err()),
        "INVALID_INPUT"
    );
    let mut io = IoModule::new(n(2.0), n(0.0)).unwrap();
    assert_eq!(
        code_of(io.write(n(1.0), JsValue::NULL, n(0.0)).unwrap_err()),
        "INVALID_INPUT"
    );
    assert_eq!(code_of(io.state(n(f64::NAN)).unwrap_err()), "INVALID_INPUT");
    assert_eq!(io.last_action(), 0.0);
}

#[wasm_bindgen_test]
fn an_integral_set_after_new_tunings_sticks() {
    let mut pid = PidLoop::new(json(PI)).unwrap();
    pid.step(n(50.0), n(40.0), n(1.0), NONE).unwrap();
    pid.set_tunings(n(1.0), n(0.0), n(0.0)).unwrap();
    pid.set_integral(n(7.0)).unwrap();
    let step = pid.step(n(50.0), n(50.0), n(1.0), NONE).unwrap();
    assert_eq!(number(&step, "output"), 7.0);
}

#[wasm_bindgen_test]
fn huge_inputs_are_coded_errors_and_the_object_keeps_working() {
    // These trapped the instance ("unreachable") or made NaN that stuck.
    let mut pid = PidLoop::new(json(
        r#"{ "pid": { "kp": 100, "tdS": 1, "outMin": 0, "outMax": 100 } }"#,
    ))
    .unwrap();
    let _ = pid.step(n(0.0), n(1e308), n(1.0), NONE);
    assert_eq!(
        code_of(pid.step(n(0.0), n(1e307), n(1.0), NONE).unwrap_err()),
        "INVALID_INPUT"
    );
    let step = pid.step(n(0.0), n(-1.0), n(1.0), NONE).unwrap();
    assert!(number(&step, "output").is_finite());
    let broken = PidLoop::new(json(
        r#"{ "pid": { "kp": 1e300, "tdS": 1e300, "outMin": 0, "outMax": 1 } }"#,
    ))
    .err()
    .unwrap();
    assert_eq!(code_of(broken), "INVALID_CONFIG");
}

const STATION: &str = r#"{ "loop": { "pid": { "kp": 2, "tiS": 10, "tdS": 1, "outMin": 0, "outMax": 100, "fallback": 7 } },
                          "tsS": 1, "staleMs": 80, "setpoint": 50 }"#;

#[wasm_bindgen_test]
fn a_station_without_stale_after_goes_stale_after_the_defaults_periods_of_ts() {
    let defaults = pid_defaults().unwrap();
    assert_eq!(
        (
            number(&defaults, "alpha"),
            number(&defaults, "h"),
            number(&defaults, "maxSamples"),
            number(&defaults, "staleSamples")
        ),
        (0.1, 3.0, 400.0, 3.0)
    );
    let blank = r#"{ "loop": { "pid": { "kp": 2, "outMin": 0, "outMax": 100 } }, "tsS": 0.5, "setpoint": 50 }"#;
    let mut station = PidStation::new(json(blank)).unwrap();
    station
        .measure(n(40.0), n(1000.0), n(1000.0), NONE, NONE)
        .unwrap();
    assert_eq!(station.next_tick_ms(), Some(2500.0), "3 × 0.5 s after");
}

#[wasm_bindgen_test]
fn a_station_steps_changes_and_goes_stale_by_tick() {
    let mut station = PidStation::new(json(STATION)).unwrap();
    let out = station
        .measure(n(40.0), n(1000.0), n(5.0), NONE, NONE)
        .unwrap();
    assert_eq!(get(&out, "engaged").as_bool(), Some(true));
    let report = get(&out, "pid");
    assert_eq!(
        (number(&report, "output"), number(&report, "dtS")),
        (22.0, 1.0)
    );
    assert!(get(&report, "deadTimeSamples").is_null());
    assert_eq!(
        station.next_tick_ms(),
        Some(85.0),
        "staleness counts on the arrival clock"
    );
    assert!(station.tick(n(84.0)).unwrap().is_undefined());
    let stale = station.tick(n(85.0)).unwrap();
    assert_eq!(get(&stale, "kind").as_string().unwrap(), "fallback");
    assert_eq!(number(&get(&stale, "pid"), "output"), 7.0);

    station
        .change(json(r#"{ "mode": "manual", "manual": 30 }"#))
        .unwrap();
    assert_eq!(
        get(&station.state().unwrap(), "mode").as_string().unwrap(),
        "manual"
    );
    let error = station
        .change(json(
            r#"{ "tunings": { "kp": 5 }, "limits": { "min": 10, "max": 60 } }"#,
        ))
        .unwrap_err();
    assert_eq!(code_of(error), "INVALID_CONFIG");
    assert_eq!(
        number(&station.config().unwrap(), "kp"),
        2.0,
        "a refused change leaves the tunings"
    );
    assert_eq!(
        code_of(station.change(json(r#"{ "setpoint": null }"#)).unwrap_err()),
        "INVALID_INPUT"
    );
    assert_eq!(
        code_of(
            station
                .measure(JsValue::from_str("41"), n(2000.0), n(90.0), NONE, NONE)
                .unwrap_err()
        ),
        "INVALID_INPUT"
    );
    station
        .restore(json(r#"{ "integral": 3, "setpoint": 55 }"#))
        .unwrap();
    assert_eq!(number(&station.state().unwrap(), "setpoint"), 55.0);
}

#[wasm_bindgen_test]
fn the_rcc_polling_timeout_is_ticked() {
    let mut rcc = Rcc::new(json(
        r#"{ "id": 1, "thresholdsMs": [100, 200], "tsMs": 50, "pollTimeoutMs": 150 }"#,
    ))
    .unwrap();
    rcc.watch_from(n(0.0)).unwrap();
    rcc.decide(
        json(r#"{ "lastAction": 1, "agesMs": [null, null] }"#),
        n(10.0),
    )
    .unwrap();
    assert_eq!(rcc.next_tick_ms(), Some(160.0));
    assert!(!rcc.tick(n(159.0)).unwrap());
    assert!(rcc.tick(n(160.0)).unwrap());
    assert!(rcc.first_cycle());
    assert_eq!(
        code_of(rcc.tick(JsValue::NULL).unwrap_err()),
        "INVALID_INPUT"
    );
}

#[wasm_bindgen_test]
fn a_pid_state_is_sealed_for_its_node_and_refused_for_another() {
    let saved = json(r#"{ "integral": 3.5, "setpoint": 55, "mode": "manual", "manual": 12 }"#);
    let text = sugarshack_wasm::seal_pid_state("pid-1", json(STATION), saved, n(9.0)).unwrap();
    let back = sugarshack_wasm::open_pid_state("file", &text, "pid-1").unwrap();
    assert_eq!(
        (number(&back, "integral"), number(&back, "setpoint")),
        (3.5, 55.0)
    );
    let mut station = PidStation::new(json(STATION)).unwrap();
    station.restore(back).unwrap();
    let other = sugarshack_wasm::open_pid_state("file", &text, "pid-2").unwrap_err();
    assert_eq!(code_of(other.clone()), "INVALID_SNAPSHOT");
    assert!(support::message_of(&other).starts_with("file: it is the state of node 'pid-1'"));
    let damaged =
        sugarshack_wasm::open_pid_state("file", &text.replace("3.5", "4.5"), "pid-1").unwrap_err();
    assert!(support::message_of(&damaged).contains("does not match its checksum"));
}
