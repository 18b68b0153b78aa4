//! Property tests of the topics module: what a device formats, the palette
//! parses back to the same values (and the reverse for commands), for every
//! profile; and any (topic, payload) either parses or is refused with a
//! reason, never panics.

use proptest::prelude::*;
use serde_json::json;
use sugarshack_core::actuator::{ActuatorId, DeviceId};
use sugarshack_core::plant::PlantModel;
use sugarshack_core::sensor::SensorId;
use sugarshack_core::time::ms;
use sugarshack_core::topics::{Command, Contract, Incoming, Reading, Readings};

const PROFILES: [&str; 5] = ["sugarshack", "esphome", "tasmota", "shelly-gen2", "custom"];

/// A panel (two valves, a pump) and a station (two sensors) speaking `profile`.
fn plant(profile: &str) -> PlantModel {
    let device = |id: &str, kind: &str| {
        let mut d = json!({ "id": id, "kind": kind, "profile": profile });
        if profile == "custom" {
            d["custom"] = json!({
                "status": { "topic": "{prefix}/avail", "online": "up", "offline": "down" },
                "actuators": {
                    "valve": { "state": "{prefix}/{entity}/pos", "value": "pos", "command": "{prefix}/{entity}/set", "payload": "p={value}" },
                    "pump": { "state": "{prefix}/{entity}", "map": { "RUN": 1, "STOP": 0 }, "command": "{prefix}/{entity}/set", "on": "RUN", "off": "STOP" }
                },
                "sensors": { "state": "{prefix}/s/{entity}" }
            });
        }
        d
    };
    let (v1, v2, p1, s1, s2) = match profile {
        "tasmota" => (
            "Shutter1",
            "Shutter2",
            "POWER1",
            "DS18B20.Temperature",
            "ANALOG.A0",
        ),
        "shelly-gen2" => (
            "cover:0",
            "cover:1",
            "switch:0",
            "temperature:0.tC",
            "voltmeter:100.voltage",
        ),
        _ => ("v1", "v2", "p1", "volume", "flow"),
    };
    let entity = |e: &str| {
        if profile == "sugarshack" {
            json!(null)
        } else {
            json!(e)
        }
    };
    let mut doc = json!({
        "actuatorTypes": {
            "valve": { "signal": "analog", "min": 0, "max": 100, "tolerance": 1, "noMotionMs": 3000, "completionMs": 10000, "staleMs": 5000 },
            "pump": { "signal": "binary", "noMotionMs": 3000, "completionMs": 6000, "staleMs": 5000 }
        },
        "devices": [device("ctrl-1", "actuator-panel"), device("station-2", "sensor-station")],
        "actuators": [
            { "id": "V1", "type": "valve", "device": "ctrl-1", "io": 1, "entity": entity(v1), "lockout": 0 },
            { "id": "V2", "type": "valve", "device": "ctrl-1", "io": 2, "entity": entity(v2), "lockout": 0 },
            { "id": "P1", "type": "pump", "device": "ctrl-1", "io": 1, "entity": entity(p1), "lockout": false }
        ],
        "sensors": [
            { "id": "S1", "device": "station-2", "name": "volume", "entity": entity(s1) },
            { "id": "S2", "device": "station-2", "name": "flow", "entity": entity(s2) }
        ]
    });
    for a in doc["actuators"].as_array_mut().unwrap() {
        if a["entity"].is_null() {
            a.as_object_mut().unwrap().remove("entity");
        }
    }
    for s in doc["sensors"].as_array_mut().unwrap() {
        if s["entity"].is_null() {
            s.as_object_mut().unwrap().remove("entity");
        }
    }
    let plant: PlantModel = serde_json::from_value(doc).unwrap();
    plant
        .validate()
        .unwrap_or_else(|e| panic!("{profile}: {e}"));
    plant
}

fn contracts() -> Vec<(&'static str, Contract)> {
    PROFILES
        .iter()
        .map(|p| (*p, Contract::new(&plant(p)).unwrap()))
        .collect()
}

/// Positions the firmware can report: whole percent where it rounds.
fn position(profile: &'static str) -> BoxedStrategy<f64> {
    match profile {
        "sugarshack" | "custom" => (0.0..=100.0f64).boxed(),
        _ => (0u8..=100).prop_map(f64::from).boxed(),
    }
}

