//! The device's side of the MQTT contract, for simulators and test devices:
//! the messages a device of the plant publishes, and the commands it reads,
//! exactly as the palette's topics module expects them.

use serde::Serialize;
use sugarshack_core::actuator::{ActuatorId, DeviceId};
use sugarshack_core::code::Code;
use sugarshack_core::plant::Plant;
use sugarshack_core::sensor::SensorId;
use sugarshack_core::text::quote;
use sugarshack_core::time::Millis;
use sugarshack_core::topics::modbus::frame::{self, Pdu, Reply, Scan, Side};
use sugarshack_core::topics::modbus::{Endpoint, Framing, RegisterKind, Target};
use sugarshack_core::topics::{Command, Message};
use wasm_bindgen::prelude::*;

use crate::{js_error, plant_document, to_js};

/// The TypeScript shapes of what this module's calls return and take
/// (`unchecked_return_type` / `unchecked_param_type` name them).
#[wasm_bindgen(typescript_custom_section)]
const TS_SHAPES: &str = r#"
/** An MQTT message a device publishes. */
export interface DeviceMessage {
    topic: string;
    payload: string;
    retain: boolean;
}

/** A command a device received. */
export type DeviceCommand =
    | { kind: "set"; actuator: number; value: number }
    | { kind: "cleared"; actuator: number }
    | { kind: "refused"; actuator: number | null; reason: string; message: string };
"#;

#[derive(Serialize)]
#[serde(rename_all = "camelCase", tag = "kind")]
enum Read {
    /// Go to `value` (0/1 for binary).
    Set { actuator: u32, value: f64 },
    /// An empty payload: a retained command cleared on the broker.
    Cleared { actuator: u32 },
    Refused {
        actuator: Option<u32>,
        reason: &'static str,
        message: String,
    },
}

/// The devices of one plant document as its devices speak.
#[wasm_bindgen]
pub struct DeviceSide {
    plant: Plant,
}

impl DeviceSide {
    fn device_id(&self, handle: u32) -> Result<DeviceId, JsValue> {
        if (handle as usize) < self.plant.devices.len() {
            Ok(DeviceId::from_index(handle))
        } else {
            Err(js_error(
                Code::UnknownDevice,
                &format!("no device #{handle}"),
            ))
        }
    }
}

#[wasm_bindgen]
impl DeviceSide {
    /// `plant`: the plant document (refused like the tracker refuses it: `INVALID_PLANT`).
    #[wasm_bindgen(constructor)]
    pub fn new(
        #[wasm_bindgen(unchecked_param_type = "PlantDocument | string")] plant: JsValue,
    ) -> Result<DeviceSide, JsValue> {
        let plant = plant_document(plant)?;
        let plant = Plant::new(plant)
            .map_err(|errors| js_error(Code::InvalidPlant, &errors.to_string()))?;
        Ok(DeviceSide { plant })
    }

    /// Handles are indices in the document: devices, actuators and sensors in their lists.
    pub fn device(&self, id: &str) -> Option<u32> {
        self.plant
            .devices
            .iter()
            .position(|d| d.id == id)
            .map(|i| i as u32)
    }

    /// The device's profile name (`esphome`...).
    pub fn profile(&self, device: u32) -> Result<String, JsValue> {
        let d = self.device_id(device)?;
        Ok(self
            .plant
            .contract()
            .profile(d)
            .map(|p| p.name().to_owned())
            .unwrap_or_default())
    }

    /// Whether its actuators publish on change only.
    #[wasm_bindgen(js_name = reportsOnChange)]
    pub fn reports_on_change(&self, actuator: u32) -> bool {
        self.plant
            .actuators
            .get(actuator as usize)
            .is_some_and(|a| self.plant.reports_on_change(a))
    }

    /// `{ topic, payload, retain }`: its birth message, or its last will when `online` is false.
    #[wasm_bindgen(unchecked_return_type = "DeviceMessage | null")]
    pub fn status(&self, device: u32, online: bool) -> Result<JsValue, JsValue> {
        to_js(
            &self
                .plant
                .contract()
                .format_status(self.device_id(device)?, online),
        )
    }

    /// The topics it subscribes to for commands.
    #[wasm_bindgen(js_name = commandTopics)]
    pub fn command_topics(&self, device: u32) -> Result<Vec<String>, JsValue> {
        Ok(self
            .plant
            .contract()
            .command_topics(self.device_id(device)?))
    }

    /// A command it received: `{ kind: "set", actuator, value }`, `{ kind: "cleared", actuator }`,
    /// `{ kind: "refused", actuator, reason, message }`, or undefined when the topic commands nothing.
    #[wasm_bindgen(js_name = parseCommand, unchecked_return_type = "DeviceCommand | undefined")]
    pub fn parse_command(&self, topic: &str, payload: &[u8]) -> Result<JsValue, JsValue> {
        let read = match self.plant.contract().parse_command(topic, payload) {
            None => return Ok(JsValue::UNDEFINED),
            Some(Ok(Command::Set(a, value))) => Read::Set {
                actuator: a.index() as u32,
                value,
            },
            Some(Ok(Command::Cleared(a))) => Read::Cleared {
                actuator: a.index() as u32,
            },
            Some(Err(refusal)) => Read::Refused {
                actuator: None,
                reason: refusal.reason,
                message: refusal.message,
            },
        };
        to_js(&read)
    }

