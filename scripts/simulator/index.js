'use strict';
// Plant simulator: actuator panels and sensor stations from the plant
// document, each its own MQTT client, plus tank hydraulics and fault injection.
//
//   const { startSimulator } = require('./scripts/simulator');
//   const sim = await startSimulator({ broker: 'mqtt://127.0.0.1:1883', plant: 'flows/plant.json' });
//   await sim.inject({ fault: 'stuck', device: 'ctrl-1', valve: 3 });
//   await sim.stop();
const mqtt = require('mqtt');
const { loadPlant, buildModel, withProfile, MODBUS_PORT } = require('./plant');
const { FlowLoop, loopPlant } = require('./loop');
const { ActuatorPanel, SensorStation } = require('./devices');
const { Hydraulics } = require('./hydraulics');
const { normalizeFault, parseFaultArg } = require('./faults');

const CONTROL_TOPIC = 'sim/control';

const DEFAULTS = {
  broker: 'mqtt://127.0.0.1:1883',
  plant: null,
  sweepS: 4, // full-sweep time of a valve (the paper's plant; Belimo units 9-150 s)
  noise: 1, // valve feedback noise, ± % (within the 3 % tolerance)
  sensorNoise: 0.1, // sensor noise, ± % of the datapoint's span
  delayMs: 0, // mean network delay of outgoing publishes
  delayJitterMs: 0, // uniform ± around the mean
  drop: 0, // share of outgoing data messages lost, all devices
  speed: 1, // simulated time runs this many times faster than the wall clock
  single: false, // per-actuator state topics instead of the panel batch
  profile: null, // every device speaks this profile (esphome, tasmota, modbus...); else each its document's
  modbusPort: MODBUS_PORT, // --profile modbus: the first device's Modbus TCP port, the next ones after it
  loop: null, // a file with a plant document whose simulation.loop is run as a Modbus/TCP I/O module
  seed: 1,
  pumpDelayMs: 1000, // pump spin-up / run-down before the feedback changes
  deadTimeMs: 0, // valve command-to-motion delay
  samplePeriodMs: 1000, // 1 Hz datapoints
  telemetryPeriodMs: 60000,
  reconnectMs: 1000,
  keepaliveS: 15,
  faults: [], // applied at start: objects or CLI strings ("stuck:ctrl-1:3")
  control: true, // listen on the control topic
  controlTopic: CONTROL_TOPIC, // its results go to <controlTopic>/result
  wait: true, // resolve once every device (not dead) has connected
  readyTimeoutMs: 10000,
  log: (line) => console.log(`sim: ${line}`),
};

function positive(name, value) {
  if (!(Number.isFinite(value) && value > 0)) throw new Error(`${name} must be > 0 (got ${value})`);
  return value;
}
function nonNegative(name, value) {
  if (!(Number.isFinite(value) && value >= 0)) throw new Error(`${name} must be >= 0 (got ${value})`);
  return value;
}

class Simulator {
  constructor(options) {
    const o = { ...DEFAULTS, ...options };
    this.broker = o.broker;
    this.sweepS = positive('sweepS', Number(o.sweepS));
    this.noise = nonNegative('noise', Number(o.noise));
    this.sensorNoise = nonNegative('sensorNoise', Number(o.sensorNoise));
    this.delayMs = nonNegative('delayMs', Number(o.delayMs));
    this.delayJitterMs = nonNegative('delayJitterMs', Number(o.delayJitterMs));
    this.dropRatio = Number(o.drop);
    if (!(this.dropRatio >= 0 && this.dropRatio <= 1)) throw new Error(`drop must be 0..1 (got ${o.drop})`);
    this.speed = positive('speed', Number(o.speed));
    this.single = Boolean(o.single);
    this.seed = o.seed;
    this.pumpDelayMs = nonNegative('pumpDelayMs', Number(o.pumpDelayMs));
    this.deadTimeMs = nonNegative('deadTimeMs', Number(o.deadTimeMs));
    this.samplePeriodMs = positive('samplePeriodMs', Number(o.samplePeriodMs));
    this.telemetryPeriodMs = positive('telemetryPeriodMs', Number(o.telemetryPeriodMs));
    this.reconnectMs = nonNegative('reconnectMs', Number(o.reconnectMs));
    this.keepaliveS = nonNegative('keepaliveS', Number(o.keepaliveS));
    this.options = o;
    this.log = typeof o.log === 'function' ? o.log : () => {};

    this.realStart = performance.now();
    const loaded = loadPlant(o.plant);
    const doc = o.profile ? withProfile(loaded, o.profile, { modbusPort: Number(o.modbusPort) }) : loaded;
    // Checked by the core, as a deploy checks it; its device side speaks the palette's own MQTT contract.
    this.model = buildModel(doc);
    this.side = this.model.side;
    this.actuatorList = (doc.actuators || []).map((a, handle) => ({ handle, ...this.model.actuators[a.id] }));
    // A sugarshack device's named actuators by `<device>/<type>/<io>`, as its command topics name them.
    this.nativeActuators = new Map(this.actuatorList.map((a) => [`${a.device}/${a.type}/${a.io}`, a]));
    this.sensorHandles = new Map((doc.sensors || []).map((x, handle) => [`${x.device}/${x.name}`, handle]));
    this.hydraulics = new Hydraulics(this.model.simulation);
    this.readings = this.hydraulics.readings();

    const idle = new Map(this.model.panels.map((id) => [id, new Map()]));
    // Named valves start at their idle position (in % of their range).
    for (const [i, a] of (doc.actuators || []).entries()) {
      const { family, slot, range: [min, max] } = this.actuatorList[i];
      if (family === 'valve' && typeof a.idle === 'number') idle.get(a.device).set(slot, ((a.idle - min) / (max - min)) * 100);
    }
    this.devices = {};
    for (const id of this.model.panels) this.devices[id] = new ActuatorPanel(this, id, this.model.panelSlots[id], idle.get(id));
    for (const st of this.model.stations) {
      this.devices[st.id] = new SensorStation(this, st.id, st.datapoints, this.model.simulation.signals.filter((s) => s.station === st.id));
    }
    this.control = null;
    this.controlChain = Promise.resolve();
    this.loops = o.loop ? [new FlowLoop(loopPlant(o.loop), { seed: o.seed, log: this.log })] : [];
  }

