use serde::Serialize;
use sugarshack_core::actuator::{ActuatorId, DeviceId, Effect, TrackError};
use sugarshack_core::plant::{PlantModel, Signal};
use sugarshack_core::sensor::{SensorError, SensorId, SensorStore};
use wasm_bindgen::prelude::*;

use crate::operation::OperationRun;
use crate::routine::Routine;
use crate::{from_js_bounded, js_error, time, to_js, Bound};
use sugarshack_core::text::quote;

fn sensor_error(err: SensorError) -> JsValue {
    js_error(err.code(), &err.to_string())
}

fn track_error(err: TrackError) -> JsValue {
    js_error(err.code(), &err.to_string())
}

/// What the tracker asks JS to do, plus feedback samples it refused.
#[derive(Serialize)]
#[serde(untagged)]
enum Output {
    Effect(Effect),
    #[serde(rename_all = "camelCase")]
    Rejected {
        kind: &'static str,
        actuator: u32,
        code: &'static str,
        message: String,
    },
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct ActuatorView<'a> {
    handle: u32,
    id: &'a str,
    #[serde(rename = "type")]
    kind: &'a str,
    device: &'a str,
    io: Option<u32>,
    binary: bool,
    idle: Option<f64>,
    lockout: f64,
}

/// The plant as JS sees it: actuator tracking, live sensor values, and the
/// operations and routines of its document. Calls queue their effects;
/// `takeEffects` returns them, so a feedback batch that changes nothing costs
/// no allocation.
#[wasm_bindgen]
pub struct Tracker {
    core: sugarshack_core::actuator::Tracker,
    sensors: SensorStore,
    effects: Vec<Output>,
    scratch: Vec<Effect>,
    batch: Vec<(ActuatorId, f64)>,
}

impl Tracker {
    fn actuator_id(&self, handle: u32) -> Result<ActuatorId, JsValue> {
        let id = ActuatorId::from_index(handle);
        self.core.actuator_name(id).map(|_| id).ok_or_else(|| {
            track_error(TrackError::UnknownActuator {
                name: format!("#{handle}"),
            })
        })
    }

    fn device_id(&self, handle: u32) -> Result<DeviceId, JsValue> {
        let id = DeviceId::from_index(handle);
        self.core.device_name(id).map(|_| id).ok_or_else(|| {
            track_error(TrackError::UnknownDevice {
                name: format!("#{handle}"),
            })
        })
    }

    fn queue(&mut self, effects: impl IntoIterator<Item = Effect>) -> u32 {
        self.effects.extend(effects.into_iter().map(Output::Effect));
        self.effects.len() as u32
    }
}

fn device_ts(ts: Option<f64>) -> Option<u64> {
    ts.filter(|t| t.is_finite() && *t >= 0.0).map(|t| t as u64)
}

#[wasm_bindgen]
impl Tracker {
    /// `plant`: the plant document. Refused with every problem listed (code `INVALID_PLANT`).
    #[wasm_bindgen(constructor)]
    pub fn new(plant: JsValue, now_ms: f64) -> Result<Tracker, JsValue> {
        let plant: PlantModel = from_js_bounded(
            plant,
            "INVALID_PLANT",
            "invalid plant document",
            Bound::PlantDocument,
        )?;
        let core = sugarshack_core::actuator::Tracker::new(plant, time(now_ms)?)
            .map_err(|errors| js_error("INVALID_PLANT", &errors.to_string()))?;
        Ok(Tracker {
            sensors: SensorStore::new(core.plant()),
            core,
            effects: Vec::new(),
            scratch: Vec::new(),
            batch: Vec::new(),
        })
    }

    /// What the plant document holds that is legal but probably unintended (duplicate priorities...).
    pub fn warnings(&self) -> Vec<String> {
        self.core
            .plant()
            .validate()
            .map(|warnings| warnings.iter().map(ToString::to_string).collect())
            .unwrap_or_default()
    }

    pub fn actuator(&self, name: &str) -> Result<u32, JsValue> {
        self.core
            .actuator(name)
            .map(|id| id.index() as u32)
            .map_err(track_error)
    }

    pub fn device(&self, name: &str) -> Result<u32, JsValue> {
        self.core
            .device(name)
            .map(|id| id.index() as u32)
            .map_err(track_error)
    }

    /// The actuator a device reports as `<type>` number `io`, if the plant names one.
    pub fn slot(&self, device: u32, kind: &str, io: u32) -> Option<u32> {
        self.core
            .slot(DeviceId::from_index(device), kind, io)
            .map(|id| id.index() as u32)
    }

    /// Every actuator: `[{ handle, id, type, device, io, binary, idle, lockout }]`.
    pub fn actuators(&self) -> Result<JsValue, JsValue> {
        let views: Vec<ActuatorView> = self
            .core
            .plant()
            .actuators
            .iter()
            .enumerate()
            .map(|(i, a)| {
                let id = ActuatorId::from_index(i as u32);
                ActuatorView {
                    handle: i as u32,
                    id: &a.id,
                    kind: &a.kind,
                    device: &a.device,
                    io: a.io,
                    binary: self.core.signal(id) == Some(Signal::Binary),
                    idle: self.core.idle_state(id),
                    lockout: self.core.lockout_state(id).unwrap_or_default(),
                }
            })
            .collect();
        to_js(&views)
    }

