//! The palette's Modbus connections without the I/O: what to send next on
//! each one, what the bytes that came back mean, and when a device is
//! offline. The caller owns the sockets and one timer per connection; it
//! hands in what happened (opened, bytes, closed, the time) and sends what
//! [`Links::next`] returns.
//!
//! One request is in flight per connection (a gateway's RS-485 bus carries
//! one at a time, and so do most TCP devices). Writes go before polls, so a
//! command waits at most for the request in flight: a unit that never
//! answers delays another unit's command by no more than its own timeout.
//! Polls go by due time, so every unit of a shared connection keeps its turn.
//!
//! A device is offline once its connection is lost, or after `offlineAfter`
//! requests in a row without a usable answer (timeouts, a gateway's "target
//! failed to respond", frames that cannot be read); any answer, an exception
//! included, brings it back.

use std::collections::VecDeque;

use super::frame::{self, Answer, Reply, Request, Scan, Side};
use super::{Framing, ModbusMap, Refusal};
use crate::actuator::DeviceId;
use crate::time::Millis;

/// A receive buffer never holds more than this: two of the largest frames.
const MAX_BUFFER: usize = 2 * 260;

/// What a connection's traffic meant.
#[derive(Clone, Debug, PartialEq)]
pub enum Event {
    /// A poll's registers (bits as 0 and 1), block `block` of the device's plan.
    Block {
        /// The device.
        device: DeviceId,
        /// Which block of its plan.
        block: usize,
        /// Its values.
        words: Vec<u16>,
        /// From the request leaving to its answer.
        round_trip: Millis,
    },
    /// A write was carried out.
    Written {
        /// The device.
        device: DeviceId,
        /// From the request leaving to its answer.
        round_trip: Millis,
    },
    /// An answer that could not be used (an exception, a garbled frame).
    Refused {
        /// The device.
        device: DeviceId,
        /// Why.
        refusal: Refusal,
    },
    /// The device went offline or came back.
    Status {
        /// The device.
        device: DeviceId,
        /// Whether it is online now.
        online: bool,
    },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Job {
    Poll(usize),
    Write,
}

#[derive(Clone, Debug)]
struct InFlight {
    device: DeviceId,
    job: Job,
    txid: u16,
    request: Request,
    sent: Millis,
    deadline: Millis,
}

#[derive(Clone, Debug)]
struct Conn {
    framing: Framing,
    open: bool,
    buffer: Vec<u8>,
    in_flight: Option<InFlight>,
    writes: VecDeque<(DeviceId, Request)>,
    txid: u16,
    devices: Vec<DeviceId>,
}

#[derive(Clone, Debug)]
struct UnitState {
    connection: usize,
    poll_ms: Millis,
    timeout_ms: Millis,
    offline_after: u32,
    blocks: Vec<Request>,
    failures: u32,
    online: bool,
    next_block: usize,
    cycle_start: Millis,
    due: Millis,
}

/// Every Modbus connection of one plant.
#[derive(Clone, Debug, Default)]
pub struct Links {
    conns: Vec<Conn>,
    units: Vec<Option<UnitState>>,
}

impl Links {
    /// The links of a planned plant, every connection closed, every unit due at `now`.
    pub fn new(map: &ModbusMap, now: Millis) -> Links {
        Links {
            conns: map
                .connections
                .iter()
                .map(|c| Conn {
                    framing: c.framing,
                    open: false,
                    buffer: Vec::new(),
                    in_flight: None,
                    writes: VecDeque::new(),
                    txid: 0,
                    devices: c.devices.clone(),
                })
                .collect(),
            units: map
                .units
                .iter()
                .map(|u| {
                    u.as_ref().map(|u| UnitState {
                        connection: u.connection,
                        poll_ms: u.poll_ms,
                        timeout_ms: u.timeout_ms,
                        offline_after: u.offline_after,
                        blocks: u.blocks.iter().map(|b| b.request(u.unit)).collect(),
                        failures: 0,
                        online: true,
                        next_block: 0,
                        cycle_start: now,
                        due: now,
                    })
                })
                .collect(),
        }
    }

    /// How many connections there are.
    pub fn len(&self) -> usize {
        self.conns.len()
    }

    /// Whether the plant has no Modbus connection.
    pub fn is_empty(&self) -> bool {
        self.conns.is_empty()
    }

    /// The connection of a Modbus device.
    pub fn connection_of(&self, device: DeviceId) -> Option<usize> {
        self.unit(device).map(|u| u.connection)
    }

    /// Whether `connection` is up.
    pub fn is_open(&self, connection: usize) -> bool {
        self.conns.get(connection).is_some_and(|c| c.open)
    }

