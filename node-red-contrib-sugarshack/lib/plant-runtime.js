'use strict';
// The running plant behind one plant config node, for the whole life of the
// Node-RED process: one core Tracker (actuators, sensors, the document's
// operations and routines) plus what Node-RED owns around it: held group
// command msgs, the tick timer, status, which actuators node speaks for which
// device, and whether each one's MQTT broker connection is up. Every rule is
// the core's; this calls it and acts on the effects it returns.
const { SugarshackError } = require('./errors');
const { PendingRegistry, heldMsg } = require('./pending');
const { actuatorStatus, errorStatus } = require('./status');
const { seconds } = require('./plant');
const { groupPayload, isLockout, actuatorIds, targetOf } = require('./group');
const { readMsg } = require('./request');
const { Condition } = require('./condition');
const { stats, timeLayer } = require('./stats');
const { journal } = require('./journal/bus');
const { clock } = require('./clock');
const { RuntimeBase, DRAINING_STATUS } = require('./runtime-base');
const wasm = require('./wasm');
const { StatusPacer } = require('./status-pacer');

const TICK_MS = 250;
const MAX_CALLER = 0xffffffff;
// Distinct (topic, reason) warnings remembered per actuators node; past it, bad input is only counted.
const MAX_WARNED = 1000;
// How long a refusal shows on an actuators node before its counts come back.
const BUS_ERROR_MS = 10000;
// Publishes kept while a deploy has no actuators node serving their device yet.
const MAX_UNSENT = 10000;
// JSON text on a foreign topic longer than this is taken as a (too large) group command unread.
const COMMAND_TEXT_MAX = 64 * 1024;

class PlantRuntime extends RuntimeBase {
  /** settings: { plant (the document), error }; RED for JSONata conditions. */
  constructor({ RED, id, settings }) {
    super('plant');
    this.RED = RED;
    this.id = id;
    this.swapOrder = 0; // before the interlocks bound to it
    this.plant = settings.plant;
    this.plantError = settings.error || null;
    this.t = null;
    this.pending = new PendingRegistry(); // caller -> held group command
    this.buses = []; // { nodeId, node, names, devices, bad, warned, broker, connected }
    this.sticky = new Map(); // node -> { status, until }: a refusal shown instead of the counts
    this.countsShown = new WeakMap(); // node -> { figures, key }: the counts its status shows
    this.statusPacer = new StatusPacer(() => this.refreshStatus(), () => this.state === 'ready'); // after feedback
    this.offline = new Set(); // device handles, as the core last reported them
    this.unserved = new Set(); // device ids already reported as served by no actuators node
    this.unsent = []; // publishes waiting for an actuators node during a deploy
    this.nextCaller = 0;
    this.tickTimer = null;
    this.watchers = new Map(); // sensor handle -> Set of functions called on each new sample
    this.conditions = new Map(); // condition text + sensors -> Condition
  }

  // ---- lifecycle -----------------------------------------------------------

  /** Builds the core tracker; a document error (or the core's INVALID_PLANT) fails every dependent node. */
  start() {
    if (this.plantError) {
      this.fail(this.plantError);
      return;
    }
    try {
      this.t = this.guard(() => this.makeTracker(this.plant));
    } catch (err) {
      this.fail(err);
      return;
    }
    this.state = 'ready';
    this.tickTimer = clock.setInterval(() => this.tick(), TICK_MS);
    this.refreshStatus();
    this.replayParked();
  }

  makeTracker(plant) {
    const { Tracker } = wasm.load();
    const t = new Tracker(plant, clock.now());
    this.index(t, plant);
    for (const warning of t.warnings()) this.log('warn', `plant document: ${warning}`);
    return t;
  }

  /** Ids, types and per-device slots, read once from the core. */
  index(t, plant) {
    this.devices = t.devices();
    this.deviceIndex = new Map(this.devices.map((id, handle) => [id, handle]));
    this.actuators = t.actuators().map((a) => ({ ...a, deviceHandle: this.deviceIndex.get(a.device) }));
    this.sensorNames = [];
    for (const sensor of plant.sensors || []) this.sensorNames[t.sensor(sensor.id)] = sensor.id;
    for (const bus of this.buses) this.resolveDevices(bus);
  }

