//! Plant document parts the core's unit tests share.

use serde_json::{json, Value};

/// A valve type and a pump type, with the timings the unit tests use.
pub(crate) fn actuator_types() -> Value {
    json!({
        "valve": { "signal": "analog", "noMotionMs": 1000, "completionMs": 6000, "staleMs": 3000 },
        "pump": { "signal": "binary", "noMotionMs": 2000, "completionMs": 4000, "staleMs": 3000 }
    })
}

/// A valve of panel ctrl-1 on line YEL, idle and locked out closed.
pub(crate) fn yel_valve(id: &str, io: u32) -> Value {
    json!({ "id": id, "type": "valve", "device": "ctrl-1", "io": io, "idle": 0, "lockout": 0, "resource": "YEL" })
}

/// A pump of panel ctrl-1 on line YEL, idle and locked out off.
pub(crate) fn yel_pump(id: &str, io: u32) -> Value {
    json!({ "id": id, "type": "pump", "device": "ctrl-1", "io": io, "idle": false, "lockout": false, "resource": "YEL" })
}

/// A plant of one line, YEL: panel ctrl-1 with these actuators, station-3
/// with the volume sensor LT-3, and operation "10" (priority 20) on YEL with
/// these steps; no routine.
pub(crate) fn yel_plant(actuators: Value, steps: Value) -> Value {
    json!({
        "actuatorTypes": actuator_types(),
        "devices": [{ "id": "ctrl-1", "kind": "actuator-panel" }, { "id": "station-3", "kind": "sensor-station" }],
        "actuators": actuators,
        "sensors": [{ "id": "LT-3", "device": "station-3", "name": "volume" }],
        "resources": [{ "id": "YEL" }],
        "operations": [{ "id": "10", "priority": 20, "resources": ["YEL"], "steps": steps }]
    })
}
