// @ts-check
'use strict';
// The running plant behind one plant config node, for the whole life of the
// Node-RED process: one core Tracker (actuators, sensors, the document's
// operations and routines) and its lifecycle (start, deploys, rebuild after a
// trap, shutdown). What Node-RED owns around the core lives in the parts it
// composes: the actuators nodes and MQTT path (plant-bus.js), the group
// commands in flight (plant-commands.js), the sensor watchers (plant-sensors.js),
// the Modbus connections (modbus-transport.js) and the nodes' status (plant-status.js). Every rule is the core's; this
// calls it and hands the effects it returns to the part they concern.
const { SugarshackError } = require('../host/errors');
const { stats, timeLayer } = require('../host/stats');
const { clock } = require('../host/clock');
const { RuntimeBase } = require('../host/runtime-base');
const { PlantBuses } = require('./plant-bus');
const { GroupCommands } = require('./plant-commands');
const { SensorWatch } = require('./plant-sensors');
const { PlantStatus } = require('./plant-status');
const { PlantChanges } = require('./plant-changes');
const { ModbusTransport } = require('./modbus-transport');
const wasm = require('../wasm');
const i18n = require('../host/i18n');
const { clusterOf } = require('../cluster');

// How often each actuators node's broker connection is looked at (its config node tells no one).
const BROKER_POLL_MS = 250;
const MAX_TIMER_MS = 2 ** 31 - 1;

class PlantRuntime extends RuntimeBase {
  /**
   * settings: { plant (the document), error }; RED, for the hot-standby cluster of this Node-RED, if any.
   * @param {{ id: string, settings: any, RED?: any }} o
   */
  constructor({ id, settings, RED = null }) {
    super('plant');
    this.id = id;
    this.swapOrder = 0; // before the interlocks bound to it
    this.plant = settings.plant;
    this.plantError = settings.error || null;
    this.t = null;
    this.deadline = null; // { at, timer }: the one timer, for the earliest of the core's next wake and the polls below
    this.coreWake = undefined; // when the core's tick is next due (epoch ms), if ever
    this.nextPoll = Infinity; // the next look at the brokers' connections
    this.bus = new PlantBuses(this);
    this.commands = new GroupCommands(this);
    this.sensors = new SensorWatch(this);
    this.statusView = new PlantStatus(this);
    this.changes = new PlantChanges((err) => this.log('error', err.message || String(err)));
    this.modbus = new ModbusTransport(this);
    /** @type {Set<() => void>} told when the alarm conditions of its devices and buses may have changed */
    this.conditionWatchers = new Set();
    this.conditionsToTell = false;
    // In a hot-standby cluster the plant follows the feedback on every instance and commands only from the leader.
    try {
      this.cluster = clusterOf(RED);
    } catch (err) {
      this.cluster = null;
      this.plantError = err;
    }
    this.stopFollowing = this.cluster ? this.cluster.follow({
      activate: () => {
        this.modbus.sync();
        this.refreshStatus();
      },
      standDown: () => {
        this.modbus.sync();
        return this.bus.standDown();
      },
      resumed: () => this.bus.sendWaiting('held'),
    }) : null;
  }

  /** A standby (not the elected leader) commands nothing; its feedback still goes in. */
  get standby() {
    return this.cluster !== null && !this.cluster.active;
  }

  /** The actuators nodes serving this plant (read by the interlock's alarms). */
  get buses() {
    return this.bus.list;
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
    this.step('started');
    this.tracking();
    this.replayParked();
  }

  /** A new tracker in force: the timer, the Modbus links, the status and the alarm conditions follow it. */
  tracking() {
    this.changes.rebuilt();
    this.followDeadline();
    this.modbus.sync();
    this.refreshStatus();
    this.conditionsMayHaveChanged();
  }

  fail(err) {
    super.fail(err);
    this.conditionsMayHaveChanged();
  }

  /** A core tracker for `plant`; its ids, types and per-device slots are read once. */
  makeTracker(plant) {
    const { Tracker } = wasm.load();
    const t = new Tracker(plant, clock.now());
    this.devices = t.devices();
    this.deviceIndex = new Map(this.devices.map((id, handle) => [id, handle]));
    this.actuators = t.actuators();
    this.sensorNames = t.sensors();
    this.bus.resolve();
    for (const warning of t.warnings()) this.log('warn', i18n.text('logs.plantWarning', { warning }));
    return t;
  }

  /** A shutdown: held msgs are completed unsent; nothing else moves. */
  async shutdown() {
    if (this.ended) return;
    const wasReady = this.state === 'ready';
    if (this.stopFollowing) this.stopFollowing();
    this.stopFollowing = null;
    this.endCommon();
    this.statusView.stop();
    this.freeTracker(wasReady);
    this.conditionsMayHaveChanged();
  }

