// @ts-check
'use strict';
// The interlock behind a config node bound to no plant, run by one core
// Engine: a node's msg becomes one engine input under a handle, and the
// engine's outputs are performed by the carrier (grants, refusals and
// timeouts, lockouts, events, journal lines, alarms, the one timer). What
// is left here is I/O: reading a msg's fields, the state file, the status,
// the events nodes and the editor's requests.
const { SugarshackError } = require('../host/errors');
const { heldMsg } = require('./pending');
const { describeEvent } = require('./events');
const { countsStatus } = require('../host/status');
const { clock } = require('../host/clock');
const { Committer } = require('../host/durable');
const { InterlockHost } = require('./host');
const { EngineCarrier, CarriedMsg, refusalError, render } = require('./engine-carrier');
const { Wire } = require('../wasm/wire');
const { unreadable, fieldsOf } = require('./request');
const { journal } = require('../journal/bus');
const { timeLayer } = require('../host/stats');
const wasm = require('../wasm');
const i18n = require('../host/i18n');

// Text up to this long crosses as a string argument; longer, the facade reads its length and head only.
const SHORT_TEXT = 1000;
// A msg handle is a u32 the engine keeps; it wraps long after any msg of its range ended.
const HANDLES = 2 ** 32;
// Operation runs (lib/operations/operation-run.js) ask the engine as nodes of these handles, above any node's.
const RUN_NODES = [
  [0xfffffff0, { kind: 'acquire', timeoutMs: 0 }],
  [0xfffffff1, { kind: 'release' }],
  [0xfffffff2, { kind: 'cancel' }],
  [0xfffffff3, { kind: 'fault', byResources: false, failMsg: false }],
];
const [RUN_ACQUIRE, RUN_RELEASE, RUN_CANCEL, RUN_FAULT] = RUN_NODES.map(([handle]) => handle);

/** Each node kind's input: its outputs, and the engine call a msg makes (read first, so a throwing getter refuses the msg). */
const KINDS = {
  acquire: {
    ports: 1,
    // The node's values read for this msg (from context, env or JSONata) go with the msg's.
    read: (msg, values) => (values
      ? [msg.operation, msg.priority, msg.resources, { operation: msg.operation, priority: msg.priority, resources: msg.resources, configured: values }]
      : [msg.operation, msg.priority, msg.resources]),
    // The same input four ways: with nothing, with only an operation's short text (one string crosses), with anything, with the node's values read.
    call: (e, now, h, k, [operation, priority, resources, fields]) => {
      if (fields) e.acquireFields(h, k, fields, now);
      else if (priority !== undefined || resources !== undefined) e.acquireNamed(h, k, operation, priority, resources, now);
      else if (operation === undefined) e.acquire(h, k, now);
      else if (typeof operation === 'string' && operation.length <= SHORT_TEXT) e.acquireOperation(h, k, operation, now);
      else e.acquireNamed(h, k, operation, priority, resources, now);
    },
  },
  release: {
    ports: 1,
    read: (msg, values) => [msg.operation, msg.interlock ? msg.interlock.operation : undefined, values],
    call: (e, now, h, k, [operation, follow, values]) => {
      if (values) e.releaseFields(h, k, { operation, follow, configured: values }, now);
      // Text or nothing in both crosses as strings; anything else the facade reads as JS values.
      else if (isShortText(operation) && isShortText(follow)) e.releaseTexts(h, k, operation, follow, now);
      else e.release(h, k, operation, follow, now);
    },
  },
  cancel: { ports: 1, read: withValues, call: (e, now, h, k, fields) => e.cancel(h, k, fields, now) },
  fault: { ports: 2, read: withValues, call: (e, now, h, k, fields) => e.fault(h, k, fields, now) },
  clear: { ports: 2, read: withValues, call: (e, now, h, k, fields) => e.clear(h, k, fields, fields.resources !== undefined, now) },
};

/** Undefined, null, or text short enough to cross whole as a string argument. */
function isShortText(value) {
  return value === undefined || value === null || (typeof value === 'string' && value.length <= SHORT_TEXT);
}

/** What a msg carries, with the node's values read for it (from context, env or JSONata) when it has any. */
function withValues(msg, values) {
  return values ? { ...fieldsOf(msg), configured: values } : fieldsOf(msg);
}

