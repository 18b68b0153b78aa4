//! The `modbus` profile: devices reached over Modbus TCP, or RTU on a serial
//! line or through a TCP gateway, polled by the palette. Per device its
//! endpoint, unit id, polling period and timeout; per actuator the coil or
//! holding register it is commanded through and the register it reports on;
//! per sensor the register it is read from; each value with its type, word
//! order and scaling. From this one description the core plans the reads
//! (contiguous registers of one kind in one request), formats commands into
//! writes, reads register blocks into feedback, and runs each connection's
//! transactions ([`link`]); the palette's JS only moves the bytes.
//!
//! | kind | holds | read | written | for |
//! |---|---|---|---|---|
//! | `coil` | one bit | FC 1 | FC 5 | a binary actuator's command or feedback, a binary sensor |
//! | `discrete` | one bit | FC 2 | no | a binary actuator's feedback, a binary sensor |
//! | `input` | 16-bit words | FC 4 | no | an analog actuator's feedback, a sensor |
//! | `holding` | 16-bit words | FC 3 | FC 6 (one word), FC 16 (two) | any command, feedback or sensor |
//!
//! ```json
//! { "id": "io-1", "kind": "actuator-panel", "profile": "modbus",
//!   "modbus": { "host": "10.0.0.21", "port": 502, "unit": 1, "pollMs": 500, "timeoutMs": 300 } }
//! { "id": "V101", "type": "valve", "device": "io-1", "lockout": 0, "modbus": {
//!     "command":  { "kind": "holding", "address": 0, "scale": { "raw": [4000, 20000], "value": [0, 100] } },
//!     "feedback": { "kind": "input", "address": 0, "scale": { "raw": [4000, 20000], "value": [0, 100] } } } }
//! ```

pub mod frame;
pub mod link;
mod value;

use std::collections::HashMap;

use serde::{Deserialize, Serialize};

pub(crate) use value::{Codec, Read};
pub use value::{RegisterKind, Scale, ValueType, WordOrder};

use self::frame::{Pdu, Request, MAX_READ_BITS, MAX_READ_REGISTERS};
use super::{actuator_path, device_path, sensor_path, Builder, Reading, Readings, Refusal};
use crate::actuator::{ActuatorId, DeviceId};
use crate::plant::{PlantModel, Profile, Signal};
use crate::sensor::SensorId;
use crate::text::quote;
use crate::time::{ms, Millis};

/// How often a device is polled unless it says.
pub const DEFAULT_POLL_MS: Millis = ms(1000);
/// How long a request may go unanswered unless the device says.
pub const DEFAULT_TIMEOUT_MS: Millis = ms(1000);
/// How long after a lost connection the palette connects again unless the device says.
pub const DEFAULT_RECONNECT_MS: Millis = ms(2000);
/// Requests in a row without an answer before a device is offline, unless it says.
pub const DEFAULT_OFFLINE_AFTER: u32 = 2;

/// How requests are framed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "kebab-case")]
pub enum Framing {
    /// Modbus TCP: the MBAP header (the default with a `host`).
    Tcp,
    /// RTU: unit, PDU, CRC; on a `serial` line, or raw through a TCP gateway.
    Rtu,
}

impl Framing {
    /// Its name in the plant document.
    pub fn name(self) -> &'static str {
        match self {
            Framing::Tcp => "tcp",
            Framing::Rtu => "rtu",
        }
    }
}

/// Parity of a serial line.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "kebab-case")]
pub enum Parity {
    /// No parity bit (the default: most devices ship 8N1).
    #[default]
    None,
    /// Even parity (the Modbus serial guide's default).
    Even,
    /// Odd parity.
    Odd,
}

/// An RS-485 (or RS-232) line the palette drives itself.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct SerialLine {
    /// The port: `/dev/ttyUSB0`, `COM3`.
    pub path: String,
    /// Bits per second (default 9600).
    #[serde(default = "default_baud_rate")]
    pub baud_rate: u32,
    /// Parity (default none).
    #[serde(default)]
    pub parity: Parity,
    /// 7 or 8 (default 8).
    #[serde(default = "default_data_bits")]
    pub data_bits: u8,
    /// 1 or 2 (default 1).
    #[serde(default = "default_stop_bits")]
    pub stop_bits: u8,
}

