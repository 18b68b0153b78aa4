#![cfg(target_arch = "wasm32")]

//! The table the nodes read instead of copying the core's codes, run under Node.

use js_sys::{Array, Reflect};
use sugarshack_wasm::{
    abnormal_event_kinds, codes, max_status_chars, routine_reset_topic, Interlock,
};
use wasm_bindgen::JsValue;
use wasm_bindgen_test::wasm_bindgen_test;

fn text(value: &JsValue, key: &str) -> String {
    Reflect::get(value, &key.into())
        .unwrap()
        .as_string()
        .unwrap()
}

#[wasm_bindgen_test]
fn the_code_table_reaches_js_with_status_texts_that_fit() {
    let rows: Array = codes().unwrap().into();
    let max = max_status_chars() as usize;
    assert_eq!(max, 19);
    let names: Vec<String> = rows.iter().map(|row| text(&row, "code")).collect();
    for row in rows.iter() {
        let status = text(&row, "status");
        assert!((1..=max).contains(&status.chars().count()), "{status}");
        assert!(!text(&row, "stem").is_empty());
    }
    // A code the facade throws is in the table.
    let thrown = Interlock::new(JsValue::from_str("{}")).err().unwrap();
    let code = Reflect::get(&thrown, &"code".into())
        .unwrap()
        .as_string()
        .unwrap();
    assert_eq!(code, "INVALID_CONFIG");
    assert!(names.contains(&code));
    assert!(
        names.iter().any(|n| n == "NO_PLANT"),
        "codes the nodes raise are there too"
    );
}

#[wasm_bindgen_test]
fn the_reserved_reset_topic_comes_from_the_core() {
    assert_eq!(routine_reset_topic(), "reset");
}

#[wasm_bindgen_test]
fn the_abnormal_event_kinds_are_the_faults_clears_and_warnings() {
    let kinds: Vec<String> = Array::from(&abnormal_event_kinds().unwrap())
        .iter()
        .map(|k| k.as_string().unwrap())
        .collect();
    for kind in [
        "faulted",
        "resource-faulted",
        "cleared",
        "interrupted",
        "state-unknown",
        "dropped",
        "warn-queued",
        "warn-held",
    ] {
        assert!(kinds.iter().any(|k| k == kind), "{kind} in {kinds:?}");
    }
    assert_eq!(kinds.len(), 8, "{kinds:?}");
}