  // Simulated milliseconds since start (the plant's clock; timestamps use the wall clock).
  simNow() {
    return (performance.now() - this.realStart) * this.speed;
  }

  async start() {
    const initial = (this.options.faults || []).map((f) => (typeof f === 'string' ? parseFaultArg(f, this.model) : normalizeFault(f, this.model)));
    // Dead-at-start devices never connect; the rest are applied once connected.
    for (const f of initial.filter((x) => x.fault === 'dead')) {
      this.devices[f.device].dead = true;
      this.log(`fault dead ${f.device} (from start: never connects)`);
    }
    this.lastStep = this.simNow();
    this.physics = setInterval(() => this.step(), 50);
    for (const d of Object.values(this.devices)) d.start();
    for (const loop of this.loops) await loop.start();
    if (this.options.control) this.startControl();
    if (this.options.wait) await this.waitReady(this.options.readyTimeoutMs);
    for (const f of initial.filter((x) => x.fault !== 'dead')) await this.inject(f);
    const panels = this.model.panels.length;
    this.log(`${panels} actuator panel(s), ${this.model.stations.length} sensor station(s) on ${this.broker}` +
      ` (sweep ${this.sweepS} s, noise ±${this.noise} %, speed ×${this.speed}${this.single ? ', single topics' : ''}`
      + `${this.options.profile ? `, profile ${this.options.profile}` : ''})`);
  }

  async waitReady(timeoutMs) {
    const live = Object.values(this.devices).filter((d) => !d.dead);
    const waits = live.map((d) => d.ready);
    if (this.controlReady) waits.push(this.controlReady);
    let timer;
    const timeout = new Promise((_, reject) => {
      timer = setTimeout(() => {
        const missing = live.filter((d) => !d.connected).map((d) => d.id);
        reject(new Error(`simulator: not connected to ${this.broker} after ${timeoutMs} ms (${missing.join(', ') || 'control client'})`));
      }, timeoutMs);
    });
    try {
      await Promise.race([Promise.all(waits), timeout]);
    } finally {
      clearTimeout(timer);
    }
  }

  step() {
    const now = this.simNow();
    const dtS = (now - this.lastStep) / 1000;
    this.lastStep = now;
    const panels = this.model.panels.map((id) => this.devices[id]);
    for (const p of panels) p.step(now, dtS);
    this.hydraulics.step(
      dtS,
      (dev, slot) => this.devices[dev].valves[slot].position,
      (dev, slot) => this.devices[dev].pumps[slot].running,
    );
    this.readings = this.hydraulics.readings();
  }

  startControl() {
    const client = mqtt.connect(this.broker, {
      clientId: `sim-control-${process.pid}-${Math.floor(Math.random() * 1e6)}`,
      reconnectPeriod: this.reconnectMs,
      resubscribe: true,
    });
    this.controlReady = new Promise((resolve) => {
      client.once('connect', () => client.subscribe(this.options.controlTopic, { qos: 1 }, () => resolve()));
    });
    client.on('error', () => {}); // the devices already log broker errors
    client.on('message', (topic, payload, packet) => {
      if (packet.retain) {
        this.log(`ignored a retained ${this.options.controlTopic} message (clear it with an empty retained publish)`);
        return;
      }
      // One request at a time, so results come back in the order asked.
      this.controlChain = this.controlChain.then(() => this.onControl(payload.toString()));
    });
    this.control = client;
  }