class EngineRuntime extends InterlockHost {
  constructor(args) {
    super(args);
    /** @type {any} the core Engine (tests and the state page read it as the interlock) */
    this.core = null;
    /** @type {Wire | null} */
    this.wire = null;
    this.carrier = this.makeCarrier();
    this.performing = false;
    /** @type {{ run: (engine: any, now: number) => void, failed?: (err: Error) => void }[]} calls made while outputs are performed */
    this.deferred = [];
    /** @type {Map<string, number>} node id -> its handle, the same for each deploy of it */
    this.nodeHandles = new Map();
    /** @type {Map<number, { node: NodeRed.Node, spec: any, kind: any }>} handle -> the instance bound now, with its kind's input */
    this.nodes = new Map();
    this.nextMsg = 0;
    this.starts = 0; // start() calls so far: one whose reads a later one overtook stops where it is
    /** @type {{ ports: any[], error: SugarshackError } | null} operation nodes' ports of held runs, waiting for a start after a failure to restore them */
    this.portsAwaitingRuns = null;
    /** @type {Map<number, { resolve: Function, reject: Function }>} operator requests waiting for their reply */
    this.replies = new Map();
    this.failingShown = false;
    // A journal attached later hears every event too.
    this.stopJournalWatch = journal.watch(() => this.listenChanged());
    this.counts = { holding: 0, queued: 0, faulted: 0, lost: false };
    this.shown = { holding: 0, queued: 0, faulted: 0, lost: false, status: countsStatus({ holding: 0, queued: 0, faulted: 0, lost: false }) };
  }

  makeCommitter() {
    return new Committer({
      store: this.store,
      clock,
      snapshot: () => this.core.seal(this.id, this.settings.plantId || undefined, this.routineSnapshots(), clock.now(), this.heldRuns()),
      // In a hot-standby cluster, only while this instance leads.
      mayAct: () => !this.cluster || this.cluster.mayAct(),
      onError: (err) => {
        this.log('error', i18n.text('logs.stateNotSaved', { where: this.store.where, message: err.message || err }));
        this.storeFailing(true);
      },
      onSaved: () => {
        this.storeFailing(false);
        this.statusPacer.request();
      },
    });
  }

  makeCarrier() {
    return new EngineCarrier({
      committer: this.committer,
      other: (output, effect) => this.other(output, effect),
      counts: (holding, queued, faulted, lost) => this.countsChanged(holding, queued, faulted, lost),
      due: () => this.tick(),
      routinesDue: (now) => this.routinesDue(now),
    });
  }

  /**
   * One engine call, `fn(engine, now, a, b, c)`; its outputs performed. `failed(err)`: told
   * when the call, deferred, throws (its msg ends with the error; else the error is logged).
   * @param {(engine: any, now: number, a?: any, b?: any, c?: any) => void} fn @param {any} [a] @param {any} [b] @param {any} [c]
   * @param {(err: Error) => void} [failed]
   */
  call(fn, a, b, c, failed) {
    if (!this.core) return;
    // An output performed may make another call (a run's release answered, its routine dispatches
    // the next operation): it waits until this call's outputs are all read, which the next would overwrite.
    if (this.performing) {
      this.deferred.push({ run: (e, now) => fn(e, now, a, b, c), failed });
      return;
    }
    this.performing = true;
    try {
      try {
        wasm.reading(this, fn, this.core, clock.now(), a, b, c);
      } catch (err) {
        throw this.trapped(err);
      }
      /** @type {EngineCarrier} */ (this.carrier).perform(/** @type {Wire} */ (this.wire));
      while (this.deferred.length > 0 && this.core) {
        const next = /** @type {{ run: (engine: any, now: number) => void, failed?: (err: Error) => void }} */ (this.deferred.shift());
        try {
          this.guard(() => wasm.reading(this, next.run, this.core, clock.now()));
        } catch (err) {
          if (next.failed) next.failed(err);
          else this.log('error', err.message);
        }
        /** @type {EngineCarrier} */ (this.carrier).perform(/** @type {Wire} */ (this.wire));
      }
    } finally {
      this.performing = false;
      // Setting an array's length is a runtime call in V8: only when something was left.
      if (this.deferred.length !== 0) this.deferred.length = 0;
    }
    this.mayBeQuiet();
  }

  // ---- lifecycle -----------------------------------------------------------

  async start() {
    const start = ++this.starts;
    const latest = () => start === this.starts;
    try {
      this.config = this.resolveConfig();
      // Made before the saved state is read: msgs meanwhile wait in it, their timeouts running.
      this.guard(() => this.newEngine());
    } catch (err) {
      this.fail(err);
      return;
    }
    if (this.cluster && this.etcdStore && !(await this.loadCommitted(this.cluster, this.etcdStore, latest))) return;
    const saved = await this.readSaved();
    // Stopped, failed or on standby meanwhile: what its engine kept is answered already. A later start (elected
    // again, new settings after a failure) reads for itself: what this one read may be older.
    if (this.state !== 'starting' || !latest()) return;
    try {
      this.guard(() => this.open(saved));
    } catch (err) {
      this.fail(err);
      return;
    }
    this.markRan();
    this.step('started');
    this.restoreHeldRuns();
    this.resumeRuns();
    this.watchPlant();
    this.listenChanged();
    this.refreshStatus();
    this.resendLockouts('atStart');
    this.replayParked();
  }

