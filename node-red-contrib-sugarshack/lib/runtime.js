'use strict';
// The running interlock behind one config node: one core Interlock plus what
// Node-RED owns around it (waiting msgs, status, persistence, event fan-out).
// Every rule is the core's; this only calls it and acts on what it returns.
const { SugarshackError, asSugarshackError } = require('./errors');
const { PendingRegistry } = require('./pending');
const { deliver, grantedBy, routeGrants } = require('./grants');
const { EventFanout, describeWarning } = require('./events');
const { countsStatus, errorStatus, StatusBoard } = require('./status');
const { stats, timeLayer } = require('./stats');

const TICK_MS = 1000;

class InterlockRuntime {
  /**
   * owner: the config node (logs through it); Interlock: the wasm class;
   * config: the core configuration; persistence: a Persistence or null;
   * plant: the TrackerRuntime of the plant it is bound to, or null.
   */
  constructor({ owner, Interlock, config, persistence, plant = null }) {
    this.owner = owner;
    this.plant = plant;
    this.Interlock = Interlock;
    this.config = config;
    this.persistence = persistence || null;
    this.state = 'starting'; // -> ready | failed -> closed
    this.failure = null;
    this.il = null;
    this.waiting = [];
    this.pending = new PendingRegistry();
    this.events = new EventFanout();
    this.users = new Set();
    this.statusBoard = new StatusBoard();
    this.tickTimer = null;
    this.flushScheduled = null;
    this.unsaved = false; // a state change not yet saved
  }

  // ---- lifecycle -----------------------------------------------------------

  /** Builds the core interlock, restoring saved state first when persistence is on. */
  start(configError) {
    if (configError) {
      this.fail(configError);
      return Promise.resolve();
    }
    if (!this.persistence) {
      this.open(undefined);
      return Promise.resolve();
    }
    return this.persistence.load().then(
      (snapshot) => this.open(snapshot),
      (err) => this.fail(new SugarshackError('INVALID_SNAPSHOT', `cannot read the saved interlock state: ${err.message || err}`)),
    );
  }

  open(snapshot) {
    if (this.state !== 'starting') return;
    const now = Date.now();
    try {
      // Queued requests are dropped on restore: the msgs that waited for them are gone.
      this.il = snapshot
        ? this.Interlock.restore(this.config, snapshot, false, now)
        : new this.Interlock(this.config);
    } catch (err) {
      const e = asSugarshackError(err);
      if (e.code === 'INVALID_SNAPSHOT' && this.persistence) {
        e.message += ` (to start afresh, delete global context key '${this.persistence.key}')`;
      }
      this.fail(e);
      return;
    }
    this.state = 'ready';
    if (this.persistence) this.persistQuietly(now);
    if (this.config.warnQueuedMs || this.config.warnHeldMs) {
      this.tickTimer = setInterval(() => this.tick(), TICK_MS);
    }
    this.scheduleFlush();
    this.refreshStatus();
    const waiting = this.waiting;
    this.waiting = [];
    for (const task of waiting) task.run();
  }

  fail(err) {
    if (this.state !== 'starting') return;
    const e = asSugarshackError(err);
    this.failure = e;
    this.state = 'failed';
    this.owner.error(e.message);
    this.refreshStatus();
    const waiting = this.waiting;
    this.waiting = [];
    for (const task of waiting) task.fail(e);
  }

