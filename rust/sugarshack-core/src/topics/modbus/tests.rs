use proptest::prelude::*;
use serde_json::{json, Value};

use super::frame::{self, Answer, Pdu, Reply, Request, Scan, Side};
use super::link::{Event, Links};
use super::*;
use crate::plant::{PlantErrors, PlantModel};
use crate::topics::Contract;

fn document(devices: Value, actuators: Value, sensors: Value) -> Value {
    json!({
        "actuatorTypes": {
            "valve": { "signal": "analog", "tolerance": 2, "noMotionMs": 3000, "completionMs": 10000, "staleMs": 5000 },
            "pump": { "signal": "binary", "noMotionMs": 3000, "completionMs": 6000, "staleMs": 5000 }
        },
        "devices": devices, "actuators": actuators, "sensors": sensors
    })
}

fn io(extra: Value) -> Value {
    let mut d = json!({ "id": "io-1", "kind": "actuator-panel", "profile": "modbus",
        "modbus": { "host": "127.0.0.1", "port": 5020, "unit": 1, "pollMs": 500, "timeoutMs": 200 } });
    for (k, v) in extra.as_object().unwrap() {
        d["modbus"][k] = v.clone();
    }
    d
}

const PCT: &str = r#"{ "raw": [4000, 20000], "value": [0, 100] }"#;

fn pct() -> Value {
    serde_json::from_str(PCT).unwrap()
}

/// An I/O module with a 4-20 mA valve (command holding 0, feedback input 0),
/// a pump on coil 0 with its run feedback on discrete 0, and a float flow on input 1-2.
fn module() -> Value {
    document(
        json!([io(json!({}))]),
        json!([
            { "id": "V1", "type": "valve", "device": "io-1", "lockout": 0, "modbus": {
                "command": { "kind": "holding", "address": 0, "scale": pct() },
                "feedback": { "kind": "input", "address": 0, "scale": pct() } } },
            { "id": "P1", "type": "pump", "device": "io-1", "lockout": false, "modbus": {
                "command": { "kind": "coil", "address": 0 }, "feedback": { "kind": "discrete", "address": 0 } } }
        ]),
        json!([{ "id": "FT-1", "device": "io-1", "name": "flow",
                 "modbus": { "kind": "input", "address": 1, "type": "f32" } }]),
    )
}

fn errors(doc: Value) -> Vec<String> {
    let plant: PlantModel = serde_json::from_value(doc).expect("reads");
    match plant.validate() {
        Ok(_) => Vec::new(),
        Err(PlantErrors(errors)) => errors.iter().map(ToString::to_string).collect(),
    }
}

fn map_of(doc: Value) -> ModbusMap {
    let plant: PlantModel = serde_json::from_value(doc).expect("reads");
    plant.validate().unwrap_or_else(|e| panic!("{e}"));
    Contract::new(&plant).unwrap().modbus().clone()
}

#[track_caller]
fn assert_refused(doc: Value, path: &str, words: &str) {
    let found = errors(doc);
    assert!(
        found
            .iter()
            .any(|e| e.starts_with(path) && e.contains(words)),
        "expected an error at {path} saying {words:?}, got {found:#?}"
    );
}

const D0: DeviceId = DeviceId::from_index(0);
const V1: ActuatorId = ActuatorId::from_index(0);
const P1: ActuatorId = ActuatorId::from_index(1);

#[test]
fn an_io_module_validates_and_is_planned_in_one_block_per_kind() {
    let map = map_of(module());
    assert_eq!(map.connections.len(), 1);
    assert_eq!(map.connections[0].key, "tcp://127.0.0.1:5020");
    let unit = map.unit(D0).unwrap();
    let plan: Vec<(RegisterKind, u16, u16)> = unit
        .blocks
        .iter()
        .map(|b| (b.kind, b.address, b.count))
        .collect();
    // The valve's feedback (input 0) and the flow (input 1-2) are one read.
    assert_eq!(
        plan,
        [(RegisterKind::Discrete, 0, 1), (RegisterKind::Input, 0, 3)]
    );
}

#[test]
fn commands_become_writes_in_the_register_s_own_units() {
    let map = map_of(module());
    let (device, write) = map.command(V1, 50.0).unwrap();
    assert_eq!(device, D0);
    assert_eq!(
        write,
        Request {
            unit: 1,
            pdu: Pdu::WriteRegister {
                address: 0,
                value: 12000
            }
        }
    );
    assert_eq!(
        map.command(P1, 1.0).unwrap().1.pdu,
        Pdu::WriteCoil {
            address: 0,
            on: true
        }
    );
    assert_eq!(
        map.command(P1, 0.0).unwrap().1.pdu,
        Pdu::WriteCoil {
            address: 0,
            on: false
        }
    );
}