  /** Its engine, made for the settings in force, started from what was saved. */
  open(saved) {
    const now = clock.now();
    this.started = { outcome: 'new', reason: null, added: [], dropped: [] };
    const plant = this.tracker();
    this.call((e) => {
      if (saved.kind === 'saved') {
        const args = [this.id, this.settings.plantId || undefined, this.store.where, saved.text, now];
        if (plant) e.startSealedAgainst(...args, plant);
        else e.startSealed(...args);
      } else {
        const [doc, lost] = saved.kind === 'lost' ? [null, saved.why] : saved.kind === 'carried-over' ? [{ interlock: saved.snapshot }, undefined] : [null, undefined];
        if (plant) e.startAgainst(doc, lost, now, plant);
        else e.start(doc, lost, now);
      }
    });
    // Started while a deploy drains: the engine holds new requests back until the drain ends.
    if (this.draining) this.call((e, at) => e.life('drain-begin', at));
    // Bound to its plant: runs saved held come back held, routines from their saved states.
    this.savedRuns = this.core.takeRestoredRuns();
    this.savedRoutines = this.core.savedRoutines();
    const lost = this.core.lost();
    this.lostState = lost === undefined ? null : lost;
    if (this.lostState !== null) this.started = { outcome: 'lost', reason: this.lostState, added: [], dropped: [] };
    else if (saved.kind !== 'first') this.started.outcome = 'restored';
  }

  newEngine() {
    const { Engine } = wasm.load();
    const engine = new Engine(this.config, { plantBound: Boolean(this.settings.plantBound), parkBound: this.bufferMax });
    if (this.core) wasm.release(this.core);
    this.core = engine;
    this.wire = new Wire(engine);
    const now = clock.now();
    this.call((e) => {
      for (const [handle, { spec }] of this.nodes) e.addNode(handle, spec, now);
      for (const [handle, spec] of RUN_NODES) e.addNode(handle, spec, now);
      // Until the flows run, events nodes may still come: the events of a start go to them.
      if (this.events.listened() || !this.flowsRunning()) e.listen(true, now);
    });
  }

  flowsRunning() {
    return !this.palette || this.palette.started;
  }

  /** Nothing more leaves: a write in flight completes, held msgs are completed unsent. */
  async shutdown() {
    if (this.ended) return;
    this.leaveCluster();
    this.endCommon();
    this.stopTimers();
    await this.committer.freeze();
    this.lifeStep('shutdown');
    this.carrier.stop();
    this.endRuns();
    this.freeCore();
  }

  /**
   * Its start failed: the msgs its engine kept for the start get the reason,
   * as those after will (the engine, never started, is freed).
   */
  fail(err) {
    const starting = this.state === 'starting' && this.core !== null;
    const parked = starting ? this.parkedOut() : [];
    super.fail(err);
    const failure = /** @type {SugarshackError} */ (this.failure);
    for (const { entry, reply } of parked) {
      if (entry) entry.reject(failure);
      else if (reply) reply.reject(failure);
    }
    // Failed part-way through its start (its engine took them, then the rest threw): nothing answers them now.
    if (starting) this.refuseHeld(failure);
    this.failAwaitingPorts(failure);
  }

  /** Stood down before it started: the msgs its engine kept are completed unsent, their nodes showing standby (the active instance answers them). */
  becomeStandby() {
    this.standByParked();
    super.becomeStandby();
  }

  standByParked() {
    if (!this.core || this.state !== 'starting') return;
    const error = this.standbyError();
    for (const { entry, reply } of this.parkedOut()) {
      if (reply) reply.reject(error);
      else if (entry) this.standbyDone(entry.node, () => entry.abandon());
    }
  }

  /**
   * Frees its unstarted engine, taking out what it kept for the start (the
   * core says which msgs): each a held msg (`entry`) or an operator's request
   * (`reply`), for the caller to answer once.
   * @returns {{ entry?: any, reply?: { resolve: Function, reject: Function } }[]}
   */
  parkedOut() {
    /** @type {number[]} */
    let handles;
    try {
      handles = [...this.guard(() => this.core.takeParked())];
    } catch {
      // Its engine unreadable (a trap): all it held waited for the start.
      handles = [...this.carrier.held.keys(), ...this.replies.keys()];
    }
    this.freeCore();
    const out = [];
    for (const k of handles) {
      const entry = this.carrier.take(k);
      const reply = entry ? undefined : this.replies.get(k);
      this.replies.delete(k);
      if (entry) out.push({ entry });
      else if (reply) out.push({ reply });
    }
    return out;
  }

  standbyError() {
    return SugarshackError.of('NO_INTERLOCK', 'standbyInterlock', { id: this.id, active: this.cluster && this.cluster.leader ? this.cluster.leader.instance : '?' });
  }

  /** Nothing of the runs and routines goes on (their state is saved as it is). */
  endRuns() {
    for (const run of this.runs) run.shutdown();
    for (const host of this.routines.values()) host.shutdown();
    this.failAwaitingPorts(null);
  }