    /// What it publishes for its actuators at `values` (`ts`: its clock, epoch ms, where the profile carries one).
    #[wasm_bindgen(js_name = actuatorMessages, unchecked_return_type = "DeviceMessage[]")]
    pub fn actuator_messages(
        &self,
        device: u32,
        actuators: &[u32],
        values: &[f64],
        ts: Option<f64>,
    ) -> Result<JsValue, JsValue> {
        let values: Vec<(ActuatorId, f64)> = actuators
            .iter()
            .zip(values)
            .map(|(&a, &v)| (ActuatorId::from_index(a), v))
            .collect();
        let messages: Vec<Message> = self.plant.contract().format_actuators(
            self.device_id(device)?,
            &values,
            ts.and_then(Millis::whole),
        );
        to_js(&messages)
    }

    /// What it publishes for its sensors at `values` (NaN: no reading).
    #[wasm_bindgen(js_name = sensorMessages, unchecked_return_type = "DeviceMessage[]")]
    pub fn sensor_messages(
        &self,
        device: u32,
        sensors: &[u32],
        values: &[f64],
        ts: Option<f64>,
    ) -> Result<JsValue, JsValue> {
        let values: Vec<(SensorId, f64)> = sensors
            .iter()
            .zip(values)
            .map(|(&s, &v)| (SensorId::from_index(s), v))
            .collect();
        to_js(&self.plant.contract().format_sensors(
            self.device_id(device)?,
            &values,
            ts.and_then(Millis::whole),
        ))
    }
}

// ---- Modbus devices ---------------------------------------------------------

/// The TypeScript shapes of the Modbus device side.
#[wasm_bindgen(typescript_custom_section)]
const TS_MODBUS_SHAPES: &str = r#"
/** Where a Modbus device of the plant answers, and as which unit. */
export interface ModbusDeviceEndpoint {
    unit: number;
    framing: "tcp" | "rtu";
    endpoint: ModbusEndpoint;
}

/** A request a Modbus device received (`write`: the values written, bits as 0/1). */
export interface ModbusServedRequest {
    txid: number;
    unit: number;
    kind: "coil" | "discrete" | "input" | "holding";
    address: number;
    count: number;
    write: number[] | null;
}

/** What a write means to a device: an actuator commanded or an output set. */
export interface ModbusWritten {
    actuator: number | null;
    output: string | null;
    value: number;
}