#[test]
fn a_block_reads_into_feedback_and_sensor_values() {
    let map = map_of(module());
    let mut out = Readings::default();
    let flow = 1.25f32.to_bits();
    map.read(D0, 1, &[12000, (flow >> 16) as u16, flow as u16], &mut out);
    assert_eq!(out.refusals, []);
    assert_eq!(
        out.samples,
        [
            Reading::Actuator(V1, 50.0),
            Reading::Sensor(SensorId::from_index(0), 1.25)
        ]
    );
    // A broken 4-20 mA loop reads below 4 mA: refused, the flow still read.
    map.read(D0, 1, &[0, 0x7FC0, 0], &mut out);
    assert_eq!(
        out.samples,
        [Reading::SensorUnavailable(SensorId::from_index(0))]
    );
    assert_eq!(out.refusals[0].reason, "out of range");
    assert!(
        out.refusals[0]
            .message
            .starts_with("input 0: raw 0 is outside"),
        "{}",
        out.refusals[0].message
    );
    map.read(D0, 1, &[12000], &mut out);
    assert_eq!(out.refusals[0].reason, "short block");
}

#[test]
fn the_document_is_checked_with_path_named_errors() {
    let valve = |command: Value, feedback: Value| {
        document(
            json!([io(json!({}))]),
            json!([{ "id": "V1", "type": "valve", "device": "io-1", "lockout": 0,
                     "modbus": { "command": command, "feedback": feedback } }]),
            json!([]),
        )
    };
    let at = "actuators[0] (V1).modbus";
    assert_refused(
        valve(
            json!({ "kind": "coil", "address": 3 }),
            json!({ "kind": "input", "address": 0 }),
        ),
        &format!("{at}.command"),
        "an analog actuator needs a holding register",
    );
    assert_refused(
        valve(
            json!({ "kind": "input", "address": 3 }),
            json!({ "kind": "input", "address": 0 }),
        ),
        &format!("{at}.command"),
        "cannot be written",
    );
    assert_refused(
        valve(
            json!({ "kind": "holding", "address": 0, "scale": { "raw": [4000, 4000], "value": [0, 100] } }),
            json!({ "kind": "input", "address": 0 }),
        ),
        &format!("{at}.command"),
        "divide by zero",
    );
    assert_refused(
        valve(
            json!({ "kind": "holding", "address": 0, "scale": { "raw": [0, 10], "value": [5, 5] } }),
            json!({ "kind": "input", "address": 0 }),
        ),
        &format!("{at}.command"),
        "no span",
    );
    assert_refused(
        valve(
            json!({ "kind": "holding", "address": 0, "scale": { "raw": [0, 70000], "value": [0, 100] } }),
            json!({ "kind": "input", "address": 0 }),
        ),
        &format!("{at}.command"),
        "does not fit a u16 register",
    );
    assert_refused(
        valve(
            json!({ "kind": "holding", "address": 0, "scale": { "raw": [0, 1000], "value": [0, 50] } }),
            json!({ "kind": "input", "address": 0 }),
        ),
        &format!("{at}.command"),
        "must map into the register",
    );
    assert_refused(
        valve(
            json!({ "kind": "holding", "address": 65535, "type": "f32" }),
            json!({ "kind": "input", "address": 0 }),
        ),
        &format!("{at}.command"),
        "runs past address 65535",
    );
    // The valve's feedback on the flow sensor's registers.
    let overlap = document(
        json!([io(json!({}))]),
        json!([{ "id": "V1", "type": "valve", "device": "io-1", "lockout": 0, "modbus": {
            "command": { "kind": "holding", "address": 0 }, "feedback": { "kind": "input", "address": 2 } } }]),
        json!([{ "id": "FT-1", "device": "io-1", "name": "flow", "modbus": { "kind": "input", "address": 1, "type": "f32" } }]),
    );
    assert_refused(
        overlap,
        "sensors[0] (FT-1).modbus",
        "input 1..2 overlaps actuators[0] (V1).modbus.feedback",
    );
    // A pump's coil without a feedback is read back; a binary register takes no scale.
    let pump = |command: Value| {
        document(
            json!([io(json!({}))]),
            json!([{ "id": "P1", "type": "pump", "device": "io-1", "lockout": false, "modbus": { "command": command } }]),
            json!([]),
        )
    };
    assert_eq!(
        errors(pump(json!({ "kind": "coil", "address": 7 }))),
        Vec::<String>::new()
    );
    assert_refused(
        pump(json!({ "kind": "holding", "address": 7, "scale": pct() })),
        "actuators[0] (P1).modbus.command",
        "takes no scale",
    );
    assert_refused(
        pump(json!({ "kind": "coil", "address": 7, "type": "u32" })),
        "actuators[0] (P1).modbus.command",
        "one bit",
    );
}

