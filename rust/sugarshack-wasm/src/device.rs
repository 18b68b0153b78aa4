//! The device's side of the MQTT contract, for simulators and test devices:
//! the messages a device of the plant publishes, and the commands it reads,
//! exactly as the palette's topics module expects them.

use serde::Serialize;
use sugarshack_core::actuator::{ActuatorId, DeviceId};
use sugarshack_core::code::Code;
use sugarshack_core::plant::Plant;
use sugarshack_core::sensor::SensorId;
use sugarshack_core::time::Millis;
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