    /// The device whose request is in flight on `connection`, if any.
    pub fn in_flight(&self, connection: usize) -> Option<DeviceId> {
        self.conns
            .get(connection)?
            .in_flight
            .as_ref()
            .map(|f| f.device)
    }

    fn unit(&self, device: DeviceId) -> Option<&UnitState> {
        self.units.get(device.index())?.as_ref()
    }

    /// The connection is up: its units are polled at once.
    pub fn opened(&mut self, connection: usize, now: Millis) {
        let Some(conn) = self.conns.get_mut(connection) else {
            return;
        };
        conn.open = true;
        conn.buffer.clear();
        conn.in_flight = None;
        for &d in &conn.devices {
            if let Some(u) = self.units[d.index()].as_mut() {
                u.next_block = 0;
                u.due = now;
            }
        }
    }

    /// The connection is lost (or could not be made): its devices are offline
    /// at once, and what waited to be written is dropped (the tracker writes
    /// commanded states and lockouts again when a device comes back).
    pub fn closed(&mut self, connection: usize, out: &mut Vec<Event>) {
        let Some(conn) = self.conns.get_mut(connection) else {
            return;
        };
        conn.open = false;
        conn.buffer.clear();
        conn.in_flight = None;
        conn.writes.clear();
        for &d in &conn.devices {
            if let Some(u) = self.units[d.index()].as_mut() {
                u.failures = u.offline_after;
                if u.online {
                    u.online = false;
                    out.push(Event::Status {
                        device: d,
                        online: false,
                    });
                }
            }
        }
    }

    /// Queues a write for `device`; a queued write to the same place is replaced.
    /// Returns its connection, or None when it is closed (the write is dropped).
    pub fn enqueue(&mut self, device: DeviceId, request: Request) -> Option<usize> {
        let connection = self.unit(device)?.connection;
        let conn = &mut self.conns[connection];
        if !conn.open {
            return None;
        }
        let same = |(d, r): &(DeviceId, Request)| {
            *d == device
                && r.pdu.function() == request.pdu.function()
                && r.pdu.address() == request.pdu.address()
        };
        match conn.writes.iter_mut().find(|w| same(w)) {
            Some(queued) => queued.1 = request,
            None => conn.writes.push_back((device, request)),
        }
        Some(connection)
    }

    /// The next request to send on `connection` now, if one is due and none is in flight.
    pub fn next(&mut self, connection: usize, now: Millis) -> Option<Vec<u8>> {
        let conn = self.conns.get(connection)?;
        if !conn.open || conn.in_flight.is_some() {
            return None;
        }
        let (device, job, request) =
            if let Some((device, request)) = self.conns[connection].writes.pop_front() {
                (device, Job::Write, request)
            } else {
                let device = self.due_unit(connection, now)?;
                let u = self.units[device.index()].as_mut().expect("due unit");
                if u.next_block == 0 {
                    u.cycle_start = now;
                }
                (
                    device,
                    Job::Poll(u.next_block),
                    u.blocks[u.next_block].clone(),
                )
            };
        let timeout = self.unit(device).map_or(Millis::ZERO, |u| u.timeout_ms);
        let conn = &mut self.conns[connection];
        conn.txid = conn.txid.wrapping_add(1);
        let bytes = frame::encode_request(conn.framing, conn.txid, &request);
        conn.in_flight = Some(InFlight {
            device,
            job,
            txid: conn.txid,
            request,
            sent: now,
            deadline: now.saturating_add(timeout),
        });
        Some(bytes)
    }

    /// The unit on `connection` whose poll is due first, if any is due by `now`.
    fn due_unit(&self, connection: usize, now: Millis) -> Option<DeviceId> {
        self.conns[connection]
            .devices
            .iter()
            .filter_map(|&d| self.unit(d).map(|u| (d, u)))
            .filter(|(_, u)| !u.blocks.is_empty() && u.due <= now)
            .min_by_key(|(d, u)| (u.due, d.index()))
            .map(|(d, _)| d)
    }

    /// When to call [`Links::timeout`] and [`Links::next`] again for `connection`:
    /// the deadline of the request in flight, else the next poll (or now, with a write waiting).
    pub fn wake(&self, connection: usize) -> Option<Millis> {
        let conn = self.conns.get(connection)?;
        if !conn.open {
            return None;
        }
        if let Some(f) = &conn.in_flight {
            return Some(f.deadline);
        }
        if !conn.writes.is_empty() {
            return Some(Millis::ZERO);
        }
        conn.devices
            .iter()
            .filter_map(|&d| self.unit(d))
            .filter(|u| !u.blocks.is_empty())
            .map(|u| u.due)
            .min()
    }