  /** A shutdown: held msgs are completed unsent; nothing else moves. */
  async shutdown() {
    if (this.ended) return;
    const wasReady = this.state === 'ready';
    this.endCommon();
    if (this.tickTimer) clock.clearInterval(this.tickTimer);
    this.tickTimer = null;
    this.statusPacer.stop();
    for (const caller of this.pending.handles()) this.pending.take(caller).abandon();
    if (wasReady) this.freeTracker();
  }

  /** Its config node left the flows: the same as a shutdown (the tracker keeps nothing on disk). */
  retire() {
    return this.shutdown();
  }

  freeTracker() {
    wasm.release(this.t);
    this.t = null;
  }

  // ---- deploys -------------------------------------------------------------

  /**
   * Drained when no group command is in flight (standing lockouts are the
   * core's and are sent again after a swap) and no condition waits on sensors
   * (its sensor handles are this document's).
   */
  quiescent() {
    if (!this.pending.entries().every((entry) => entry.lockout)) return false;
    for (const watching of this.watchers.values()) if (watching.size > 0) return false;
    return true;
  }

  /** The new document after the drain: a new tracker; the lockouts of faulted lines go out again through the interlocks. */
  swap(settings) {
    this.plant = settings.plant;
    this.plantError = settings.error || null;
    this.conditions.clear();
    this.watchers.clear();
    for (const caller of this.pending.handles()) this.pending.take(caller).abandon();
    if (this.t) this.freeTracker();
    if (this.tickTimer) clock.clearInterval(this.tickTimer);
    this.tickTimer = null;
    this.state = 'starting';
    this.failure = null;
    this.start();
  }

  /** After a wasm trap: a new tracker (positions come back with the next feedback); held commands fail. */
  rebuild() {
    if (this.state !== 'ready') return;
    const error = new SugarshackError('INTERNAL', 'the plant core failed and was rebuilt; this group command was dropped (its actuators keep their last command)');
    for (const caller of this.pending.handles()) this.pending.take(caller).refuse(error);
    wasm.forget(this.t);
    this.t = null;
    this.conditions.clear();
    try {
      this.t = this.makeTracker(this.plant);
    } catch (err) {
      this.fail(err);
      return;
    }
    this.refreshStatus();
  }

  // ---- nodes using this plant ----------------------------------------------

  removeUser(node) {
    super.removeUser(node);
    this.sticky.delete(node);
  }

  /**
   * An actuators node: it speaks for `names` (device ids), or for every device
   * when null; `broker`: its mqtt-broker config node, watched to know when the
   * MQTT path is down. A new instance of a deployed node takes its place.
   */
  addBus(node, names, broker) {
    this.buses = this.buses.filter((b) => b.nodeId !== node.id);
    const bus = { nodeId: node.id, node, names, devices: null, bad: 0, ignored: 0, warned: new Set(), broker: broker || null, connected: null };
    if (this.state === 'ready') this.resolveDevices(bus);
    this.buses.push(bus);
    this.unserved.clear();
    this.sendUnsent();
    this.refreshStatus(node);
  }

  resolveDevices(bus) {
    if (!bus.names) return;
    bus.devices = new Set();
    bus.deviceHandles = null;
    for (const name of bus.names) {
      const handle = this.deviceIndex.get(name);
      if (handle === undefined) {
        bus.node.error(`unknown device '${name}' in this node's device list (the plant has ${this.devices.join(', ')}); it is ignored`);
      } else {
        bus.devices.add(handle);
      }
    }
  }

  heldEntries() {
    return this.pending.entries();
  }

  closing(node) {
    this.buses = this.buses.filter((b) => b.node !== node);
  }

  withdrawOrphans(nodeId) {
    for (const caller of this.pending.handles()) {
      const entry = this.pending.get(caller);
      if (entry.nodeId !== nodeId || entry.node) continue;
      this.pending.take(caller);
      this.guard(() => this.t.withdraw(caller));
    }
    this.refreshStatus();
  }

  // ---- group commands ------------------------------------------------------