fn last_actuator(readings: &[Reading], id: ActuatorId) -> Option<f64> {
    readings.iter().rev().find_map(|r| match r {
        Reading::Actuator(a, v) if *a == id => Some(*v),
        _ => None,
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn actuator_feedback_round_trips(profile in prop::sample::select(PROFILES.to_vec()), seed in any::<u64>()) {
        let contract = Contract::new(&plant(profile)).unwrap();
        let mut runner = proptest::test_runner::TestRunner::new_with_rng(
            ProptestConfig::default(), proptest::test_runner::TestRng::from_seed(proptest::test_runner::RngAlgorithm::ChaCha, &seed_bytes(seed)));
        let v1 = position(profile).new_tree(&mut runner).unwrap().current();
        let v2 = position(profile).new_tree(&mut runner).unwrap().current();
        let pump = if seed % 2 == 0 { 1.0 } else { 0.0 };
        let values = [(ActuatorId::from_index(0), v1), (ActuatorId::from_index(1), v2), (ActuatorId::from_index(2), pump)];
        let ts = (profile == "sugarshack").then_some(1_700_000_000_000 + seed % 1000);
        let messages = contract.format_actuators(DeviceId::from_index(0), &values, ts.map(ms));
        prop_assert!(!messages.is_empty());
        let mut seen = Vec::new();
        let mut out = Readings::default();
        for m in &messages {
            let incoming = contract.parse(&m.topic, m.payload.as_bytes(), ms(1_700_000_000_000), &mut out);
            prop_assert!(out.refusals.is_empty(), "{profile}: {} {:?} -> {:?}", m.topic, m.payload, out.refusals);
            if let Incoming::Samples { ts: got, .. } = incoming {
                prop_assert_eq!(got, ts.map(ms));
            }
            seen.extend(out.samples.iter().copied());
        }
        for (id, value) in values {
            let got = last_actuator(&seen, id);
            prop_assert!(got.is_some_and(|g| (g - value).abs() < 1e-9), "{profile}: {id:?} {value} -> {got:?} via {messages:?}");
        }
    }

    #[test]
    fn sensor_values_round_trip(profile in prop::sample::select(PROFILES.to_vec()),
                                a in -1e6..1e6f64, b in prop::option::of(-1e3..1e3f64)) {
        let contract = Contract::new(&plant(profile)).unwrap();
        // No reading: ESPHome and custom say `nan`; JSON documents null.
        let b = b.unwrap_or(f64::NAN);
        let b = if b.is_nan() && profile == "sugarshack" { 0.5 } else { b };
        let values = [(SensorId::from_index(0), a), (SensorId::from_index(1), b)];
        let mut seen = Vec::new();
        let mut out = Readings::default();
        for m in contract.format_sensors(DeviceId::from_index(1), &values, None) {
            contract.parse(&m.topic, m.payload.as_bytes(), ms(0), &mut out);
            prop_assert!(out.refusals.is_empty(), "{profile}: {} {:?} -> {:?}", m.topic, m.payload, out.refusals);
            seen.extend(out.samples.iter().copied());
        }
        // serde_json reads floats to within one unit in the last place.
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-12 * x.abs().max(1.0);
        let got = |id| seen.iter().find_map(|r| match r {
            Reading::Sensor(s, v) if *s == id => Some(Some(*v)),
            Reading::SensorUnavailable(s) if *s == id => Some(None),
            _ => None,
        });
        prop_assert!(got(SensorId::from_index(0)).flatten().is_some_and(|v| close(v, a)), "{profile}: {seen:?}");
        match got(SensorId::from_index(1)) {
            Some(None) => prop_assert!(b.is_nan(), "{profile}: {seen:?}"),
            Some(Some(v)) => prop_assert!(close(v, b), "{profile}: {seen:?}"),
            None => prop_assert!(false, "{profile}: nothing for S2 in {seen:?}"),
        }
    }

    #[test]
    fn commands_round_trip(profile in prop::sample::select(PROFILES.to_vec()), target in 0.0..=100.0f64, on in any::<bool>()) {
        let contract = Contract::new(&plant(profile)).unwrap();
        let valve = ActuatorId::from_index(1);
        let m = contract.command(valve, target);
        match contract.parse_command(&m.topic, m.payload.as_bytes()) {
            Some(Ok(Command::Set(id, v))) => prop_assert!(id == valve && (v - target).abs() < 1e-9, "{profile}: {m:?} -> {v}"),
            other => prop_assert!(false, "{profile}: {m:?} -> {other:?}"),
        }
        let pump = ActuatorId::from_index(2);
        let want = if on { 1.0 } else { 0.0 };
        let m = contract.command(pump, want);
        prop_assert_eq!(contract.parse_command(&m.topic, m.payload.as_bytes()), Some(Ok(Command::Set(pump, want))));
        prop_assert!(contract.command_topics(DeviceId::from_index(0)).contains(&m.topic));
        // The palette's own commands, echoed back to a `#` subscriber, are the device's business.
        let mut out = Readings::default();
        prop_assert_eq!(contract.parse(&m.topic, m.payload.as_bytes(), ms(0), &mut out), Incoming::Other { device: DeviceId::from_index(0) });
    }

    #[test]
    fn availability_round_trips(profile in prop::sample::select(PROFILES.to_vec()), online in any::<bool>(), device in 0u32..2) {
        let contract = Contract::new(&plant(profile)).unwrap();
        let device = DeviceId::from_index(device);
        let m = contract.format_status(device, online).unwrap();
        prop_assert!(m.retain);
        let mut out = Readings::default();
        prop_assert_eq!(contract.parse(&m.topic, m.payload.as_bytes(), ms(0), &mut out), Incoming::Status { device, online });
    }

    #[test]
    fn any_message_parses_or_is_refused_with_a_reason(
        which in 0usize..5,
        topic in topic(),
        payload in payload(),
        now in prop::sample::select(vec![0u64, 1_700_000_000_000]),
    ) {
        let (profile, contract) = &contracts()[which];
        let mut out = Readings::default();
        match contract.parse(&topic, &payload, ms(now), &mut out) {
            Incoming::Refused { refusal, .. } => prop_assert!(!refusal.reason.is_empty() && !refusal.message.is_empty()),
            Incoming::Samples { .. } => prop_assert!(!out.samples.is_empty() || !out.refusals.is_empty(), "{profile}"),
            Incoming::UnknownDevice { name } => prop_assert!(!name.is_empty()),
            Incoming::Foreign | Incoming::Other { .. } | Incoming::Status { .. } => {}
        }
        for refusal in &out.refusals {
            prop_assert!(!refusal.reason.is_empty() && refusal.message.chars().count() < 400, "{refusal:?}");
        }
        if let Some(Err(refusal)) = contract.parse_command(&topic, &payload) {
            prop_assert!(!refusal.message.is_empty());
        }
    }
}

fn seed_bytes(seed: u64) -> [u8; 32] {
    let mut bytes = [0u8; 32];
    bytes[..8].copy_from_slice(&seed.to_le_bytes());
    bytes
}

/// Real topics of the five plants, some cut or extended, and arbitrary ones.
fn topic() -> impl Strategy<Value = String> {
    let real: Vec<String> = contracts()
        .iter()
        .flat_map(|(_, c)| {
            let mut topics = Vec::new();
            for d in 0..2 {
                let d = DeviceId::from_index(d);
                topics.extend(c.format_status(d, true).map(|m| m.topic));
                topics.extend(c.command_topics(d));
            }
            let values = [
                (ActuatorId::from_index(0), 50.0),
                (ActuatorId::from_index(2), 1.0),
            ];
            topics.extend(
                c.format_actuators(DeviceId::from_index(0), &values, None)
                    .into_iter()
                    .map(|m| m.topic),
            );
            let sensors = [
                (SensorId::from_index(0), 1.0),
                (SensorId::from_index(1), 2.0),
            ];
            topics.extend(
                c.format_sensors(DeviceId::from_index(1), &sensors, None)
                    .into_iter()
                    .map(|m| m.topic),
            );
            topics
        })
        .chain([
            "ctrl-1/state".into(),
            "homeassistant/valve/ctrl-1/v1/config".into(),
            "ctrl-9/valve/1/state".into(),
        ])
        .collect();
    prop_oneof![
        prop::sample::select(real.clone()),
        (prop::sample::select(real), "[a-z/+#0-9]{0,6}").prop_map(|(t, tail)| format!("{t}{tail}")),
        "\\PC{0,40}",
    ]
}

/// Payloads devices send, broken ones and arbitrary bytes.
fn payload() -> impl Strategy<Value = Vec<u8>> {
    let words = [
        "ON", "off", "online", "Offline", "true", "false", "nan", "None", "open", "opening", "37", "37.000000",
        "-4.50", "1e309", "", "{}", "[]", "null", "{\"ts\": 1700000000, \"value\": 3}",
        "{\"valve\": {\"1\": 40, \"2\": \"x\"}, \"pump\": {\"1\": true}, \"ts\": 1700000000000}",
        "{\"POWER1\":\"ON\",\"Shutter1\":{\"Position\":54}}", "{\"output\":true,\"current_pos\":null}",
        "{\"params\":{\"ts\":1700000000.5,\"switch:0\":{\"output\":false},\"cover:0\":{\"current_pos\":140}}}",
        "{\"DS18B20\":{\"Temperature\":\"x\"},\"pos\":{\"a\":1}}", "p=12", "RUN", "pos,50",
    ];
    prop_oneof![
        prop::sample::select(words.to_vec()).prop_map(|w| w.as_bytes().to_vec()),
        prop::collection::vec(any::<u8>(), 0..64),
        "\\PC{0,40}".prop_map(String::into_bytes),
    ]
}
