'use strict';
// One simulated ESP32 device = one MQTT client (client id = device id) with
// an "offline" retained last will, an "online" retained birth message,
// datapoints sampled at 1 Hz (scaled by the simulator speed) and telemetry
// once a minute. ActuatorPanel and SensorStation add their own datapoints.
const mqtt = require('mqtt');
const { stream } = require('./random');
const { ModbusServer } = require('./modbus');
const { datapointDefaults, PANEL_VALVES } = require('./plant');

const round = (value, decimals) => {
  const f = 10 ** decimals;
  return Math.round(value * f) / f;
};
const clamp = (value, lo, hi) => Math.min(hi, Math.max(lo, value));

class Device {
  constructor(sim, id, kind) {
    this.sim = sim;
    this.id = id;
    this.kind = kind;
    // Separate streams: enabling drops or delays does not change the noise sequence.
    this.rng = stream(sim.seed, id);
    this.netRng = stream(sim.seed, `${id}/net`);
    this.client = null;
    this.connected = false;
    this.dead = false;
    this.stopped = false;
    this.faults = { noisy: null, drop: 0 };
    this.pending = new Set(); // delayed publishes
    this.sendAfter = 0; // keeps delayed publishes in order, as one TCP connection would
    this.timers = [];
    this.lastError = '';
    // Its MQTT dialect, from the palette's contract: sugarshack devices keep
    // the simulator's own batch format; the others publish on change.
    this.handle = sim.side.device(id);
    this.profile = sim.side.profile(this.handle);
    this.native = this.profile === 'sugarshack';
    // A modbus device is a server the palette polls, not an MQTT client.
    this.modbus = this.profile === 'modbus' ? new ModbusServer({
      side: sim.side,
      device: this.handle,
      endpoint: sim.side.modbusEndpoint(this.handle),
      network: { delay: () => this.drawDelay(), drop: () => this.netRng.chance(Math.max(this.sim.dropRatio, this.faults.drop)) },
      onWrite: (written) => this.written(written),
      log: (line) => this.log(line),
    }) : null;
    this.boot();
  }

  statusMessage(online) {
    return this.sim.side.status(this.handle, online);
  }

  // Power-on: counters and uptime start over (also on revive).
  boot() {
    this.counters = { published: 0, dropped: 0 };
    this.bootSimMs = this.sim.simNow();
    this.rssi = Math.round(this.rng.between(-72, -55));
  }

  log(msg) {
    this.sim.log(`${this.id}: ${msg}`);
  }

  start() {
    const period = this.sim.samplePeriodMs / this.sim.speed;
    // Devices boot at different moments; spread their sampling phases.
    const phase = this.rng.next() * period;
    const t = setTimeout(() => {
      this.sample();
      this.timers.push(setInterval(() => this.sample(), period));
    }, phase);
    this.timers.push(t);
    this.timers.push(setInterval(() => this.telemetry(), this.sim.telemetryPeriodMs / this.sim.speed));
    if (!this.dead) this.connect();
  }

  connect() {
    if (this.modbus) {
      this.ready = this.modbus.listen().then(() => {
        this.connected = true;
        this.log(`modbus server on ${this.modbus.host}:${this.modbus.port} (unit ${this.modbus.unit})`);
        this.resumed();
        this.sample();
      }, (err) => this.log(`modbus server not started: ${err.message}`));
      return;
    }
    this.ready = new Promise((resolve) => { this.markReady = resolve; });
    const client = mqtt.connect(this.sim.broker, {
      clientId: this.id,
      clean: true,
      keepalive: this.sim.keepaliveS,
      reconnectPeriod: this.sim.reconnectMs,
      connectTimeout: 10000,
      // Subscriptions are made again on every connect (see onConnect).
      resubscribe: false,
      // Like the firmware: a datapoint sampled while offline is not sent later.
      queueQoSZero: false,
      will: (({ topic, payload }) => ({ topic, payload, qos: 1, retain: true }))(this.statusMessage(false)),
    });
    client.on('connect', () => this.onConnect(client));
    client.on('close', () => this.onDisconnect(client));
    client.on('message', (topic, payload, packet) => this.onMessage(topic, payload, packet));
    client.on('error', (err) => {
      if (err.message !== this.lastError) this.log(`mqtt error: ${err.message}`);
      this.lastError = err.message;
    });
    this.client = client;
  }