    /// Bytes from `connection`: every whole frame in them is read against the request in flight.
    pub fn receive(&mut self, connection: usize, bytes: &[u8], now: Millis, out: &mut Vec<Event>) {
        let Some(conn) = self.conns.get_mut(connection) else {
            return;
        };
        if !conn.open {
            return;
        }
        conn.buffer.extend_from_slice(bytes);
        if conn.buffer.len() > MAX_BUFFER {
            let excess = conn.buffer.len() - MAX_BUFFER;
            conn.buffer.drain(..excess);
        }
        loop {
            let conn = &mut self.conns[connection];
            let length = match frame::scan(conn.framing, Side::Replies, &conn.buffer) {
                Scan::Need => return,
                Scan::Skip(n) => {
                    conn.buffer.drain(..n);
                    continue;
                }
                Scan::Frame(n) => n,
            };
            let Some(f) = conn.in_flight.as_ref() else {
                // Nothing asked: a late reply to a request that timed out.
                conn.buffer.drain(..length);
                continue;
            };
            let decoded =
                frame::decode_reply(conn.framing, &conn.buffer[..length], f.txid, &f.request);
            match decoded {
                // A serial stream out of step: look for a frame one byte further.
                Err(r) if conn.framing == Framing::Rtu && r.reason == "bad CRC" => {
                    conn.buffer.drain(..1);
                    continue;
                }
                Ok(Answer::Foreign) => {
                    conn.buffer.drain(..length);
                    continue;
                }
                _ => {}
            }
            conn.buffer.drain(..length);
            let f = conn.in_flight.take().expect("checked above");
            let round_trip = now.saturating_sub(f.sent);
            match decoded {
                Ok(Answer::Reply(reply)) => self.answered(f, reply, round_trip, out),
                Err(refusal) => {
                    out.push(Event::Refused {
                        device: f.device,
                        refusal,
                    });
                    self.failed(f, out);
                }
                Ok(Answer::Foreign) => unreachable!("skipped above"),
            }
        }
    }

    /// Gives up on the request in flight once its deadline has come.
    pub fn timeout(&mut self, connection: usize, now: Millis, out: &mut Vec<Event>) {
        let Some(conn) = self.conns.get_mut(connection) else {
            return;
        };
        if conn.in_flight.as_ref().is_none_or(|f| now < f.deadline) {
            return;
        }
        let f = conn.in_flight.take().expect("checked above");
        if conn.framing == Framing::Rtu {
            // Whatever part of a reply came is no start for the next one.
            conn.buffer.clear();
        }
        self.failed(f, out);
    }

    fn answered(&mut self, f: InFlight, reply: Reply, round_trip: Millis, out: &mut Vec<Event>) {
        let device = f.device;
        let words = match reply {
            // "Gateway path unavailable" and "target failed to respond": the unit did not answer.
            Reply::Exception(code @ (10 | 11)) => {
                out.push(Event::Refused {
                    device,
                    refusal: exception(&f.request, code),
                });
                self.failed(f, out);
                return;
            }
            Reply::Exception(code) => {
                out.push(Event::Refused {
                    device,
                    refusal: exception(&f.request, code),
                });
                None
            }
            Reply::Bits(bits) => Some(bits.into_iter().map(u16::from).collect()),
            Reply::Registers(words) => Some(words),
            Reply::Written => {
                out.push(Event::Written { device, round_trip });
                None
            }
        };
        let u = self.units[device.index()]
            .as_mut()
            .expect("a unit's request");
        u.failures = 0;
        if !u.online {
            u.online = true;
            out.push(Event::Status {
                device,
                online: true,
            });
        }
        if let Job::Poll(block) = f.job {
            if let Some(words) = words {
                out.push(Event::Block {
                    device,
                    block,
                    words,
                    round_trip,
                });
            }
            advance(u, block + 1);
        }
    }

    fn failed(&mut self, f: InFlight, out: &mut Vec<Event>) {
        let u = self.units[f.device.index()]
            .as_mut()
            .expect("a unit's request");
        u.failures = u.failures.saturating_add(1);
        if u.online && u.failures >= u.offline_after {
            u.online = false;
            out.push(Event::Status {
                device: f.device,
                online: false,
            });
        }
        // A poll that failed ends its cycle: the next blocks would wait as long.
        if let Job::Poll(_) = f.job {
            advance(u, u.blocks.len());
        }
    }
}

/// The unit's next block, or its next cycle after its polling period.
fn advance(u: &mut UnitState, next: usize) {
    if next < u.blocks.len() {
        u.next_block = next;
    } else {
        u.next_block = 0;
        u.due = u.cycle_start.saturating_add(u.poll_ms);
    }
}

fn exception(request: &Request, code: u8) -> Refusal {
    Refusal::new(
        "modbus exception",
        format!(
            "unit {} answered function {} at {} with exception {code} ({})",
            request.unit,
            request.pdu.function(),
            request.pdu.address(),
            frame::exception_name(code)
        ),
    )
}
