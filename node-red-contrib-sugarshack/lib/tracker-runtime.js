'use strict';
// The running tracker behind one plant config node: one core Tracker plus what
// Node-RED owns around it (waiting msgs, the tick timer, status, and which
// actuators node speaks for which device). Every rule is the core's; this only
// calls it and acts on the effects it returns.
const { SugarshackError, asSugarshackError } = require('./errors');
const { PendingRegistry } = require('./pending');
const { actuatorStatus, errorStatus, StatusBoard } = require('./status');
const { describeFault, seconds } = require('./plant');
const { groupPayload, isLockout, actuatorIds, targetOf } = require('./group');
const feedback = require('./feedback');
const { stats, timeLayer } = require('./stats');

const TICK_MS = 250;
const MAX_CALLER = 0xffffffff;
// Distinct (topic, reason) warnings remembered per actuators node; past it, bad input is only counted.
const MAX_WARNED = 1000;
// How long a refusal shows on an actuators node before its counts come back.
const BUS_ERROR_MS = 10000;

class TrackerRuntime {
  /** owner: the plant config node (logs through it); Tracker: the wasm class; plant: the document. */
  constructor({ owner, Tracker, plant }) {
    this.owner = owner;
    this.Tracker = Tracker;
    this.plant = plant;
    this.state = 'starting'; // -> ready | failed -> closed
    this.failure = null;
    this.t = null;
    this.pending = new PendingRegistry();
    this.users = new Set();
    this.buses = []; // { node, names, devices: Set of device handles | null (all), bad, warned }
    this.statusBoard = new StatusBoard();
    this.sticky = new Map(); // node -> { status, until }: a refusal shown instead of the counts
    this.offline = new Set(); // device handles, as the core last reported them
    this.unserved = new Set(); // device ids already reported as served by no actuators node
    this.nextCaller = 0;
    this.tickTimer = null;
    this.watchers = new Map(); // sensor handle -> Set of functions called on each new sample
    this.plans = new Map(); // operation id -> plan, from the core
  }

  // ---- lifecycle -----------------------------------------------------------

  /** Builds the core tracker; `plantError` (or the core's INVALID_PLANT) fails every dependent node. */
  start(plantError) {
    if (plantError) {
      this.fail(plantError);
      return;
    }
    try {
      this.t = new this.Tracker(this.plant, Date.now());
    } catch (err) {
      this.fail(err);
      return;
    }
    this.index();
    for (const warning of this.t.warnings()) this.owner.warn(`plant document: ${warning}`);
    this.state = 'ready';
    this.tickTimer = setInterval(() => this.tick(), TICK_MS);
    this.refreshStatus();
  }

  /** Ids, types and per-device slots, read once from the core. */
  index() {
    const types = this.plant.actuatorTypes;
    this.devices = this.t.devices();
    this.deviceIndex = new Map(this.devices.map((id, handle) => [id, handle]));
    this.actuators = this.t.actuators().map((a) => ({
      ...a,
      deviceHandle: this.deviceIndex.get(a.device),
      unit: types[a.type].unit,
      timing: types[a.type],
    }));
    this.typeNames = new Set(Object.keys(types));
    this.slotCache = this.devices.map(() => new Map());
    const perDevice = this.devices.map(() => 0);
    for (const a of this.actuators) perDevice[a.deviceHandle]++;
    // Reused for every batch of a device: at most one sample per named actuator.
    this.scratch = perDevice.map((n) => ({ handles: new Uint32Array(n), values: new Float64Array(n) }));
  }

  fail(err) {
    const e = asSugarshackError(err);
    this.failure = e;
    this.state = 'failed';
    this.owner.error(e.message);
    this.refreshStatus();
  }

  /** Withdraws every waiting group command and completes its msg without sending it; frees the core. */
  close() {
    const wasReady = this.state === 'ready';
    this.state = 'closed';
    if (this.tickTimer) clearInterval(this.tickTimer);
    this.tickTimer = null;
    for (const caller of this.pending.handles()) {
      const entry = this.pending.take(caller);
      if (wasReady) this.t.withdraw(caller);
      entry.done();
    }
    if (wasReady) {
      this.t.free();
      this.t = null;
    }
  }

  // ---- nodes using this plant ----------------------------------------------

  addUser(node) {
    this.users.add(node);
    this.refreshStatus(node);
  }

  removeUser(node) {
    this.users.delete(node);
    this.sticky.delete(node);
    this.buses = this.buses.filter((b) => b.node !== node);
  }