#[test]
fn devices_and_connections_are_checked() {
    let at = "devices[0] (io-1).modbus";
    let one = |m: Value| document(json!([io(m)]), json!([]), json!([]));
    assert_refused(
        one(json!({ "serial": { "path": "/dev/ttyUSB0" } })),
        at,
        "either 'host' or 'serial'",
    );
    assert_refused(
        one(json!({ "framing": "rtu", "unit": 0 })),
        at,
        "not an RTU address",
    );
    assert_refused(one(json!({ "pollMs": 0 })), at, "pollMs must be positive");
    assert_refused(one(json!({ "host": "a b" })), at, "not a host name");
    let bare = document(
        json!([{ "id": "io-1", "kind": "actuator-panel", "profile": "modbus" }]),
        json!([]),
        json!([]),
    );
    assert_refused(bare, "devices[0] (io-1)", "needs 'modbus'");
    let mqtt = document(
        json!([{ "id": "ctrl-1", "kind": "actuator-panel", "modbus": { "host": "h", "unit": 1 } }]),
        json!([]),
        json!([]),
    );
    assert_refused(
        mqtt,
        "devices[0] (ctrl-1)",
        "'modbus' is for devices with profile",
    );
    // Two units behind one gateway share its connection; one unit id twice is an error.
    let gateway = |unit2: u8, framing2: &str| {
        let mut second = io(json!({ "unit": unit2, "framing": framing2 }));
        second["id"] = "io-2".into();
        document(
            json!([io(json!({ "framing": "rtu" })), second]),
            json!([]),
            json!([]),
        )
    };
    let shared = map_of(gateway(2, "rtu"));
    assert_eq!(shared.connections.len(), 1);
    assert_eq!(shared.connections[0].key, "rtu+tcp://127.0.0.1:5020");
    assert_eq!(shared.connections[0].devices.len(), 2);
    assert_refused(
        gateway(1, "rtu"),
        "devices[1] (io-2).modbus",
        "unit 1 on rtu+tcp://127.0.0.1:5020 is also device 'io-1''s",
    );
    assert_refused(gateway(2, "tcp"), "devices[1] (io-2).modbus", "framed rtu");
    // An actuator on a Modbus device says where it is.
    let bare_actuator = document(
        json!([io(json!({}))]),
        json!([{ "id": "V1", "type": "valve", "device": "io-1", "lockout": 0 }]),
        json!([]),
    );
    assert_refused(bare_actuator, "actuators[0] (V1)", "needs 'modbus'");
    let bare_sensor = document(
        json!([io(json!({}))]),
        json!([]),
        json!([{ "id": "FT-1", "device": "io-1", "name": "flow" }]),
    );
    assert_refused(bare_sensor, "sensors[0] (FT-1)", "needs 'modbus'");
    // ... and only there.
    let panel = json!([{ "id": "ctrl-1", "kind": "actuator-panel" }]);
    let register = json!({ "kind": "input", "address": 1 });
    let mqtt_actuator = document(
        panel.clone(),
        json!([{ "id": "V1", "type": "valve", "device": "ctrl-1", "lockout": 0, "modbus": { "command": register } }]),
        json!([]),
    );
    assert_refused(
        mqtt_actuator,
        "actuators[0] (V1)",
        "'modbus' is for actuators on devices with profile \"modbus\"",
    );
    let mqtt_sensor = document(
        panel,
        json!([]),
        json!([{ "id": "FT-1", "device": "ctrl-1", "name": "flow", "modbus": register }]),
    );
    assert_refused(
        mqtt_sensor,
        "sensors[0] (FT-1)",
        "'modbus' is for sensors on devices with profile \"modbus\"",
    );
}

#[test]
fn outputs_are_written_untracked_within_their_scale() {
    let doc = document(
        json!([io(
            json!({ "outputs": [{ "id": "FCV-1", "kind": "holding", "address": 10, "scale": pct() }] })
        )]),
        json!([]),
        json!([]),
    );
    let map = map_of(doc);
    let (device, write) = map.output("FCV-1", 25.0).unwrap();
    assert_eq!(
        (device, write.pdu),
        (
            D0,
            Pdu::WriteRegister {
                address: 10,
                value: 8000
            }
        )
    );
    assert_eq!(
        map.output("FCV-1", 101.0).unwrap_err().reason,
        "out of range"
    );
    assert_eq!(
        map.output("FCV-1", f64::NAN).unwrap_err().reason,
        "out of range"
    );
    assert_eq!(
        map.output("nope", 1.0).unwrap_err().reason,
        "unknown output"
    );
    // The device side reads the write back as the output's value.
    assert_eq!(
        map.written(D0, RegisterKind::Holding, 10, &[8000]),
        [(Target::Output(0), 25.0)]
    );
}

#[test]
fn the_device_side_holds_what_the_palette_reads() {
    let map = map_of(module());
    let image = map.image(
        D0,
        &[(Target::Actuator(V1), 25.0), (Target::Actuator(P1), 1.0)],
    );
    assert_eq!(
        image,
        [
            (RegisterKind::Input, 0, vec![8000]),
            (RegisterKind::Discrete, 0, vec![1])
        ]
    );
    assert_eq!(
        map.written(D0, RegisterKind::Coil, 0, &[1]),
        [(Target::Actuator(P1), 1.0)]
    );
    assert_eq!(
        map.written(D0, RegisterKind::Holding, 0, &[20000]),
        [(Target::Actuator(V1), 100.0)]
    );
}

// ---- values ---------------------------------------------------------------