    /// Device ids in handle order.
    pub fn devices(&self) -> Vec<String> {
        self.core
            .plant()
            .devices
            .iter()
            .map(|d| d.id.clone())
            .collect()
    }

    /// Issues a group command (`{"valves": {"V12": 100}, "pumps": {"P1": true}}`), all or
    /// nothing; returns how many effects are queued. A refusal throws and sends nothing.
    /// `within`: the resources the commanding operation holds (C2), if it is one.
    /// A normal command to an actuator whose lockout is unconfirmed throws `LOCKOUT_PENDING`.
    pub fn command(
        &mut self,
        payload: JsValue,
        caller: u32,
        lockout: bool,
        now_ms: f64,
        within: Option<Vec<String>>,
    ) -> Result<u32, JsValue> {
        let now = time(now_ms)?;
        let payload: serde_json::Value = from_js_bounded(
            payload,
            "INVALID_GROUP",
            "invalid group command",
            Bound::GroupCommand,
        )?;
        let targets = self.core.parse_group(&payload).map_err(track_error)?;
        if let Some(held) = within {
            self.core
                .check_within(&targets, &held)
                .map_err(track_error)?;
        }
        let effects = self
            .core
            .command(&targets, u64::from(caller), lockout, now)
            .map_err(track_error)?;
        Ok(self.queue(effects))
    }

    /// Stops waiting for a caller's group (its msg timed out, or its node closed);
    /// an unconfirmed lockout stays standing.
    pub fn withdraw(&mut self, caller: u32) -> bool {
        self.core.withdraw(u64::from(caller))
    }

    /// One sample; `ts` is the device's timestamp (ms), if it sent one. A `ts`
    /// more than the plant's `clockSkewMs` ahead of `nowMs` throws `FUTURE_TIMESTAMP`.
    pub fn feedback(
        &mut self,
        actuator: u32,
        value: f64,
        ts: Option<f64>,
        now_ms: f64,
    ) -> Result<u32, JsValue> {
        let id = self.actuator_id(actuator)?;
        let effects = self
            .core
            .feedback(id, value, device_ts(ts), time(now_ms)?)
            .map_err(track_error)?;
        Ok(self.queue(effects))
    }

    /// A device batch as parallel arrays of actuator handles and values. Refused
    /// samples are queued as `{ kind: "rejected", actuator, code, message }`.
    /// A batch stamped too far in the future throws `FUTURE_TIMESTAMP`, nothing applied.
    #[wasm_bindgen(js_name = feedbackBatch)]
    pub fn feedback_batch(
        &mut self,
        actuators: &[u32],
        values: &[f64],
        ts: Option<f64>,
        now_ms: f64,
    ) -> Result<u32, JsValue> {
        let now = time(now_ms)?;
        if actuators.len() != values.len() {
            return Err(js_error(
                "INVALID_FEEDBACK",
                "a batch needs as many values as actuators",
            ));
        }
        self.batch.clear();
        for (&handle, &value) in actuators.iter().zip(values) {
            self.batch.push((self.actuator_id(handle)?, value));
        }
        let mut effects = std::mem::take(&mut self.scratch);
        let outcome = self
            .core
            .feedback_batch(&self.batch, device_ts(ts), now, &mut effects);
        self.effects.extend(effects.drain(..).map(Output::Effect));
        self.scratch = effects;
        for (id, err) in outcome.map_err(track_error)? {
            self.effects.push(Output::Rejected {
                kind: "rejected",
                actuator: id.index() as u32,
                code: err.code(),
                message: err.to_string(),
            });
        }
        Ok(self.effects.len() as u32)
    }

    /// A device's availability (its retained status or last will).
    #[wasm_bindgen(js_name = deviceStatus)]
    pub fn device_status(
        &mut self,
        device: u32,
        online: bool,
        now_ms: f64,
    ) -> Result<u32, JsValue> {
        let id = self.device_id(device)?;
        let effects = self
            .core
            .device_status(id, online, time(now_ms)?)
            .map_err(track_error)?;
        Ok(self.queue(effects))
    }

    /// The MQTT connection is back: every commanded state is published again
    /// and running commands get a fresh window; returns how many effects are queued.
    #[wasm_bindgen(js_name = pathRestored)]
    pub fn path_restored(&mut self, now_ms: f64) -> Result<u32, JsValue> {
        let effects = self.core.path_restored(time(now_ms)?);
        Ok(self.queue(effects))
    }

    /// Checks every threshold; returns how many effects are queued.
    pub fn tick(&mut self, now_ms: f64) -> Result<u32, JsValue> {
        let effects = self.core.tick(time(now_ms)?);
        Ok(self.queue(effects))
    }