  /** No start restores the runs their ports wait for: each owner's msg ends (with `error`, or unsent). */
  failAwaitingPorts(error) {
    const awaiting = this.portsAwaitingRuns;
    this.portsAwaitingRuns = null;
    for (const port of awaiting ? awaiting.ports : []) {
      if (error) port.fail(error);
      else if (port.abandon) port.abandon();
    }
  }

  /** Its config node left the flows: waiting requests are withdrawn and the state written. */
  async retire() {
    if (this.ended) return;
    const ready = this.state === 'ready';
    // With no interlock to supervise them, granted runs fault and waiting ones withdraw.
    if (ready) for (const run of [...this.runs]) run.interrupt('its interlock was removed from the flows');
    this.leaveCluster();
    this.endCommon('retire');
    this.stopTimers();
    // Still starting, its engine completes what it kept unsent and saves nothing.
    this.lifeStep('retire');
    if (ready) await this.committer.drain();
    this.carrier.stop();
    this.endRuns();
    this.freeCore();
  }

  /** @param {'shutdown' | 'retire'} [step] */
  endCommon(step) {
    super.endCommon(step);
    this.stopJournalWatch();
  }

  /** Deposed (a hot-standby cluster): nothing more leaves; what waited here is completed unsent, and the state followed again. */
  async standDown() {
    if (this.ended || this.state === 'standby') return;
    this.stopTimers();
    await this.committer.freeze();
    this.standByParked();
    this.carrier.stop();
    for (const [k, entry] of [...this.carrier.held]) {
      this.carrier.take(k);
      entry.abandon();
    }
    const error = this.standbyError();
    for (const { reject } of this.replies.values()) reject(error);
    this.replies.clear();
    this.endRuns();
    this.runs.clear();
    this.mayBeQuiet();
    this.routines.clear();
    this.savedRoutines = {};
    if (this.core) this.freeCore();
    this.lostState = null;
    this.committer = this.makeCommitter();
    this.carrier = this.makeCarrier();
    this.becomeStandby();
  }

  lifeStep(step) {
    try {
      this.call((e, now) => e.life(step, now));
    } catch (err) {
      this.log('error', err.message);
    }
  }

  freeCore() {
    wasm.release(this.core);
    this.core = null;
    this.wire = null;
  }

  // ---- deploys -------------------------------------------------------------

  /** A drain begins: the engine holds waiting requests back until the new settings apply. */
  onGateClosed() {
    if (this.state === 'ready') this.lifeStep('drain-begin');
  }

  onGateOpened() {
    if (this.state === 'ready') this.lifeStep('drain-end');
  }

  /** New settings after the drain: a new engine takes the old one's state over (holds, waiting msgs, their deadlines). */
  swap(settings) {
    this.applySettings(settings);
    // A standby has no state of its own: it takes the new settings when it is elected.
    if (this.state === 'standby') return;
    if (!this.takeConfig()) return;
    if (this.state === 'starting') {
      this.renewUnstarted();
      return;
    }
    // Its start failed: nothing runs to hand over, so it starts again from what was saved, never from nothing.
    if (this.state === 'failed') {
      this.failure = null;
      // As at a restart: its runs end, one held comes back held from the saved state (its owner's port waits for it).
      this.suspendRuns(SugarshackError.of('INTERNAL', 'interlockRestarted'));
      this.step('restart');
      this.start();
      return;
    }
    const old = this.core;
    try {
      this.guard(() => {
        const text = old ? old.stateText(clock.now(), {}) : null;
        this.core = null; // kept by newEngine() below from freeing it before it is read
        this.newEngine();
        // Two calls: each one's outputs are performed before the next overwrites them.
        this.call((e, now) => (text ? e.handOver(text, now) : e.start(null, undefined, now)));
        this.call((e, now) => e.life('drain-begin', now));
      });
      if (old) wasm.release(old);
      // Started again under the new settings (a failure before is over).
      this.step('restart');
      this.step('started');
      this.failure = null;
    } catch (err) {
      this.fail(err);
      return;
    }
    for (const host of this.routines.values()) host.rebuild(host.snapshot());
    this.listenChanged();
    this.refreshStatus();
    // A new plant tracker knows no standing lockout yet.
    this.resendLockouts('plantChanged');
  }

  /**
   * New settings before the saved state was read: an engine for them takes
   * over the msgs the old one kept, each as of its arrival (the core moves
   * them); the start goes on with it.
   */
  renewUnstarted() {
    const old = this.core;
    try {
      this.guard(() => {
        this.core = null; // kept by newEngine() below from freeing it before its msgs move
        this.newEngine();
        this.call((e, now) => old.handParkedTo(e, now));
      });
      wasm.release(old);
    } catch (err) {
      // The old engine still has them (nothing moved): they get the reason from it.
      if (this.core && this.core !== old) wasm.release(this.core);
      this.core = old;
      this.wire = new Wire(old);
      this.fail(err);
    }
  }