fn default_baud_rate() -> u32 {
    9600
}
fn default_data_bits() -> u8 {
    8
}
fn default_stop_bits() -> u8 {
    1
}

/// A device's `modbus`: where it is and how it is polled.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct ModbusDevice {
    /// Its address on the network (or its gateway's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub host: Option<String>,
    /// Its TCP port (default 502).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub port: Option<u16>,
    /// A serial line instead of a host.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub serial: Option<SerialLine>,
    /// `tcp` (the default with a host) or `rtu` (on a serial line, or RTU frames through a gateway).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub framing: Option<Framing>,
    /// Its unit (slave) id: 1-247 on RTU; 0-255 on TCP, where a device that is no gateway often ignores it.
    pub unit: u8,
    /// How often its registers are read (default 1000).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub poll_ms: Option<Millis>,
    /// How long a request may go unanswered (default 1000).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub timeout_ms: Option<Millis>,
    /// How long after a lost connection to connect again (default 2000).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reconnect_ms: Option<Millis>,
    /// Requests in a row without an answer before it is offline (default 2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offline_after: Option<u32>,
    /// Its 32-bit values' word order unless a register says (default `high-first`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub word_order: Option<WordOrder>,
    /// Registers written as given, untracked: a control loop's outputs (`output/<id>` msgs).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub outputs: Vec<ModbusOutput>,
}

/// One value on a device: its kind and address, how its words read, and its scaling.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct ModbusRegister {
    /// `coil`, `discrete`, `input` or `holding`.
    pub kind: RegisterKind,
    /// Its address, 0-65535 (the PDU address: register 40001 is holding 0).
    pub address: u16,
    /// A register's number type (default `u16`); none for a bit.
    #[serde(default, rename = "type", skip_serializing_if = "Option::is_none")]
    pub value_type: Option<ValueType>,
    /// Overrides the device's word order for this 32-bit value.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub word_order: Option<WordOrder>,
    /// Raw range to engineering range.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<Scale>,
}

/// An actuator's `modbus`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct ModbusActuator {
    /// The coil or holding register it is commanded through.
    pub command: ModbusRegister,
    /// The register it reports on; without one, the command register is read back.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub feedback: Option<ModbusRegister>,
}

/// A named output of a device, written untracked (a pid's action).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct ModbusOutput {
    /// Its id, unique among the plant's outputs: `output/<id>` writes it.
    pub id: String,
    /// `coil` or `holding`.
    pub kind: RegisterKind,
    /// Its address.
    pub address: u16,
    /// A register's number type (default `u16`).
    #[serde(default, rename = "type", skip_serializing_if = "Option::is_none")]
    pub value_type: Option<ValueType>,
    /// Overrides the device's word order.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub word_order: Option<WordOrder>,
    /// Raw range to engineering range.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<Scale>,
}

impl ModbusOutput {
    fn register(&self) -> ModbusRegister {
        ModbusRegister {
            kind: self.kind,
            address: self.address,
            value_type: self.value_type,
            word_order: self.word_order,
            scale: self.scale,
        }
    }
}

/// Where a connection goes.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase", tag = "kind")]
pub enum Endpoint {
    /// A TCP socket.
    Tcp {
        /// Host name or address.
        host: String,
        /// Port.
        port: u16,
    },
    /// A serial port.
    Serial(SerialLine),
}

/// One connection the palette keeps open, shared by the devices on it (a gateway's units).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Connection {
    /// `tcp://host:port`, `rtu+tcp://host:port` or `rtu:/dev/ttyUSB0`.
    pub key: String,
    /// How its frames are built.
    pub framing: Framing,
    /// Where it goes.
    pub endpoint: Endpoint,
    /// How long after losing it to connect again (the shortest of its devices').
    pub reconnect_ms: Millis,
    /// Its devices.
    pub devices: Vec<DeviceId>,
}

/// Registers of one kind read in one request, and what each value in it is.
#[derive(Clone, Debug, PartialEq)]
pub struct Block {
    /// Their kind.
    pub kind: RegisterKind,
    /// The first address.
    pub address: u16,
    /// How many registers (or bits).
    pub count: u16,
    entries: Vec<Entry>,
}

