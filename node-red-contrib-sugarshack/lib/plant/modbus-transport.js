// @ts-check
'use strict';
// A plant's Modbus connections: a TCP socket (or a serial port) per
// connection of the core's plan, one timer each, and reconnects. What to send
// and when, what the answers mean and when a device is offline are the core's
// (its link, through the tracker: modbusNext / modbusReceive / modbusTimeout /
// modbusClosed); this only moves the bytes. A connection is open while an
// actuators node serves one of its devices and this instance is not a hot
// standby: a Modbus unit has no broker to fence a deposed writer.
const net = require('net');
const { clock } = require('../host/clock');
const { journal } = require('../journal/bus');
const i18n = require('../host/i18n');

const SERIALPORT_MISSING = 'SERIALPORT_MISSING';

class ModbusTransport {
  /** plant: the PlantRuntime (its core `t`, buses, effects pump and sensors). */
  constructor(plant) {
    this.plant = plant;
    this.t = null; // the tracker the connections below belong to
    this.conns = []; // by connection handle: { handle, key, framing, endpoint, reconnectMs, devices, link, ... } or null
    this.serialport = undefined; // the serialport package, once looked for
  }

  /**
   * Opens the connections whose devices an actuators node serves, closes the
   * others; after a new tracker (a deploy, a rebuild), every connection is
   * made again for it.
   */
  sync() {
    const { plant } = this;
    const t = plant.state === 'ready' ? plant.t : null;
    if (t !== this.t) {
      this.closeAll();
      this.t = t;
      this.plan = t ? t.modbusConnections() : [];
      this.conns = this.plan.map(() => null);
    }
    if (!t) return;
    this.plan.forEach((spec, handle) => {
      const served = !plant.standby && spec.devices.some((d) => plant.bus.serving(d));
      if (served && !this.conns[handle]) this.open(handle);
      else if (!served && this.conns[handle]) this.close(handle);
    });
  }

  closeAll() {
    for (let handle = 0; handle < this.conns.length; handle++) if (this.conns[handle]) this.close(handle);
  }

  /** Requests in flight, as [{ connection (key), device (id) }]: what a test waits for. */
  inFlight() {
    const out = [];
    for (const c of this.conns) {
      if (!c || !c.open) continue;
      const device = this.t.modbusInFlight(c.handle);
      if (device !== undefined) out.push({ connection: c.key, device: this.plant.devices[device] });
    }
    return out;
  }

  /** Whether every connection that is wanted is open. */
  connected() {
    return this.conns.every((c) => !c || c.open);
  }

  // ---- one connection --------------------------------------------------------

  open(handle) {
    const spec = this.plan[handle];
    const c = this.conns[handle] || { ...spec, handle, link: null, open: false, wake: null, retry: null, warned: false };
    this.conns[handle] = c;
    c.retry = null;
    let link;
    try {
      link = spec.endpoint.kind === 'tcp' ? this.tcp(spec.endpoint) : this.serial(spec);
    } catch (err) {
      this.down(c, null, err);
      return;
    }
    c.link = link;
    link.on('data', (bytes) => this.received(c, link, bytes));
    link.on('error', (err) => {
      c.lastError = err;
      // A serial port that fails to open never closes: give it up here.
      if (!c.open) this.down(c, link, err);
    });
    link.on('close', () => this.down(c, link, c.lastError));
    link.once(spec.endpoint.kind === 'tcp' ? 'connect' : 'open', () => this.opened(c, link));
  }

  tcp({ host, port }) {
    const socket = net.connect({ host, port });
    socket.setNoDelay(true);
    return socket;
  }

  /** A serial port through the `serialport` package (an optional peer dependency, loaded on first use). */
  serial(spec) {
    if (this.serialport === undefined) {
      try {
        this.serialport = require('serialport');
      } catch {
        this.serialport = null;
      }
    }
    if (!this.serialport) {
      throw Object.assign(new Error(i18n.text('logs.modbusSerialMissing', { path: spec.endpoint.path })), { code: SERIALPORT_MISSING });
    }
    const { path, baudRate, parity, dataBits, stopBits } = spec.endpoint;
    return new this.serialport.SerialPort({ path, baudRate, parity, dataBits, stopBits });
  }

  opened(c, link) {
    if (c.link !== link) return;
    c.open = true;
    c.warned = false;
    c.lastError = null;
    this.call(() => this.t.modbusOpened(c.handle, clock.now()));
    this.emitLink(c, true);
    this.pump(c.handle);
  }