  /** Its engine was lost to a trap while the saved state was read: what it kept is refused, and a new one waits for the start. */
  renewAfterTrap(error) {
    this.carrier.stop();
    this.refuseHeld(error);
    wasm.forget(this.core);
    this.core = null;
    this.wire = null;
    try {
      this.guard(() => this.newEngine());
    } catch (err) {
      this.fail(err);
    }
  }

  /** Every msg it holds, and every operator's request waiting for its reply, ends with `error`. @param {Error} error */
  refuseHeld(error) {
    for (const [k, entry] of [...this.carrier.held]) {
      this.carrier.take(k);
      entry.reject(error);
    }
    for (const { reject } of this.replies.values()) reject(error);
    this.replies.clear();
  }

  /**
   * Its runs, before it opens its saved state again: a held one's operation
   * node keeps its port for the run that comes back held (`resumeRuns`; a
   * routine's is taken by the routine as it rebuilds); the others end with
   * `error`. If it fails instead, the ports get the failure (`fail`).
   */
  suspendRuns(error) {
    for (const host of this.routines.values()) host.suspend();
    const ports = [];
    for (const run of [...this.runs]) {
      if (run.heldBeforeTrap) ports.push(run.suspend());
      else run.abandon(error);
    }
    this.portsAwaitingRuns = { ports: ports.filter((p) => p.owner.kind === 'node'), error };
  }

  /** After its saved state opened again: the runs restored held take their nodes' ports back (a port no run came back for ends with the suspension's error); routines rebuild. */
  resumeRuns() {
    const awaiting = this.portsAwaitingRuns;
    this.portsAwaitingRuns = null;
    if (!awaiting) return;
    const { ports, error } = awaiting;
    for (const port of ports) {
      const run = this.heldRunOf(port.owner);
      if (run) run.takePort(port);
      else port.fail(error);
    }
    for (const [id, host] of this.routines) host.rebuild(this.savedRoutines[id]);
  }

  /** After a wasm trap: back to the last saved state, as after a restart; what waited is refused. */
  rebuild() {
    if (this.state === 'starting' && this.core) {
      this.renewAfterTrap(SugarshackError.of('INTERNAL', 'interlockRebuilt'));
      return;
    }
    if (this.state !== 'ready') return;
    this.committer.discard();
    this.carrier.stop();
    const error = SugarshackError.of('INTERNAL', 'interlockRebuilt');
    this.suspendRuns(error);
    this.refuseHeld(error);
    wasm.forget(this.core);
    this.core = null;
    try {
      this.newEngine();
      this.open(this.readStore());
    } catch (err) {
      this.fail(err); // no run comes back for the suspended ones' ports: they get the reason
      return;
    }
    this.restoreHeldRuns();
    this.resumeRuns();
    this.listenChanged();
    this.refreshStatus();
    this.resendLockouts('afterRebuild');
  }

  // ---- nodes -----------------------------------------------------------------

  /** A node of a deploy binds to the engine under its handle (the same for its next instances). */
  addNodeSpec(node, spec) {
    let handle = this.nodeHandles.get(node.id);
    if (handle === undefined) {
      handle = this.nodeHandles.size + 1;
      this.nodeHandles.set(node.id, handle);
    }
    this.nodes.set(handle, { node, spec, kind: KINDS[spec.kind] });
    this.call((e, now) => e.addNode(handle, spec, now));
  }

  heldEntries() {
    return [...this.carrier.held.values()];
  }

  /** The engine decides: removed, what the node waits for is withdrawn now; restarted, at the deploy's end unless it came back. */
  closing(node, removed) {
    this.closingRuns(node);
    const handle = this.nodeHandles.get(node.id);
    const bound = handle === undefined ? undefined : this.nodes.get(handle);
    if (handle === undefined || !bound || bound.node !== node) return;
    this.nodes.delete(handle);
    // Starting too: the msgs its engine keeps for the start follow the node as those it holds do.
    if (this.core) this.call((e, now) => e.closeNode(handle, removed, now));
  }

  closingRuns(node) {
    for (const run of this.runs) run.detachNode(node);
  }

  deployBegins() {
    super.deployBegins();
    this.lifeStep('deploy-begin');
  }

  deployEnds() {
    super.deployEnds();
    this.lifeStep('deploy-end');
  }

  addEventsNode(node) {
    super.addEventsNode(node);
    this.listenChanged();
  }

  removeUser(node) {
    super.removeUser(node);
    this.listenChanged();
  }

  /** Tells the engine whether its events go anywhere (until the flows run, events nodes may still come). */
  listenChanged() {
    if (this.state !== 'ready') return;
    const running = this.flowsRunning();
    if (!running && !this.listenAgain) {
      this.listenAgain = true;
      this.palette.whenStarted(() => {
        this.listenAgain = false;
        this.listenChanged();
      });
    }
    try {
      this.call((e, now) => e.listen(this.events.listened() || !running, now));
    } catch (err) {
      this.log('error', err.message);
    }
  }

  /** A msg into one of its nodes while it runs with the gate open (see onInterlockInput): `input` with no values read. */
  inputNow(node, msg, send, done) {
    try {
      this.input(node, msg, send, done, undefined);
    } catch (err) {
      this.refuse(node, done, this.trapped(err));
    }
  }