  /**
   * Issues msg.payload as a group command and holds the msg until it completes;
   * it then leaves `node` on output `output` (of `outputs`). Throws the core's refusal.
   * `within`: the resources the commanding operation holds; a command outside them is refused (C2).
   */
  command({ node, msg, send, done, output = 0, outputs = 1, timeoutMs = 0, within }) {
    // The msg is read again here: a getter or proxy that throws is the sender's error (INVALID_INPUT).
    const { payload, lockout } = readMsg(() => ({ payload: groupPayload(msg), lockout: isLockout(msg) }));
    const caller = this.newCaller();
    const now = clock.now();
    this.t.command(payload, caller, lockout, now, within);
    this.sticky.delete(node);
    const entry = msgEntry({ node, msg, send, done, output, outputs, payload, lockout, sinceMs: now });
    this.hold(caller, entry, timeoutMs);
    this.flush(null);
  }

  /**
   * A group command of an operation's run (not gated by a drain: the run must
   * finish). `onDone(err)` gets the outcome; returns a function that withdraws it.
   */
  runCommand({ payload, timeoutMs, within, onDone }) {
    const caller = this.newCaller();
    const now = clock.now();
    this.guard(() => this.t.command(payload, caller, false, now, within));
    const entry = callbackEntry({ payload, onDone, sinceMs: now });
    this.hold(caller, entry, timeoutMs);
    this.flush(null);
    return () => {
      if (this.pending.get(caller) !== entry) return;
      this.pending.take(caller);
      this.guard(() => this.t.withdraw(caller));
      this.refreshStatus();
    };
  }

  /**
   * Sends lockout commands ([{ resource, command }]) of faulted lines. The core
   * keeps each one as a standing order until feedback confirms it, re-sending it
   * whatever happens to this call; a refusal here is logged.
   */
  issueLockouts(lockouts, operation) {
    if (this.state !== 'ready') {
      if (lockouts.length) this.log('error', `lockouts of ${lockouts.map((l) => l.resource).join(', ')} not sent: the plant is not running`);
      return;
    }
    const faultAtMs = clock.now();
    for (const { resource, command } of lockouts) {
      const onDone = (err) => {
        if (err) this.log('warn', `lockout of ${resource} is not confirmed yet (${err.message}); it is sent again until it is`);
      };
      const carrier = { topic: `lockout/${resource}`, payload: command, resource, operation, faultAtMs };
      try {
        const caller = this.newCaller();
        this.guard(() => this.t.command(command, caller, true, faultAtMs, undefined));
        const entry = callbackEntry({ payload: command, onDone, sinceMs: faultAtMs, msg: carrier, lockout: true });
        this.hold(caller, entry, 0);
        this.flush(null);
      } catch (err) {
        this.log('error', `lockout of ${resource} could not be sent: ${err.message}`);
      }
    }
  }

  hold(caller, entry, timeoutMs) {
    this.pending.add(caller, entry);
    if (timeoutMs > 0) entry.timer = clock.setTimeout(() => this.expire(caller, entry, timeoutMs), timeoutMs);
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
    try {
      this.guard(() => this.t.withdraw(caller));
    } catch (err) {
      this.log('error', err.message);
    }
    const completed = new Set(entry.completed.map((c) => c.actuator));
    const waiting = actuatorIds(entry.payload).filter((id) => !completed.has(id));
    if (entry.msg) entry.msg.command = { waiting, actuators: entry.completed };
    if (entry.node) this.showError(entry.node, 'COMMAND_TIMEOUT');
    entry.refuse(new SugarshackError(
      'COMMAND_TIMEOUT',
      `group command did not complete within ${seconds(timeoutMs)}: ${waiting.join(', ')} had not completed; `
        + 'the command was withdrawn (its actuators keep their last command)',
    ));
    this.refreshStatus();
  }

  // ---- device feedback -----------------------------------------------------