fn any_kind() -> impl Strategy<Value = RegisterKind> {
    prop::sample::select(RegisterKind::ALL.to_vec())
}

fn any_type() -> impl Strategy<Value = ValueType> {
    prop::sample::select(vec![
        ValueType::U16,
        ValueType::I16,
        ValueType::U32,
        ValueType::I32,
        ValueType::F32,
    ])
}

fn any_order() -> impl Strategy<Value = WordOrder> {
    prop::sample::select(vec![WordOrder::HighFirst, WordOrder::LowFirst])
}

/// A scale whose raw range fits `t`, with a value span, either way round.
fn any_scale(t: ValueType) -> impl Strategy<Value = Option<Scale>> {
    let (low, high) = t.bounds();
    let (low, high) = (low.max(-1e6), high.min(1e6));
    prop::option::of(
        (low..high, low..high, -1e4f64..1e4, -1e4f64..1e4).prop_filter_map(
            "a span both ways",
            move |(r0, r1, v0, v1)| {
                let (r0, r1) = if t.is_integer() {
                    (r0.round(), r1.round())
                } else {
                    (r0, r1)
                };
                let s = Scale {
                    raw: [r0, r1],
                    value: [v0, v1],
                };
                ((r1 - r0).abs() >= 1.0 && (v1 - v0).abs() >= 1e-3 && s.problem().is_none())
                    .then_some(s)
            },
        ),
    )
}

fn any_codec() -> impl Strategy<Value = Codec> {
    (any_kind(), any_type(), any_order(), any::<bool>()).prop_flat_map(
        |(kind, t, order, binary)| {
            let scale = if kind.is_bit() || binary {
                Just(None).boxed()
            } else {
                any_scale(t).boxed()
            };
            scale.prop_map(move |scale| Codec {
                kind,
                value_type: if kind.is_bit() { ValueType::U16 } else { t },
                order,
                scale,
                binary: binary || kind.is_bit(),
            })
        },
    )
}

/// The most a value may move through encode then decode: half a raw step (or an f32's rounding).
fn quantum(c: &Codec, value: f64) -> f64 {
    let per_raw = c.scale.map_or(1.0, |s| {
        ((s.value[1] - s.value[0]) / (s.raw[1] - s.raw[0])).abs()
    });
    let raw = c.scale.map_or(value, |s| s.to_raw(value));
    let step = if c.value_type.is_integer() {
        0.5
    } else {
        raw.abs() * f64::from(f32::EPSILON)
    };
    step * per_raw + 1e-9 * (1.0 + value.abs())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// Format then parse gives the value back, within the register's resolution,
    /// for every register kind, number type, word order and scaling.
    #[test]
    fn a_value_round_trips_through_its_register(c in any_codec(), at in 0.0f64..=1.0) {
        let (low, high) = c.value_bounds();
        let (low, high) = (low.max(-1e9), high.min(1e9));
        let value = if c.binary { at.round() } else { low + at * (high - low) };
        let words = c.encode(value).expect("a value within range encodes");
        prop_assert_eq!(words.len(), usize::from(c.width()));
        match c.decode(&words) {
            Ok(Read::Value(back)) => prop_assert!((back - value).abs() <= quantum(&c, value), "{value} -> {words:?} -> {back}"),
            other => prop_assert!(false, "{value} -> {words:?} -> {other:?}"),
        }
    }

    /// Any words either read as a finite value (or "no reading") or are refused with a reason.
    #[test]
    fn any_words_read_or_are_refused(c in any_codec(), words in prop::collection::vec(any::<u16>(), 0..4)) {
        match c.decode(&words) {
            Ok(Read::Value(v)) => prop_assert!(v.is_finite()),
            Ok(Read::Unavailable) => prop_assert!(c.value_type == ValueType::F32),
            Err(refusal) => prop_assert!(!refusal.reason.is_empty() && !refusal.message.is_empty()),
        }
    }

    /// A value outside the register is refused, never wrapped around.
    #[test]
    fn a_value_outside_the_register_is_refused(c in any_codec().prop_filter("analog", |c| !c.binary), past in 1.0f64..1e12) {
        let (_, high) = c.value_bounds();
        let (r0, r1) = c.scale.map_or(c.value_type.bounds(), |s| (s.to_raw(s.value[0]), s.to_raw(s.value[1])));
        let value = high + past * (high.abs() + 1.0);
        let raw = c.scale.map_or(value, |s| s.to_raw(value));
        prop_assume!(raw < r0.min(r1) - 1.0 || raw > r0.max(r1) + 1.0);
        prop_assert!(c.encode(value).is_err());
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1000))]

    /// Any block a device answers, of any length: each of its values is read
    /// (a finite value, or "no reading" for a sensor) or refused with a reason;
    /// a block of the wrong length is refused whole.
    #[test]
    fn any_register_block_reads_or_is_refused(block in 0usize..2, words in prop::collection::vec(any::<u16>(), 0..6)) {
        let map = map_of(module());
        let expected = map.unit(D0).unwrap().blocks[block].count;
        let mut out = Readings::default();
        map.read(D0, block, &words, &mut out);
        if words.len() != usize::from(expected) {
            prop_assert!(out.samples.is_empty());
            prop_assert_eq!(out.refusals.len(), 1);
            prop_assert_eq!(out.refusals[0].reason, "short block");
        } else {
            let entries = if block == 0 { 1 } else { 2 };
            prop_assert_eq!(out.samples.len() + out.refusals.len(), entries);
            for sample in &out.samples {
                let ok = match sample {
                    Reading::Actuator(_, v) | Reading::Sensor(_, v) => v.is_finite(),
                    Reading::SensorUnavailable(_) => true,
                };
                prop_assert!(ok, "{:?}", sample);
            }
            prop_assert!(out.refusals.iter().all(|r| !r.reason.is_empty() && !r.message.is_empty()));
        }
    }
}