  /**
   * An interlock node's msg waits in its engine once made (kept for the start,
   * its timeout running); behind work held here while it starts (a run's), it
   * waits here too, so they replay as they came.
   * @param {import('../host/runtime-base').ParkedWork} task
   */
  park(task) {
    if (task.engine && this.core !== null && !(this.state === 'starting' && this.parked.length > 0)) this.perform(task.node, task.done, task.work);
    else super.park(task);
  }

  /** A msg into one of its nodes: held under a new handle, and handed to the engine. */
  input(node, msg, send, done, values) {
    const handle = /** @type {number} */ (this.nodeHandles.get(node.id));
    const { spec, kind } = /** @type {{ spec: any, kind: any }} */ (this.nodes.get(handle));
    // Read first: a getter that throws refuses the msg before anything is held.
    /** @type {any} */
    let read;
    try {
      read = kind.read(msg, values);
    } catch (err) {
      throw unreadable(err);
    }
    const k = this.newHandle();
    const entry = new CarriedMsg(node, msg, send, done, kind.ports);
    // A Catch node's error stays the cause of the error a failed fault msg ends with.
    if (spec.kind === 'fault' && msg.error && typeof msg.error === 'object') entry.cause = msg.error;
    this.carrier.hold(k, entry);
    const plant = spec.kind === 'clear' ? this.tracker() : null;
    // The plant's tracker is lent to the engine while it reads the clear's values: the plant takes no call meanwhile.
    const owner = this.plant;
    // Deferred (sent in while outputs are performed), a refusal still ends this msg.
    const failed = this.performing ? (/** @type {Error} */ err) => {
      const held = this.carrier.take(k);
      if (held) held.reject(err);
    } : undefined;
    try {
      if (plant) this.call((e, now) => wasm.reading(owner, () => e.clearAgainst(handle, k, read, read.resources !== undefined, now, plant)), undefined, undefined, undefined, failed);
      else this.call(kind.call, handle, k, read, failed);
    } catch (err) {
      this.carrier.take(k);
      throw err;
    }
  }

  /** A new msg handle. */
  newHandle() {
    const k = this.nextMsg;
    this.nextMsg = k === HANDLES - 1 ? 0 : k + 1;
    return k;
  }

  // ---- outputs with no msg of their own ----------------------------------------

  other(o, effect) {
    switch (o.kind) {
      case 'event': {
        // In a cluster each event names the instance and the fencing token it was committed under.
        const { cluster } = this;
        const event = cluster ? { ...o.event, instance: cluster.instance, token: cluster.token } : o.event;
        effect(() => this.events.publish([event]));
        break;
      }
      case 'journal':
        effect(() => journal.action(o.action, { by: o.by, reason: o.reason }, o.target));
        break;
      case 'nodeError': {
        const bound = this.nodes.get(o.node);
        if (bound) this.showError(bound.node, o.code);
        break;
      }
      case 'alarm':
        if (this.palette) this.palette.changes.touch(this);
        break;
      case 'log':
        this.noteStart(o.text);
        effect(() => this.log(o.level, render(o.text)));
        break;
      case 'reply':
        effect(() => this.reply(o.msg, o.answer));
        break;
      case 'lockouts':
        effect(() => this.plant && this.plant.issueLockouts(lockoutsOf(o.lockouts), null));
        break;
      default:
        break;
    }
  }

  /** A line added or dropped since the state was saved, as the engine logs it at start, for describe(). */
  noteStart(text) {
    if (!this.started) return;
    const list = text.key === 'logs.lineAdded' ? this.started.added : text.key === 'logs.lineDropped' ? this.started.dropped : null;
    if (list) list.push(text.params[0][1].value);
  }

  countsChanged(holding, queued, faulted, lost) {
    if (!lost) this.lostState = null;
    if (this.palette) this.palette.changes.touch(this);
    // Kept in place: they change with every grant, and are read when shown (paced).
    const c = this.counts;
    c.holding = holding;
    c.queued = queued;
    c.faulted = faulted;
    c.lost = lost;
    this.statusPacer.request();
  }

  /** The counts as a status, made when shown (paced), the same object while they do not change. */
  countsStatus() {
    const c = this.counts;
    const seen = this.shown;
    if (seen.holding !== c.holding || seen.queued !== c.queued || seen.faulted !== c.faulted || seen.lost !== c.lost) {
      this.shown = { ...c, status: countsStatus(c) };
    }
    return this.shown.status;
  }

  /** The engine is due: its deadlines (acquire timeouts, warnings, alarms; starting, the timeouts of the msgs it keeps). */
  tick() {
    if (this.state !== 'ready' && this.state !== 'starting') return;
    try {
      this.call((e, now) => e.tick(now));
    } catch (err) {
      this.log('error', err.message);
    }
  }