  /**
   * Hands a device msg (its topic and payload) to the core, which reads it by
   * the plant's device profiles and applies it. Returns false when the msg is
   * a group command: its topic is no device's, and it comes from the flow or
   * carries a group command. Other MQTT traffic on topics of no device
   * (discovery, other devices: `fromMqtt`) is ignored and counted; bad input
   * is warned about, counted and skipped.
   */
  feedback(node, topic, payload, fromMqtt = false) {
    if (typeof topic !== 'string' || topic === '') return false;
    const bus = this.busOf(node);
    if (bus && bus.devices) {
      const device = this.t.topicDevice(topic);
      if (device !== undefined && !bus.devices.has(device)) {
        this.malformed(bus, topic, this.devices[device], 'device not served', `device '${this.devices[device]}' is not in this node's device list`);
        this.refreshStatus(node);
        return true;
      }
    }
    const now = clock.now();
    const text = payloadText(payload);
    const kind = text === null ? this.t.ingestBytes(topic, payload, now) : this.t.ingest(topic, text, now);
    const { Ingest } = wasm.load();
    if (kind === Ingest.Foreign) return fromMqtt && this.foreign(bus, payload);
    if (kind === Ingest.Other) return true;
    if (kind === Ingest.Samples) this.sampled(now);
    this.flush({ bus, topic });
    return true;
  }

  /**
   * Whether a payload on a foreign topic is meant as a group command: an
   * object with a group command key, or JSON text that is not an object
   * without one (so that a broken command is refused, not ignored).
   */
  commandLike(payload) {
    let value = payload;
    if (typeof payload === 'string') {
      const start = payload.trimStart()[0];
      if (start === '[') return true;
      if (start !== '{') return false;
      if (payload.length > COMMAND_TEXT_MAX) return true;
      try {
        value = JSON.parse(payload);
      } catch {
        return true;
      }
    }
    if (value === null || typeof value !== 'object' || Buffer.isBuffer(value)) return false;
    if (Array.isArray(value)) return true;
    const keys = Object.keys(value);
    for (let i = 0; i < keys.length && i < 100; i++) if (this.t.isGroupKey(keys[i])) return true;
    return false;
  }

  /** Every value the last device msg carried, to the journal (the entity is the actuator's or sensor's id). */
  journalSamples(ts, now) {
    const device = this.devices[this.t.lastDevice()];
    const samples = this.t.lastSamples();
    for (let i = 0; i + 2 < samples.length; i += 3) {
      const entity = samples[i] === 0 ? this.actuators[samples[i + 1]].id : this.sensorNames[samples[i + 1]];
      journal.datapoint(device, entity, samples[i + 2], ts, now);
    }
  }

  /** After samples: the device time of flight, and the conditions watching updated sensors. */
  sampled(now) {
    const ts = this.t.lastTs();
    if (journal.active) this.journalSamples(ts, now);
    if (ts !== undefined) stats.add(`tof/${this.devices[this.t.lastDevice()]}`, now - ts);
    if (this.watchers.size === 0) return;
    for (const handle of this.t.lastSensors()) {
      const watching = this.watchers.get(handle);
      if (watching) for (const fn of [...watching]) fn();
    }
  }

  /** An MQTT msg on a topic of no device: a group command if it carries one, else someone else's traffic (ignored, counted). */
  foreign(bus, payload) {
    if (this.commandLike(payload)) return false;
    if (bus) {
      bus.ignored += 1;
      this.refreshStatus(bus.node);
    }
    return true;
  }

  malformed(bus, topic, device, reason, message) {
    if (!bus) return;
    bus.bad += 1;
    this.warnOnce(bus, topic, reason, `ignored ${clip(topic)}: ${message}`);
    this.emit(bus, `actuator/malformed/${device}`, { kind: 'malformed', device, topic, reason, message, count: bus.bad });
  }

  warnOnce(bus, topic, reason, text) {
    // Keyed by the start of the topic: a stream of long distinct topics must not grow the set by their size.
    const key = `${String(topic).slice(0, 200)}\u0000${reason}`;
    if (bus.warned.has(key) || bus.warned.size >= MAX_WARNED) return;
    bus.warned.add(key);
    bus.node.warn(text);
  }

  // ---- time, the MQTT path and effects -------------------------------------

  tick() {
    if (this.state !== 'ready') return;
    try {
      this.guard(() => {
        this.watchBrokers();
        if (this.t.tick(clock.now()) > 0) this.flush(null);
        else if (this.sticky.size > 0) this.refreshStatus();
      });
    } catch (err) {
      this.log('error', err.message);
    }
  }

