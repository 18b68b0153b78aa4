//! The tracker's Modbus connections as JS drives them: JS owns the sockets
//! (or serial ports) and one timer per connection; it says what happened
//! (opened, bytes, closed, the time) and writes what `modbusNext` returns.
//! The core's link decides what to send and when a device is offline; its
//! events become the tracker's feedback, sensor values and device status.

use sugarshack_core::actuator::{DeviceId, Effect};
use sugarshack_core::code::Code;
use sugarshack_core::text::quote;
use sugarshack_core::time::Millis;
use sugarshack_core::topics::modbus::link::Event;
use wasm_bindgen::prelude::*;

use crate::tracker::Tracker;
use crate::{js_error, time, to_js};

/// The TypeScript shapes of what this module's calls return and take
/// (`unchecked_return_type` / `unchecked_param_type` name them).
#[wasm_bindgen(typescript_custom_section)]
const TS_SHAPES: &str = r#"
/** Where a Modbus connection goes. */
export type ModbusEndpoint =
    | { kind: "tcp"; host: string; port: number }
    | { kind: "serial"; path: string; baudRate: number; parity: "none" | "even" | "odd"; dataBits: number; stopBits: number };

/** One connection the palette keeps open (a gateway's units share one). */
export interface ModbusConnection {
    key: string;
    framing: "tcp" | "rtu";
    endpoint: ModbusEndpoint;
    reconnectMs: number;
    /** Device handles. */
    devices: number[];
}
"#;

impl Tracker {
    fn connection(&self, connection: u32) -> Result<usize, JsValue> {
        let c = connection as usize;
        if c < self.links.len() {
            Ok(c)
        } else {
            Err(js_error(
                Code::InvalidInput,
                &format!("no Modbus connection #{connection}"),
            ))
        }
    }

    /// What the link's events mean to the tracker: feedback and sensor values,
    /// refusals, devices offline or back.
    fn link_events(&mut self, events: Vec<Event>, now: Millis) -> Result<u32, JsValue> {
        for event in events {
            match event {
                Event::Block {
                    device,
                    block,
                    words,
                    round_trip,
                } => {
                    let mut readings = std::mem::take(&mut self.readings);
                    self.core
                        .contract()
                        .modbus()
                        .read(device, block, &words, &mut readings);
                    self.readings = readings;
                    self.last_device = Some(device.index() as u32);
                    self.last_round_trip = Some(round_trip.as_f64());
                    self.apply(device, None, now);
                }
                Event::Written { .. } => {}
                Event::Refused { device, refusal } => {
                    self.last_device = Some(device.index() as u32);
                    self.refused(device, refusal);
                }
                Event::Status { device, online } => {
                    let effects = self
                        .core
                        .device_status(device, online, now)
                        .map_err(|e| js_error(e.code(), &e.to_string()))?;
                    self.queue(effects);
                }
            }
        }
        Ok(self.queued())
    }
}

#[wasm_bindgen]
impl Tracker {
    /// `[{ key, framing, endpoint, reconnectMs, devices }]`: the connections
    /// to open, in handle order (none without Modbus devices).
    #[wasm_bindgen(js_name = modbusConnections, unchecked_return_type = "ModbusConnection[]")]
    pub fn modbus_connections(&self) -> Result<JsValue, JsValue> {
        to_js(&self.core.contract().modbus().connections)
    }

    /// Connection `connection` is up: its units are polled from now.
    #[wasm_bindgen(js_name = modbusOpened)]
    pub fn modbus_opened(&mut self, connection: u32, now_ms: f64) -> Result<(), JsValue> {
        let c = self.connection(connection)?;
        self.links.opened(c, time(now_ms)?);
        Ok(())
    }

    /// Connection `connection` is lost or could not be made: its devices are
    /// offline at once (their commands fail). Returns how many effects are queued.
    #[wasm_bindgen(js_name = modbusClosed)]
    pub fn modbus_closed(&mut self, connection: u32, now_ms: f64) -> Result<u32, JsValue> {
        let c = self.connection(connection)?;
        let now = time(now_ms)?;
        self.forget_last();
        let mut events = Vec::new();
        self.links.closed(c, &mut events);
        self.link_events(events, now)
    }