  /** A routine's deadline changed: the one timer follows the earliest (the core says each; JS takes the minimum). */
  routineDeadlinesChanged() {
    let at = -1;
    for (const host of this.routines.values()) {
      if (host.dueAt !== undefined && (at < 0 || host.dueAt < at)) at = host.dueAt;
    }
    this.carrier.followRoutines(at);
  }

  /** The one timer at a routine's deadline: the routines due check their conditions. @param {number} now */
  routinesDue(now) {
    for (const host of [...this.routines.values()]) host.checkIfDue(now);
    this.routineDeadlinesChanged();
  }

  storeFailing(failing) {
    if (this.state !== 'ready' || this.ended || this.failingShown === failing) return;
    this.failingShown = failing;
    this.call((e, now) => e.storeFailing(failing ? this.store.where : null, now));
    this.refreshStatus();
  }

  // ---- a person's requests (operator.js) -----------------------------------------

  /** An operator's action; resolves with the engine's reply once its state is written. */
  operate(action, who) {
    return new Promise((resolve, reject) => {
      const k = this.newHandle();
      this.replies.set(k, { resolve, reject });
      const plant = this.tracker();
      try {
        this.call((e, now) => (plant ? wasm.reading(this.plant, () => e.operatorAgainst(k, action, who, now, plant)) : e.operator(k, action, who, now)));
      } catch (err) {
        this.replies.delete(k);
        reject(err);
      }
    });
  }

  /** The state node's alarm requests: the engine's, `then(changes)` once saved. */
  acknowledgeAlarms(ids, who, then) {
    this.alarmRequest({ kind: 'ack', ids }, who, then);
  }

  shelveAlarm(id, untilMs, who, then, { oneShot = false } = {}) {
    this.alarmRequest({ kind: 'shelve', id, untilMs, oneShot }, who, then);
  }

  unshelveAlarm(id, who, then) {
    this.alarmRequest({ kind: 'unshelve', id }, who, then);
  }

  alarmRequest(action, who, then) {
    this.operate(action, who).then((answer) => then(answer.changes), (err) => {
      this.log('warn', err.message);
      then([]);
    });
  }

  reply(k, answer) {
    const waiting = this.replies.get(k);
    if (!waiting) return;
    this.replies.delete(k);
    if ('Ok' in answer) waiting.resolve(answer.Ok);
    else waiting.reject(refusalError(answer.Err));
  }

  faultedResources() {
    return this.core.faultedResources();
  }

  hasAlarm(id) {
    return Boolean(this.core) && this.core.alarmIds().includes(id);
  }

  /** The state as a person reads it: the engine's view, with what the host knows (its store, how it started). */
  describe() {
    // A standby shows which committed state it follows (the etcd revision of its last write).
    if (this.state === 'standby' && this.etcdStore) return { failure: null, following: { where: this.etcdStore.where, revision: this.etcdStore.held.revision } };
    if (this.state !== 'ready') return { failure: this.failure ? { code: this.failure.code, message: this.failure.message } : null };
    const now = clock.now();
    const plant = this.tracker();
    const view = plant ? this.core.viewAgainst(now, plant) : this.core.view(now);
    delete view.stage;
    return {
      ...view,
      // Each event with its one readable line, as the events nodes send it.
      recentEvents: view.recentEvents.map((e) => ({ ...e, summary: describeEvent(e) })),
      plant: this.plant ? this.plant.id : null,
      routines: [...this.routines.values()].map((host) => host.describe()),
      started: this.started,
      saved: { where: this.store.where, failing: this.committer.failing, writes: this.committer.writes },
      runs: this.describeRuns(now),
    };
  }

  // ---- the plant bound to it: its runs, routines, lockouts and conditions ------------

  /** The plant's tracker while the plant runs (clears are checked against it), else null. */
  tracker() {
    return this.plant && this.plant.state === 'ready' ? this.plant.t : null;
  }

  /** Faulted lines send their lockouts again once the flows run ("atStart", "plantChanged", "afterRebuild"). */
  resendLockouts(why) {
    if (!this.plant || !this.palette) return;
    this.palette.whenStarted(() => {
      if (this.state === 'ready') this.lifeCall((e, now) => e.resendLockouts(why, now));
    });
  }

  /** An engine call whose failure is logged, not thrown (no msg to refuse). @param {(engine: any, now: number) => void} fn */
  lifeCall(fn) {
    try {
      this.call(fn);
    } catch (err) {
      this.log('error', err.message);
    }
  }

  /**
   * The plant's device and bus conditions, and the cluster's, go to the
   * engine's alarms as they change: the plant and the cluster say when they
   * may have (no poll).
   */
  watchPlant() {
    this.stopTimers();
    if (!this.plant && !this.cluster) return;
    this.plantConditions = '';
    const observe = () => this.observePlant();
    const unwatch = this.plant ? this.plant.watchConditions(observe) : () => {};
    const { cluster } = this;
    if (cluster) cluster.on('changed', observe);
    this.unwatchPlant = () => {
      unwatch();
      if (cluster) cluster.removeListener('changed', observe);
    };
    this.observePlant();
  }