impl Block {
    /// The request that reads it.
    pub fn request(&self, unit: u8) -> Request {
        Request {
            unit,
            pdu: Pdu::Read {
                function: self.kind.read_function(),
                address: self.address,
                count: self.count,
            },
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
struct Entry {
    offset: u16,
    target: Target,
    codec: Codec,
}

/// What a value of a device is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    /// An actuator's feedback.
    Actuator(ActuatorId),
    /// A sensor.
    Sensor(SensorId),
    /// An output, by its index in [`ModbusMap::outputs`].
    Output(usize),
}

/// A Modbus device of the plant, as polled.
#[derive(Clone, Debug, PartialEq)]
pub struct Unit {
    /// Its connection, an index in [`ModbusMap::connections`].
    pub connection: usize,
    /// Its unit id.
    pub unit: u8,
    /// Its polling period.
    pub poll_ms: Millis,
    /// How long a request may go unanswered.
    pub timeout_ms: Millis,
    /// Requests in a row without an answer before it is offline.
    pub offline_after: u32,
    /// What one poll reads, in order.
    pub blocks: Vec<Block>,
    /// The values it holds that a client may write (device side): each entry's
    /// `offset` is its address.
    writes: Vec<Entry>,
}

/// A named output.
#[derive(Clone, Debug, PartialEq)]
pub struct Output {
    /// Its id.
    pub id: String,
    /// Its device.
    pub device: DeviceId,
    address: u16,
    codec: Codec,
}

/// Every Modbus device, actuator, sensor and output of one plant, checked and planned.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ModbusMap {
    /// The connections, in the order of their first device.
    pub connections: Vec<Connection>,
    /// Per device of the plant (by index): its polling plan, if it speaks Modbus.
    pub units: Vec<Option<Unit>>,
    /// Per actuator of the plant: its device and command register, if it is on a Modbus device.
    commands: Vec<Option<(DeviceId, u16, Codec)>>,
    /// The outputs.
    pub outputs: Vec<Output>,
}

/// A register claimed by an entry, for the overlap check.
struct Claim {
    kind: RegisterKind,
    start: u32,
    end: u32,
    path: String,
    /// The actuator it belongs to: its command may be its own feedback.
    owner: Option<ActuatorId>,
}

/// An actuator's or sensor's `modbus` section: there exactly when its device speaks Modbus.
fn modbus_section<'a, T>(
    section: Option<&'a T>,
    on_modbus: bool,
    path: &str,
    things: &str,
    missing: &str,
    b: &mut Builder,
) -> Option<&'a T> {
    match (section, on_modbus) {
        (Some(_), false) => {
            b.error(
                path,
                format!("'modbus' is for {things} on devices with profile \"modbus\""),
            );
            None
        }
        (None, true) => {
            b.error(path, missing);
            None
        }
        (section, _) => section,
    }
}

fn path_at(base: &str, field: &str) -> String {
    format!("{base}.modbus.{field}")
}

/// Checks one register's description; its codec when it can be used.
fn codec(
    r: &ModbusRegister,
    device_order: WordOrder,
    signal: Option<Signal>,
    at: &str,
    b: &mut Builder,
) -> Option<Codec> {
    let before = b.errors.len();
    if r.kind.is_bit() && (r.value_type.is_some() || r.scale.is_some()) {
        b.error(
            at,
            format!("a {} is one bit: it has no type or scale", r.kind.name()),
        );
    }
    if r.kind.is_bit() && signal == Some(Signal::Analog) {
        b.error(
            at,
            format!(
                "a {} carries on/off: an analog actuator needs a holding register (or an input register for feedback)",
                r.kind.name()
            ),
        );
    }
    if signal == Some(Signal::Binary) && r.scale.is_some() {
        b.error(
            at,
            "a binary actuator's register holds 0 or 1: it takes no scale",
        );
    }
    let value_type = r.value_type.unwrap_or_default();
    if let Some(why) = r.scale.and_then(|s| s.problem()) {
        b.error(at, why);
    } else if let Some(scale) = r.scale {
        let (low, high) = value_type.bounds();
        if scale.raw.iter().any(|raw| *raw < low || *raw > high) {
            b.error(
                at,
                format!(
                    "scale.raw [{}, {}] does not fit a {} register ({}..{})",
                    quote(scale.raw[0]),
                    quote(scale.raw[1]),
                    value_type.name(),
                    quote(low),
                    quote(high)
                ),
            );
        }
    }
    let width = if r.kind.is_bit() {
        1
    } else {
        u32::from(value_type.words())
    };
    if u32::from(r.address) + width > 0x1_0000 {
        b.error(
            at,
            format!(
                "a {width}-register value at {} runs past address 65535",
                r.address
            ),
        );
    }
    (b.errors.len() == before).then_some(Codec {
        kind: r.kind,
        value_type,
        order: r.word_order.unwrap_or(device_order),
        scale: r.scale,
        binary: signal == Some(Signal::Binary),
    })
}