  /** An actuators node: it speaks for `names` (device ids), or for every device when null. */
  addBus(node, names) {
    const bus = { node, names, devices: null, bad: 0, warned: new Set() };
    if (names && this.state === 'ready') {
      bus.devices = new Set();
      for (const name of names) {
        const handle = this.deviceIndex.get(name);
        if (handle === undefined) {
          node.error(`unknown device '${name}' in this node's device list (the plant has ${this.devices.join(', ')}); it is ignored`);
        } else {
          bus.devices.add(handle);
        }
      }
    }
    this.buses.push(bus);
    this.unserved.clear();
    this.refreshStatus(node);
  }

  /**
   * Runs `work` if the tracker is up. A refusal (thrown) completes the msg with
   * the error, so a Catch node gets it, and shows a short reason on the node.
   */
  submit(node, done, work) {
    if (this.state === 'ready') {
      try {
        work(this);
      } catch (err) {
        const e = asSugarshackError(err);
        this.showError(node, e.code);
        done(e);
      }
    } else if (this.state === 'failed') {
      done(this.failure);
    } else {
      done();
    }
  }

  // ---- group commands ------------------------------------------------------

  /**
   * Issues msg.payload as a group command and holds the msg until it completes;
   * it then leaves `node` on output `output` (of `outputs`). Throws the core's refusal.
   * `within`: the resources the commanding operation holds; a command outside them is refused (C2).
   */
  command({ node, msg, send, done, output = 0, outputs = 1, timeoutMs = 0, within }) {
    const payload = groupPayload(msg);
    const caller = this.newCaller();
    const now = Date.now();
    this.t.command(payload, caller, isLockout(msg), now, within);
    this.sticky.delete(node);
    const entry = { node, msg, send, done, output, outputs, payload, completed: [], retries: new Map(), sinceMs: now, timer: null };
    this.pending.add(caller, entry);
    if (timeoutMs > 0) entry.timer = setTimeout(() => this.expire(caller, entry, timeoutMs), timeoutMs);
    this.flush(null);
  }

  newCaller() {
    do {
      this.nextCaller = this.nextCaller >= MAX_CALLER ? 1 : this.nextCaller + 1;
    } while (this.pending.has(this.nextCaller));
    return this.nextCaller;
  }

  expire(caller, entry, timeoutMs) {
    if (this.state !== 'ready' || this.pending.get(caller) !== entry) return;
    this.pending.take(caller);
    this.t.withdraw(caller);
    const completed = new Set(entry.completed.map((c) => c.actuator));
    const waiting = actuatorIds(entry.payload).filter((id) => !completed.has(id));
    entry.msg.command = { waiting, actuators: entry.completed };
    this.showError(entry.node, 'COMMAND_TIMEOUT');
    entry.done(new SugarshackError(
      'COMMAND_TIMEOUT',
      `group command did not complete within ${seconds(timeoutMs)}: ${waiting.join(', ')} had not completed; `
        + 'the command was withdrawn (its actuators keep their last command)',
    ));
    this.refreshStatus();
  }

  /** A node is closing: withdraw its waiting group commands and complete their msgs. */
  dropNode(node) {
    if (this.state !== 'ready') return;
    const mine = this.pending.handles(node);
    for (const caller of mine) {
      this.t.withdraw(caller);
      this.pending.take(caller).done();
    }
    if (mine.length) this.refreshStatus();
  }

  // ---- device feedback -----------------------------------------------------

