use serde_json::json;

use super::*;
use crate::plant::PlantModel;
use crate::time::ms;

fn plant(
    devices: serde_json::Value,
    actuators: serde_json::Value,
    sensors: serde_json::Value,
) -> PlantModel {
    serde_json::from_value(json!({
        "actuatorTypes": {
            "valve": { "signal": "analog", "tolerance": 2, "noMotionMs": 3000, "completionMs": 10000, "staleMs": 5000 },
            "pump": { "signal": "binary", "noMotionMs": 3000, "completionMs": 6000, "staleMs": 5000 }
        },
        "devices": devices, "actuators": actuators, "sensors": sensors
    }))
    .unwrap()
}

fn contract(p: &PlantModel) -> Contract {
    p.validate().unwrap_or_else(|e| panic!("{e}"));
    Contract::new(p).unwrap()
}

fn parse(c: &Contract, topic: &str, payload: &str) -> (Incoming, Readings) {
    let mut out = Readings::default();
    let seen = c.parse(topic, payload.as_bytes(), ms(0), &mut out);
    (seen, out)
}

/// The samples one message yields.
fn samples(c: &Contract, topic: &str, payload: &str) -> Vec<Reading> {
    parse(c, topic, payload).1.samples
}

/// Checks the samples each message yields, naming the message that differs.
#[track_caller]
fn assert_samples(c: &Contract, cases: &[(&str, &str, Vec<Reading>)]) {
    for (topic, payload, expected) in cases {
        assert_eq!(&samples(c, topic, payload), expected, "{topic} {payload}");
    }
}

/// Asserts where the command driving `id` to `target` goes and what it says.
#[track_caller]
fn assert_command(c: &Contract, id: ActuatorId, target: f64, topic: &str, payload: &str) {
    let m = c.command(id, target);
    assert_eq!((m.topic.as_str(), m.payload.as_str()), (topic, payload));
}

const V: ActuatorId = ActuatorId::from_index(0);
const P: ActuatorId = ActuatorId::from_index(1);
const D0: DeviceId = DeviceId::from_index(0);
/// The first device reported offline.
const D0_OFFLINE: Incoming = Incoming::Status {
    device: D0,
    online: false,
};

fn esphome() -> PlantModel {
    plant(
        json!([{ "id": "ctrl-1", "kind": "actuator-panel", "profile": "esphome" },
               { "id": "station-2", "kind": "sensor-station", "profile": "esphome" }]),
        json!([{ "id": "V101", "type": "valve", "device": "ctrl-1", "io": 1, "lockout": 0 },
               { "id": "P1", "type": "pump", "device": "ctrl-1", "lockout": false }]),
        json!([{ "id": "LT-2", "device": "station-2", "name": "volume" }]),
    )
}

#[test]
fn esphome_states_read_as_the_firmware_writes_them() {
    let c = contract(&esphome());
    let (seen, out) = parse(&c, "ctrl-1/valve/v101/position/state", "37");
    assert_eq!(
        seen,
        Incoming::Samples {
            device: D0,
            ts: None
        }
    );
    assert_eq!(out.samples, vec![Reading::Actuator(V, 37.0)]);
    // The state word carries no position for an analog valve.
    assert_eq!(
        parse(&c, "ctrl-1/valve/v101/state", "opening").0,
        Incoming::Other { device: D0 }
    );
    assert_eq!(
        samples(&c, "ctrl-1/switch/p1/state", "OFF"),
        vec![Reading::Actuator(P, 0.0)]
    );
    assert_eq!(parse(&c, "ctrl-1/status", "offline").0, D0_OFFLINE);
    assert_samples(
        &c,
        &[
            (
                "station-2/sensor/volume/state",
                "nan",
                vec![Reading::SensorUnavailable(SensorId::from_index(0))],
            ),
            (
                "station-2/sensor/volume/state",
                "-4.50",
                vec![Reading::Sensor(SensorId::from_index(0), -4.5)],
            ),
        ],
    );
}

#[test]
fn what_is_not_the_contract_is_foreign_or_the_devices_own_business() {
    let c = contract(&esphome());
    assert_eq!(
        parse(&c, "homeassistant/valve/ctrl-1/v101/config", "{}").0,
        Incoming::Foreign
    );
    assert_eq!(
        parse(&c, "esphome/discover/ctrl-1", "{}").0,
        Incoming::Foreign
    );
    assert_eq!(parse(&c, "", "").0, Incoming::Foreign);
    assert_eq!(
        parse(&c, "ctrl-1/debug", "[D][valve]").0,
        Incoming::Other { device: D0 }
    );
    assert_eq!(
        parse(&c, "ctrl-1/valve/v101/position/command", "100").0,
        Incoming::Other { device: D0 }
    );
    assert_eq!(
        parse(&c, "ctrl-1/valve/v999/position/state", "3").0,
        Incoming::Other { device: D0 }
    );
}

