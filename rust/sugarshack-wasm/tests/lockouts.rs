#![cfg(target_arch = "wasm32")]

//! Standing lockouts, a restored MQTT path and future device timestamps at
//! the JS boundary, run under Node.

use js_sys::Array;
use sugarshack_wasm::Tracker;
use wasm_bindgen::JsValue;
use wasm_bindgen_test::wasm_bindgen_test;

mod support;
use support::{code_of, get, json, message_of};

const PLANT: &str = r#"{
    "actuatorTypes": {
        "valve": { "signal": "analog", "tolerance": 2, "noMotionMs": 1000, "completionMs": 5000, "staleMs": 60000, "retries": 0 }
    },
    "devices": [{ "id": "ctrl-1", "kind": "actuator-panel" }],
    "actuators": [
        { "id": "V12", "type": "valve", "device": "ctrl-1", "io": 12, "idle": 0, "lockout": 0 }
    ]
}"#;

fn effects(t: &mut Tracker) -> Vec<JsValue> {
    Array::from(&t.take_effects().unwrap()).iter().collect()
}

fn kinds(effects: &[JsValue]) -> Vec<String> {
    effects
        .iter()
        .map(|e| get(e, "kind").as_string().unwrap())
        .collect()
}

fn find<'a>(effects: &'a [JsValue], kind: &str) -> &'a JsValue {
    effects
        .iter()
        .find(|e| get(e, "kind").as_string().as_deref() == Some(kind))
        .unwrap_or_else(|| panic!("no {kind} in {:?}", kinds(effects)))
}

fn lockouts_pending(t: &Tracker) -> f64 {
    get(&t.counts().unwrap(), "lockoutsPending")
        .as_f64()
        .unwrap()
}