// ---- frames ---------------------------------------------------------------

#[test]
fn frames_are_the_spec_s_bytes() {
    let read = Request {
        unit: 1,
        pdu: Pdu::Read {
            function: 3,
            address: 0,
            count: 1,
        },
    };
    // The Modbus serial guide's classic example: 01 03 00 00 00 01, CRC 84 0A.
    assert_eq!(
        frame::encode_request(Framing::Rtu, 0, &read),
        [1, 3, 0, 0, 0, 1, 0x84, 0x0A]
    );
    assert_eq!(
        frame::encode_request(Framing::Tcp, 0x1234, &read),
        [0x12, 0x34, 0, 0, 0, 6, 1, 3, 0, 0, 0, 1]
    );
    let coils = Request {
        unit: 17,
        pdu: Pdu::WriteCoils {
            address: 19,
            bits: vec![
                true, false, true, true, false, false, true, true, true, false,
            ],
        },
    };
    // The application protocol spec's FC 15 example: 0F 0013 000A 02 CD 01.
    assert_eq!(
        frame::encode_request(Framing::Tcp, 1, &coils)[7..],
        [0x0F, 0x00, 0x13, 0x00, 0x0A, 0x02, 0xCD, 0x01]
    );
}

fn any_pdu() -> impl Strategy<Value = Pdu> {
    prop_oneof![
        (1u8..=2, any::<u16>(), 1u16..=2000).prop_map(|(function, address, count)| Pdu::Read {
            function,
            address: address.min(u16::MAX - count + 1),
            count
        }),
        (3u8..=4, any::<u16>(), 1u16..=125).prop_map(|(function, address, count)| Pdu::Read {
            function,
            address: address.min(u16::MAX - count + 1),
            count
        }),
        (any::<u16>(), any::<bool>()).prop_map(|(address, on)| Pdu::WriteCoil { address, on }),
        (any::<u16>(), any::<u16>())
            .prop_map(|(address, value)| Pdu::WriteRegister { address, value }),
        (0u16..60000, prop::collection::vec(any::<bool>(), 1..300))
            .prop_map(|(address, bits)| Pdu::WriteCoils { address, bits }),
        (0u16..60000, prop::collection::vec(any::<u16>(), 1..=123))
            .prop_map(|(address, values)| Pdu::WriteRegisters { address, values }),
    ]
}

fn framing() -> impl Strategy<Value = Framing> {
    prop::sample::select(vec![Framing::Tcp, Framing::Rtu])
}

/// A device's answer to `request`: its values, an echo, or an exception.
fn reply_to(request: &Request, seed: u64, exception: Option<u8>) -> Reply {
    if let Some(code) = exception {
        return Reply::Exception(code);
    }
    match request.pdu {
        Pdu::Read {
            function: 1 | 2,
            count,
            ..
        } => Reply::Bits((0..count).map(|i| (seed >> (i % 64)) & 1 == 1).collect()),
        Pdu::Read { count, .. } => Reply::Registers(
            (0..count)
                .map(|i| (seed as u16).wrapping_mul(i + 1))
                .collect(),
        ),
        _ => Reply::Written,
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1000))]

    /// A request the palette frames is what the device reads, and the device's
    /// reply is what the palette reads back, both framings.
    #[test]
    fn requests_and_replies_round_trip(f in framing(), txid in any::<u16>(), unit in any::<u8>(), pdu in any_pdu(),
                                        seed in any::<u64>(), exception in prop::option::of(1u8..12)) {
        let request = Request { unit, pdu };
        let bytes = frame::encode_request(f, txid, &request);
        prop_assert_eq!(frame::scan(f, Side::Requests, &bytes), Scan::Frame(bytes.len()));
        let (got_txid, read) = frame::decode_request(f, &bytes).expect("a request the palette made");
        prop_assert_eq!(&read, &request);
        let reply = reply_to(&request, seed, exception);
        let answer = frame::encode_reply(f, got_txid, &read, &reply);
        prop_assert_eq!(frame::scan(f, Side::Replies, &answer), Scan::Frame(answer.len()));
        prop_assert_eq!(frame::decode_reply(f, &answer, txid, &request), Ok(Answer::Reply(reply)));
    }

    /// Any bytes: the stream only yields lengths within it, and a frame decodes or is refused.
    #[test]
    fn any_bytes_frame_or_are_refused(f in framing(), bytes in prop::collection::vec(any::<u8>(), 0..300), pdu in any_pdu()) {
        for side in [Side::Requests, Side::Replies] {
            match frame::scan(f, side, &bytes) {
                Scan::Frame(n) => {
                    prop_assert!(n <= bytes.len());
                    let request = Request { unit: bytes.first().copied().unwrap_or(0), pdu: pdu.clone() };
                    let _ = frame::decode_reply(f, &bytes[..n], 0, &request);
                    let _ = frame::decode_request(f, &bytes[..n]);
                }
                Scan::Skip(n) => prop_assert!(n >= 1 && n <= bytes.len()),
                Scan::Need => {}
            }
        }
    }
}