    /// Bytes from connection `connection`: the answers in them are applied
    /// (`lastDevice`, `lastSensors`, `lastRoundTripMs` tell what the last one
    /// read). Returns how many effects are queued.
    #[wasm_bindgen(js_name = modbusReceive)]
    pub fn modbus_receive(
        &mut self,
        connection: u32,
        bytes: &[u8],
        now_ms: f64,
    ) -> Result<u32, JsValue> {
        let c = self.connection(connection)?;
        let now = time(now_ms)?;
        self.forget_last();
        let mut events = Vec::new();
        self.links.receive(c, bytes, now, &mut events);
        self.link_events(events, now)
    }

    /// The time has come (see `modbusWake`): a request past its timeout is
    /// given up. Returns how many effects are queued.
    #[wasm_bindgen(js_name = modbusTimeout)]
    pub fn modbus_timeout(&mut self, connection: u32, now_ms: f64) -> Result<u32, JsValue> {
        let c = self.connection(connection)?;
        let now = time(now_ms)?;
        self.forget_last();
        let mut events = Vec::new();
        self.links.timeout(c, now, &mut events);
        self.link_events(events, now)
    }

    /// The bytes to write on connection `connection` now, if a request is due
    /// and none is in flight.
    #[wasm_bindgen(js_name = modbusNext)]
    pub fn modbus_next(
        &mut self,
        connection: u32,
        now_ms: f64,
    ) -> Result<Option<Vec<u8>>, JsValue> {
        let c = self.connection(connection)?;
        Ok(self.links.next(c, time(now_ms)?))
    }

    /// When to call `modbusTimeout` then `modbusNext` for `connection` again
    /// (epoch ms; 0 for now), or undefined while it is closed.
    #[wasm_bindgen(js_name = modbusWake)]
    pub fn modbus_wake(&self, connection: u32) -> Result<Option<f64>, JsValue> {
        let c = self.connection(connection)?;
        Ok(self.links.wake(c).map(Millis::as_f64))
    }

    /// The device whose request is in flight on `connection`, if any.
    #[wasm_bindgen(js_name = modbusInFlight)]
    pub fn modbus_in_flight(&self, connection: u32) -> Result<Option<u32>, JsValue> {
        let c = self.connection(connection)?;
        Ok(self.links.in_flight(c).map(|d| d.index() as u32))
    }

    /// The round trip of the poll the last `modbusReceive` read, in ms.
    #[wasm_bindgen(js_name = lastRoundTripMs)]
    pub fn last_round_trip_ms(&self) -> Option<f64> {
        self.last_round_trip
    }

    /// Writes `value` to Modbus output `id`, untracked (a control loop's
    /// action). Throws `UNKNOWN_OUTPUT`, `INVALID_TARGET` (outside its scale)
    /// or `DEVICE_OFFLINE` (its connection is down). Returns how many effects are queued.
    pub fn output(&mut self, id: &str, value: f64, now_ms: f64) -> Result<u32, JsValue> {
        time(now_ms)?;
        let (device, request) =
            self.core
                .contract()
                .modbus()
                .output(id, value)
                .map_err(|refusal| {
                    let code = if refusal.reason == "unknown output" {
                        Code::UnknownOutput
                    } else {
                        Code::InvalidTarget
                    };
                    js_error(code, &refusal.message)
                })?;
        let open = self
            .links
            .connection_of(device)
            .is_some_and(|c| self.links.is_open(c));
        if !open {
            return Err(self.offline(device, id));
        }
        Ok(self.queue([Effect::Write { device, request }]))
    }
}

impl Tracker {
    fn offline(&self, device: DeviceId, output: &str) -> JsValue {
        js_error(
            Code::DeviceOffline,
            &format!(
                "output {} not written: the connection to device '{}' is down",
                quote(output),
                quote(self.core.device_name(device).unwrap_or_default())
            ),
        )
    }
}
