//! Modbus frames, both ways (the Modbus Application Protocol v1.1b3 and the
//! Modbus over Serial Line guide v1.02): the request PDUs this palette sends
//! (FC 1-6, 15, 16), wrapped for TCP (the MBAP header: transaction id,
//! protocol 0, length, unit) or RTU (unit, PDU, CRC-16 low byte first, on a
//! serial line or tunnelled through a TCP gateway), and the replies. The
//! device side (a request read, a reply written) serves the plant simulator.
//!
//! Nothing here trusts its input: every frame either decodes or is refused
//! with a reason, and a stream of any bytes only ever yields frame lengths.

use super::super::Refusal;
use super::Framing;
use crate::text::quote;

/// Most registers one read may ask for (the spec's 125).
pub const MAX_READ_REGISTERS: u16 = 125;
/// Most bits one read may ask for (the spec's 2000).
pub const MAX_READ_BITS: u16 = 2000;
/// Most registers one FC 16 write may carry (the spec's 123).
pub const MAX_WRITE_REGISTERS: u16 = 123;
/// Most bits one FC 15 write may carry (the spec's 1968).
pub const MAX_WRITE_BITS: u16 = 1968;
/// A PDU is at most 253 bytes (the RS-485 ADU's 256 less unit and CRC).
const MAX_PDU: usize = 253;

/// One request PDU.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Pdu {
    /// FC 1, 2, 3 or 4: `count` bits or registers from `address`.
    Read {
        /// 1 coils, 2 discrete inputs, 3 holding registers, 4 input registers.
        function: u8,
        /// The first address.
        address: u16,
        /// How many.
        count: u16,
    },
    /// FC 5.
    WriteCoil {
        /// Its address.
        address: u16,
        /// On (0xFF00) or off (0x0000).
        on: bool,
    },
    /// FC 6.
    WriteRegister {
        /// Its address.
        address: u16,
        /// The value.
        value: u16,
    },
    /// FC 15.
    WriteCoils {
        /// The first address.
        address: u16,
        /// The values, first address first.
        bits: Vec<bool>,
    },
    /// FC 16.
    WriteRegisters {
        /// The first address.
        address: u16,
        /// The values, first address first.
        values: Vec<u16>,
    },
}

impl Pdu {
    /// Its function code.
    pub fn function(&self) -> u8 {
        match self {
            Pdu::Read { function, .. } => *function,
            Pdu::WriteCoil { .. } => 5,
            Pdu::WriteRegister { .. } => 6,
            Pdu::WriteCoils { .. } => 15,
            Pdu::WriteRegisters { .. } => 16,
        }
    }

    /// The first address it touches.
    pub fn address(&self) -> u16 {
        match self {
            Pdu::Read { address, .. }
            | Pdu::WriteCoil { address, .. }
            | Pdu::WriteRegister { address, .. }
            | Pdu::WriteCoils { address, .. }
            | Pdu::WriteRegisters { address, .. } => *address,
        }
    }

    fn bytes(&self) -> Vec<u8> {
        let mut out = vec![self.function()];
        out.extend(self.address().to_be_bytes());
        match self {
            Pdu::Read { count, .. } => out.extend(count.to_be_bytes()),
            Pdu::WriteCoil { on, .. } => out.extend(if *on { [0xFF, 0] } else { [0, 0] }),
            Pdu::WriteRegister { value, .. } => out.extend(value.to_be_bytes()),
            Pdu::WriteCoils { bits, .. } => {
                out.extend((bits.len() as u16).to_be_bytes());
                let packed = pack_bits(bits);
                out.push(packed.len() as u8);
                out.extend(packed);
            }
            Pdu::WriteRegisters { values, .. } => {
                out.extend((values.len() as u16).to_be_bytes());
                out.push((values.len() * 2) as u8);
                for v in values {
                    out.extend(v.to_be_bytes());
                }
            }
        }
        out
    }
}

/// A request to one unit.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Request {
    /// The unit (slave) id.
    pub unit: u8,
    /// What it asks.
    pub pdu: Pdu,
}

/// What a device answered.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Reply {
    /// FC 1 or 2: the bits asked for.
    Bits(Vec<bool>),
    /// FC 3 or 4: the registers asked for.
    Registers(Vec<u16>),
    /// A write was carried out (its echo matched).
    Written,
    /// An exception code instead.
    Exception(u8),
}

/// What a reply is to the request in flight.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Answer {
    /// Its answer.
    Reply(Reply),
    /// Not its answer: a late reply to an earlier request that timed out.
    Foreign,
}

