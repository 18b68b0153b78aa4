// @ts-check
'use strict';
// A plant's MQTT side: the actuators nodes that speak for its devices, the
// device msgs they hand in (read by the core's topics module), the publishes
// and event msgs that leave from them, and whether each one's broker is up.
// Which topic is whose, and whether a payload on a foreign topic is a group
// command, is the core's to say; here its answer is carried out.
const { journal } = require('../journal/bus');
const { clock } = require('../host/clock');
const wasm = require('../wasm');
const i18n = require('../host/i18n');

// Distinct (topic, reason) warnings remembered per actuators node; past it, bad input is only counted.
const MAX_WARNED = 1000;

class PlantBuses {
  /** plant: the PlantRuntime (its core `t`, device ids and handles, effects pump and status). */
  constructor(plant) {
    this.plant = plant;
    this.list = []; // { nodeId, node, names, devices, deviceHandles, bad, ignored, warned, broker, connected }
    this.bufferMax = 0; // Node-RED's nodeMessageBufferMaxLength (0: unset), as the plant node last read it
  }

  /**
   * An actuators node: it speaks for `names` (device ids), or for every device
   * when null; `broker`: its mqtt-broker config node, watched to know when the
   * MQTT path is down. A new instance of a deployed node takes its place.
   */
  add(node, names, broker, resolve) {
    this.list = this.list.filter((b) => b.nodeId !== node.id);
    const bus = { nodeId: node.id, node, names, devices: null, bad: 0, ignored: 0, warned: new Set(), broker: broker || null, connected: null };
    if (resolve) this.resolve([bus]);
    this.list.push(bus);
    // A device served by no actuators node is reported again (the core remembers which were).
    if (this.plant.t) this.plant.t.servingChanged();
    this.sendWaiting('unsent');
  }

  /** The device handles of `buses` (all by default), against the document in force. */
  resolve(buses = this.list) {
    const { deviceIndex, devices } = this.plant;
    for (const bus of buses.filter((b) => b.names)) {
      bus.devices = new Set();
      for (const name of bus.names) {
        const handle = deviceIndex.get(name);
        if (handle === undefined) bus.node.error(i18n.text('logs.unknownDevice', { name, devices: devices.join(', ') }));
        else bus.devices.add(handle);
      }
      bus.deviceHandles = Uint32Array.from(bus.devices);
    }
  }

  remove(node) {
    this.list = this.list.filter((b) => b.node !== node);
  }

  of(node) {
    return this.list.find((b) => b.node === node);
  }

  /** The first actuators node serving the device (its MQTT msgs and events leave from it). */
  serving(device) {
    return this.list.find((b) => !b.devices || b.devices.has(device)) || null;
  }

  // ---- device msgs in ------------------------------------------------------

  /**
   * Hands a device msg (its topic and payload) to the core, which reads it by
   * the plant's device profiles and applies it. Returns false when the msg is
   * a group command: on a lockout topic, or on no device's topic from the
   * flow, or one the core reads as a command. Other MQTT traffic on topics of
   * no device (discovery, other devices: `fromMqtt`) is ignored and counted;
   * bad input is warned about, counted and skipped.
   */
  feedback(node, topic, payload, fromMqtt) {
    if (typeof topic !== 'string' || topic === '') return false;
    const { plant } = this;
    const bus = this.of(node);
    const served = bus && bus.devices ? bus.deviceHandles : undefined;
    const now = clock.now();
    const withSamples = journal.active;
    // One call: the core reads the msg, applies it and answers all of it (see Tracker.ingestMsg).
    // Text and bytes (a Buffer; isView first: no proxy's trap runs here) cross as received;
    // the facade reads any other value (what auto-detect parsed, or a hostile one).
    const answer = JSON.parse(typeof payload === 'string' ? plant.t.ingestMsg(topic, payload, now, served, withSamples, fromMqtt)
      : ArrayBuffer.isView(payload) && payload instanceof Uint8Array ? plant.t.ingestMsgBytes(topic, payload, now, served, withSamples, fromMqtt)
        : wasm.reading(plant, () => plant.t.ingestMsgValue(topic, payload, now, served, withSamples, fromMqtt)));
    const { Ingest } = wasm.load();
    if (answer.kind === Ingest.Command) return false;
    if (answer.kind === Ingest.Foreign) {
      // From MQTT on a topic of no device and no group command: someone else's traffic, ignored and counted.
      if (bus) {
        bus.ignored += 1;
        plant.refreshStatus(node);
      }
      return true;
    }
    if (answer.kind === Ingest.Other) return true;
    if (answer.kind === Ingest.Samples) plant.sensors.sampled(now, answer);
    plant.flush({ bus, topic }, answer);
    return true;
  }

  malformed(bus, topic, device, reason, message) {
    if (bus) this.bad(bus, topic, reason, `ignored ${clip(topic)}: ${message}`, `actuator/malformed/${device}`, { kind: 'malformed', device, topic, reason, message });
  }

  /** A sample the core refused (`source`: the feedback msg's bus and topic, when it came from one). */
  reject(e, source) {
    const a = this.plant.actuators[e.actuator];
    const bus = (source && source.bus) || this.serving(a.deviceHandle);
    const topic = source ? source.topic : a.device;
    if (bus) this.bad(bus, topic, e.code, i18n.text('logs.sampleIgnored', { topic, message: e.message }), `actuator/rejected/${a.id}`, { ...e, actuator: a.id, topic: source ? source.topic : null });
  }