  /** Completes every waiting msg without sending it, saves the state, frees the core. */
  async close() {
    const wasReady = this.state === 'ready';
    this.state = 'closed';
    if (this.tickTimer) clearInterval(this.tickTimer);
    if (this.flushScheduled) clearImmediate(this.flushScheduled);
    this.tickTimer = null;
    this.flushScheduled = null;
    for (const task of this.waiting.splice(0)) task.abandon();
    if (wasReady) this.flushEvents(); // what happened before the close, still unpublished
    if (!wasReady) {
      await this.persistence?.flush().catch(() => {});
      return;
    }
    const now = Date.now();
    // Last in grant order first: withdrawing a waiter then unblocks nobody.
    for (const handle of Array.from(this.il.queuedOperations()).reverse()) {
      const entry = this.pending.take(handle);
      if (entry) {
        this.il.cancel(handle, now);
        entry.done();
      }
    }
    for (const handle of this.pending.handles()) this.pending.take(handle).done();
    this.il.drainEvents();
    if (this.persistence) {
      try {
        await this.persist(now);
      } catch (err) {
        this.owner.error(`cannot save the interlock state: ${err.message || err}`);
      }
    }
    this.il.free();
    this.il = null;
  }

  // ---- nodes using this interlock ------------------------------------------

  addUser(node) {
    this.users.add(node);
    this.refreshStatus(node);
  }

  removeUser(node) {
    this.users.delete(node);
    this.events.remove(node);
  }

  addEventsNode(node) {
    this.events.add(node);
    this.scheduleFlush();
  }

  /**
   * Runs `work` once the interlock is ready. A refusal (thrown) completes the msg
   * with the error, so a Catch node gets it, and shows a short reason on the node.
   */
  submit(node, done, work) {
    const task = {
      run: () => {
        try {
          work(this);
        } catch (err) {
          const e = asSugarshackError(err);
          this.showError(node, e.code);
          done(e);
        }
      },
      fail: (err) => done(err),
      abandon: () => done(),
    };
    if (this.state === 'ready') task.run();
    else if (this.state === 'starting') this.waiting.push(task);
    else if (this.state === 'failed') task.fail(this.failure);
    else task.abandon();
  }

  // ---- interlock calls (each throws the core's refusal unchanged) ----------

  /** Grants and sends the msg on at once, or holds it until a grant. */
  acquire({ node, msg, send, done, operation, priority, resources, timeoutMs }) {
    const now = Date.now();
    const handle = this.il.operation(operation);
    const set = this.il.resourceSet(resources);
    const entry = { node, msg, send, done, operation, priority, resources, sinceMs: now, timer: null };
    if (this.il.acquire(handle, priority, set, now)) {
      deliver(entry, now);
    } else {
      this.pending.add(handle, entry);
      if (timeoutMs > 0) entry.timer = setTimeout(() => this.expire(handle, entry, timeoutMs), timeoutMs);
    }
    this.settle([], now);
  }

  release(operation) {
    const now = Date.now();
    const grants = grantedBy(this.il, this.il.release(this.findOperation(operation), now));
    this.settle(grants, now);
  }

  /** Withdraws a queued request; its held msg is completed without being sent. */
  cancel(operation) {
    const now = Date.now();
    const handle = this.findOperation(operation);
    const grants = grantedBy(this.il, this.il.cancel(handle, now));
    this.completeUnsent(handle);
    this.settle(grants, now);
  }

  /** Returns the lockouts ([{ resource, command }]) to issue. */
  fault(operation, note) {
    const now = Date.now();
    const handle = this.findOperation(operation);
    const outcome = this.il.fault(handle, note, now);
    if (outcome.dropped) this.completeUnsent(handle);
    this.settle(outcome.grants, now);
    return outcome.lockouts;
  }

  faultResources(names, note) {
    const now = Date.now();
    const outcome = this.il.faultResources(this.il.resourceSet(names), note, now);
    this.settle(outcome.grants, now);
    return outcome.lockouts;
  }

  /** Clears the named resources, or every faulted one when `names` is null; returns what was cleared. */
  clear(names) {
    const now = Date.now();
    const targets = names === null ? this.il.faultedResources() : names;
    if (names === null && targets.length === 0) return [];
    const grants = grantedBy(this.il, this.il.clear(this.il.resourceSet(targets), now));
    this.settle(grants, now);
    return targets;
  }

  faultedResources() {
    return this.il.faultedResources();
  }