  /** Its config node left the flows: the same as a shutdown (the tracker keeps nothing on disk). */
  retire() {
    return this.shutdown();
  }

  /** Held commands end unsent and the timer stops; the tracker, if `built`, is freed with its Modbus links. */
  freeTracker(built) {
    this.commands.endAll();
    this.stopDeadline();
    if (!built) return;
    this.modbus.closeAll();
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
    return this.commands.onlyLockouts() && !this.sensors.waiting();
  }

  /** The new document after the drain: a new tracker; the lockouts of faulted lines go out again through the interlocks. */
  swap(settings) {
    this.plant = settings.plant;
    this.plantError = settings.error || null;
    this.sensors.forget({ watchers: true });
    this.freeTracker(this.t !== null);
    this.step('restart');
    this.failure = null;
    this.start();
  }

  /** After a wasm trap: a new tracker (positions come back with the next feedback); held commands fail. */
  rebuild() {
    if (this.state !== 'ready') return;
    this.commands.endAll(SugarshackError.of('INTERNAL', 'plantRebuilt'));
    this.modbus.closeAll();
    wasm.forget(this.t);
    this.t = null;
    this.sensors.forget({ watchers: false });
    try {
      this.t = this.makeTracker(this.plant);
    } catch (err) {
      this.fail(err);
      return;
    }
    this.tracking();
  }

  // ---- nodes using this plant ----------------------------------------------

  removeUser(node) {
    super.removeUser(node);
    this.statusView.dropRefusal(node);
  }

  /** An actuators node (see PlantBuses.add). */
  addBus(node, names, broker) {
    this.bus.add(node, names, broker, this.state === 'ready');
    this.arm(); // its broker is looked at from now on
    this.modbus.sync();
    this.refreshStatus(node);
    this.conditionsMayHaveChanged();
  }

  heldEntries() {
    return this.commands.entries();
  }

  /** A plant has no engine: the commands of a node that did not come back by the deploy's end are withdrawn here. */
  closing(node, removed) {
    this.bus.remove(node);
    this.modbus.sync();
    this.conditionsMayHaveChanged();
    const settle = () => {
      if (this.state !== 'ready') return;
      this.commands.withdrawOrphans(node.id);
      this.refreshStatus();
    };
    if (removed) settle();
    else this.palette.whenStarted(settle);
  }

  // ---- calls from nodes and runs (see the part each goes to) ---------------

  issueLockouts(lockouts, operation) {
    if (this.state !== 'ready') {
      if (lockouts.length) this.log('error', i18n.text('logs.lockoutsNotSent', { lines: lockouts.map((l) => l.resource).join(', ') }));
      return;
    }
    this.commands.lockouts(lockouts, operation);
  }

  /** Writes a Modbus output (`output/<id>`), untracked; throws UNKNOWN_OUTPUT, INVALID_TARGET, DEVICE_OFFLINE. */
  output(id, value) {
    this.guard(() => this.t.output(id, value, clock.now()));
    this.flush(null);
  }

  // ---- time and effects ----------------------------------------------------

  /** The core's next wake (`next`, epoch ms; never when undefined): the one timer follows it. */
  setDeadline(next) {
    this.coreWake = next;
    this.arm();
  }

  /**
   * The one timer, at the earliest of the core's wake, the next look at the
   * brokers (while any actuators node has one) and the end of a refusal shown.
   */
  arm() {
    if (this.state !== 'ready') {
      this.stopDeadline();
      return;
    }
    if (this.nextPoll === Infinity && this.bus.list.some((b) => b.broker)) this.nextPoll = clock.now() + BROKER_POLL_MS;
    const at = Math.min(this.coreWake === undefined ? Infinity : this.coreWake, this.nextPoll, this.statusView.shownUntil());
    if (this.deadline && this.deadline.at === at) return;
    this.stopDeadline();
    if (at === Infinity) return;
    // Node fires a longer timeout at once; woken early, it sleeps again until the deadline.
    const timer = clock.setTimeout(() => this.wake(), Math.min(Math.max(0, at - clock.now()), MAX_TIMER_MS));
    this.deadline = { at, timer };
  }

  stopDeadline() {
    if (this.deadline) clock.clearTimeout(this.deadline.timer);
    this.deadline = null;
  }

  /** After a call that answered no wake: the timer follows the core's. */
  followDeadline() {
    if (this.state === 'ready') this.setDeadline(this.t.nextWake());
  }