  onConnect(client) {
    if (client !== this.client) return;
    const first = !this.everConnected;
    this.connected = true;
    this.everConnected = true;
    this.lastError = '';
    this.log(first ? 'connected' : 'reconnected');
    const birth = this.statusMessage(true);
    client.publish(birth.topic, birth.payload, { qos: 1, retain: true });
    this.sent = new Map(); // on-change devices publish every state again on connect
    const topics = this.commandTopics();
    // Resume only once subscribed, so that retained commands get their say.
    const subscribed = (err) => {
      if (err) this.log(`subscribe failed: ${err.message}`);
      if (client !== this.client) return;
      this.resumed();
      this.markReady();
    };
    if (topics.length) client.subscribe(topics, { qos: 1 }, subscribed);
    else subscribed();
    this.telemetry();
  }

  onDisconnect(client) {
    if (client !== this.client || !this.connected) return;
    this.connected = false;
    if (!this.stopped) this.log(this.dead ? 'dead (connection dropped)' : 'lost the broker');
    this.paused();
  }

  /** A Modbus client's write: each actuator it commands, as an MQTT command would. */
  written(written) {
    for (const w of written) {
      if (w.actuator === null) continue;
      const a = this.sim.actuatorList[w.actuator];
      const text = a.family === 'pump' ? (w.value >= 0.5 ? 'ON' : 'OFF') : String(w.value);
      this.onCommand(a.family, String(a.slot), text, false, a.range);
    }
  }

  // Hooks for subclasses.
  commandTopics() { return []; }
  onCommand() {}
  resumed() {}
  paused() {}
  datapoints() { return []; }
  step() {}

  onMessage(topic, payload, packet) {
    if (this.dead) return;
    if (!this.native) {
      const read = this.sim.side.parseCommand(topic, payload);
      if (!read || read.kind === 'cleared') return;
      if (read.kind === 'refused') return this.malformed(`${topic}: ${read.message}`);
      const a = this.sim.actuatorList[read.actuator];
      const text = a.family === 'pump' ? (read.value >= 0.5 ? 'ON' : 'OFF') : String(read.value);
      return this.onCommand(a.family, String(a.slot), text, packet.retain, a.range);
    }
    const rest = topic.startsWith(`${this.id}/`) ? topic.slice(this.id.length + 1) : null;
    const m = rest && /^([^/]+)\/([^/]+)\/command$/.exec(rest);
    if (!m) return;
    // A named actuator by its type and io; else one of the panel's unnamed valves and pump.
    const a = this.sim.nativeActuators.get(`${this.id}/${m[1]}/${m[2]}`);
    if (a) this.onCommand(a.family, String(a.slot), payload.toString(), packet.retain, a.range);
    else if (m[1] === 'valve' || m[1] === 'pump') this.onCommand(m[1], m[2], payload.toString(), packet.retain);
  }

  malformed(what) {
    this.counters.dropped++;
    this.log(`ignored malformed command: ${what}`);
  }

  sample() {
    if (this.dead || this.stopped) return;
    const ts = Date.now(); // the device's clock, read when the sample is taken
    if (this.modbus) {
      if (this.connected) this.modbus.hold(this.registers());
      return;
    }
    // One sample goes out as one burst: its messages share one network delay.
    const delay = this.drawDelay();
    if (!this.native) {
      for (const m of this.messages()) this.publishText(m.topic, m.payload, m.retain, delay);
      return;
    }
    for (const [topic, body] of this.datapoints()) this.publishData(topic, { ts, ...body }, delay);
  }

  /** The firmware's own messages (profiles other than sugarshack). */
  messages() { return []; }

  /** A modbus device's registers now (DeviceSide.modbusImage). */
  registers() { return []; }

  /** Of `values` (handle -> value), those that changed since last sent (all after a connect). */
  changed(values) {
    const out = [];
    for (const [handle, value] of values) {
      if (this.sent && this.sent.get(handle) === value) continue;
      if (this.sent) this.sent.set(handle, value);
      out.push([handle, value]);
    }
    return out;
  }

  telemetry() {
    if (this.dead || this.stopped || !this.connected || this.modbus) return;
    this.publishData(`${this.id}/telemetry`, {
      ts: Date.now(),
      uptimeS: Math.floor((this.sim.simNow() - this.bootSimMs) / 1000),
      rssi: Math.round(clamp(this.rssi + this.rng.symmetric(3), -95, -30)),
      freeHeap: 180000 + Math.round(this.rng.symmetric(4000)),
      published: this.counters.published,
      dropped: this.counters.dropped,
    });
  }