  /**
   * The palette sees its MQTT path through each actuators node's broker config
   * node (`mqtt out` drops publishes while disconnected without telling anyone):
   * when it comes back, every commanded state and standing lockout is sent again.
   */
  watchBrokers() {
    let restored = false;
    for (const bus of this.buses) {
      if (!bus.broker) continue;
      const connected = Boolean(bus.broker.connected);
      // First seen up, or back up: what went out before may have been dropped.
      if (bus.connected !== true && connected) restored = true;
      if (bus.connected !== connected) {
        bus.connected = connected;
        this.emit(bus, 'actuator/mqtt', { kind: 'mqtt', connected });
        this.refreshStatus(bus.node);
      }
    }
    if (restored && this.t.pathRestored(clock.now()) > 0) this.flush(null);
  }

  /**
   * After every core call: act on its effects, then update status. `source`:
   * the feedback msg's bus and topic. A feedback msg whose effects are only
   * new values (or none: the usual report of positions that did not move)
   * changed no count, so the status is left as it is.
   */
  flush(source) {
    const effects = this.t.queued() > 0 ? this.t.takeEffects() : [];
    let counted = source === null;
    try {
      for (const effect of effects) {
        this.route(effect, source);
        if (effect.kind !== 'changed') counted = true;
      }
    } catch (err) {
      counted = true;
      this.log('error', `cannot route actuator effects: ${err.message || err}`);
    }
    if (!counted) {
      if (this.palette) this.palette.changes.touch();
    } else if (source === null) {
      this.refreshStatus();
    } else {
      this.statusPacer.request();
    }
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
      case 'malformed':
        this.malformed(source ? source.bus : null, source ? source.topic : '', e.device, e.reason, e.message);
        break;
      default:
        if (e.kind === 'completed') this.recordCompleted(e);
        else if (e.kind === 'retry') this.recordRetry(e);
        else if (e.kind === 'lockoutConfirmed' && e.afterMs !== undefined) stats.add('lockout/confirm', e.afterMs);
        this.emitActuator(e);
    }
  }

  publish(e) {
    const name = this.devices[e.device];
    const bus = this.busFor(e.device);
    if (!bus) {
      if (this.palette && !this.palette.started) {
        // A deploy in progress: the actuators node serving it comes back in a moment.
        if (this.unsent.length < MAX_UNSENT) this.unsent.push(e);
        return;
      }
      if (!this.unserved.has(name)) {
        this.unserved.add(name);
        this.log('error', `no actuators node serves device '${name}': ${e.topic} "${e.payload}" was not sent `
          + `(add an actuators node for all devices, or list ${name} in one)`);
      }
      return;
    }
    bus.node.send([{ topic: e.topic, payload: e.payload, retain: e.retain, qos: 1 }, null, null]);
  }

  sendUnsent() {
    const unsent = this.unsent;
    this.unsent = [];
    for (const e of unsent) this.publish(e);
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
    const result = { completionMs: e.completionMs, actuators: entry.completed };
    const { msg } = entry;
    // A lockout from a fault node: the paper's fault lockout time, fault to isolation.
    if (msg && typeof msg.faultAtMs === 'number') {
      result.faultLockoutMs = Math.max(0, clock.now() - msg.faultAtMs);
      stats.add('fault/lockout', result.faultLockoutMs);
    }
    entry.complete(result);
  }

  /** The msg ends with an error a Catch node can turn into a fault of the operation. */
  failGroup(e) {
    const entry = this.pending.take(e.caller);
    if (!entry) return;
    const a = this.actuators[e.actuator];
    const retries = entry.retries.get(e.actuator) || 0;
    const { code, message } = this.t.describeFault(e.actuator, e.fault, retries, targetOf(entry.payload, a.id));
    if (entry.msg) {
      entry.msg.command = {
        failed: { actuator: a.id, device: a.device, fault: e.fault, retries },
        actuators: entry.completed,
      };
    }
    if (entry.node) this.showError(entry.node, code);
    entry.refuse(new SugarshackError(code, message));
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
    if (!a) return;
    const bus = this.busFor(a.deviceHandle);
    if (!journal.active && !(bus && bus.node && eventsWired(bus.node))) return;
    const payload = { ...e, actuator: a.id };
    journal.event('actuator', e.kind, a.id, e);
    if (e.caller !== undefined) {
      const entry = this.pending.get(e.caller);
      payload.msgid = entry && entry.msg ? entry.msg._msgid : null;
    }
    this.emit(bus, `actuator/${e.kind}/${a.id}`, payload);
  }

  emit(bus, topic, payload) {
    if (bus && bus.node && eventsWired(bus.node)) bus.node.send([null, null, { topic, payload }]);
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

  /** A compiled condition over sensors of this plant, shared by everything waiting on the same text. */
  condition(text, sensors) {
    const key = `${text}\u0000${sensors.join('\u0000')}`;
    let condition = this.conditions.get(key);
    if (!condition) {
      condition = new Condition(this.RED, this.owner, text, sensors, this, 'operation');
      this.conditions.set(key, condition);
    }
    return condition;
  }

  /** The operation's plan (steps, then the return to idle); throws UNKNOWN_OPERATION. */
  plan(id) {
    return this.t.operationPlan(id);
  }

  /** A new run of operation `id` (the core's state machine); throws UNKNOWN_OPERATION. */
  operationRun(id) {
    return this.t.operationRun(id);
  }

  /** Resources and lockout commands for an interlock bound to this plant. */
  interlockResources() {
    return this.t.interlockResources();
  }

  routine(id) {
    return this.t.routine(id);
  }

  /**
   * The plant as a person (or a dashboard) reads it: unconfirmed lockouts,
   * each device online or offline and its actuators with stale feedback, the
   * last value of every sensor and whether it is fresh, each actuators node's
   * broker connection.
   */
  describe() {
    if (this.state !== 'ready') return { failure: this.failure ? { code: this.failure.code, message: this.failure.message } : null };
    const health = this.t.health(clock.now());
    return {
      lockoutsPending: this.t.pendingLockouts().map((o) => ({ ...o, actuator: this.actuators[o.actuator].id })),
      buses: this.buses.map((b) => ({ node: b.nodeId, connected: b.connected })),
      devicesOffline: [...this.offline].map((d) => this.devices[d]),
      devices: health.devices.map((d) => ({ ...d, state: !d.online ? 'offline' : d.stale.length ? 'stale' : 'online' })),
      sensors: health.sensors,
    };
  }

  // ---- status --------------------------------------------------------------

  busOf(node) {
    return this.buses.find((b) => b.node === node);
  }

  /** The first actuators node serving the device (its MQTT msgs and events leave from it). */
  busFor(device) {
    return this.buses.find((b) => !b.devices || b.devices.has(device)) || null;
  }

  /** Counts of the actuators on a bus's devices (phases and unconfirmed lockouts, kept by the core). */
  countsOn(bus) {
    if (!bus.deviceHandles) bus.deviceHandles = Uint32Array.from(bus.devices);
    const c = this.t.countsOn(bus.deviceHandles);
    return { moving: c.moving, stopped: c.stopped, faulted: c.faulted, lockouts: c.lockoutsPending };
  }

  refreshStatus(only) {
    if (this.palette) this.palette.changes.touch();
    const nodes = only ? [only] : this.users;
    if (this.state === 'failed') {
      for (const node of nodes) this.statusBoard.set(node, errorStatus(this.failure.code));
      return;
    }
    if (this.state !== 'ready') return;
    const now = clock.now();
    let all = null;
    for (const node of nodes) {
      const sticky = this.sticky.get(node);
      if (sticky && sticky.until > now) {
        this.statusBoard.set(node, sticky.status);
        continue;
      }
      if (sticky) this.sticky.delete(node);
      if (!this.gateOpen) {
        this.statusBoard.set(node, DRAINING_STATUS);
        continue;
      }
      const bus = this.busOf(node);
      if (bus && bus.connected === false) {
        this.statusBoard.set(node, { fill: 'red', shape: 'ring', text: 'mqtt down' });
        continue;
      }
      let counts;
      let offline;
      if (bus && bus.devices) {
        counts = this.countsOn(bus);
        offline = [...bus.devices].filter((d) => this.offline.has(d)).length;
      } else {
        if (!all) {
          const c = this.t.counts();
          all = { ...c, lockouts: c.lockoutsPending };
        }
        counts = all;
        offline = this.offline.size;
      }
      const bad = bus ? bus.bad : 0;
      const ignored = bus ? bus.ignored : 0;
      // The same counts as last shown on this node: no text to make again (hundreds of changes a second at plant scale).
      const seen = this.countsShown.get(node);
      const figures = [counts.moving, counts.stopped, counts.faulted, counts.lockouts, bad, ignored, offline];
      if (seen && this.statusBoard.shown.get(node) === seen.key && figures.every((n, i) => n === seen.figures[i])) continue;
      const status = actuatorStatus({ ...counts, bad, ignored }, { offline });
      this.statusBoard.set(node, status);
      this.countsShown.set(node, { figures, key: this.statusBoard.shown.get(node) });
    }
  }

  /** A short reason in a red ring: on an actuators node for a while, on other nodes until their next accepted command. */
  showError(node, code) {
    const status = errorStatus(code);
    this.sticky.set(node, { status, until: this.busOf(node) ? clock.now() + BUS_ERROR_MS : Infinity });
    this.statusBoard.set(node, status);
  }
}