  /** Bad input on `bus`: counted, warned about once per topic and reason, and told as `event` on its events output. */
  bad(bus, topic, reason, warning, event, payload) {
    bus.bad += 1;
    // Keyed by the start of the topic: a stream of long distinct topics must not grow the set by their size.
    const key = `${String(topic).slice(0, 200)}\u0000${reason}`;
    if (!bus.warned.has(key) && bus.warned.size < MAX_WARNED) {
      bus.warned.add(key);
      bus.node.warn(warning);
    }
    this.emit(bus, event, { ...payload, count: bus.bad });
  }

  // ---- msgs out ------------------------------------------------------------

  /**
   * Publish `e` goes out from the actuators node serving its device. Else the core is told why not (a
   * fact: this instance's cluster role, a deploy, no such node) and keeps it or drops it: its rule.
   */
  publish(e) {
    const { plant } = this;
    const acting = !plant.cluster || plant.cluster.mayAct();
    const bus = acting ? this.serving(e.device) : null;
    if (bus) {
      bus.node.send([{ topic: e.topic, payload: e.payload, retain: e.retain, qos: 1 }, null, null]);
      return;
    }
    const blocked = !acting ? plant.cluster.role : plant.palette && !plant.palette.started ? 'deploying' : 'unserved';
    const told = plant.t.notSent(blocked, e.device, e.topic, e.payload, e.retain, this.bufferMax);
    if (told > 0) plant.log('warn', i18n.text('logs.publishesDropped', { max: told }));
    if (told < 0) plant.log('error', i18n.text('logs.deviceUnserved', { name: plant.devices[e.device], topic: e.topic, payload: e.payload }));
  }

  /** What waited in `which` goes out, with every commanded state and standing lockout after it if the core dropped some. */
  sendWaiting(which) {
    if (this.plant.t && this.plant.t.sendKept(which, clock.now()) > 0) this.plant.flush(null);
  }

  /**
   * Deposed: what waited is not this instance's to send any more, and every
   * broker connection is made anew. An MQTT client sends its unacknowledged
   * QoS 1 publishes again when it reconnects: a leader paused mid-publish and
   * kicked by the broker would otherwise replay its old commands once let in
   * again as a standby. A new client starts with none.
   */
  async standDown() {
    if (this.plant.t) this.plant.t.dropKept('held');
    const brokers = new Set(this.list.map((b) => b.broker).filter((b) => b && typeof b.disconnect === 'function' && typeof b.connect === 'function'));
    await Promise.all([...brokers].map((broker) => new Promise((resolve) => broker.disconnect(resolve)).then(() => broker.connect())));
  }

  deviceStatus(e) {
    const name = this.plant.devices[e.device];
    this.emit(this.serving(e.device), `actuator/deviceStatus/${name}`, { ...e, device: name });
  }

  /** Report by exception, motion, completion, faults...: an event msg from the node serving the actuator. */
  emitActuator(e) {
    const a = this.plant.actuators[e.actuator];
    if (!a) return;
    const bus = this.serving(a.deviceHandle);
    if (!journal.active && !(bus && bus.node && eventsWired(bus.node))) return;
    const payload = { ...e, actuator: a.id };
    journal.event('actuator', e.kind, a.id, e);
    if (e.caller !== undefined) payload.msgid = this.plant.commands.msgId(e.caller);
    this.emit(bus, `actuator/${e.kind}/${a.id}`, payload);
  }

  /** A msg on the events output (the third) of an actuators node, if it is wired; `extra`: its other properties. */
  emit(bus, topic, payload, extra = undefined) {
    if (bus && bus.node && eventsWired(bus.node)) bus.node.send([null, null, Object.assign({ topic, payload }, extra)]);
  }

  /**
   * The palette sees its MQTT path through each actuators node's broker config
   * node (`mqtt out` drops publishes while disconnected without telling anyone):
   * when it comes back, every commanded state and standing lockout is sent again.
   */
  watchBrokers() {
    const { plant } = this;
    let restored = false;
    for (const bus of this.list) {
      if (!bus.broker) continue;
      const connected = Boolean(bus.broker.connected);
      // First seen up, or back up: what went out before may have been dropped.
      if (bus.connected !== true && connected) restored = true;
      if (bus.connected !== connected) {
        bus.connected = connected;
        this.emit(bus, 'actuator/mqtt', { kind: 'mqtt', connected });
        plant.refreshStatus(bus.node);
        plant.conditionsMayHaveChanged();
      }
    }
    if (restored && plant.t.pathRestored(clock.now()) > 0) plant.flush(null);
  }
}

/**
 * Whether an actuators node's events output (its third) is wired: at plant
 * scale an event msg per changed value costs as much as the feedback itself,
 * and one wired to nothing goes nowhere.
 */
function eventsWired(node) {
  return !Array.isArray(node.wires) || (Array.isArray(node.wires[2]) && node.wires[2].length > 0);
}

/** A value as a short quote for a log line. */
function clip(value) {
  const s = String(value);
  return s.length > 60 ? `${s.slice(0, 57)}...` : s;
}

module.exports = { PlantBuses };