  /**
   * Feeds a device msg to the tracker. Returns false when the topic is not a device
   * topic (the msg is a command). Bad input is warned about, counted and skipped.
   */
  feedback(node, msg) {
    const { topic } = msg;
    if (isLockout(msg)) return false; // "lockout/<resource>" from a fault node, whatever the resource's name
    const route = feedback.classify(topic, (id) => this.deviceIndex.has(id));
    if (!route) return false;
    if (route.kind === 'other') return true; // telemetry, sensor datapoints, our own commands
    const bus = this.busOf(node);
    const device = this.deviceIndex.get(route.device);
    if (device === undefined) {
      this.malformed(bus, topic, route.device, 'unknown device', `device '${route.device}' is not in the plant document`);
      this.refreshStatus(node);
      return true;
    }
    if (bus && bus.devices && !bus.devices.has(device)) {
      this.malformed(bus, topic, route.device, 'device not served', `device '${route.device}' is not in this node's device list`);
      this.refreshStatus(node);
      return true;
    }
    const now = Date.now();
    try {
      if (route.kind === 'status') {
        this.t.deviceStatus(device, feedback.statusOf(msg.payload), now);
      } else if (route.kind === 'sensor') {
        this.sensorSample(route, msg.payload, now);
        return true;
      } else if (route.kind === 'batch') {
        this.batch(bus, topic, device, feedback.batchOf(msg.payload), now);
      } else {
        const handle = this.slotOf(device, route.type, route.io);
        if (handle === undefined) return true; // a slot the plant does not name
        const sample = feedback.singleOf(msg.payload);
        if (sample.ts !== undefined) stats.add(`tof/${route.device}`, now - sample.ts);
        try {
          this.t.feedback(handle, sample.value, sample.ts, now);
        } catch (err) {
          // Refused as a state of this actuator: reported like a refused sample of a batch.
          if (err.code !== 'INVALID_FEEDBACK') throw err;
          this.reject({ kind: 'rejected', actuator: handle, code: err.code, message: err.message }, { bus, topic });
        }
      }
    } catch (err) {
      if (!(err instanceof feedback.Malformed) && !(err && typeof err.code === 'string')) throw err;
      this.malformed(bus, topic, route.device, err.reason || err.code, err.message);
    }
    this.flush({ bus, topic });
    return true;
  }

  /** A sensor datapoint: kept by the core with its time; conditions watching it are re-checked. */
  sensorSample(route, payload, now) {
    const handle = this.t.sensorSlot(route.device, route.name);
    if (handle === undefined) return; // a datapoint the plant does not name
    const sample = feedback.singleOf(payload);
    if (sample.ts !== undefined) stats.add(`tof/${route.device}`, now - sample.ts);
    if (!this.t.recordSensor(handle, sample.value, sample.ts, now)) return;
    const watching = this.watchers.get(handle);
    if (watching) for (const fn of [...watching]) fn();
  }

  batch(bus, topic, device, { ts, groups }, now) {
    if (ts !== undefined) stats.add(`tof/${this.devices[device]}`, now - ts);
    const { handles, values } = this.scratch[device];
    let n = 0;
    for (const [type, members] of groups) {
      if (!this.typeNames.has(type)) continue; // other fields a device may add
      if (!feedback.isObject(members)) {
        this.malformed(bus, topic, this.devices[device], 'bad group', `'${type}' must map io numbers to values, got ${feedback.clip(members)}`);
        continue;
      }
      for (const key of Object.keys(members)) {
        const handle = this.slotOf(device, type, key);
        if (handle === undefined || n === handles.length) continue;
        const value = feedback.sampleValue(members[key]);
        if (Number.isNaN(value)) {
          this.malformed(bus, topic, this.devices[device], 'non-numeric value', `${type} ${key}: value must be a number or a boolean, got ${feedback.clip(members[key])}`);
          continue;
        }
        handles[n] = handle;
        values[n] = value;
        n++;
      }
    }
    if (n > 0) this.t.feedbackBatch(handles.subarray(0, n), values.subarray(0, n), ts, now);
  }

  /** The actuator a device reports as `type` number `key`, cached; undefined when the plant names none. */
  slotOf(device, type, key) {
    const cache = this.slotCache[device];
    const cacheKey = `${type}/${key}`;
    let handle = cache.get(cacheKey);
    if (handle === undefined) {
      const io = feedback.ioNumber(key);
      if (!this.typeNames.has(type) || io === null) return undefined;
      const slot = this.t.slot(device, type, io);
      handle = slot === undefined ? -1 : slot;
      cache.set(cacheKey, handle);
    }
    return handle < 0 ? undefined : handle;
  }

  malformed(bus, topic, device, reason, message) {
    if (!bus) return;
    bus.bad += 1;
    this.warnOnce(bus, topic, reason, `ignored ${topic}: ${message}`);
    this.emit(bus, `actuator/malformed/${device}`, { kind: 'malformed', device, topic, reason, message, count: bus.bad });
  }

  warnOnce(bus, topic, reason, text) {
    const key = `${topic}\u0000${reason}`;
    if (bus.warned.has(key) || bus.warned.size >= MAX_WARNED) return;
    bus.warned.add(key);
    bus.node.warn(text);
  }

  // ---- time and effects ----------------------------------------------------