// The actuator layer's own time per call, for the overhead figures.
timeLayer(PlantRuntime, 'actuator', ['command', 'feedback', 'tick']);


/**
 * Whether an actuators node's events output (its third) is wired: at plant
 * scale an event msg per changed value costs as much as the feedback itself,
 * and one wired to nothing goes nowhere.
 */
function eventsWired(node) {
  return !Array.isArray(node.wires) || (Array.isArray(node.wires[2]) && node.wires[2].length > 0);
}

/** A group command msg held by a group command or actuators node until its command completes. */
function msgEntry({ node, msg, send, done, output, outputs, payload, lockout, sinceMs }) {
  const entry = heldMsg({ node, msg, send, done, sinceMs, output, outputs, payload, lockout, completed: [], retries: new Map() });
  entry.complete = (result) => {
    msg.command = result;
    if (entry.send) {
      if (outputs === 1) {
        entry.send(msg);
      } else {
        const out = new Array(outputs).fill(null);
        out[output] = msg;
        entry.send(out);
      }
    }
    if (entry.done) entry.done();
  };
  entry.refuse = entry.reject;
  return entry;
}

/** A group command of the palette itself (an operation step, a lockout): the outcome goes to `onDone`, once. */
function callbackEntry({ payload, onDone, sinceMs, msg = null, lockout = false }) {
  const entry = heldMsg({ node: null, msg, send: null, done: null, sinceMs, payload, lockout, completed: [], retries: new Map() });
  let answered = false;
  const answer = (err) => {
    if (answered) return;
    answered = true;
    onDone(err || null);
  };
  entry.complete = () => answer(null);
  entry.refuse = (err) => answer(err);
  return entry;
}