  /** An acquire node is closing: withdraw its waiting requests and complete their msgs. */
  dropNode(node) {
    if (this.state !== 'ready') return;
    const mine = new Set(this.pending.handles(node));
    if (mine.size === 0) return;
    const now = Date.now();
    const grants = [];
    for (const handle of Array.from(this.il.queuedOperations()).reverse()) {
      if (!mine.has(handle)) continue;
      const entry = this.pending.take(handle);
      grants.push(...grantedBy(this.il, this.il.cancel(handle, now)));
      entry.done();
    }
    for (const handle of this.pending.handles(node)) this.pending.take(handle).done();
    this.settle(grants, now);
  }

  // ---- internals -----------------------------------------------------------

  findOperation(name) {
    if (!name) throw new SugarshackError('MISSING_OPERATION', 'an operation id is required');
    return this.il.findOperation(name);
  }

  completeUnsent(handle) {
    const entry = this.pending.take(handle);
    if (entry) entry.done();
  }

  expire(handle, entry, timeoutMs) {
    if (this.state !== 'ready' || this.pending.get(handle) !== entry) return;
    const now = Date.now();
    this.pending.take(handle);
    let grants = [];
    try {
      grants = grantedBy(this.il, this.il.cancel(handle, now));
    } catch (err) {
      this.owner.warn(`timed-out request of '${entry.operation}' was no longer queued: ${err.message}`);
    }
    this.settle(grants, now);
    this.showError(entry.node, 'ACQUIRE_TIMEOUT');
    entry.done(new SugarshackError(
      'ACQUIRE_TIMEOUT',
      `operation '${entry.operation}' was not granted ${entry.resources.join(', ')} within ${timeoutMs / 1000} s; its request was withdrawn`,
    ));
  }

  /**
   * After every state change: send granted msgs and update status now; save and
   * publish events once per turn of the event loop, however many calls it held.
   */
  settle(grants, now) {
    try {
      routeGrants(this.il, this.pending, grants, { nowMs: now, warn: (text) => this.owner.warn(text) });
    } catch (err) {
      this.owner.error(`cannot route grants: ${err.message || err}`);
    }
    this.refreshStatus();
    this.unsaved = true;
    this.scheduleFlush();
  }

  persist(now) {
    return this.persistence.save(this.il.snapshot(now));
  }

  persistQuietly(now) {
    this.persist(now).catch((err) => this.owner.error(`cannot save the interlock state: ${err.message || err}`));
  }

  tick() {
    if (this.state !== 'ready') return;
    for (const warning of this.il.tick(Date.now())) this.owner.warn(describeWarning(warning));
    this.flushEvents();
  }

  scheduleFlush() {
    if (this.flushScheduled || this.state !== 'ready') return;
    this.flushScheduled = setImmediate(() => {
      this.flushScheduled = null;
      if (this.state === 'ready') stats.time('interlock', () => this.flush());
    });
  }

  flush() {
    if (this.persistence && this.unsaved) this.persistQuietly(Date.now());
    this.unsaved = false;
    this.flushEvents();
  }

  flushEvents() {
    this.events.publish(this.il.drainEvents());
  }

  refreshStatus(only) {
    let status;
    if (this.state === 'ready') status = countsStatus(this.il.counts());
    else if (this.state === 'failed') status = errorStatus(this.failure.code);
    else if (this.state === 'starting') status = { fill: 'grey', shape: 'ring', text: 'starting' };
    else return;
    for (const node of only ? [only] : this.users) this.setStatus(node, status);
  }

  showError(node, code) {
    this.setStatus(node, errorStatus(code));
  }

  setStatus(node, status) {
    this.statusBoard.set(node, status);
  }
}

// The interlock layer's own time per call, for the overhead figures.
timeLayer(InterlockRuntime, 'interlock', ['acquire', 'release', 'cancel', 'fault', 'faultResources', 'clear']);

module.exports = { InterlockRuntime };