  observePlant() {
    const plant = this.tracker();
    if (this.state !== 'ready') return;
    try {
      const buses = plant ? this.plant.buses.filter((b) => b.connected === false).map((b) => ({ kind: 'bus-disconnected', subject: (b.node && b.node.name) || b.nodeId })) : [];
      const devices = plant ? this.guard(() => plant.alarmConditions()) : [];
      const conditions = [...devices, ...buses, ...(this.cluster ? this.cluster.alarmConditions() : [])];
      const seen = JSON.stringify(conditions);
      if (seen === this.plantConditions) return;
      this.plantConditions = seen;
      this.call((e, now) => e.plantConditions(conditions, now));
    } catch (err) {
      this.log('error', i18n.text('logs.alarmsNotUpdated', { message: err.message }));
    }
  }

  /** The routines' states now, by id, for the state document. */
  routineSnapshots() {
    const routines = {};
    for (const [id, host] of this.routines) {
      const snapshot = host.snapshot();
      if (snapshot) routines[id] = snapshot;
    }
    return routines;
  }

  /** The runs held now, saved so that they come back held. */
  heldRuns() {
    const runs = [];
    for (const run of this.runs) {
      const held = run.snapshot();
      if (held) runs.push(held);
    }
    return runs;
  }

  /**
   * The operations aborted and not reset, kept by the engine (a run's abort, a routine's reset, an operator's).
   * @returns {any}
   */
  abortedOperations() {
    const core = this.core;
    if (!core) throw SugarshackError.of('INTERNAL', 'interlockRebuilt');
    // Called at once on the engine, not through `call`: refused while the engine reads a msg.
    wasm.entering(this);
    return {
      checkStart: (operation) => core.abortedCheckStart(operation),
      state: (operation) => core.abortedState(operation),
      ended: (operation, _state, by, reason, now) => core.operationAborted(operation, by, reason, now),
      command: (operation, command) => core.abortedCommand(operation, command),
      resetRoutine: (machine) => core.abortedResetRoutine(machine),
    };
  }

  /**
   * A run's request to the engine, as a msg of one of the run nodes: the
   * carrier holds an entry for it, and its answer (`sent`, `failed`, or
   * `abandoned` when completed unsent) comes back once.
   */
  runRequest(ports, call, { sent, failed, abandoned = () => {} }) {
    const k = this.newHandle();
    let open = true;
    const once = (fn) => (arg) => {
      if (!open) return;
      open = false;
      fn(arg);
    };
    const entry = heldMsg({ node: null, msg: null, send: once(sent), done: null, sinceMs: 0, ports });
    entry.reject = once(failed);
    entry.abandon = once(abandoned);
    this.carrier.hold(k, entry);
    // Made while outputs are performed, it runs after them, and its refusal goes to the run.
    const deferred = this.performing;
    this.call((e, now) => {
      try {
        call(e, k, now);
      } catch (err) {
        this.carrier.take(k);
        if (deferred) entry.reject(err);
        throw err;
      }
    });
  }

  /** A run waits for its grant (`entry.grant`), or is refused (`entry.refuse`) or taken out of the queue (`entry.abandon`). */
  request(entry) {
    this.runRequest(1, (e, k, now) => e.acquireNamed(RUN_ACQUIRE, k, entry.operation, entry.priority, entry.resources, now), {
      sent: () => entry.grant(clock.now()),
      failed: (err) => entry.refuse(err),
      abandoned: () => entry.abandon(),
    });
  }

  /** A run releases its lines: `then` once saved, `refused(err)` when the engine refuses. */
  release(operation, then, refused = () => {}) {
    this.runRequest(1, (e, k, now) => e.releaseTexts(RUN_RELEASE, k, operation, undefined, now), { sent: () => then(), failed: refused });
  }

  /** A run withdraws its waiting request. */
  cancel(operation, then, refused = () => {}) {
    this.runRequest(1, (e, k, now) => e.cancel(RUN_CANCEL, k, { operation }, now), { sent: () => then && then(), failed: refused });
  }

  /** A run faults: `then(lockouts)` once saved, or if saving fails (isolation first). */
  fault(operation, note, then, refused = (err) => this.log('error', err.message)) {
    this.runRequest(2, (e, k, now) => e.fault(RUN_FAULT, k, { operation, errorMessage: note }, now), {
      sent: (out) => then(lockoutsOf(out[1] || [])),
      failed: refused,
    });
  }
}

/** The engine's lockout msgs as the plant's lockout commands. @param {any[]} msgs */
function lockoutsOf(msgs) {
  return msgs.map((m) => ({ resource: m.resource, topic: m.topic, command: m.payload }));
}

// The interlock layer's own time per msg, for the overhead figures.
timeLayer(EngineRuntime, 'interlock', ['input', 'operate']);

module.exports = { EngineRuntime };