/// The connection key and endpoint of a device's `modbus`, or why it has none.
fn endpoint(m: &ModbusDevice) -> Result<(String, Framing, Endpoint), String> {
    match (&m.host, &m.serial) {
        (Some(_), Some(_)) => Err("give either 'host' or 'serial', not both".into()),
        (None, None) => Err("a modbus device needs a 'host' (TCP) or a 'serial' line".into()),
        (Some(host), None) => {
            if host.trim().is_empty() || host.chars().any(char::is_whitespace) {
                return Err(format!(
                    "host '{}' is not a host name or address",
                    quote(host)
                ));
            }
            let port = m.port.unwrap_or(502);
            if port == 0 {
                return Err("port must be 1-65535".into());
            }
            let framing = m.framing.unwrap_or(Framing::Tcp);
            let scheme = match framing {
                Framing::Tcp => "tcp",
                Framing::Rtu => "rtu+tcp",
            };
            Ok((
                format!("{scheme}://{host}:{port}"),
                framing,
                Endpoint::Tcp {
                    host: host.clone(),
                    port,
                },
            ))
        }
        (None, Some(line)) => {
            if m.port.is_some() {
                return Err("'port' is for a TCP host, not a serial line".into());
            }
            if m.framing == Some(Framing::Tcp) {
                return Err("a serial line carries RTU frames: framing must be \"rtu\"".into());
            }
            if line.path.trim().is_empty() {
                return Err("serial.path names the port, e.g. \"/dev/ttyUSB0\"".into());
            }
            if line.baud_rate == 0
                || !(7..=8).contains(&line.data_bits)
                || !(1..=2).contains(&line.stop_bits)
            {
                return Err("serial needs baudRate > 0, dataBits 7 or 8, stopBits 1 or 2".into());
            }
            Ok((
                format!("rtu:{}", line.path),
                Framing::Rtu,
                Endpoint::Serial(line.clone()),
            ))
        }
    }
}

/// Contiguous entries of one kind, in requests the spec allows.
fn plan_blocks(mut entries: Vec<(RegisterKind, u16, Entry)>) -> Vec<Block> {
    entries.sort_by_key(|(kind, address, _)| (*kind, *address));
    let mut blocks: Vec<Block> = Vec::new();
    for (kind, address, mut entry) in entries {
        let width = entry.codec.width();
        let max = if kind.is_bit() {
            MAX_READ_BITS
        } else {
            MAX_READ_REGISTERS
        };
        if let Some(block) = blocks.last_mut().filter(|bl| {
            bl.kind == kind
                && u32::from(bl.address) + u32::from(bl.count) == u32::from(address)
                && bl.count + width <= max
        }) {
            entry.offset = block.count;
            block.count += width;
            block.entries.push(entry);
            continue;
        }
        entry.offset = 0;
        blocks.push(Block {
            kind,
            address,
            count: width,
            entries: vec![entry],
        });
    }
    blocks
}