#[test]
fn bad_payloads_are_refused_with_a_reason() {
    let c = contract(&esphome());
    let (seen, out) = parse(&c, "ctrl-1/switch/p1/state", "true");
    assert_eq!(
        seen,
        Incoming::Samples {
            device: D0,
            ts: None
        }
    );
    assert_eq!(out.refusals[0].reason, "non-numeric value");
    assert_eq!(out.refusals[0].message, "value must be ON or OFF, got true");
    let (_, out) = parse(&c, "ctrl-1/valve/v101/position/state", "140");
    assert_eq!(
        out.refusals[0].message,
        "value must be a position within 0..100, got 140"
    );
    match parse(&c, "ctrl-1/status", "maybe").0 {
        Incoming::Refused { refusal, .. } => assert_eq!(
            refusal.message,
            "status must be \"online\" or \"offline\", got maybe"
        ),
        other => panic!("{other:?}"),
    }
    let mut out = Readings::default();
    assert!(matches!(
        c.parse("ctrl-1/switch/p1/state", &[0xff, 0xfe], ms(0), &mut out),
        Incoming::Refused { .. }
    ));
}

#[test]
fn esphome_commands_go_where_the_firmware_listens() {
    let c = contract(&esphome());
    assert_command(&c, V, 37.5, "ctrl-1/valve/v101/position/command", "37.5");
    assert_command(&c, P, 1.0, "ctrl-1/switch/p1/command", "ON");
    assert_eq!(
        c.parse_command("ctrl-1/switch/p1/command", b"on"),
        Some(Ok(Command::Set(P, 1.0)))
    );
    assert_eq!(
        c.parse_command("ctrl-1/switch/p1/command", b""),
        Some(Ok(Command::Cleared(P)))
    );
    assert!(matches!(
        c.parse_command("ctrl-1/valve/v101/position/command", b"OPEN"),
        Some(Err(_))
    ));
    assert_eq!(c.parse_command("ctrl-1/valve/v101/command", b"OPEN"), None);
    assert_eq!(
        c.command_topics(D0),
        vec![
            "ctrl-1/valve/v101/position/command",
            "ctrl-1/switch/p1/command"
        ]
    );
}

#[test]
fn a_valve_range_maps_onto_esphome_percent() {
    let mut p = esphome();
    p.actuator_types.get_mut("valve").unwrap().min = Some(0.0);
    p.actuator_types.get_mut("valve").unwrap().max = Some(50.0);
    let c = contract(&p);
    assert_eq!(c.command(V, 25.0).payload, "50");
    assert_eq!(
        samples(&c, "ctrl-1/valve/v101/position/state", "100"),
        vec![Reading::Actuator(V, 50.0)]
    );
}

#[test]
fn sugarshack_keeps_todays_format() {
    let p = plant(
        json!([{ "id": "ctrl-1", "kind": "actuator-panel" }, { "id": "station-2", "kind": "sensor-station" }]),
        json!([{ "id": "V12", "type": "valve", "device": "ctrl-1", "io": 12, "lockout": 0 },
               { "id": "P1", "type": "pump", "device": "ctrl-1", "io": 1, "lockout": false }]),
        json!([{ "id": "LT-2", "device": "station-2", "name": "volume" }]),
    );
    let c = contract(&p);
    let (seen, out) = parse(
        &c,
        "ctrl-1/state",
        r#"{"ts": 5, "valve": {"12": 40, "13": 1}, "pump": {"1": true}, "relay": 3}"#,
    );
    assert_eq!(
        seen,
        Incoming::Samples {
            device: D0,
            ts: Some(ms(5))
        }
    );
    assert_eq!(
        out.samples,
        vec![Reading::Actuator(V, 40.0), Reading::Actuator(P, 1.0)]
    );
    assert_samples(
        &c,
        &[
            (
                "ctrl-1/valve/12/state",
                r#"{"ts": 5, "value": 41}"#,
                vec![Reading::Actuator(V, 41.0)],
            ),
            (
                "ctrl-1/valve/12/state",
                "42",
                vec![Reading::Actuator(V, 42.0)],
            ),
            (
                "station-2/sensor/volume/state",
                r#"{"value": 7}"#,
                vec![Reading::Sensor(SensorId::from_index(0), 7.0)],
            ),
        ],
    );
    assert_eq!(
        parse(&c, "ctrl-1/telemetry", "{}").0,
        Incoming::Other { device: D0 }
    );
    match parse(&c, "ctrl-1/state", r#"{"relay": {"1": 1}}"#).0 {
        Incoming::Refused { refusal, .. } => assert_eq!(refusal.reason, "no known type"),
        other => panic!("{other:?}"),
    }
    assert_command(&c, V, 100.0, "ctrl-1/valve/12/command", "100");
}