  async onControl(text) {
    let faults;
    try {
      const parsed = JSON.parse(text);
      faults = Array.isArray(parsed) ? parsed : [parsed];
    } catch (err) {
      this.log(`${this.options.controlTopic}: not JSON: ${text.slice(0, 80)}`);
      this.reply({ ok: false, error: `not JSON: ${err.message}`, request: text.slice(0, 200) });
      return;
    }
    for (const f of faults) {
      try {
        const applied = await this.inject(f);
        this.reply({ ok: true, fault: applied });
      } catch (err) {
        this.log(`${this.options.controlTopic}: ${err.message}`);
        this.reply({ ok: false, error: err.message, request: f });
      }
    }
  }

  reply(obj) {
    if (this.control && this.control.connected) this.control.publish(`${this.options.controlTopic}/result`, JSON.stringify(obj), { qos: 1 });
  }

  // fault: object (see README) or CLI string. Resolves with the normalized fault once applied.
  async inject(fault) {
    const f = typeof fault === 'string' ? parseFaultArg(fault, this.model) : normalizeFault(fault, this.model);
    const dev = f.device && this.devices[f.device];
    const what = f.valve !== undefined ? ` valve ${f.valve}` : f.pump !== undefined ? ` pump ${f.pump}` : '';
    const extra = ['factor', 'amplitude', 'ratio', 'to', 'forMs'].filter((k) => f[k] !== undefined).map((k) => ` ${k}=${f[k]}`).join('');
    this.log(`fault ${f.fault}${f.device ? ` ${f.device}` : ''}${what}${extra}`);
    switch (f.fault) {
      case 'clear': {
        const targets = dev ? [dev] : Object.values(this.devices);
        for (const d of targets) {
          d.faults = { noisy: null, drop: 0 };
          if (d.valves) {
            for (const v of Object.values(d.valves)) Object.assign(v, { stuck: false, slowFactor: 1 });
            for (const p of Object.values(d.pumps)) p.stuck = false;
          }
        }
        for (const d of targets) d.comeBack();
        await Promise.all(targets.filter((d) => d.dead).map((d) => d.revive()));
        break;
      }
      case 'stuck':
        if (f.pump !== undefined) dev.pumps[f.pump].stuck = true;
        else dev.valves[f.valve].stuck = true;
        break;
      case 'slow':
        dev.valves[f.valve].slowFactor = f.factor;
        break;
      case 'drift': {
        // Uncommanded: the valve moves, the commanded value stays what it was.
        const v = dev.valves[f.valve];
        v.target = f.to;
        v.moveAt = 0;
        break;
      }
      case 'noisy':
        dev.faults.noisy = f.amplitude;
        break;
      case 'drop':
        dev.faults.drop = f.ratio;
        break;
      case 'dead':
        await dev.kill();
        break;
      case 'revive':
        await dev.revive();
        break;
      case 'disconnect':
        await dev.disconnectFor(f.forMs);
        break;
      default:
        break;
    }
    return f;
  }

  async stop() {
    if (this.stopping) return this.stopping;
    this.stopping = (async () => {
      clearInterval(this.physics);
      await Promise.all(Object.values(this.devices).map((d) => d.stop()));
      await Promise.all(this.loops.map((loop) => loop.stop()));
      if (this.control) await new Promise((resolve) => this.control.end(true, {}, () => resolve()));
      this.log('stopped');
    })();
    return this.stopping;
  }

  snapshot() {
    const out = { hydraulics: this.hydraulics.snapshot(), devices: {} };
    for (const [id, d] of Object.entries(this.devices)) {
      const s = { connected: d.connected, dead: d.dead, faults: { ...d.faults }, counters: { ...d.counters } };
      if (d.valves) {
        s.valves = Object.fromEntries(Object.values(d.valves).map((v) => [v.io, { position: v.position, target: v.target, commanded: v.commanded, stuck: v.stuck, slowFactor: v.slowFactor }]));
        s.pump = { ...d.pump };
        s.pumps = Object.fromEntries(Object.values(d.pumps).map((p) => [p.io, { ...p }]));
      }
      out.devices[id] = s;
    }
    return out;
  }
}

// Resolves with { stop(), inject(fault), devices, model, hydraulics, snapshot() }
// once every device has connected (unless options.wait is false).
async function startSimulator(options = {}) {
  const sim = new Simulator(options);
  try {
    await sim.start();
  } catch (err) {
    await sim.stop().catch(() => {});
    throw err;
  }
  return {
    devices: sim.devices,
    model: sim.model,
    hydraulics: sim.hydraulics,
    inject: (fault) => sim.inject(fault),
    stop: () => sim.stop(),
    snapshot: () => sim.snapshot(),
    simulator: sim,
  };
}

module.exports = { startSimulator, Simulator, DEFAULTS, CONTROL_TOPIC };