  tick() {
    if (this.state !== 'ready') return;
    if (this.t.tick(Date.now()) > 0) this.flush(null);
    else if (this.sticky.size > 0) this.refreshStatus();
  }

  /** After every core call: act on its effects, then update status. `source`: the feedback msg's bus and topic. */
  flush(source) {
    const effects = this.t.takeEffects();
    try {
      for (const effect of effects) this.route(effect, source);
    } catch (err) {
      this.owner.error(`cannot route actuator effects: ${err.message || err}`);
    }
    this.refreshStatus();
  }

  route(e, source) {
    switch (e.kind) {
      case 'publish':
        this.publish(e);
        break;
      case 'groupCompleted':
        this.completeGroup(e);
        break;
      case 'groupFailed':
        this.failGroup(e);
        break;
      case 'deviceStatus':
        if (e.online) this.offline.delete(e.device);
        else this.offline.add(e.device);
        this.emit(this.busFor(e.device), `actuator/deviceStatus/${this.devices[e.device]}`, { ...e, device: this.devices[e.device] });
        break;
      case 'rejected':
        this.reject(e, source);
        break;
      default:
        if (e.kind === 'completed') this.recordCompleted(e);
        else if (e.kind === 'retry') this.recordRetry(e);
        this.emitActuator(e);
    }
  }

  publish(e) {
    const name = e.topic.slice(0, e.topic.indexOf('/'));
    const device = this.deviceIndex.get(name);
    const bus = device === undefined ? null : this.busFor(device);
    if (!bus) {
      if (!this.unserved.has(name)) {
        this.unserved.add(name);
        this.owner.error(`no actuators node serves device '${name}': ${e.topic} "${e.payload}" was not sent `
          + `(add an actuators node for all devices, or list ${name} in one)`);
      }
      return;
    }
    bus.node.send([{ topic: e.topic, payload: e.payload, retain: e.retain, qos: 1 }, null, null]);
  }

  recordCompleted(e) {
    const entry = this.pending.get(e.caller);
    if (!entry) return;
    // Commands that found their actuator already in place say nothing about timing.
    if (e.completionMs > 0) {
      stats.add('command/issueToMotion', e.issueToMotionMs);
      stats.add('command/completion', e.completionMs);
    }
    entry.completed.push({
      actuator: this.actuators[e.actuator].id,
      target: e.target,
      issueToMotionMs: e.issueToMotionMs,
      completionMs: e.completionMs,
      retries: e.retries,
    });
  }

  recordRetry(e) {
    const entry = this.pending.get(e.caller);
    if (entry) entry.retries.set(e.actuator, e.attempt);
  }

  /** The same msg goes on from the node that holds it (a link call return stays intact). */
  completeGroup(e) {
    const entry = this.pending.take(e.caller);
    if (!entry) return;
    const { msg } = entry;
    msg.command = { completionMs: e.completionMs, actuators: entry.completed };
    // A lockout from a fault node: the paper's fault lockout time, fault to isolation.
    if (typeof msg.faultAtMs === 'number') {
      msg.command.faultLockoutMs = Math.max(0, Date.now() - msg.faultAtMs);
      stats.add('fault/lockout', msg.command.faultLockoutMs);
    }
    if (entry.outputs === 1) {
      entry.send(msg);
    } else {
      const out = new Array(entry.outputs).fill(null);
      out[entry.output] = msg;
      entry.send(out);
    }
    entry.done();
  }

  /** The msg ends with an error a Catch node can turn into a fault of the operation. */
  failGroup(e) {
    const entry = this.pending.take(e.caller);
    if (!entry) return;
    const a = this.actuators[e.actuator];
    const retries = entry.retries.get(e.actuator) || 0;
    const code = e.fault === 'locked-out' ? 'LOCKED_OUT' : 'COMMAND_FAILED';
    entry.msg.command = {
      failed: { actuator: a.id, device: a.device, fault: e.fault, retries },
      actuators: entry.completed,
    };
    this.showError(entry.node, code);
    entry.done(new SugarshackError(code, describeFault(a, e.fault, { retries, target: targetOf(entry.payload, a.id) })));
  }

  reject(e, source) {
    const a = this.actuators[e.actuator];
    const bus = (source && source.bus) || this.busFor(a.deviceHandle);
    if (!bus) return;
    bus.bad += 1;
    this.warnOnce(bus, source ? source.topic : a.device, e.code, `ignored a sample in ${source ? source.topic : a.device}: ${e.message}`);
    this.emit(bus, `actuator/rejected/${a.id}`, { ...e, actuator: a.id, topic: source ? source.topic : null, count: bus.bad });
  }

