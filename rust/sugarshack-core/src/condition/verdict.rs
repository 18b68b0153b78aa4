//! One check of a condition at a moment, decided whole here: it passes only
//! on fresh values (a stale or missing sensor means it does not hold, never
//! old data), and when it does not hold it says why in a person's words.

use serde_json::{Map, Value};

use super::Condition;
use crate::sensor::SensorError;
use crate::text::js_number;

/// What one check of a condition found.
#[derive(Clone, Debug, PartialEq)]
pub struct Verdict {
    /// Its sensors' values by id, in the order listed (a repeated id once,
    /// with its last value); none when one was not fresh.
    pub values: Option<Map<String, Value>>,
    /// Why it did not hold; none when it held.
    pub reason: Option<String>,
}

impl Verdict {
    /// Whether it held.
    pub fn met(&self) -> bool {
        self.reason.is_none()
    }
}

impl Condition {
    /// Checks it on `read`, its listed sensors' values (in order) if every
    /// one was fresh, else why the first that was not could not be read.
    pub fn verdict(&self, read: Result<Vec<f64>, SensorError>) -> Verdict {
        let values = match read {
            Ok(values) => values,
            Err(not_fresh) => {
                return Verdict {
                    values: None,
                    reason: Some(not_fresh.to_string()),
                }
            }
        };
        let mut by_id = Map::new();
        for (id, &value) in self.sensors().iter().zip(&values) {
            by_id.insert(id.clone(), Value::from(value));
        }
        let reason = match self.holds(&values) {
            Ok(true) => None,
            Ok(false) => Some(format!("values {}", values_text(&by_id))),
            Err(no_number) => Some(no_number.to_string()),
        };
        Verdict {
            values: Some(by_id),
            reason,
        }
    }
}

/// The values as a JS object's JSON: ids that are array indices first, in
/// numeric order, as JavaScript keeps an object's keys.
fn values_text(by_id: &Map<String, Value>) -> String {
    let mut entries: Vec<(&String, &Value)> = by_id.iter().collect();
    entries.sort_by_key(|(id, _)| array_index(id).map_or((1, 0), |i| (0, i)));
    let fields: Vec<String> = entries
        .into_iter()
        .map(|(id, value)| {
            let key = serde_json::to_string(id).unwrap_or_default();
            format!("{key}:{}", js_number(value.as_f64().unwrap_or(f64::NAN)))
        })
        .collect();
    format!("{{{}}}", fields.join(","))
}

/// `id` as an array index (canonical, below 2^32 - 1), as JavaScript orders keys.
fn array_index(id: &str) -> Option<u32> {
    let n: u32 = id.parse().ok()?;
    (n != u32::MAX && n.to_string() == id).then_some(n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::time::ms;

    fn condition(text: &str, listed: &[&str]) -> Condition {
        let listed: Vec<String> = listed.iter().map(|s| s.to_string()).collect();
        Condition::compile(text, &listed, &["LT-3", "FT-3", "12", "3"]).unwrap()
    }

    #[test]
    fn it_holds_on_fresh_values_and_gives_them_by_id() {
        let c = condition("`LT-3` >= 100", &["LT-3", "FT-3"]);
        let v = c.verdict(Ok(vec![120.0, 2.5]));
        assert!(v.met());
        assert_eq!(
            Value::Object(v.values.unwrap()),
            serde_json::json!({ "LT-3": 120.0, "FT-3": 2.5 })
        );
    }

    #[test]
    fn a_stale_or_missing_sensor_never_passes_and_says_which() {
        // Even a condition that holds on any value: old data is no answer.
        let c = condition("`LT-3` = `LT-3`", &["LT-3"]);
        let stale = c.verdict(Err(SensorError::Stale {
            sensor: "LT-3".into(),
            age_ms: ms(4000),
            stale_ms: ms(3000),
        }));
        assert!(!stale.met());
        assert_eq!(stale.values, None);
        assert_eq!(
            stale.reason.as_deref(),
            Some("sensor 'LT-3' is stale: its last value is 4000 ms old (limit 3000 ms)")
        );
        let missing = c.verdict(Err(SensorError::NoValue {
            sensor: "LT-3".into(),
        }));
        assert_eq!(
            missing.reason.as_deref(),
            Some("sensor 'LT-3' has sent no value yet")
        );
    }

    #[test]
    fn not_holding_is_worded_with_the_values_as_javascript_writes_them() {
        let c = condition("`LT-3` >= 100", &["LT-3", "FT-3"]);
        let v = c.verdict(Ok(vec![50.0, 1e21]));
        assert_eq!(
            v.reason.as_deref(),
            Some(r#"values {"LT-3":50,"FT-3":1e+21}"#)
        );
        assert!(v.values.is_some());
        // Ids that are array indices come first, ascending, as in a JS object.
        let c = condition("`LT-3` > 0", &["LT-3", "12", "3"]);
        let v = c.verdict(Ok(vec![-0.0, 1.0, 2.0]));
        assert_eq!(
            v.reason.as_deref(),
            Some(r#"values {"3":2,"12":1,"LT-3":0}"#)
        );
    }

    #[test]
    fn arithmetic_with_no_number_is_the_reason() {
        let c = condition("100 / `LT-3` * 2 > 1", &["LT-3"]);
        let v = c.verdict(Ok(vec![0.0]));
        assert_eq!(
            v.reason.as_deref(),
            Some("'100 / `LT-3`' gives no finite number with these values (a division by zero?)")
        );
        assert!(v.values.is_some());
    }

    #[test]
    fn a_repeated_id_keeps_its_first_place_and_last_value() {
        let c = condition("`LT-3` > 1000", &["LT-3", "FT-3", "LT-3"]);
        let v = c.verdict(Ok(vec![1.0, 2.0, 3.0]));
        assert_eq!(v.reason.as_deref(), Some(r#"values {"LT-3":3,"FT-3":2}"#));
    }
}
