//! Feedback ingest benchmark, native side: actuator panels of 16 valves and a
//! pump report once per plant second; the tracker takes every batch. Prints
//! one JSON line with datapoints per second, which `tests/bench/tracker-bench.js`
//! puts beside the wasm figures.
//!
//! usage: cargo run --release -p sugarshack-core --example tracker_bench [-- PANELS SECONDS]

use std::hint::black_box;
use std::time::Instant;
use sugarshack_core::time::ms;

use serde_json::json;
use sugarshack_core::actuator::{ActuatorId, Tracker};
use sugarshack_core::plant::PlantModel;

const VALVES: u32 = 16;

fn plant(panels: u32) -> PlantModel {
    let mut actuators = Vec::new();
    for p in 1..=panels {
        for io in 1..=VALVES {
            actuators.push(json!({ "id": format!("V{p}-{io}"), "type": "valve", "device": format!("ctrl-{p}"), "io": io, "idle": 0, "lockout": 0 }));
        }
        actuators.push(json!({ "id": format!("P{p}"), "type": "pump", "device": format!("ctrl-{p}"), "io": 1, "idle": false, "lockout": false }));
    }
    let devices: Vec<_> = (1..=panels)
        .map(|p| json!({ "id": format!("ctrl-{p}"), "kind": "actuator-panel" }))
        .collect();
    serde_json::from_value(json!({
        "actuatorTypes": {
            "valve": { "signal": "analog", "tolerance": 3, "noMotionMs": 4000, "completionMs": 15000, "staleMs": 5000 },
            "pump": { "signal": "binary", "noMotionMs": 4000, "completionMs": 6000, "staleMs": 5000 }
        },
        "devices": devices,
        "actuators": actuators
    }))
    .unwrap()
}

/// The value a slot reports in a given second: noise within tolerance, and
/// every 7th valve sweeping, so some samples change and are passed on.
pub fn sample(panel: u32, slot: u32, second: u32) -> f64 {
    if slot == VALVES {
        return f64::from((panel + second / 30) % 2);
    }
    let noise = f64::from((panel * 31 + slot * 17 + second * 13) % 5) * 0.5 - 1.0;
    if (panel + slot) % 7 == 0 {
        f64::from((second * 25) % 100) + noise.abs()
    } else {
        50.0 + noise
    }
}

fn main() {
    let mut args = std::env::args().skip(1);
    let panels: u32 = args.next().and_then(|a| a.parse().ok()).unwrap_or(1000);
    let seconds: u32 = args.next().and_then(|a| a.parse().ok()).unwrap_or(20);
    let mut tracker = Tracker::new(plant(panels), ms(0)).unwrap();
    let slots: Vec<Vec<ActuatorId>> = (1..=panels)
        .map(|p| {
            let device = tracker.device(&format!("ctrl-{p}")).unwrap();
            let mut ids: Vec<ActuatorId> = (1..=VALVES)
                .map(|io| tracker.slot(device, "valve", io).unwrap())
                .collect();
            ids.push(tracker.slot(device, "pump", 1).unwrap());
            ids
        })
        .collect();
    let batches: Vec<Vec<Vec<(ActuatorId, f64)>>> = (0..seconds)
        .map(|s| {
            slots
                .iter()
                .enumerate()
                .map(|(p, ids)| {
                    ids.iter()
                        .enumerate()
                        .map(|(i, &id)| (id, sample(p as u32 + 1, i as u32, s)))
                        .collect()
                })
                .collect()
        })
        .collect();
    let mut effects = Vec::new();
    let mut passed_on = 0usize;
    let started = Instant::now();
    for (s, second) in batches.iter().enumerate() {
        let now = 1000 * (s as u64 + 1);
        for batch in second {
            black_box(
                tracker
                    .feedback_batch(batch, Some(ms(now - 80)), ms(now), &mut effects)
                    .expect("stamped before reception"),
            );
            passed_on += effects.len();
            effects.clear();
        }
        black_box(tracker.tick(ms(now)));
    }
    let elapsed = started.elapsed().as_secs_f64();
    let datapoints = u64::from(seconds) * u64::from(panels) * u64::from(VALVES + 1);
    println!(
        "{}",
        json!({ "impl": "native", "panels": panels, "seconds": seconds, "datapoints": datapoints,
                "elapsedS": elapsed, "perSecond": datapoints as f64 / elapsed, "passedOn": passed_on })
    );
}