impl ModbusMap {
    /// Checks and plans the Modbus side of a plant; each problem is an error at its entry's path.
    pub(crate) fn new(
        plant: &PlantModel,
        device_index: &HashMap<&str, DeviceId>,
        b: &mut Builder,
    ) -> ModbusMap {
        let mut map = ModbusMap {
            units: vec![None; plant.devices.len()],
            commands: vec![None; plant.actuators.len()],
            ..ModbusMap::default()
        };
        let mut keys: HashMap<String, usize> = HashMap::new();
        let mut unit_ids: HashMap<(usize, u8), String> = HashMap::new();
        let mut claims: Vec<Vec<Claim>> = (0..plant.devices.len()).map(|_| Vec::new()).collect();
        let mut reads: Vec<Vec<(RegisterKind, u16, Entry)>> = vec![Vec::new(); plant.devices.len()];
        let mut served: Vec<Vec<Entry>> = vec![Vec::new(); plant.devices.len()];
        let mut orders = vec![WordOrder::default(); plant.devices.len()];

        for (i, d) in plant.devices.iter().enumerate() {
            let path = device_path(i, &d.id);
            let m = match (&d.modbus, d.profile) {
                (Some(_), p) if p != Profile::Modbus => {
                    b.error(&path, "'modbus' is for devices with profile \"modbus\"");
                    continue;
                }
                (None, Profile::Modbus) => {
                    b.error(
                        &path,
                        "a modbus device needs 'modbus': its host (or serial line) and unit",
                    );
                    continue;
                }
                (Some(m), _) => m,
                (None, _) => continue,
            };
            let at = format!("{path}.modbus");
            let (key, framing, endpoint) = match endpoint(m) {
                Ok(found) => found,
                Err(why) => {
                    b.error(&at, why);
                    continue;
                }
            };
            if framing == Framing::Rtu && !(1..=247).contains(&m.unit) {
                b.error(
                    &at,
                    format!("unit {} is not an RTU address (1-247)", m.unit),
                );
            }
            let poll_ms = m.poll_ms.unwrap_or(DEFAULT_POLL_MS);
            let timeout_ms = m.timeout_ms.unwrap_or(DEFAULT_TIMEOUT_MS);
            let reconnect_ms = m.reconnect_ms.unwrap_or(DEFAULT_RECONNECT_MS);
            for (field, value) in [
                ("pollMs", poll_ms),
                ("timeoutMs", timeout_ms),
                ("reconnectMs", reconnect_ms),
            ] {
                if value == Millis::ZERO {
                    b.error(&at, format!("{field} must be positive"));
                }
            }
            if m.offline_after == Some(0) {
                b.error(&at, "offlineAfter must be at least 1");
            }
            // The same host and port, or the same port name, is one connection.
            let connection = match keys.get(&key) {
                Some(&c) => {
                    let other = &map.connections[c];
                    let same_line = match (&other.endpoint, &endpoint) {
                        (Endpoint::Serial(a), Endpoint::Serial(b)) => a == b,
                        _ => true,
                    };
                    if !same_line {
                        b.error(
                            &at,
                            format!(
                                "serial line '{}' is also device '{}''s, with other settings",
                                quote(&key),
                                quote(&plant.devices[other.devices[0].index()].id)
                            ),
                        );
                    }
                    let conn = &mut map.connections[c];
                    conn.reconnect_ms = conn.reconnect_ms.min(reconnect_ms);
                    conn.devices.push(DeviceId::from_index(i as u32));
                    c
                }
                None => {
                    // One host and port takes one framing.
                    let host_port = key.split_once("://").map(|(_, rest)| rest.to_owned());
                    if let Some(hp) = host_port {
                        if let Some(other) = map.connections.iter().find(|c| {
                            c.key.split_once("://").map(|(_, rest)| rest) == Some(hp.as_str())
                        }) {
                            b.error(
                                &at,
                                format!(
                                    "{} is also device '{}''s, framed {}",
                                    quote(&hp),
                                    quote(&plant.devices[other.devices[0].index()].id),
                                    other.framing.name()
                                ),
                            );
                        }
                    }
                    keys.insert(key.clone(), map.connections.len());
                    map.connections.push(Connection {
                        key: key.clone(),
                        framing,
                        endpoint,
                        reconnect_ms,
                        devices: vec![DeviceId::from_index(i as u32)],
                    });
                    map.connections.len() - 1
                }
            };
            if let Some(other) = unit_ids.insert((connection, m.unit), d.id.clone()) {
                b.error(
                    &at,
                    format!(
                        "unit {} on {} is also device '{}''s",
                        m.unit,
                        quote(&key),
                        quote(&other)
                    ),
                );
            }
            orders[i] = m.word_order.unwrap_or_default();
            map.units[i] = Some(Unit {
                connection,
                unit: m.unit,
                poll_ms,
                timeout_ms,
                offline_after: m.offline_after.unwrap_or(DEFAULT_OFFLINE_AFTER).max(1),
                blocks: Vec::new(),
                writes: Vec::new(),
            });
            let mut ids: HashMap<&str, ()> = HashMap::new();
            for (o, out) in m.outputs.iter().enumerate() {
                let at = format!("{path}.modbus.outputs[{o}] ({})", quote(&out.id));
                if out.id.trim().is_empty() {
                    b.error(&at, "an output needs an id");
                }
                if map.outputs.iter().any(|x| x.id == out.id) || ids.insert(&out.id, ()).is_some() {
                    b.error(&at, format!("output id '{}' is used twice", quote(&out.id)));
                }
                if !out.kind.is_writable() {
                    b.error(&at, "an output is a coil or a holding register");
                    continue;
                }
                let r = out.register();
                let Some(codec) = codec(&r, orders[i], None, &at, b) else {
                    continue;
                };
                let target = Target::Output(map.outputs.len());
                claims[i].push(claim(&r, &codec, &at, None));
                served[i].push(Entry {
                    offset: r.address,
                    target,
                    codec,
                });
                map.outputs.push(Output {
                    id: out.id.clone(),
                    device: DeviceId::from_index(i as u32),
                    address: r.address,
                    codec,
                });
            }
        }

        for (i, a) in plant.actuators.iter().enumerate() {
            let path = actuator_path(i, &a.id);
            let Some(&device) = device_index.get(a.device.as_str()) else {
                continue;
            };
            let on_modbus = plant.devices[device.index()].profile == Profile::Modbus;
            let Some(m) = modbus_section(
                a.modbus.as_ref(),
                on_modbus,
                &path,
                "actuators",
                "an actuator on a modbus device needs 'modbus': the register it is commanded through (and read from)",
                b,
            ) else {
                continue;
            };
            let Some(t) = plant.actuator_types.get(&a.kind) else {
                continue;
            };
            if map.units[device.index()].is_none() {
                continue;
            }
            let order = orders[device.index()];
            let id = ActuatorId::from_index(i as u32);
            let at = path_at(&path, "command");
            if !m.command.kind.is_writable() {
                b.error(
                    &at,
                    format!(
                        "a {} cannot be written: command through a coil or a holding register",
                        m.command.kind.name()
                    ),
                );
                continue;
            }
            let Some(command) = codec(&m.command, order, Some(t.signal), &at, b) else {
                continue;
            };
            let range = t.range(a.tolerance);
            let (low, high) = command.value_bounds();
            if t.signal == Signal::Analog && !(range.min >= low && range.max <= high) {
                b.error(
                    &at,
                    format!(
                        "the type's range {}..{} must map into the register, which holds {}..{}",
                        quote(range.min),
                        quote(range.max),
                        quote(low),
                        quote(high)
                    ),
                );
                continue;
            }
            let (feedback, feedback_at) = match &m.feedback {
                Some(r) => {
                    let at = path_at(&path, "feedback");
                    match codec(r, order, Some(t.signal), &at, b) {
                        Some(c) => ((r.clone(), c), at),
                        None => continue,
                    }
                }
                None => ((m.command.clone(), command), at.clone()),
            };
            claims[device.index()].push(claim(&m.command, &command, &at, Some(id)));
            if m.feedback.is_some() {
                claims[device.index()].push(claim(
                    &feedback.0,
                    &feedback.1,
                    &feedback_at,
                    Some(id),
                ));
            }
            map.commands[i] = Some((device, m.command.address, command));
            served[device.index()].push(Entry {
                offset: m.command.address,
                target: Target::Actuator(id),
                codec: command,
            });
            reads[device.index()].push((
                feedback.0.kind,
                feedback.0.address,
                Entry {
                    offset: 0,
                    target: Target::Actuator(id),
                    codec: feedback.1,
                },
            ));
        }

        for (i, s) in plant.sensors.iter().enumerate() {
            let path = sensor_path(i, &s.id);
            let Some(&device) = device_index.get(s.device.as_str()) else {
                continue;
            };
            let on_modbus = plant.devices[device.index()].profile == Profile::Modbus;
            let Some(r) = modbus_section(
                s.modbus.as_ref(),
                on_modbus,
                &path,
                "sensors",
                "a sensor on a modbus device needs 'modbus': the register it is read from",
                b,
            ) else {
                continue;
            };
            if map.units[device.index()].is_none() {
                continue;
            }
            let at = format!("{path}.modbus");
            let Some(c) = codec(r, orders[device.index()], None, &at, b) else {
                continue;
            };
            claims[device.index()].push(claim(r, &c, &at, None));
            let target = Target::Sensor(SensorId::from_index(i as u32));
            reads[device.index()].push((
                r.kind,
                r.address,
                Entry {
                    offset: 0,
                    target,
                    codec: c,
                },
            ));
        }

        for device_claims in &mut claims {
            overlaps(device_claims, b);
        }
        for (i, unit) in map.units.iter_mut().enumerate() {
            if let Some(unit) = unit {
                unit.blocks = plan_blocks(std::mem::take(&mut reads[i]));
                unit.writes = std::mem::take(&mut served[i]);
            }
        }
        map
    }

