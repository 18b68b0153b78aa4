'use strict';
// A simulated device's Modbus server: a TCP listener holding the device's
// registers (coils, discrete inputs, holding and input registers), reading
// requests and writing replies through the palette's own frames (the wasm
// core's device side, DeviceSide.modbusRequest / modbusReply), so the palette
// and the simulator agree on every byte; tests/integration/modbus.spec.js
// checks the palette against pymodbus's server instead.
//
// The network is simulated per request: half the delay before the request
// takes effect, half before its reply leaves, in order (one TCP stream);
// a dropped request gets no reply (the palette times out).
const net = require('net');

const KINDS = ['coil', 'discrete', 'input', 'holding'];
const ILLEGAL_DATA_ADDRESS = 2;

class ModbusServer {
  /**
   * side: the plant's DeviceSide; device: the device handle; endpoint:
   * side.modbusEndpoint(device); network: { delay() -> ms, drop() -> boolean };
   * onWrite([{ actuator, output, value }]): what a client's write means.
   */
  constructor({ side, device, endpoint, network, onWrite, log }) {
    this.side = side;
    this.device = device;
    this.unit = endpoint.unit;
    this.framing = endpoint.framing;
    this.host = endpoint.endpoint.host;
    this.port = endpoint.endpoint.port;
    this.network = network;
    this.onWrite = onWrite;
    this.log = log;
    this.memory = Object.fromEntries(KINDS.map((k) => [k, new Uint16Array(65536)]));
    this.server = null;
    this.sockets = new Set();
    this.requests = 0;
  }

  /** Resolves once listening. */
  listen() {
    if (this.server) return Promise.resolve();
    const server = net.createServer((socket) => this.serve(socket));
    this.server = server;
    return new Promise((resolve, reject) => {
      server.once('error', reject);
      server.listen(this.port, this.host, () => {
        server.off('error', reject);
        resolve();
      });
    });
  }

  /** Stops listening and drops every connection (a power cut, a cable pulled). */
  close() {
    const server = this.server;
    this.server = null;
    for (const socket of this.sockets) socket.destroy();
    this.sockets.clear();
    if (!server) return Promise.resolve();
    return new Promise((resolve) => server.close(() => resolve()));
  }

  /** Power on: every register 0 until the device fills its inputs. */
  reset() {
    for (const kind of KINDS) this.memory[kind].fill(0);
  }

  /** Puts `image` ([{ kind, address, words }], DeviceSide.modbusImage) into the registers. */
  hold(image) {
    for (const { kind, address, words } of image) this.memory[kind].set(words, address);
  }

  serve(socket) {
    this.sockets.add(socket);
    socket.setNoDelay(true);
    let buffer = Buffer.alloc(0);
    let sendAfter = 0; // keeps replies in order, as one TCP stream would
    socket.on('close', () => this.sockets.delete(socket));
    socket.on('error', () => {});
    socket.on('data', (data) => {
      buffer = Buffer.concat([buffer, data]);
      for (;;) {
        const n = this.side.modbusScan(this.framing, buffer);
        if (n === 0) break;
        if (n < 0) {
          buffer = buffer.subarray(-n);
          continue;
        }
        const frame = buffer.subarray(0, n);
        buffer = buffer.subarray(n);
        if (this.network.drop()) continue;
        const half = this.network.delay() / 2;
        const now = Date.now();
        const at = Math.max(now + half, sendAfter);
        const leave = at + half;
        sendAfter = leave;
        const reply = () => {
          const bytes = this.answer(Uint8Array.from(frame));
          if (bytes && !socket.destroyed) setTimeout(() => socket.destroyed || socket.write(bytes), Math.max(0, leave - Date.now()));
        };
        if (at <= now) reply();
        else setTimeout(reply, at - now);
      }
    });
  }

  /** The reply to one request frame; null for a frame that is not one, or for another unit. */
  answer(frame) {
    let request;
    try {
      request = this.side.modbusRequest(this.framing, frame);
    } catch (err) {
      this.log(`ignored a malformed Modbus request: ${err.message}`);
      return null;
    }
    // A unit of TCP 0 or 255 reaches the device itself; on RTU only its own unit answers.
    const mine = request.unit === this.unit || (this.framing === 'tcp' && (request.unit === 0 || request.unit === 255));
    if (!mine) return null;
    this.requests += 1;
    const memory = this.memory[request.kind];
    if (request.address + request.count > memory.length) return this.side.modbusReply(this.framing, frame, undefined, ILLEGAL_DATA_ADDRESS);
    if (!request.write) {
      return this.side.modbusReply(this.framing, frame, memory.slice(request.address, request.address + request.count), undefined);
    }
    memory.set(request.write, request.address);
    const meant = this.side.modbusWritten(this.device, request.kind, request.address, Uint16Array.from(request.write));
    if (meant.length) this.onWrite(meant);
    return this.side.modbusReply(this.framing, frame, undefined, undefined);
  }
}

module.exports = { ModbusServer };