#[test]
fn a_device_time_in_seconds_is_refused_once_the_clock_is_an_epoch_clock() {
    let p = plant(
        json!([{ "id": "ctrl-1", "kind": "actuator-panel" }]),
        json!([{ "id": "V12", "type": "valve", "device": "ctrl-1", "io": 12, "lockout": 0 }]),
        json!([]),
    );
    let c = contract(&p);
    let mut out = Readings::default();
    let now = 1_714_564_800_000;
    let seen = c.parse(
        "ctrl-1/valve/12/state",
        br#"{"ts": 1714564800, "value": 3}"#,
        ms(now),
        &mut out,
    );
    assert!(
        matches!(
            seen,
            Incoming::Refused {
                refusal: Refusal {
                    reason: "bad timestamp",
                    ..
                },
                ..
            }
        ),
        "{seen:?}"
    );
    let seen = c.parse(
        "ctrl-1/valve/12/state",
        br#"{"ts": 1714564800000, "value": 3}"#,
        ms(now),
        &mut out,
    );
    assert_eq!(
        seen,
        Incoming::Samples {
            device: D0,
            ts: Some(ms(now))
        }
    );
}

#[test]
fn tasmota_reads_power_shutters_and_sensor_telemetry() {
    let p = plant(
        json!([{ "id": "ctrl-1", "kind": "actuator-panel", "profile": "tasmota", "prefix": "panel" },
               { "id": "station-2", "kind": "sensor-station", "profile": "tasmota" }]),
        json!([{ "id": "V1", "type": "valve", "device": "ctrl-1", "entity": "Shutter1", "lockout": 0 },
               { "id": "P1", "type": "pump", "device": "ctrl-1", "entity": "POWER1", "lockout": false }]),
        json!([{ "id": "TT-2", "device": "station-2", "name": "t", "entity": "DS18B20.Temperature" }]),
    );
    let c = contract(&p);
    assert_eq!(parse(&c, "tele/panel/LWT", "Offline").0, D0_OFFLINE);
    assert_samples(
        &c,
        &[
            ("stat/panel/POWER1", "ON", vec![Reading::Actuator(P, 1.0)]),
            (
                "stat/panel/RESULT",
                r#"{"POWER1":"OFF"}"#,
                vec![Reading::Actuator(P, 0.0)],
            ),
            (
                "stat/panel/RESULT",
                r#"{"Shutter1":{"Position":54,"Direction":1,"Target":100,"Tilt":0}}"#,
                vec![Reading::Actuator(V, 54.0)],
            ),
        ],
    );
    assert_eq!(
        parse(&c, "stat/panel/RESULT", r#"{"Command":"Unknown"}"#).0,
        Incoming::Other { device: D0 }
    );
    assert_eq!(
        parse(&c, "cmnd/panel/POWER", "").0,
        Incoming::Other { device: D0 }
    );
    assert_eq!(
        samples(
            &c,
            "tele/station-2/SENSOR",
            r#"{"Time":"2024-05-01T12:00:00","DS18B20":{"Id":"01","Temperature":21.5},"TempUnit":"C"}"#
        ),
        vec![Reading::Sensor(SensorId::from_index(0), 21.5)]
    );
    assert_command(&c, V, 50.0, "cmnd/panel/ShutterPosition1", "50");
    assert_eq!(c.command(P, 0.0).topic, "cmnd/panel/POWER1");
}

#[test]
fn shelly_reads_component_status_and_notifications() {
    let p = plant(
        json!([{ "id": "ctrl-1", "kind": "actuator-panel", "profile": "shelly-gen2" },
               { "id": "station-2", "kind": "sensor-station", "profile": "shelly-gen2" }]),
        json!([{ "id": "V1", "type": "valve", "device": "ctrl-1", "entity": "cover:0", "lockout": 0 },
               { "id": "P1", "type": "pump", "device": "ctrl-1", "entity": "switch:0", "lockout": false }]),
        json!([{ "id": "TT-2", "device": "station-2", "name": "t", "entity": "temperature:0.tC" }]),
    );
    let c = contract(&p);
    assert_eq!(parse(&c, "ctrl-1/online", "false").0, D0_OFFLINE);
    assert_samples(
        &c,
        &[
            (
                "ctrl-1/status/switch:0",
                r#"{"id":0, "source":"init", "output":true, "apower":0.0}"#,
                vec![Reading::Actuator(P, 1.0)],
            ),
            (
                "ctrl-1/status/cover:0",
                r#"{"id":0,"state":"open","current_pos":100}"#,
                vec![Reading::Actuator(V, 100.0)],
            ),
        ],
    );
    let (_, out) = parse(
        &c,
        "ctrl-1/status/cover:0",
        r#"{"id":0,"state":"stopped","current_pos":null}"#,
    );
    assert_eq!(out.refusals[0].reason, "no position");
    let (seen, out) = parse(
        &c,
        "ctrl-1/events/rpc",
        r#"{"src":"x","dst":"ctrl-1/events","method":"NotifyStatus","params":{"ts":1661517432.85,"switch:0":{"id":0,"output":false}}}"#,
    );
    assert_eq!(
        seen,
        Incoming::Samples {
            device: D0,
            ts: Some(ms(1_661_517_432_850))
        }
    );
    assert_eq!(out.samples, vec![Reading::Actuator(P, 0.0)]);
    assert_eq!(
        samples(
            &c,
            "station-2/status/temperature:0",
            r#"{"id":0,"tC":21.5,"tF":70.7}"#
        ),
        vec![Reading::Sensor(SensorId::from_index(0), 21.5)]
    );
    assert_command(&c, V, 50.0, "ctrl-1/command/cover:0", "pos,50");
    assert_eq!(c.command(P, 1.0).payload, "on");
}

#[test]
fn a_custom_device_reads_by_template_path_and_map() {
    let p: PlantModel = serde_json::from_value(json!({
        "actuatorTypes": {
            "valve": { "signal": "analog", "noMotionMs": 3000, "completionMs": 10000, "staleMs": 5000 },
            "pump": { "signal": "binary", "noMotionMs": 3000, "completionMs": 6000, "staleMs": 5000 }
        },
        "devices": [{ "id": "ctrl-1", "kind": "actuator-panel", "profile": "custom", "prefix": "z2m", "custom": {
            "status": { "topic": "{prefix}/bridge/state", "online": "online", "offline": "offline" },
            "actuators": {
                "valve": { "state": "{prefix}/{entity}", "value": "position", "ts": "time",
                           "command": "{prefix}/{entity}/set", "payload": "{\"position\":{value}}" },
                "pump": { "state": "{prefix}/{entity}/state", "map": { "RUN": 1, "STOP": 0 },
                          "command": "{prefix}/{entity}/set", "on": "RUN", "off": "STOP" }
            }
        }}],
        "actuators": [{ "id": "V1", "type": "valve", "device": "ctrl-1", "entity": "tap", "lockout": 0 },
                      { "id": "P1", "type": "pump", "device": "ctrl-1", "lockout": false }]
    }))
    .unwrap();
    let c = contract(&p);
    let (seen, out) = parse(&c, "z2m/tap", r#"{"position": 30, "time": 99}"#);
    assert_eq!(
        seen,
        Incoming::Samples {
            device: D0,
            ts: Some(ms(99))
        }
    );
    assert_eq!(out.samples, vec![Reading::Actuator(V, 30.0)]);
    assert_eq!(
        samples(&c, "z2m/P1/state", "RUN"),
        vec![Reading::Actuator(P, 1.0)]
    );
    assert_eq!(parse(&c, "z2m/bridge/state", "offline").0, D0_OFFLINE);
    assert_eq!(c.command(V, 12.0).payload, r#"{"position":12}"#);
    assert_eq!(c.command(P, 0.0).payload, "STOP");
    assert_eq!(
        c.parse_command("z2m/tap/set", br#"{"position":12}"#),
        Some(Ok(Command::Set(V, 12.0)))
    );
}

#[test]
fn a_msg_of_a_device_not_served_is_refused_in_words_naming_the_device() {
    let refusal = Refusal::not_served("ctrl-2");
    assert_eq!(refusal.reason, "device not served");
    assert_eq!(
        refusal.message,
        "device 'ctrl-2' is not in this node's device list"
    );
}

#[test]
fn a_device_msg_on_a_node_not_serving_its_device_is_named_unserved() {
    let p = plant(
        json!([{ "id": "ctrl-1", "kind": "actuator-panel" }, { "id": "ctrl-2", "kind": "actuator-panel" }]),
        json!([{ "id": "V1", "type": "valve", "device": "ctrl-1", "io": 1, "lockout": 0 },
               { "id": "V2", "type": "valve", "device": "ctrl-2", "io": 1, "lockout": 0 }]),
        json!([]),
    );
    let c = contract(&p);
    let one = DeviceId::from_index(0);
    let two = DeviceId::from_index(1);
    assert_eq!(c.unserved("ctrl-2/state", &[one]), Some(two));
    assert_eq!(c.unserved("ctrl-1/state", &[one]), None);
    assert_eq!(c.unserved("ctrl-1/valve/1/state", &[]), Some(one));
    // Not a device's topic: nobody's to serve.
    assert_eq!(c.unserved("elsewhere/state", &[one]), None);
}