// ---- links ----------------------------------------------------------------

/// Two units behind one RTU gateway, each with a valve; unit 2 may be mute.
fn gateway() -> ModbusMap {
    let valve = |id: &str, device: &str| {
        json!({ "id": id, "type": "valve", "device": device, "lockout": 0, "modbus": {
            "command": { "kind": "holding", "address": 0 }, "feedback": { "kind": "input", "address": 0 } } })
    };
    let mut second = io(json!({ "unit": 2, "framing": "rtu", "timeoutMs": 300 }));
    second["id"] = "io-2".into();
    map_of(document(
        json!([io(json!({ "framing": "rtu", "timeoutMs": 200 })), second]),
        json!([valve("V1", "io-1"), valve("V2", "io-2")]),
        json!([]),
    ))
}

const D1: DeviceId = DeviceId::from_index(1);

/// Plays the devices: answers what is in flight on connection 0 unless its unit is mute.
fn answer(
    links: &mut Links,
    map: &ModbusMap,
    sent: &[u8],
    now: Millis,
    mute: &[u8],
    out: &mut Vec<Event>,
) -> bool {
    let (txid, request) = frame::decode_request(map.connections[0].framing, sent).unwrap();
    if mute.contains(&request.unit) {
        return false;
    }
    let reply = reply_to(&request, 7, None);
    let bytes = frame::encode_reply(map.connections[0].framing, txid, &request, &reply);
    links.receive(0, &bytes, now, out);
    true
}

#[test]
fn a_mute_unit_delays_another_unit_s_command_by_at_most_its_own_timeout() {
    let map = gateway();
    let mut links = Links::new(&map, ms(0));
    let mut out = Vec::new();
    links.opened(0, ms(0));
    // Unit 1 is polled first, then unit 2, which never answers.
    let first = links.next(0, ms(0)).unwrap();
    assert!(answer(&mut links, &map, &first, ms(5), &[2], &mut out));
    let to_mute = links.next(0, ms(5)).unwrap();
    assert_eq!(links.in_flight(0), Some(D1));
    assert!(!answer(&mut links, &map, &to_mute, ms(6), &[2], &mut out));
    // Unit 1's command comes now: it waits for unit 2's request, no longer.
    let (device, write) = map.command(V1, 40.0).unwrap();
    assert_eq!(links.enqueue(device, write.clone()), Some(0));
    assert_eq!(links.next(0, ms(10)), None, "one request in flight");
    assert_eq!(links.wake(0), Some(ms(305)));
    links.timeout(0, ms(304), &mut out);
    assert_eq!(links.in_flight(0), Some(D1), "not before its deadline");
    links.timeout(0, ms(305), &mut out);
    let sent = links.next(0, ms(305)).unwrap();
    assert_eq!(
        frame::decode_request(Framing::Rtu, &sent).unwrap().1,
        write,
        "the write goes before any poll"
    );
    assert!(answer(&mut links, &map, &sent, ms(306), &[2], &mut out));
    assert!(out
        .iter()
        .any(|e| matches!(e, Event::Written { device: D0, .. })));
}

#[test]
fn a_unit_goes_offline_after_its_timeouts_and_comes_back_with_an_answer() {
    let map = gateway();
    let mut links = Links::new(&map, ms(0));
    let mut out = Vec::new();
    links.opened(0, ms(0));
    let mut now = ms(0);
    let mut offline_at = None;
    // Unit 2 is mute for a while: each of its polls times out.
    for _ in 0..20 {
        let Some(sent) = links.next(0, now) else {
            now = links.wake(0).unwrap().max(now);
            continue;
        };
        if !answer(&mut links, &map, &sent, now, &[2], &mut out) {
            now = links.wake(0).unwrap();
            links.timeout(0, now, &mut out);
        }
        if offline_at.is_none()
            && out.contains(&Event::Status {
                device: D1,
                online: false,
            })
        {
            offline_at = Some(now);
        }
    }
    assert!(offline_at.is_some(), "{out:?}");
    assert!(
        !out.contains(&Event::Status {
            device: D0,
            online: false
        }),
        "unit 1 answered all along"
    );
    // Unit 2 answers again: it is back.
    out.clear();
    for _ in 0..6 {
        match links.next(0, now) {
            Some(sent) => {
                answer(&mut links, &map, &sent, now, &[], &mut out);
            }
            None => now = links.wake(0).unwrap().max(now),
        }
    }
    assert!(
        out.contains(&Event::Status {
            device: D1,
            online: true
        }),
        "{out:?}"
    );
}