/// What the start of a byte stream holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scan {
    /// Not a whole frame yet.
    Need,
    /// A frame of this many bytes.
    Frame(usize),
    /// This many bytes cannot start a frame: drop them.
    Skip(usize),
}

/// Which way the frames go.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// Requests (the device side reads them).
    Requests,
    /// Replies (the palette reads them).
    Replies,
}

/// The name of an exception code, as the spec has it.
pub fn exception_name(code: u8) -> &'static str {
    match code {
        1 => "illegal function",
        2 => "illegal data address",
        3 => "illegal data value",
        4 => "server device failure",
        5 => "acknowledge",
        6 => "server device busy",
        8 => "memory parity error",
        10 => "gateway path unavailable",
        11 => "gateway target device failed to respond",
        _ => "unknown exception",
    }
}

/// CRC-16/MODBUS (reflected 0xA001, initial 0xFFFF).
pub fn crc16(bytes: &[u8]) -> u16 {
    let mut crc: u16 = 0xFFFF;
    for &b in bytes {
        crc ^= u16::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xA001
            } else {
                crc >> 1
            };
        }
    }
    crc
}

fn pack_bits(bits: &[bool]) -> Vec<u8> {
    let mut out = vec![0u8; bits.len().div_ceil(8)];
    for (i, &b) in bits.iter().enumerate() {
        if b {
            out[i / 8] |= 1 << (i % 8);
        }
    }
    out
}

fn unpack_bits(bytes: &[u8], count: usize) -> Vec<bool> {
    (0..count)
        .map(|i| bytes[i / 8] & (1 << (i % 8)) != 0)
        .collect()
}

fn wrap(framing: Framing, txid: u16, unit: u8, pdu: &[u8]) -> Vec<u8> {
    match framing {
        Framing::Tcp => {
            let mut out = Vec::with_capacity(7 + pdu.len());
            out.extend(txid.to_be_bytes());
            out.extend([0, 0]);
            out.extend(((pdu.len() + 1) as u16).to_be_bytes());
            out.push(unit);
            out.extend(pdu);
            out
        }
        Framing::Rtu => {
            let mut out = Vec::with_capacity(3 + pdu.len());
            out.push(unit);
            out.extend(pdu);
            let crc = crc16(&out);
            out.extend(crc.to_le_bytes());
            out
        }
    }
}

/// The bytes of a request (`txid` only counts for TCP).
pub fn encode_request(framing: Framing, txid: u16, request: &Request) -> Vec<u8> {
    wrap(framing, txid, request.unit, &request.pdu.bytes())
}

/// Where the first frame of `buffer` ends.
pub fn scan(framing: Framing, side: Side, buffer: &[u8]) -> Scan {
    match framing {
        Framing::Tcp => {
            if buffer.len() < 7 {
                return Scan::Need;
            }
            let protocol = u16::from_be_bytes([buffer[2], buffer[3]]);
            let length = usize::from(u16::from_be_bytes([buffer[4], buffer[5]]));
            if protocol != 0 || !(2..=MAX_PDU + 1).contains(&length) {
                return Scan::Skip(1);
            }
            if buffer.len() < 6 + length {
                Scan::Need
            } else {
                Scan::Frame(6 + length)
            }
        }
        Framing::Rtu => {
            if buffer.len() < 2 {
                return Scan::Need;
            }
            let function = buffer[1];
            let counted = |at: usize, extra: usize| {
                if buffer.len() <= at {
                    Scan::Need
                } else {
                    let n = at + 1 + usize::from(buffer[at]) + extra;
                    if buffer.len() < n {
                        Scan::Need
                    } else {
                        Scan::Frame(n)
                    }
                }
            };
            let fixed = |n: usize| {
                if buffer.len() < n {
                    Scan::Need
                } else {
                    Scan::Frame(n)
                }
            };
            match (side, function) {
                (Side::Replies, f) if f & 0x80 != 0 && matches!(f & 0x7F, 1..=6 | 15 | 16) => {
                    fixed(5)
                }
                (Side::Replies, 1..=4) => counted(2, 2),
                (Side::Replies, 5 | 6 | 15 | 16) => fixed(8),
                (Side::Requests, 1..=6) => fixed(8),
                (Side::Requests, 15 | 16) => counted(6, 2),
                _ => Scan::Skip(1),
            }
        }
    }
}