/** Registers a device holds: `words` from `address` on, bits as 0/1. */
export interface ModbusImage {
    kind: "coil" | "discrete" | "input" | "holding";
    address: number;
    words: number[];
}
"#;

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct DeviceEndpoint<'a> {
    unit: u8,
    framing: Framing,
    endpoint: &'a Endpoint,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct Served {
    txid: u16,
    unit: u8,
    kind: RegisterKind,
    address: u16,
    count: u16,
    write: Option<Vec<u16>>,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct Written {
    actuator: Option<u32>,
    output: Option<String>,
    value: f64,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct Image {
    kind: RegisterKind,
    address: u16,
    words: Vec<u16>,
}

fn framing(name: &str) -> Result<Framing, JsValue> {
    match name {
        "tcp" => Ok(Framing::Tcp),
        "rtu" => Ok(Framing::Rtu),
        other => Err(js_error(
            Code::InvalidInput,
            &format!("framing must be \"tcp\" or \"rtu\", got '{}'", quote(other)),
        )),
    }
}

fn kind(name: &str) -> Result<RegisterKind, JsValue> {
    RegisterKind::ALL
        .into_iter()
        .find(|k| k.name() == name)
        .ok_or_else(|| {
            js_error(
                Code::InvalidInput,
                &format!("no register kind '{}'", quote(name)),
            )
        })
}

fn refusal(r: sugarshack_core::topics::Refusal) -> JsValue {
    js_error(Code::InvalidInput, &format!("{}: {}", r.reason, r.message))
}

#[wasm_bindgen]
impl DeviceSide {
    /// `{ unit, framing, endpoint }` of a Modbus device, or null for another profile.
    #[wasm_bindgen(js_name = modbusEndpoint, unchecked_return_type = "ModbusDeviceEndpoint | null")]
    pub fn modbus_endpoint(&self, device: u32) -> Result<JsValue, JsValue> {
        let map = self.plant.contract().modbus();
        let d = self.device_id(device)?;
        let found = map.unit(d).map(|u| DeviceEndpoint {
            unit: u.unit,
            framing: map.connections[u.connection].framing,
            endpoint: &map.connections[u.connection].endpoint,
        });
        to_js(&found)
    }

    /// Where the first request in `bytes` ends: its length, 0 while it is
    /// incomplete, or -n when its first n bytes cannot start one.
    #[wasm_bindgen(js_name = modbusScan)]
    pub fn modbus_scan(&self, framing_name: &str, bytes: &[u8]) -> Result<i32, JsValue> {
        Ok(
            match frame::scan(framing(framing_name)?, Side::Requests, bytes) {
                Scan::Need => 0,
                Scan::Frame(n) => n as i32,
                Scan::Skip(n) => -(n as i32),
            },
        )
    }

    /// A request frame as the device reads it; throws `INVALID_INPUT` with the reason it cannot be.
    #[wasm_bindgen(js_name = modbusRequest, unchecked_return_type = "ModbusServedRequest")]
    pub fn modbus_request(&self, framing_name: &str, bytes: &[u8]) -> Result<JsValue, JsValue> {
        let (txid, request) =
            frame::decode_request(framing(framing_name)?, bytes).map_err(refusal)?;
        let kind_of = |f: u8| match f {
            1 | 5 | 15 => RegisterKind::Coil,
            2 => RegisterKind::Discrete,
            4 => RegisterKind::Input,
            _ => RegisterKind::Holding,
        };
        let write = match &request.pdu {
            Pdu::Read { .. } => None,
            Pdu::WriteCoil { on, .. } => Some(vec![u16::from(*on)]),
            Pdu::WriteRegister { value, .. } => Some(vec![*value]),
            Pdu::WriteCoils { bits, .. } => Some(bits.iter().map(|&b| u16::from(b)).collect()),
            Pdu::WriteRegisters { values, .. } => Some(values.clone()),
        };
        to_js(&Served {
            txid,
            unit: request.unit,
            kind: kind_of(request.pdu.function()),
            address: request.pdu.address(),
            count: frame::extent(&request.pdu),
            write,
        })
    }

    /// The device's reply to the request `bytes`: `words` read (bits as 0/1),
    /// the write's echo when neither is given, or `exception`.
    #[wasm_bindgen(js_name = modbusReply)]
    pub fn modbus_reply(
        &self,
        framing_name: &str,
        bytes: &[u8],
        words: Option<Vec<u16>>,
        exception: Option<u8>,
    ) -> Result<Vec<u8>, JsValue> {
        let f = framing(framing_name)?;
        let (txid, request) = frame::decode_request(f, bytes).map_err(refusal)?;
        let reply = match (exception, words, &request.pdu) {
            (Some(code), _, _) => Reply::Exception(code),
            (
                None,
                Some(words),
                Pdu::Read {
                    function: 1 | 2, ..
                },
            ) => Reply::Bits(words.iter().map(|&w| w != 0).collect()),
            (None, Some(words), Pdu::Read { .. }) => Reply::Registers(words),
            _ => Reply::Written,
        };
        Ok(frame::encode_reply(f, txid, &request, &reply))
    }

    /// What a write of `words` from `address` means to device `device`:
    /// `[{ actuator, output, value }]`, one per actuator commanded or output set.
    #[wasm_bindgen(js_name = modbusWritten, unchecked_return_type = "ModbusWritten[]")]
    pub fn modbus_written(
        &self,
        device: u32,
        kind_name: &str,
        address: u16,
        words: &[u16],
    ) -> Result<JsValue, JsValue> {
        let map = self.plant.contract().modbus();
        let read: Vec<Written> = map
            .written(self.device_id(device)?, kind(kind_name)?, address, words)
            .into_iter()
            .map(|(target, value)| match target {
                Target::Output(o) => Written {
                    actuator: None,
                    output: Some(map.outputs[o].id.clone()),
                    value,
                },
                Target::Actuator(a) => Written {
                    actuator: Some(a.index() as u32),
                    output: None,
                    value,
                },
                Target::Sensor(_) => Written {
                    actuator: None,
                    output: None,
                    value,
                },
            })
            .collect();
        to_js(&read)
    }

    /// The registers device `device` holds for its actuators at `values` and
    /// its sensors at `sensorValues` (NaN: no reading): `[{ kind, address, words }]`.
    #[wasm_bindgen(js_name = modbusImage, unchecked_return_type = "ModbusImage[]")]
    pub fn modbus_image(
        &self,
        device: u32,
        actuators: &[u32],
        values: &[f64],
        sensors: &[u32],
        sensor_values: &[f64],
    ) -> Result<JsValue, JsValue> {
        let targets: Vec<(Target, f64)> = actuators
            .iter()
            .zip(values)
            .map(|(&a, &v)| (Target::Actuator(ActuatorId::from_index(a)), v))
            .chain(
                sensors
                    .iter()
                    .zip(sensor_values)
                    .map(|(&s, &v)| (Target::Sensor(SensorId::from_index(s)), v)),
            )
            .collect();
        let image: Vec<Image> = self
            .plant
            .contract()
            .modbus()
            .image(self.device_id(device)?, &targets)
            .into_iter()
            .map(|(kind, address, words)| Image {
                kind,
                address,
                words,
            })
            .collect();
        to_js(&image)
    }
}