#[test]
fn a_lost_connection_puts_its_devices_offline_at_once_and_drops_queued_writes() {
    let map = gateway();
    let mut links = Links::new(&map, ms(0));
    let mut out = Vec::new();
    let (device, write) = map.command(V1, 40.0).unwrap();
    assert_eq!(
        links.enqueue(device, write.clone()),
        None,
        "nothing is queued on a closed connection"
    );
    links.opened(0, ms(0));
    assert_eq!(links.enqueue(device, write), Some(0));
    links.closed(0, &mut out);
    assert_eq!(
        out,
        [
            Event::Status {
                device: D0,
                online: false
            },
            Event::Status {
                device: D1,
                online: false
            }
        ]
    );
    links.opened(0, ms(100));
    let sent = links.next(0, ms(100)).unwrap();
    assert!(matches!(
        frame::decode_request(Framing::Rtu, &sent).unwrap().1.pdu,
        Pdu::Read { .. }
    ));
}

#[test]
fn exceptions_late_replies_and_noise() {
    let map = gateway();
    let mut links = Links::new(&map, ms(0));
    let mut out = Vec::new();
    links.opened(0, ms(0));
    let sent = links.next(0, ms(0)).unwrap();
    let (_, request) = frame::decode_request(Framing::Rtu, &sent).unwrap();
    // Noise, then a late reply from unit 2, then the answer, split across reads.
    let late = frame::encode_reply(
        Framing::Rtu,
        0,
        &Request {
            unit: 2,
            ..request.clone()
        },
        &Reply::Registers(vec![9]),
    );
    let mut stream = vec![0xFF, 0x00];
    stream.extend(&late);
    stream.extend(frame::encode_reply(
        Framing::Rtu,
        0,
        &request,
        &Reply::Exception(2),
    ));
    links.receive(0, &stream[..5], ms(1), &mut out);
    links.receive(0, &stream[5..], ms(2), &mut out);
    assert_eq!(out.len(), 1, "{out:?}");
    assert!(
        matches!(&out[0], Event::Refused { device: D0, refusal } if refusal.reason == "modbus exception"
        && refusal.message.contains("exception 2 (illegal data address)"))
    );
    // A gateway that says its target did not answer: a failure, twice in a row makes it offline.
    out.clear();
    for _ in 0..4 {
        let now = links.wake(0).unwrap();
        let sent = links.next(0, now).unwrap();
        let (_, request) = frame::decode_request(Framing::Rtu, &sent).unwrap();
        links.receive(
            0,
            &frame::encode_reply(Framing::Rtu, 0, &request, &Reply::Exception(11)),
            now,
            &mut out,
        );
    }
    assert!(
        out.iter()
            .any(|e| matches!(e, Event::Status { online: false, .. })),
        "{out:?}"
    );
}

#[derive(Clone, Debug)]
enum Step {
    Open,
    Close,
    Send,
    Answer,
    Exception(u8),
    Wait(u64),
    Write(f64),
}