  received(c, link, bytes) {
    if (c.link !== link || !c.open) return;
    const { plant } = this;
    const now = clock.now();
    if (this.call(() => this.t.modbusReceive(c.handle, bytes, now)) === null) return;
    const device = this.t.lastDevice();
    if (device !== undefined) {
      const sensors = this.t.lastSensors();
      if (sensors.length > 0) {
        plant.sensors.sampled(now, { device, ts: this.t.lastTs(), sensors, samples: journal.active ? this.t.lastSamples() : [] });
        this.emitSamples(device, now);
      }
    }
    plant.flush({ bus: device === undefined ? null : plant.bus.serving(device), topic: c.key });
    this.pump(c.handle);
  }

  /** Each sensor value a poll read, as `sensor/<id>` from the node serving its device: a pid's measurement. */
  emitSamples(device, now) {
    const { plant } = this;
    const bus = plant.bus.serving(device);
    if (!bus) return;
    const samples = this.t.lastSamples();
    const roundTripMs = this.t.lastRoundTripMs();
    for (let i = 0; i + 2 < samples.length; i += 3) {
      if (samples[i] !== 1) continue;
      const sensor = plant.sensorNames[samples[i + 1]];
      const value = samples[i + 2];
      plant.bus.emit(bus, `sensor/${sensor}`, Number.isNaN(value) ? null : value, { sensor, device: plant.devices[device], timestamp: now, roundTripMs });
    }
  }

  /** The link is gone (or never came): its devices go offline, and it is made again after `reconnectMs`. */
  down(c, link, err) {
    if (link && c.link !== link) return;
    const wasOpen = c.open;
    c.link = null;
    c.open = false;
    clock.clearTimeout(c.wake);
    c.wake = null;
    if (link) link.removeAllListeners('data');
    if (c.closing) return;
    if (this.call(() => this.t.modbusClosed(c.handle, clock.now())) !== null) this.plant.flush(null);
    if (wasOpen) this.emitLink(c, false);
    if (!c.warned) {
      c.warned = true;
      const message = (err && (err.code || err.message)) || i18n.text('logs.modbusClosed');
      this.plant.log('warn', i18n.text('logs.modbusDown', { key: c.key, message, seconds: c.reconnectMs / 1000 }));
    }
    if (err && err.code === SERIALPORT_MISSING) return; // no use trying again without the package
    clock.clearTimeout(c.retry);
    c.retry = clock.setTimeout(() => {
      if (this.conns[c.handle] === c && !c.closing) this.open(c.handle);
    }, c.reconnectMs);
  }

  close(handle) {
    const c = this.conns[handle];
    if (!c) return;
    this.conns[handle] = null;
    c.closing = true;
    clock.clearTimeout(c.wake);
    clock.clearTimeout(c.retry);
    const { link } = c;
    c.link = null;
    c.open = false;
    if (!link) return;
    link.removeAllListeners('data');
    link.on('error', () => {});
    if (typeof link.destroy === 'function') link.destroy();
    else if (link.isOpen) link.close(() => {});
  }

  /** Sends what the core says is due on the connection, and sets its one timer for the next thing due. */
  pump(handle) {
    const c = this.conns[handle];
    if (!c || !c.open || !c.link) return;
    const now = clock.now();
    const bytes = this.call(() => this.t.modbusNext(handle, now));
    if (bytes) c.link.write(Buffer.from(bytes));
    const wake = this.call(() => this.t.modbusWake(handle));
    clock.clearTimeout(c.wake);
    c.wake = null;
    if (typeof wake === 'number') c.wake = clock.setTimeout(() => this.woken(c), Math.max(0, wake - clock.now()));
  }

  woken(c) {
    c.wake = null;
    if (this.conns[c.handle] !== c || !c.open) return;
    const queued = this.call(() => this.t.modbusTimeout(c.handle, clock.now()));
    if (queued) this.plant.flush(null);
    this.pump(c.handle);
  }

  /** A call into the core, guarded: a trap rebuilds the tracker (and so the connections). Null when it threw. */
  call(fn) {
    try {
      return this.plant.guard(fn);
    } catch (err) {
      this.plant.log('error', err.message);
      return null;
    }
  }

  emitLink(c, connected) {
    const { plant } = this;
    const bus = c.devices.map((d) => plant.bus.serving(d)).find(Boolean);
    if (bus) plant.bus.emit(bus, 'actuator/modbus', { kind: 'modbus', connection: c.key, connected });
  }
}

module.exports = { ModbusTransport };