/// The unit and PDU of one whole frame, its transaction id (0 for RTU), or why it is refused.
fn unwrap(framing: Framing, frame: &[u8]) -> Result<(u16, u8, &[u8]), Refusal> {
    match framing {
        Framing::Tcp => {
            if frame.len() < 8 {
                return Err(Refusal::new(
                    "short frame",
                    "an MBAP frame has at least 8 bytes",
                ));
            }
            let length = usize::from(u16::from_be_bytes([frame[4], frame[5]]));
            if frame[2..4] != [0, 0] || length + 6 != frame.len() {
                return Err(Refusal::new(
                    "bad frame",
                    format!(
                        "MBAP header says protocol {} and length {}, frame has {} bytes",
                        u16::from_be_bytes([frame[2], frame[3]]),
                        length,
                        frame.len()
                    ),
                ));
            }
            Ok((
                u16::from_be_bytes([frame[0], frame[1]]),
                frame[6],
                &frame[7..],
            ))
        }
        Framing::Rtu => {
            if frame.len() < 4 {
                return Err(Refusal::new(
                    "short frame",
                    "an RTU frame has at least 4 bytes",
                ));
            }
            let (body, crc) = frame.split_at(frame.len() - 2);
            if crc16(body).to_le_bytes() != [crc[0], crc[1]] {
                return Err(Refusal::new(
                    "bad CRC",
                    format!("CRC {:02X}{:02X} does not match the frame", crc[0], crc[1]),
                ));
            }
            Ok((0, body[0], &body[1..]))
        }
    }
}

fn word(pdu: &[u8], at: usize) -> u16 {
    u16::from_be_bytes([pdu[at], pdu[at + 1]])
}

fn mismatch(what: impl Into<String>) -> Refusal {
    Refusal::new("mismatched reply", what)
}

/// Reads one whole reply frame against the request in flight (sent with `txid`).
pub fn decode_reply(
    framing: Framing,
    frame: &[u8],
    txid: u16,
    request: &Request,
) -> Result<Answer, Refusal> {
    let (got_txid, unit, pdu) = unwrap(framing, frame)?;
    let function = request.pdu.function();
    if pdu.is_empty() {
        return Err(Refusal::new(
            "short frame",
            "a reply without a function code",
        ));
    }
    match framing {
        // A TCP reply names its request; an RTU reply is its request's only by unit and function.
        Framing::Tcp if got_txid != txid => return Ok(Answer::Foreign),
        Framing::Rtu if unit != request.unit || pdu[0] & 0x7F != function => {
            return Ok(Answer::Foreign)
        }
        _ => {}
    }
    if unit != request.unit {
        return Err(mismatch(format!(
            "reply from unit {unit} to a request to unit {}",
            request.unit
        )));
    }
    if pdu[0] == function | 0x80 {
        return match pdu.get(1) {
            Some(&code) if pdu.len() == 2 => Ok(Answer::Reply(Reply::Exception(code))),
            _ => Err(Refusal::new(
                "short frame",
                "an exception reply has one code",
            )),
        };
    }
    if pdu[0] != function {
        return Err(mismatch(format!(
            "reply with function {} to function {function}",
            pdu[0]
        )));
    }
    let reply = match &request.pdu {
        Pdu::Read { count, .. } => {
            let count = usize::from(*count);
            let bits = function <= 2;
            let expected = if bits { count.div_ceil(8) } else { count * 2 };
            let given = pdu.get(1).map(|&n| usize::from(n));
            if given != Some(expected) || pdu.len() != 2 + expected {
                return Err(mismatch(format!(
                    "byte count {} in a {}-byte reply, expected {expected} for {count} {}",
                    given.map_or_else(|| "none".into(), |n| n.to_string()),
                    pdu.len(),
                    if bits { "bits" } else { "registers" }
                )));
            }
            let data = &pdu[2..];
            if bits {
                Reply::Bits(unpack_bits(data, count))
            } else {
                Reply::Registers((0..count).map(|i| word(data, 2 * i)).collect())
            }
        }
        written => {
            let echo = match written {
                Pdu::WriteCoil { address, on } => {
                    let mut e = address.to_be_bytes().to_vec();
                    e.extend(if *on { [0xFF, 0] } else { [0, 0] });
                    e
                }
                Pdu::WriteRegister { address, value } => {
                    [address.to_be_bytes(), value.to_be_bytes()].concat()
                }
                Pdu::WriteCoils { address, bits } => {
                    [address.to_be_bytes(), (bits.len() as u16).to_be_bytes()].concat()
                }
                Pdu::WriteRegisters { address, values } => {
                    [address.to_be_bytes(), (values.len() as u16).to_be_bytes()].concat()
                }
                Pdu::Read { .. } => unreachable!("matched above"),
            };
            if pdu[1..] != echo[..] {
                return Err(mismatch(format!(
                    "the write's echo {} differs from the request {}",
                    quote(hex(&pdu[1..])),
                    hex(&echo)
                )));
            }
            Reply::Written
        }
    };
    Ok(Answer::Reply(reply))
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02X}")).collect()
}