fn step() -> impl Strategy<Value = Step> {
    prop_oneof![
        1 => Just(Step::Open),
        1 => Just(Step::Close),
        4 => Just(Step::Send),
        3 => Just(Step::Answer),
        1 => (1u8..12).prop_map(Step::Exception),
        3 => (0u64..800).prop_map(Step::Wait),
        1 => (0.0f64..=100.0).prop_map(Step::Write),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(500))]

    /// Against a reference model of the offline rule, under any traffic: one
    /// request in flight at most, writes before polls, a device offline exactly
    /// when its connection closed or `offlineAfter` requests failed in a row,
    /// and back with its first answer.
    #[test]
    fn links_follow_the_offline_rule(steps in prop::collection::vec(step(), 1..120)) {
        let map = gateway();
        let mut links = Links::new(&map, ms(0));
        let mut now = ms(0);
        let mut out = Vec::new();
        // Model: per unit, failures in a row and online; and whether the connection is open.
        let mut model = [(0u32, true), (0u32, true)];
        let mut open = false;
        let mut in_flight: Option<(u16, Request, u8)> = None;
        let mut queued_writes = 0usize;
        for s in steps {
            out.clear();
            match s {
                Step::Open => {
                    links.opened(0, now);
                    open = true;
                    in_flight = None;
                }
                Step::Close => {
                    links.closed(0, &mut out);
                    model.fill((2, false));
                    open = false;
                    in_flight = None;
                    queued_writes = 0;
                }
                Step::Send => {
                    let sent = links.next(0, now);
                    if let Some(bytes) = sent {
                        prop_assert!(open && in_flight.is_none());
                        let (txid, request) = frame::decode_request(Framing::Rtu, &bytes).unwrap();
                        if queued_writes > 0 {
                            prop_assert!(!matches!(request.pdu, Pdu::Read { .. }), "a write waits behind a poll");
                            queued_writes -= 1;
                        }
                        let unit = request.unit;
                        in_flight = Some((txid, request, unit));
                    }
                }
                Step::Answer | Step::Exception(_) => {
                    if let Some((txid, request, unit)) = in_flight.take() {
                        let exception = if let Step::Exception(code) = s { Some(code) } else { None };
                        let bytes = frame::encode_reply(Framing::Rtu, txid, &request, &reply_to(&request, 3, exception));
                        links.receive(0, &bytes, now, &mut out);
                        let m = &mut model[usize::from(unit - 1)];
                        if matches!(exception, Some(10 | 11)) {
                            m.0 += 1;
                            if m.0 >= 2 { m.1 = false; }
                        } else {
                            *m = (0, true);
                        }
                    }
                }
                Step::Wait(dt) => {
                    now = now.saturating_add(ms(dt));
                    links.timeout(0, now, &mut out);
                    if links.in_flight(0).is_none() {
                        if let Some((_, _, unit)) = in_flight.take() {
                            let m = &mut model[usize::from(unit - 1)];
                            m.0 += 1;
                            if m.0 >= 2 { m.1 = false; }
                        }
                    }
                }
                Step::Write(value) => {
                    let (device, write) = map.command(V1, value).unwrap();
                    let was = links.enqueue(device, write);
                    prop_assert_eq!(was.is_some(), open);
                    if was.is_some() { queued_writes = 1; }
                }
            }
            for e in &out {
                if let Event::Status { device, online } = e {
                    prop_assert_eq!(model[device.index()].1, *online, "{:?} disagrees with the model {:?}", e, model);
                }
            }
            prop_assert_eq!(links.in_flight(0).is_some(), in_flight.is_some());
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// Noise at any moment, between answers and timeouts: nothing panics, at
    /// most one request is in flight, and every event names a device of the plant.
    #[test]
    fn links_take_any_bytes(chunks in prop::collection::vec((prop::collection::vec(any::<u8>(), 0..64), 0u64..400, any::<bool>()), 1..60)) {
        let map = gateway();
        let mut links = Links::new(&map, ms(0));
        let mut now = ms(0);
        let mut out = Vec::new();
        links.opened(0, now);
        for (bytes, dt, answer_it) in chunks {
            if let Some(sent) = links.next(0, now) {
                if answer_it {
                    answer(&mut links, &map, &sent, now, &[], &mut out);
                }
            }
            links.receive(0, &bytes, now, &mut out);
            now = now.saturating_add(ms(dt));
            links.timeout(0, now, &mut out);
            if links.next(0, now).is_some() {
                prop_assert!(links.in_flight(0).is_some());
                prop_assert!(links.next(0, now).is_none(), "one request in flight");
            }
        }
        let named = out.iter().all(|e| match e {
            Event::Block { device, .. } | Event::Written { device, .. } | Event::Refused { device, .. } | Event::Status { device, .. } => device.index() < 2,
        });
        prop_assert!(named);
    }
}

#[test]
fn the_tracker_writes_commands_and_writes_them_again_when_the_device_returns() {
    use crate::actuator::{Effect, Tracker};
    let plant: PlantModel = serde_json::from_value(module()).unwrap();
    let mut tracker = Tracker::new(plant, ms(0)).unwrap();
    let writes = |effects: &[Effect]| -> Vec<Request> {
        effects
            .iter()
            .filter_map(|e| match e {
                Effect::Write {
                    device: D0,
                    request,
                } => Some(request.clone()),
                Effect::Publish { .. } => panic!("a Modbus device gets no MQTT message: {e:?}"),
                _ => None,
            })
            .collect()
    };
    let lockout = tracker.command(&[(P1, 0.0)], 1, true, ms(0)).unwrap();
    assert_eq!(
        writes(&lockout),
        [Request {
            unit: 1,
            pdu: Pdu::WriteCoil {
                address: 0,
                on: false
            }
        }]
    );
    tracker.feedback(P1, 0.0, None, ms(10)).unwrap();
    let sent = tracker
        .command(&[(V1, 50.0), (P1, 1.0)], 2, false, ms(20))
        .unwrap();
    // No retained lockout to clear on a register: just the two writes.
    assert_eq!(writes(&sent).len(), 2);
    let offline = tracker.device_status(D0, false, ms(30)).unwrap();
    assert!(offline
        .iter()
        .any(|e| matches!(e, Effect::GroupFailed { caller: 2, .. })));
    let back = tracker.device_status(D0, true, ms(40)).unwrap();
    assert_eq!(
        writes(&back),
        [
            Request {
                unit: 1,
                pdu: Pdu::WriteRegister {
                    address: 0,
                    value: 12000
                }
            },
            Request {
                unit: 1,
                pdu: Pdu::WriteCoil {
                    address: 0,
                    on: true
                }
            },
        ]
    );
}