    /// The queued effects, oldest first, as plain objects with a `kind`.
    #[wasm_bindgen(js_name = takeEffects)]
    pub fn take_effects(&mut self) -> Result<JsValue, JsValue> {
        let out = to_js(&self.effects);
        self.effects.clear();
        out
    }

    /// `{ moving, stopped, faulted, lockoutsPending }`.
    pub fn counts(&self) -> Result<JsValue, JsValue> {
        to_js(&self.core.counts())
    }

    /// Lockouts feedback has not confirmed yet: `[{ actuator, target, sinceMs, sends }]`
    /// (`actuator` a handle, `target` a number, 0/1 for binary), in handle order.
    #[wasm_bindgen(js_name = pendingLockouts)]
    pub fn pending_lockouts(&self) -> Result<JsValue, JsValue> {
        to_js(&self.core.pending_lockouts())
    }

    /// `idle`, `pending`, `moving`, `stopped` or `faulted`.
    pub fn phase(&self, actuator: u32) -> Result<String, JsValue> {
        let phase = self
            .core
            .phase(self.actuator_id(actuator)?)
            .expect("checked handle");
        Ok(serde_json::to_value(phase)
            .ok()
            .and_then(|v| v.as_str().map(str::to_owned))
            .unwrap_or_default())
    }

    pub fn position(&self, actuator: u32) -> Option<f64> {
        self.core.position(ActuatorId::from_index(actuator))
    }

    // ---- operations and routines -------------------------------------------

    /// The plan of an operation: `{ id, priority, resources, steps: [{ kind, ... }] }`,
    /// its last step returning every commanded actuator to idle.
    #[wasm_bindgen(js_name = operationPlan)]
    pub fn operation_plan(&self, id: &str) -> Result<JsValue, JsValue> {
        let plan = self.core.plant().operation_plan(id).ok_or_else(|| {
            js_error(
                "UNKNOWN_OPERATION",
                &format!(
                    "unknown operation '{}': it is not in the plant document",
                    quote(id)
                ),
            )
        })?;
        to_js(&plan)
    }

    /// `[{ name, lockout }]`: the plant's resources as an interlock configures them.
    #[wasm_bindgen(js_name = interlockResources)]
    pub fn interlock_resources(&self) -> Result<JsValue, JsValue> {
        to_js(&self.core.plant().interlock_config().resources)
    }

    /// A run of operation `id` of this plant, not started.
    #[wasm_bindgen(js_name = operationRun)]
    pub fn operation_run(&self, id: &str) -> Result<OperationRun, JsValue> {
        OperationRun::of(self.core.plant(), id)
    }

    /// Routine `id` of this plant, in its initial state.
    pub fn routine(&self, id: &str) -> Result<Routine, JsValue> {
        Routine::of(self.core.plant(), id)
    }

    // ---- sensors ---------------------------------------------------------------

    pub fn sensor(&self, name: &str) -> Result<u32, JsValue> {
        self.sensors
            .sensor(name)
            .map(|id| id.index() as u32)
            .map_err(sensor_error)
    }

    /// The sensor a device publishes as datapoint `name`, if the plant names one.
    #[wasm_bindgen(js_name = sensorSlot)]
    pub fn sensor_slot(&self, device: &str, name: &str) -> Option<u32> {
        self.sensors.slot(device, name).map(|id| id.index() as u32)
    }

    fn sensor_id(&self, handle: u32) -> Result<SensorId, JsValue> {
        if (handle as usize) < self.sensors.len() {
            Ok(SensorId::from_index(handle))
        } else {
            Err(sensor_error(SensorError::UnknownSensor {
                name: format!("#{handle}"),
            }))
        }
    }

    /// Keeps a sample in place of the last one received (`ts`: the device's
    /// timestamp, else the reception time): true. Throws `FUTURE_TIMESTAMP`,
    /// keeping nothing, when `ts` is further ahead of `now` than the plant's
    /// `clockSkewMs`.
    #[wasm_bindgen(js_name = recordSensor)]
    pub fn record_sensor(
        &mut self,
        sensor: u32,
        value: f64,
        ts: Option<f64>,
        now_ms: f64,
    ) -> Result<bool, JsValue> {
        let now = time(now_ms)?;
        let id = self.sensor_id(sensor)?;
        self.sensors
            .record(id, value, device_ts(ts).unwrap_or(now), now)
            .map_err(sensor_error)?;
        Ok(true)
    }

    /// The values of `sensors` if every one is fresh; else throws `SENSOR_STALE` or `SENSOR_NO_VALUE`.
    #[wasm_bindgen(js_name = readSensors)]
    pub fn read_sensors(&self, sensors: &[u32], now_ms: f64) -> Result<Vec<f64>, JsValue> {
        let now = time(now_ms)?;
        let ids = sensors
            .iter()
            .map(|&h| self.sensor_id(h))
            .collect::<Result<Vec<_>, _>>()?;
        self.sensors.read(&ids, now).map_err(sensor_error)
    }
}