  drawDelay() {
    const { delayMs, delayJitterMs } = this.sim;
    if (delayMs <= 0 && delayJitterMs <= 0) return 0;
    return Math.max(0, delayMs + this.netRng.symmetric(delayJitterMs));
  }

  // Outgoing data goes through the simulated network: drop ratio, then delay.
  publishData(topic, obj, delay = this.drawDelay()) {
    this.publishText(topic, JSON.stringify(obj), false, delay);
  }

  publishText(topic, payload, retain, delay = this.drawDelay()) {
    if (!this.connected) {
      this.counters.dropped++;
      return;
    }
    this.counters.published++;
    const ratio = Math.max(this.sim.dropRatio, this.faults.drop);
    if (this.netRng.chance(ratio)) return; // lost on the way; the device does not know
    const client = this.client;
    const send = () => {
      if (client.connected && client === this.client) client.publish(topic, payload, { qos: 0, retain });
    };
    const now = Date.now();
    if (delay <= 0 && this.sendAfter <= now) {
      send();
      return;
    }
    const at = Math.max(now + delay, this.sendAfter);
    this.sendAfter = at;
    const t = setTimeout(() => {
      this.pending.delete(t);
      send();
    }, at - now);
    this.pending.add(t);
  }

  // Abrupt loss (power cut, crash): no DISCONNECT packet, so the broker sends the last will.
  kill() {
    if (this.dead) return Promise.resolve();
    this.dead = true;
    clearTimeout(this.netTimer);
    this.away = false;
    if (this.modbus) return this.modbusDown('dead (power cut)');
    const client = this.client;
    if (!client) return Promise.resolve();
    this.onDisconnect(client);
    return new Promise((resolve) => client.end(true, {}, () => resolve()));
  }

  // Network loss without a reboot (Wi-Fi gone, then back): the broker sees
  // the connection drop and sends the last will; the device keeps its state
  // and reconnects after `ms`.
  async disconnectFor(ms) {
    if (this.modbus && !this.dead) {
      await this.modbusDown('unreachable');
      this.away = true;
      clearTimeout(this.netTimer);
      this.netTimer = setTimeout(() => this.comeBack(), ms);
      return;
    }
    if (this.dead || !this.client) return;
    const client = this.client;
    this.onDisconnect(client);
    await new Promise((resolve) => client.end(true, {}, () => resolve()));
    clearTimeout(this.netTimer);
    this.away = true;
    this.netTimer = setTimeout(() => this.comeBack(), ms);
  }

  comeBack() {
    clearTimeout(this.netTimer);
    if (!this.away) return;
    this.away = false;
    if (!this.dead && !this.stopped) this.connect();
  }

  revive() {
    if (!this.dead) return Promise.resolve();
    this.dead = false;
    this.everConnected = false;
    this.rebooted();
    this.boot();
    if (this.modbus) this.modbus.reset();
    this.log('revived (rebooting)');
    this.connect();
    return this.ready;
  }

  rebooted() {}

  /** A modbus device gone from the network: its connections drop, nothing answers. */
  async modbusDown(why) {
    await this.modbus.close();
    if (this.connected) {
      this.connected = false;
      if (!this.stopped) this.log(why);
      this.paused();
    }
  }

  // Orderly shutdown: says "offline" itself, then disconnects (no will).
  async stop() {
    this.stopped = true;
    clearTimeout(this.netTimer);
    for (const t of this.timers) clearTimeout(t), clearInterval(t);
    for (const t of this.pending) clearTimeout(t);
    this.pending.clear();
    if (this.modbus) {
      await this.modbus.close();
      return;
    }
    const client = this.client;
    if (!client || this.dead || this.away) return; // its client is already closed
    if (client.connected) {
      await new Promise((resolve) => {
        const last = this.statusMessage(false);
        client.publish(last.topic, last.payload, { qos: 1, retain: true }, () => resolve());
        setTimeout(resolve, 1000);
      });
    }
    await new Promise((resolve) => {
      client.end(!client.connected, {}, () => resolve());
      setTimeout(resolve, 2000);
    });
  }
}