  /** The timer: the brokers looked at when due, the core's tick when due, a refusal shown ended; then the timer again. */
  wake() {
    this.deadline = null;
    if (this.state !== 'ready') return;
    try {
      this.guard(() => {
        const now = clock.now();
        if (this.nextPoll <= now) {
          this.nextPoll = Infinity;
          this.bus.watchBrokers();
        }
        if (this.coreWake !== undefined && this.coreWake <= now) {
          if (this.t.tick(now) > 0) this.flush(null);
          this.sensors.expire(now);
          this.coreWake = this.t.nextWake();
          // Staleness falls due on the core's wake.
          this.conditionsMayHaveChanged();
        }
        if (this.statusView.shownUntil() <= now) this.refreshStatus();
      });
    } catch (err) {
      this.log('error', err.message);
    }
    this.arm();
  }

  /**
   * After every core call: act on its effects, then update status. `source`:
   * the feedback msg's bus and topic. `answer`: what the call answered in one
   * value (effects, the timing figures they measure, whether they may move the
   * status or the devices' health, next deadline, counts), else the queued effects are taken as one. A
   * feedback msg whose effects are only new values (or none: the usual report
   * of positions that did not move) changed no count, so the status is left as it is.
   * @param {{ bus: any, topic: string } | null} source
   * @param {{ effects?: any[], timings?: [string, number][], status?: boolean, health?: boolean, deadline?: number, counts?: any, lockout?: boolean }} [answer]
   */
  flush(source, answer = this.t.queued() > 0 ? JSON.parse(this.t.takeAnswer()) : {}) {
    const effects = answer.effects || [];
    for (const [series, ms] of answer.timings || []) stats.add(series, ms);
    try {
      for (const effect of effects) this.route(effect, source);
    } catch (err) {
      answer.status = true;
      answer.health = true;
      this.log('error', i18n.text('logs.effectsNotRouted', { message: err.message || err }));
    }
    if (answer.health) this.conditionsMayHaveChanged();
    // An answer with effects or a command carries the core's next wake.
    if (answer.effects || answer.lockout !== undefined) this.setDeadline(answer.deadline);
    this.changes.effects(effects);
    if (source === null) this.refreshStatus(undefined, answer.counts);
    else if (answer.status) this.statusView.request();
    else if (this.palette) this.palette.changes.touch(this);
  }

  /** One effect of the core, to the part it concerns. */
  route(e, source) {
    switch (e.kind) {
      case 'publish':
        this.bus.publish(e);
        break;
      case 'modbusSend':
        this.modbus.pump(e.connection);
        break;
      case 'groupCompleted':
      case 'groupFailed':
      case 'groupTimedOut':
        this.commands.settle(e);
        break;
      case 'deviceStatus':
        this.bus.deviceStatus(e);
        break;
      case 'rejected':
        this.bus.reject(e, source);
        break;
      case 'malformed':
        this.bus.malformed(source ? source.bus : null, source ? source.topic : '', e.device, e.reason, e.message);
        break;
      default:
        this.bus.emitActuator(e);
    }
  }

  // ---- alarm conditions ----------------------------------------------------

  /**
   * Calls `fn` when the alarm conditions of its devices (the core's
   * `alarmConditions`) or of its buses may have changed, at most once per
   * turn of the event loop; returns the function that stops it.
   * @param {() => void} fn
   */
  watchConditions(fn) {
    this.conditionWatchers.add(fn);
    return () => this.conditionWatchers.delete(fn);
  }

  /** A device, a bus or the tracker itself may have changed: the watchers are told once this burst is over. */
  conditionsMayHaveChanged() {
    if (this.conditionsToTell || this.conditionWatchers.size === 0) return;
    this.conditionsToTell = true;
    setImmediate(() => {
      this.conditionsToTell = false;
      for (const fn of [...this.conditionWatchers]) fn();
    });
  }

  // ---- state and status ----------------------------------------------------

  /**
   * The plant as a person (or a dashboard) reads it: unconfirmed lockouts,
   * each device online or offline and its actuators with stale feedback, the
   * last value of every sensor and whether it is fresh, each actuators node's
   * broker connection; the document's operations in its words.
   */
  describe() {
    if (this.state !== 'ready') return { failure: this.failure ? { code: this.failure.code, message: this.failure.message } : null };
    return { ...this.t.health(clock.now()), buses: this.buses.map((b) => ({ node: b.nodeId, connected: b.connected })) };
  }

  /** `counts`: the core's counts of every actuator, if a call just answered them. */
  refreshStatus(only, counts) {
    this.statusView.refresh(only, counts);
  }

  showError(node, code) {
    this.statusView.showError(node, code);
  }
}

// The actuator layer's own time per call, for the overhead figures.
timeLayer(PlantRuntime, 'actuator', ['wake']);
timeLayer(GroupCommands, 'actuator', ['command']);
timeLayer(PlantBuses, 'actuator', ['feedback']);

module.exports = { PlantRuntime };