/**
 * A payload as the text its device sent: `mqtt in` hands over text, a Buffer
 * (null here: passed as bytes), or what auto-detect parsed from JSON text.
 */
function payloadText(payload) {
  if (typeof payload === 'string') return payload;
  try {
    if (payload instanceof Uint8Array) return null; // a Buffer too
  } catch (err) {
    return JSON.stringify(`(unreadable: ${clip(err && err.message)})`); // a revoked proxy
  }
  if (payload === undefined) return '';
  return jsonText(payload, true);
}

/**
 * JSON text of a value; one that cannot be written (circular, too deep, a
 * getter that throws) becomes a string saying so, which the core refuses as
 * it would any wrong value: at the top, or in its own field (`value`).
 */
function jsonText(value, top) {
  try {
    const text = JSON.stringify(value);
    return text === undefined ? JSON.stringify(String(value)) : text;
  } catch (err) {
    if (top && value !== null && typeof value === 'object' && !Array.isArray(value)) {
      try {
        const fields = Object.keys(value).slice(0, 1000).map((k) => `${JSON.stringify(k)}:${jsonText(value[k], false)}`);
        return `{${fields.join(',')}}`;
      } catch {
        // a proxy or getter that throws on its keys: unreadable as a whole
      }
    }
    return JSON.stringify(`(unreadable: ${clip(err && err.message)})`);
  }
}

/** A value as a short quote for a log line. */
function clip(value) {
  const s = String(value);
  return s.length > 60 ? `${s.slice(0, 57)}...` : s;
}

module.exports = { PlantRuntime };