    /// Whether device `device` speaks Modbus.
    pub fn is_modbus(&self, device: DeviceId) -> bool {
        self.unit(device).is_some()
    }

    /// The polling plan of a Modbus device.
    pub fn unit(&self, device: DeviceId) -> Option<&Unit> {
        self.units.get(device.index()).and_then(Option::as_ref)
    }

    /// The write that commands actuator `id` to `target` (a target of its range), if it is on a Modbus device.
    pub fn command(&self, id: ActuatorId, target: f64) -> Option<(DeviceId, Request)> {
        let (device, address, codec) = self.commands.get(id.index())?.as_ref()?;
        let request = self.write_request(*device, *address, codec, target).ok()?;
        Some((*device, request))
    }

    /// The write that sets output `id` to `value`, or why it cannot be written.
    pub fn output(&self, id: &str, value: f64) -> Result<(DeviceId, Request), Refusal> {
        let output = self.outputs.iter().find(|o| o.id == id).ok_or_else(|| {
            Refusal::new(
                "unknown output",
                format!("no modbus output '{}' in the plant document", quote(id)),
            )
        })?;
        let (low, high) = output.codec.value_bounds();
        if !(value >= low && value <= high) {
            return Err(Refusal::new(
                "out of range",
                format!(
                    "output {} takes {}..{}, got {}",
                    quote(id),
                    quote(low),
                    quote(high),
                    quote(value)
                ),
            ));
        }
        let request = self.write_request(output.device, output.address, &output.codec, value)?;
        Ok((output.device, request))
    }