class ActuatorPanel extends Device {
  /** `slots`: its outputs ({ valves: [slot], pumps: [slot] }); `idle`: slot -> starting valve position, %. */
  constructor(sim, id, slots, idle) {
    super(sim, id, 'actuator-panel');
    this.valves = {};
    for (const slot of slots.valves) {
      const start = idle.get(slot) ?? 0;
      this.valves[slot] = { io: slot, position: start, target: start, commanded: start, moveAt: 0, stuck: false, slowFactor: 1 };
    }
    this.pumps = {};
    for (const slot of slots.pumps) {
      this.pumps[slot] = { io: slot, running: false, commanded: false, pendingValue: null, pendingAt: 0, paused: true, stuck: false };
    }
    this.pump = this.pumps[1];
    this.named = sim.actuatorList.filter((a) => a.device === id);
  }

  commandTopics() {
    if (!this.native) return this.sim.side.commandTopics(this.handle);
    return [`${this.id}/+/+/command`];
  }

  /** An actuator's value in its own units: a pump's 0/1, a valve's position scaled to its type's range. */
  valueOf(a, position = this.valves[a.slot] && this.valves[a.slot].position) {
    if (a.family === 'pump') return this.pumps[a.slot].running ? 1 : 0;
    const [min, max] = a.range;
    return min + (clamp(position, 0, 100) / 100) * (max - min);
  }

  /** An I/O module's inputs: each valve's position (with its noise), the pump's run feedback. */
  registers() {
    const values = this.named.map((a) => this.valueOf(a, a.family === 'valve' ? this.feedback(a.slot) : undefined));
    return this.sim.side.modbusImage(this.handle, Uint32Array.from(this.named.map((a) => a.handle)), Float64Array.from(values), new Uint32Array(0), new Float64Array(0));
  }

  /** On change, as stock firmware: whole percent positions without noise, the pump's relay. */
  messages() {
    const values = this.named.map((a) => [a.handle, this.valueOf(a, Math.round(clamp(this.valves[a.slot]?.position ?? 0, 0, 100)))]);
    const changed = this.changed(values);
    if (changed.length === 0) return [];
    return this.sim.side.actuatorMessages(this.handle, Uint32Array.from(changed.map(([h]) => h)), Float64Array.from(changed.map(([, v]) => v)), undefined);
  }

  /** A command for output `ioText` of `family` (`valve`: a position in `range`, `pump`: ON/OFF). */
  onCommand(family, ioText, text, retained, range = [0, 100]) {
    const io = Number(ioText);
    const tag = retained ? ' (retained)' : '';
    if (family === 'valve') {
      const trimmed = text.trim();
      const value = Number(trimmed);
      const v = this.valves[io];
      if (!v) return this.malformed(`valve/${ioText}: no such valve`);
      const [min, max] = range;
      if (trimmed === '' || !Number.isFinite(value) || value < min || value > max) {
        return this.malformed(`valve/${io}: ${JSON.stringify(text.slice(0, 40))} is not ${min}..${max}`);
      }
      const percent = ((value - min) / (max - min)) * 100;
      v.commanded = percent;
      v.target = percent;
      v.moveAt = this.sim.simNow() + this.sim.deadTimeMs;
      this.log(`valve ${io} -> ${value}${tag}${v.stuck ? ' (stuck: will not move)' : ''}`);
      return undefined;
    }
    const pump = this.pumps[io];
    if (!pump) return this.malformed(`pump/${ioText}: no such pump`);
    const word = text.trim().toUpperCase();
    if (word !== 'ON' && word !== 'OFF') return this.malformed(`pump/${io}: ${JSON.stringify(text.slice(0, 40))} is not ON/OFF`);
    pump.commanded = word === 'ON';
    this.schedulePump(pump, pump.commanded);
    this.log(`pump ${io} -> ${word}${tag}${pump.stuck ? ' (stuck: will not change)' : ''}`);
    return undefined;
  }

  schedulePump(pump, value) {
    pump.pendingValue = value;
    pump.pendingAt = this.sim.simNow() + this.sim.pumpDelayMs;
  }

  // Connected again: each pump resumes what it was told, after its spin-up;
  // a retained (lockout) command arriving on subscribe replaces that first.
  // At least 100 ms (wall clock) even without spin-up: retained messages may
  // follow the SUBACK.
  resumed() {
    for (const p of Object.values(this.pumps)) {
      p.paused = false;
      if (p.commanded && !p.running && p.pendingValue === null) {
        p.pendingValue = true;
        p.pendingAt = this.sim.simNow() + Math.max(this.sim.pumpDelayMs, 100 * this.sim.speed);
      }
    }
  }

  // Broker lost: the pumps pause until the connection is back.
  paused() {
    for (const p of Object.values(this.pumps)) {
      if (!p.stuck && p.running && !this.stopped) this.log(`pump ${p.io} paused (no broker)`);
      p.paused = true;
      p.pendingValue = null;
      if (!p.stuck) p.running = false;
    }
  }