/// Reads one whole request frame, as a device does: its transaction id (0 for RTU) and request.
pub fn decode_request(framing: Framing, frame: &[u8]) -> Result<(u16, Request), Refusal> {
    let (txid, unit, pdu) = unwrap(framing, frame)?;
    let bad = |why: &str| Refusal::new("bad request", why.to_owned());
    if pdu.len() < 5 {
        return Err(bad(
            "a request has a function, an address and a count or value",
        ));
    }
    let function = pdu[0];
    let address = word(pdu, 1);
    let n = word(pdu, 3);
    let body = match function {
        1..=4 => {
            let max = if function <= 2 {
                MAX_READ_BITS
            } else {
                MAX_READ_REGISTERS
            };
            if pdu.len() != 5 || n == 0 || n > max {
                return Err(bad("a read asks for 1 to 2000 bits or 1 to 125 registers"));
            }
            Pdu::Read {
                function,
                address,
                count: n,
            }
        }
        5 => match (pdu.len(), n) {
            (5, 0xFF00) => Pdu::WriteCoil { address, on: true },
            (5, 0) => Pdu::WriteCoil { address, on: false },
            _ => return Err(bad("a coil is written 0xFF00 or 0x0000")),
        },
        6 if pdu.len() == 5 => Pdu::WriteRegister { address, value: n },
        15 | 16 => {
            let bytes = pdu.get(5).map_or(0, |&b| usize::from(b));
            let expected = if function == 15 {
                usize::from(n).div_ceil(8)
            } else {
                usize::from(n) * 2
            };
            let max = if function == 15 {
                MAX_WRITE_BITS
            } else {
                MAX_WRITE_REGISTERS
            };
            if n == 0 || n > max || bytes != expected || pdu.len() != 6 + bytes {
                return Err(bad("the write's count and byte count do not agree"));
            }
            let data = &pdu[6..];
            if function == 15 {
                Pdu::WriteCoils {
                    address,
                    bits: unpack_bits(data, usize::from(n)),
                }
            } else {
                Pdu::WriteRegisters {
                    address,
                    values: (0..usize::from(n)).map(|i| word(data, 2 * i)).collect(),
                }
            }
        }
        _ => return Err(bad("unsupported function")),
    };
    if u32::from(address) + u32::from(extent(&body)) > 0x1_0000 {
        return Err(bad("the request runs past address 65535"));
    }
    Ok((txid, Request { unit, pdu: body }))
}

/// How many addresses a request spans.
pub fn extent(pdu: &Pdu) -> u16 {
    match pdu {
        Pdu::Read { count, .. } => *count,
        Pdu::WriteCoil { .. } | Pdu::WriteRegister { .. } => 1,
        Pdu::WriteCoils { bits, .. } => bits.len() as u16,
        Pdu::WriteRegisters { values, .. } => values.len() as u16,
    }
}

/// The bytes of a device's reply to `request` (read with `txid`).
pub fn encode_reply(framing: Framing, txid: u16, request: &Request, reply: &Reply) -> Vec<u8> {
    let function = request.pdu.function();
    let pdu = match reply {
        Reply::Exception(code) => vec![function | 0x80, *code],
        Reply::Bits(bits) => {
            let packed = pack_bits(bits);
            let mut out = vec![function, packed.len() as u8];
            out.extend(packed);
            out
        }
        Reply::Registers(values) => {
            let mut out = vec![function, (values.len() * 2) as u8];
            for v in values {
                out.extend(v.to_be_bytes());
            }
            out
        }
        // A single write is echoed whole; a multiple one as address and count.
        Reply::Written => match &request.pdu {
            Pdu::WriteCoil { .. } | Pdu::WriteRegister { .. } => request.pdu.bytes(),
            other => {
                let mut out = vec![function];
                out.extend(other.address().to_be_bytes());
                out.extend(extent(other).to_be_bytes());
                out
            }
        },
    };
    wrap(framing, txid, request.unit, &pdu)
}