    fn write_request(
        &self,
        device: DeviceId,
        address: u16,
        codec: &Codec,
        value: f64,
    ) -> Result<Request, Refusal> {
        let unit = self.unit(device).map_or(0, |u| u.unit);
        let words = codec.encode(value)?;
        let pdu = match (codec.kind, words.as_slice()) {
            (RegisterKind::Coil, [bit]) => Pdu::WriteCoil {
                address,
                on: *bit != 0,
            },
            (_, [one]) => Pdu::WriteRegister {
                address,
                value: *one,
            },
            _ => Pdu::WriteRegisters {
                address,
                values: words,
            },
        };
        Ok(Request { unit, pdu })
    }

    /// Reads block `block` of `device` (its words, or its bits as 0 and 1) into `out`.
    pub fn read(&self, device: DeviceId, block: usize, words: &[u16], out: &mut Readings) {
        out.clear();
        let Some(block) = self.unit(device).and_then(|u| u.blocks.get(block)) else {
            return;
        };
        if words.len() != usize::from(block.count) {
            out.refusals.push(Refusal::new(
                "short block",
                format!(
                    "{} values where {} {} from {} were asked for",
                    words.len(),
                    block.count,
                    block.kind.name(),
                    block.address
                ),
            ));
            return;
        }
        for entry in &block.entries {
            let at = usize::from(entry.offset);
            let slice = &words[at..at + usize::from(entry.codec.width())];
            match (entry.codec.decode(slice), entry.target) {
                (Ok(Read::Value(v)), Target::Actuator(a)) => {
                    out.samples.push(Reading::Actuator(a, v))
                }
                (Ok(Read::Value(v)), Target::Sensor(s)) => out.samples.push(Reading::Sensor(s, v)),
                (Ok(Read::Unavailable), Target::Sensor(s)) => {
                    out.samples.push(Reading::SensorUnavailable(s))
                }
                (Ok(Read::Unavailable), _) => out.refusals.push(Refusal::new(
                    "no reading",
                    "the device holds NaN for an actuator",
                )),
                (Err(refusal), _) => out.refusals.push(Refusal {
                    message: format!(
                        "{} {}: {}",
                        block.kind.name(),
                        block.address + entry.offset,
                        refusal.message
                    ),
                    ..refusal
                }),
                (Ok(_), Target::Output(_)) => {}
            }
        }
    }