  // A revived panel has rebooted: the relays start off, nothing commanded.
  rebooted() {
    for (const p of Object.values(this.pumps)) {
      p.commanded = false;
      p.pendingValue = null;
    }
  }

  step(simNowMs, dtS) {
    const fullRate = 100 / this.sim.sweepS; // % per simulated second
    for (const v of Object.values(this.valves)) {
      if (v.stuck || simNowMs < v.moveAt || v.position === v.target) continue;
      const stepPct = (fullRate / v.slowFactor) * dtS;
      const delta = v.target - v.position;
      v.position = Math.abs(delta) <= stepPct ? v.target : v.position + Math.sign(delta) * stepPct;
    }
    for (const p of Object.values(this.pumps)) {
      if (!p.paused && !p.stuck && p.pendingValue !== null && simNowMs >= p.pendingAt) {
        p.running = p.pendingValue;
        p.pendingValue = null;
      }
    }
  }

  feedback(io) {
    const amplitude = this.faults.noisy ?? this.sim.noise;
    const v = this.valves[io];
    return round(clamp(v.position + this.rng.symmetric(amplitude), 0, 100), 1);
  }

  /** Its own format: the 16 valves and the pump under `valve` and `pump`, named actuators of other types under theirs. */
  datapoints() {
    const state = { valve: {}, pump: {} };
    for (let io = 1; io <= PANEL_VALVES; io++) state.valve[io] = this.feedback(io);
    state.pump[1] = this.pump.running;
    for (const a of this.named) {
      if (!state[a.type]) state[a.type] = {};
      const already = a.type === a.family && a.slot === a.io && (a.family === 'pump' || (a.range[0] === 0 && a.range[1] === 100));
      if (already && state[a.type][a.io] !== undefined) continue;
      state[a.type][a.io] = a.family === 'pump' ? this.pumps[a.slot].running : round(this.valueOf(a, this.feedback(a.slot)), 1);
    }
    if (!this.sim.single) return [[`${this.id}/state`, state]];
    const out = [];
    for (const [type, outputs] of Object.entries(state)) {
      for (const [io, value] of Object.entries(outputs)) out.push([`${this.id}/${type}/${io}/state`, { value }]);
    }
    return out;
  }
}

class SensorStation extends Device {
  constructor(sim, id, datapoints, signals) {
    super(sim, id, 'sensor-station');
    this.points = datapoints.map((dp) => {
      const d = datapointDefaults(dp.name);
      const s = signals.find((x) => x.datapoint === dp.name) || {};
      return { name: dp.name, unit: dp.unit, d, base: s.base ?? d.base, span: s.span ?? d.span };
    });
  }

  /** The plant's named sensors in their input registers. */
  registers() {
    const { handles, values } = this.named();
    return this.sim.side.modbusImage(this.handle, new Uint32Array(0), new Float64Array(0), Uint32Array.from(handles), Float64Array.from(values));
  }

  /** The values of the plant's named sensors on this station. */
  named() {
    const handles = [];
    const values = [];
    for (const [name, value] of this.datapoints()) {
      const handle = this.sim.sensorHandles.get(`${this.id}/${name.split('/')[2]}`);
      if (handle === undefined) continue;
      handles.push(handle);
      values.push(value.value);
    }
    return { handles, values };
  }

  /** Every sample (sensors publish each update, as ESPHome's do); only the plant's named sensors. */
  messages() {
    const { handles, values } = this.named();
    if (handles.length === 0) return [];
    return this.sim.side.sensorMessages(this.handle, Uint32Array.from(handles), Float64Array.from(values), undefined);
  }

  datapoints() {
    const driven = this.sim.readings.get(this.id);
    const noisePct = this.faults.noisy ?? this.sim.sensorNoise;
    return this.points.map((p) => {
      const fromPlant = driven && driven.has(p.name);
      let value = fromPlant ? driven.get(p.name) : p.base;
      // A stopped flowmeter or an empty tank reads a clean zero.
      if (!(fromPlant && value === 0)) value += this.rng.symmetric((noisePct * p.span) / 100);
      value = clamp(value, p.d.min ?? -Infinity, p.d.max ?? Infinity);
      return [`${this.id}/sensor/${p.name}/state`, { value: round(value, p.d.decimals) }];
    });
  }
}

module.exports = { Device, ActuatorPanel, SensorStation };