#[wasm_bindgen_test]
fn a_lockout_stands_until_feedback_confirms_it() {
    let mut t = Tracker::new(json(PLANT), 0.0).unwrap();
    let v12 = t.actuator("V12").unwrap();
    t.feedback(v12, 99.0, None, 10.0).unwrap();
    effects(&mut t);
    t.command(
        json(r#"{ "valves": { "V12": 0 } }"#),
        1,
        true,
        100.0,
        None,
        None,
        None,
    )
    .unwrap();
    let sent = effects(&mut t);
    assert_eq!(get(&sent[0], "retain").as_bool(), Some(true));
    assert_eq!(lockouts_pending(&t), 1.0);
    let pending = Array::from(&t.pending_lockouts().unwrap());
    assert_eq!(pending.length(), 1);
    let order = pending.get(0);
    assert_eq!(get(&order, "actuator").as_f64(), Some(f64::from(v12)));
    assert_eq!(get(&order, "target").as_f64(), Some(0.0));
    assert_eq!(get(&order, "sinceMs").as_f64(), Some(100.0));
    assert_eq!(get(&order, "sends").as_f64(), Some(1.0));

    let refused = t
        .command(
            json(r#"{ "valves": { "V12": 50 } }"#),
            2,
            false,
            200.0,
            None,
            None,
            None,
        )
        .unwrap_err();
    assert!(message_of(&refused).contains("has not yet confirmed its lockout state"));
    assert_eq!(code_of(refused), "LOCKOUT_PENDING");

    t.tick(1100.0).unwrap();
    assert!(kinds(&effects(&mut t)).contains(&"groupFailed".to_string()));
    assert_eq!(t.tick(5099.0).unwrap(), 0);
    t.tick(5100.0).unwrap();
    let resent = effects(&mut t);
    assert_eq!(kinds(&resent), ["lockoutResent", "publish"]);
    assert_eq!(get(&resent[0], "actuator").as_f64(), Some(f64::from(v12)));
    assert_eq!(get(&resent[0], "attempt").as_f64(), Some(1.0));
    assert_eq!(get(&resent[1], "payload").as_string().as_deref(), Some("0"));
    assert_eq!(get(&resent[1], "retain").as_bool(), Some(true));

    assert_eq!(t.path_restored(6000.0).unwrap(), 2);
    let restored = effects(&mut t);
    assert_eq!(kinds(&restored), ["lockoutResent", "publish"]);
    assert_eq!(get(&restored[0], "attempt").as_f64(), Some(2.0));
    assert_eq!(
        code_of(t.path_restored(f64::NAN).unwrap_err()),
        "INVALID_TIME"
    );

    t.feedback(v12, 1.0, Some(6050.0), 6100.0).unwrap();
    let confirmed = effects(&mut t);
    let done = find(&confirmed, "lockoutConfirmed");
    assert_eq!(get(done, "actuator").as_f64(), Some(f64::from(v12)));
    assert_eq!(get(done, "afterMs").as_f64(), Some(6000.0));
    assert_eq!(get(done, "sends").as_f64(), Some(3.0));
    assert_eq!(lockouts_pending(&t), 0.0);
    assert_eq!(Array::from(&t.pending_lockouts().unwrap()).length(), 0);
    t.command(
        json(r#"{ "valves": { "V12": 50 } }"#),
        3,
        false,
        6200.0,
        None,
        None,
        None,
    )
    .unwrap();
}

#[wasm_bindgen_test]
fn a_future_timestamp_throws_and_applies_nothing() {
    let mut t = Tracker::new(json(PLANT), 0.0).unwrap();
    let v12 = t.actuator("V12").unwrap();
    let single = t.feedback(v12, 40.0, Some(20_000.0), 10_000.0).unwrap_err();
    assert!(
        message_of(&single).contains("10000 ms ahead"),
        "{}",
        message_of(&single)
    );
    assert_eq!(code_of(single), "FUTURE_TIMESTAMP");
    let batch = t
        .feedback_batch(&[v12], &[f64::NAN], Some(15_001.0), 10_000.0)
        .unwrap_err();
    assert_eq!(code_of(batch), "FUTURE_TIMESTAMP");
    assert!(
        effects(&mut t).is_empty(),
        "no rejection queued, nothing applied"
    );
    assert_eq!(t.position(v12), None);
    t.feedback_batch(&[v12], &[40.0], Some(15_000.0), 10_000.0)
        .unwrap();
    assert_eq!(t.position(v12), Some(40.0), "at the skew limit it applies");
}

/// A publish effect handed back to `notSent`, `blocked`, within `bound`: what `notSent` answers.
fn not_sent(t: &mut Tracker, blocked: &str, publish: &JsValue, bound: f64) -> f64 {
    t.not_sent(
        blocked,
        get(publish, "device").as_f64().unwrap() as u32,
        get(publish, "topic").as_string().unwrap(),
        get(publish, "payload").as_string().unwrap(),
        get(publish, "retain").as_bool().unwrap(),
        bound,
    )
    .unwrap()
}

#[wasm_bindgen_test]
fn publishes_not_sent_keep_a_lockout_past_the_bound_and_send_every_state_again_after_a_drop() {
    let mut t = Tracker::new(json(PLANT), 0.0).unwrap();
    let v12 = t.actuator("V12").unwrap();
    t.feedback(v12, 99.0, None, 10.0).unwrap();
    effects(&mut t);
    let command = json(r#"{ "valves": { "V12": 50 } }"#);
    t.command(command, 1, false, 100.0, None, None, None)
        .unwrap();
    let sent = effects(&mut t);
    assert_eq!(not_sent(&mut t, "suspended", &sent[0], 1.0), 0.0, "kept");
    t.withdraw(1);
    let lockout = json(r#"{ "valves": { "V12": 0 } }"#);
    t.command(lockout, 2, true, 200.0, None, None, None)
        .unwrap();
    let locked = effects(&mut t);
    // Past the bound: the lockout takes the command's place, and the bound is told to warn of.
    assert_eq!(not_sent(&mut t, "suspended", &locked[0], 1.0), 1.0);
    assert_eq!(t.kept_publishes("held").unwrap(), 1);
    assert_eq!(t.kept_publishes("unsent").unwrap(), 0);
    assert_eq!(t.send_kept("held", 300.0).unwrap(), 3);
    let out = effects(&mut t);
    assert_eq!(kinds(&out), ["publish", "lockoutResent", "publish"]);
    for publish in [&out[0], &out[2]] {
        assert_eq!(get(publish, "payload").as_string().as_deref(), Some("0"));
        assert_eq!(get(publish, "retain").as_bool(), Some(true));
    }
    assert_eq!(t.send_kept("held", 400.0).unwrap(), 0);

    // A deploy's waits apart (an unset bound is the core's default); forgotten, it never goes out.
    assert_eq!(not_sent(&mut t, "deploying", &out[0], 0.0), 0.0);
    assert_eq!(t.kept_publishes("unsent").unwrap(), 1);
    t.drop_kept("unsent").unwrap();
    assert_eq!(t.send_kept("unsent", 500.0).unwrap(), 0);
    // A standby's is dropped unsaid; an unserved device is told once.
    assert_eq!(not_sent(&mut t, "standby", &out[0], 0.0), 0.0);
    assert_eq!(not_sent(&mut t, "unserved", &out[0], 0.0), -1.0);
    assert_eq!(not_sent(&mut t, "unserved", &out[0], 0.0), 0.0);
    assert_eq!(
        t.kept_publishes("held").unwrap() + t.kept_publishes("unsent").unwrap(),
        0
    );

    let refused = |r: Result<f64, JsValue>| code_of(r.unwrap_err());
    assert_eq!(
        code_of(t.kept_publishes("later").unwrap_err()),
        "INVALID_INPUT"
    );
    let publish = |t: &mut Tracker, blocked: &str, device: u32, topic: String, bound: f64| {
        t.not_sent(blocked, device, topic, "p".into(), false, bound)
    };
    assert_eq!(
        refused(publish(&mut t, "active", 0, "t".into(), 1.0)),
        "INVALID_INPUT"
    );
    assert_eq!(
        refused(publish(&mut t, "suspended", 0, "t".into(), -1.0)),
        "INVALID_INPUT"
    );
    assert_eq!(
        refused(publish(&mut t, "suspended", 0, "t".into(), f64::NAN)),
        "INVALID_INPUT"
    );
    assert_eq!(
        refused(publish(&mut t, "suspended", 7, "t".into(), 1.0)),
        "UNKNOWN_DEVICE"
    );
    let long = "t".repeat(65_536);
    assert_eq!(
        refused(publish(&mut t, "suspended", 0, long, 1.0)),
        "INPUT_TOO_LARGE"
    );
    assert_eq!(
        code_of(t.send_kept("held", f64::NAN).unwrap_err()),
        "INVALID_TIME"
    );
}