    // ---- the device's side -----------------------------------------------

    /// What a device holds for its actuators and sensors at `values`: (kind, address, words).
    pub fn image(
        &self,
        device: DeviceId,
        values: &[(Target, f64)],
    ) -> Vec<(RegisterKind, u16, Vec<u16>)> {
        let Some(unit) = self.unit(device) else {
            return Vec::new();
        };
        let mut out = Vec::new();
        for &(target, value) in values {
            for block in &unit.blocks {
                for e in block.entries.iter().filter(|e| e.target == target) {
                    let words = match e.codec.encode(value) {
                        Ok(words) => words,
                        // NaN on a float input: what a device shows without a reading.
                        Err(_)
                            if e.codec.value_type == ValueType::F32 && !e.codec.kind.is_bit() =>
                        {
                            e.codec.split(f32::NAN.to_bits())
                        }
                        Err(_) => continue,
                    };
                    out.push((block.kind, block.address + e.offset, words));
                }
            }
        }
        out
    }

    /// What a write to `device` means to it: each actuator commanded or output set, with its value.
    pub fn written(
        &self,
        device: DeviceId,
        kind: RegisterKind,
        address: u16,
        words: &[u16],
    ) -> Vec<(Target, f64)> {
        let Some(unit) = self.unit(device) else {
            return Vec::new();
        };
        let mut out = Vec::new();
        for e in unit.writes.iter().filter(|e| e.codec.kind == kind) {
            let Some(at) = e.offset.checked_sub(address).map(usize::from) else {
                continue;
            };
            let width = usize::from(e.codec.width());
            if at + width > words.len() {
                continue;
            }
            if let Ok(Read::Value(v)) = e.codec.decode(&words[at..at + width]) {
                out.push((e.target, v));
            }
        }
        out
    }
}

fn claim(r: &ModbusRegister, c: &Codec, path: &str, owner: Option<ActuatorId>) -> Claim {
    Claim {
        kind: r.kind,
        start: u32::from(r.address),
        end: u32::from(r.address) + u32::from(c.width()),
        path: path.to_owned(),
        owner,
    }
}

/// Two entries on one register: an error at the later one, naming the first.
fn overlaps(claims: &mut [Claim], b: &mut Builder) {
    for j in 1..claims.len() {
        for i in 0..j {
            let (x, y) = (&claims[i], &claims[j]);
            let same_owner =
                x.owner.is_some() && x.owner == y.owner && x.start == y.start && x.end == y.end;
            if x.kind == y.kind && x.start < y.end && y.start < x.end && !same_owner {
                b.error(
                    &y.path,
                    format!(
                        "{} {}..{} overlaps {}, which uses {} {}..{}",
                        y.kind.name(),
                        y.start,
                        y.end - 1,
                        x.path,
                        x.kind.name(),
                        x.start,
                        x.end - 1
                    ),
                );
                break;
            }
        }
    }
}

#[cfg(test)]
mod tests;