  /** Report by exception, motion, completion, faults...: an event msg from the node serving the actuator. */
  emitActuator(e) {
    const a = this.actuators[e.actuator];
    const payload = { ...e, actuator: a.id };
    if (e.caller !== undefined) {
      const entry = this.pending.get(e.caller);
      payload.msgid = entry ? entry.msg._msgid : null;
    }
    this.emit(this.busFor(a.deviceHandle), `actuator/${e.kind}/${a.id}`, payload);
  }

  emit(bus, topic, payload) {
    if (bus) bus.node.send([null, null, { topic, payload }]);
  }

  // ---- sensors, operations, routines ---------------------------------------

  /** The core's handle of sensor `id`; throws UNKNOWN_SENSOR. */
  sensorHandle(id) {
    return this.t.sensor(id);
  }

  /** Fresh values of `handles` at `now`; throws SENSOR_STALE / SENSOR_NO_VALUE. */
  readSensors(handles, now) {
    return this.t.readSensors(Uint32Array.from(handles), now);
  }

  /** Calls `fn` on each new sample of any of `handles`; returns the function that stops it. */
  watchSensors(handles, fn) {
    for (const h of handles) {
      if (!this.watchers.has(h)) this.watchers.set(h, new Set());
      this.watchers.get(h).add(fn);
    }
    return () => {
      for (const h of handles) this.watchers.get(h)?.delete(fn);
    };
  }

  /** The operation's plan (steps, then the return to idle); throws UNKNOWN_OPERATION. */
  plan(id) {
    let plan = this.plans.get(id);
    if (!plan) {
      plan = this.t.operationPlan(id);
      this.plans.set(id, plan);
    }
    return plan;
  }

  /** Resources and lockout commands for an interlock bound to this plant. */
  interlockResources() {
    return this.t.interlockResources();
  }

  routine(id) {
    return this.t.routine(id);
  }

  // ---- status --------------------------------------------------------------

  busOf(node) {
    return this.buses.find((b) => b.node === node);
  }

  /** The first actuators node serving the device (its MQTT msgs and events leave from it). */
  busFor(device) {
    return this.buses.find((b) => !b.devices || b.devices.has(device)) || null;
  }

  /** Counts of the actuators on `devices` (phases from the core). */
  countsOn(devices) {
    const counts = { moving: 0, stopped: 0, faulted: 0 };
    for (const a of this.actuators) {
      if (!devices.has(a.deviceHandle)) continue;
      const phase = this.t.phase(a.handle);
      if (phase === 'pending' || phase === 'moving') counts.moving++;
      else if (phase === 'stopped') counts.stopped++;
      else if (phase === 'faulted') counts.faulted++;
    }
    return counts;
  }

  refreshStatus(only) {
    const nodes = only ? [only] : this.users;
    if (this.state === 'failed') {
      for (const node of nodes) this.statusBoard.set(node, errorStatus(this.failure.code));
      return;
    }
    if (this.state !== 'ready') return;
    const now = Date.now();
    let all = null;
    for (const node of nodes) {
      const sticky = this.sticky.get(node);
      if (sticky && sticky.until > now) {
        this.statusBoard.set(node, sticky.status);
        continue;
      }
      if (sticky) this.sticky.delete(node);
      const bus = this.busOf(node);
      let counts;
      let offline;
      if (bus && bus.devices) {
        counts = this.countsOn(bus.devices);
        offline = [...bus.devices].filter((d) => this.offline.has(d)).length;
      } else {
        counts = all || (all = this.t.counts());
        offline = this.offline.size;
      }
      this.statusBoard.set(node, actuatorStatus({ ...counts, bad: bus ? bus.bad : 0 }, { offline }));
    }
  }

  /** A short reason in a red ring: on an actuators node for a while, on other nodes until their next accepted command. */
  showError(node, code) {
    const status = errorStatus(code);
    this.sticky.set(node, { status, until: this.busOf(node) ? Date.now() + BUS_ERROR_MS : Infinity });
    this.statusBoard.set(node, status);
  }
}

// The actuator layer's own time per call, for the overhead figures.
timeLayer(TrackerRuntime, 'actuator', ['command', 'feedback', 'tick']);

module.exports = { TrackerRuntime, TICK_MS };
