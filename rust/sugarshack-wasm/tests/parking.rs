//! An engine's msgs kept before its start, as JS reaches them: the park
//! bound among its options (checked as it crosses), the handles a host takes
//! out when it frees the engine unstarted, and the move to a new engine.
#![cfg(target_arch = "wasm32")]

use sugarshack_wasm::Engine;
use wasm_bindgen::JsValue;
use wasm_bindgen_test::wasm_bindgen_test;

mod support;
use support::{code_of, json, message_of};

fn config() -> JsValue {
    json(r#"{ "resources": [{ "name": "YEL", "lockout": { "valves": { "V12": 0 } } }] }"#)
}

/// An unstarted engine with acquire node 1 (op 10 on YEL, a 1 s timeout).
fn unstarted(options: &str) -> Engine {
    let mut engine = Engine::new(config(), json(options)).expect("valid options");
    let spec = json(
        r#"{ "kind": "acquire", "timeoutMs": 1000, "operation": "10", "priority": 1, "resources": "YEL" }"#,
    );
    engine.add_node(1, spec, 0.0).unwrap();
    engine
}

#[wasm_bindgen_test]
fn the_park_bound_is_a_whole_number_of_msgs() {
    for bad in ["-1", "1.5", "\"2\"", "true"] {
        let err = Engine::new(config(), json(&format!(r#"{{ "parkBound": {bad} }}"#)))
            .err()
            .expect("refused");
        let message = message_of(&err);
        assert_eq!(code_of(err), "INVALID_CONFIG", "{bad}");
        assert!(
            message.starts_with("parkBound must be a whole number"),
            "{message}"
        );
    }
    // Absent, null, 0 or more than memory holds: accepted.
    for good in [
        "{}",
        r#"{ "parkBound": null }"#,
        r#"{ "parkBound": 0 }"#,
        r#"{ "parkBound": 1e15 }"#,
    ] {
        assert!(Engine::new(config(), json(good)).is_ok(), "{good}");
    }
}

#[wasm_bindgen_test]
fn kept_msgs_are_taken_out_once_or_moved_with_their_arrival() {
    // An engine freed unstarted hands its host every msg it kept, once.
    let mut freed = unstarted("{}");
    freed.acquire(1, 4, 0.0);
    freed.acquire(1, 5, 0.0);
    assert_eq!(freed.take_parked(), [4, 5]);
    assert_eq!(freed.take_parked(), Vec::<u32>::new());
    // Moved to an engine made for new settings, within its own bound: one is refused there.
    let mut first = unstarted(r#"{ "parkBound": 3 }"#);
    for msg in [7, 8, 9] {
        first.acquire(1, msg, 100.0);
    }
    let mut next = unstarted(r#"{ "parkBound": 2 }"#);
    first.hand_parked_to(&mut next, 300.0).unwrap();
    assert_eq!(
        first.take_parked(),
        Vec::<u32>::new(),
        "nothing left behind"
    );
    assert_eq!(next.take_parked(), [7, 8]);
    // Their timeouts still count from their arrival at 100: due at 1100, before any start.
    for (at, left) in [(1099.0, vec![6]), (1100.0, vec![])] {
        let mut kept = unstarted("{}");
        kept.acquire(1, 6, 100.0);
        let mut next = unstarted("{}");
        kept.hand_parked_to(&mut next, 500.0).unwrap();
        next.tick(at).unwrap();
        assert_eq!(next.take_parked(), left, "at {at}");
    }
    assert_eq!(
        code_of(first.hand_parked_to(&mut next, -1.0).unwrap_err()),
        "INVALID_TIME"
    );
}
