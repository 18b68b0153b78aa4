// @ts-check
'use strict';
// The interlock behind a config node bound to no plant, run by one core
// Engine: a node's msg becomes one engine input under a handle, and the
// engine's outputs are performed by the carrier (grants, refusals and
// timeouts, lockouts, events, journal lines, alarms, the one timer). What
// is left here is I/O: reading a msg's fields, the state file, the status,
// the events nodes and the editor's requests.
const { SugarshackError } = require('../errors');
const { describeEvent } = require('../events');
const { countsStatus } = require('../status');
const { clock } = require('../clock');
const { Committer } = require('../durable');
const { InterlockRuntime } = require('../interlock-runtime');
const { EngineCarrier, CarriedMsg, refusalError, render } = require('../engine-carrier');
const { Wire } = require('../wasm/wire');
const { readMsg, fieldsOf } = require('../request');
const { journal } = require('../journal/bus');
const { timeLayer } = require('../stats');
const wasm = require('../wasm');
const i18n = require('../i18n');

// Text up to this long crosses as a string argument; longer, the facade reads its length and head only.
const SHORT_TEXT = 1000;
// A msg handle is a u32 the engine keeps; it wraps long after any msg of its range ended.
const HANDLES = 2 ** 32;

/** Each node kind's input: its outputs, and the engine call a msg makes (read first, so a throwing getter refuses the msg). */
const KINDS = {
  acquire: {
    ports: 1,
    // The node's values read for this msg (from context, env or JSONata) go with the msg's.
    read: (msg, values) => (values
      ? [msg.operation, msg.priority, msg.resources, { operation: msg.operation, priority: msg.priority, resources: msg.resources, configured: values }]
      : [msg.operation, msg.priority, msg.resources]),
    // The same input four ways: with nothing, with only an operation's short text (one string crosses), with anything, with the node's values read.
    call: (e, h, k, [operation, priority, resources, fields], now) => {
      if (fields) e.acquireFields(h, k, fields, now);
      else if (priority !== undefined || resources !== undefined) e.acquireNamed(h, k, operation, priority, resources, now);
      else if (operation === undefined) e.acquire(h, k, now);
      else if (typeof operation === 'string' && operation.length <= SHORT_TEXT) e.acquireOperation(h, k, operation, now);
      else e.acquireNamed(h, k, operation, priority, resources, now);
    },
  },
  release: {
    ports: 1,
    read: (msg) => [msg.operation, msg.interlock ? msg.interlock.operation : undefined],
    call: (e, h, k, [operation, follow], now) => (typeof operation === 'string' && operation.length <= SHORT_TEXT && follow === undefined
      ? e.releaseOperation(h, k, operation, now) : e.release(h, k, operation, follow, now)),
  },
  cancel: { ports: 1, read: fieldsOf, call: (e, h, k, fields, now) => e.cancel(h, k, fields, now) },
  fault: { ports: 2, read: fieldsOf, call: (e, h, k, fields, now) => e.fault(h, k, fields, now) },
  clear: { ports: 2, read: fieldsOf, call: (e, h, k, fields, now) => e.clear(h, k, fields, fields.resources !== undefined, now) },
};

class EngineRuntime extends InterlockRuntime {
  constructor(args) {
    super(args);
    /** @type {any} the core Engine (tests and the state page read it as the interlock) */
    this.core = null;
    /** @type {Wire | null} */
    this.wire = null;
    this.carrier = this.makeCarrier();
    /** @type {Map<string, number>} node id -> its handle, the same for each deploy of it */
    this.nodeHandles = new Map();
    /** @type {Map<number, { node: NodeRed.Node, spec: object }>} handle -> the instance bound now */
    this.nodes = new Map();
    this.nextMsg = 0;
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
      snapshot: () => this.core.seal(this.id, this.settings.plantId || undefined, {}, clock.now()),
      mayAct: () => true,
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
    });
  }

  /** One engine call; its outputs performed. @param {(engine: any, now: number) => void} fn */
  call(fn) {
    if (!this.core) return;
    this.guard(() => fn(this.core, clock.now()));
    /** @type {EngineCarrier} */ (this.carrier).perform(/** @type {Wire} */ (this.wire));
  }

  // ---- lifecycle -----------------------------------------------------------

  async start() {
    try {
      this.config = this.resolveConfig();
    } catch (err) {
      this.fail(err);
      return;
    }
    const saved = await this.readSaved();
    if (this.ended) return;
    try {
      this.guard(() => this.open(saved));
    } catch (err) {
      this.fail(err);
      return;
    }
    this.markRan();
    this.state = 'ready';
    this.listenChanged();
    this.refreshStatus();
    this.replayParked();
  }

  /** A new engine for the settings in force, its nodes added, started from what was saved. */
  open(saved) {
    this.newEngine();
    const now = clock.now();
    this.started = { outcome: 'new', reason: null, added: [], dropped: [] };
    this.call((e) => {
      if (saved.kind === 'saved') e.startSealed(this.id, this.settings.plantId || undefined, this.store.where, saved.text, now);
      else if (saved.kind === 'lost') e.start(null, saved.why, now);
      else if (saved.kind === 'carried-over') e.start({ interlock: saved.snapshot }, undefined, now);
      else e.start(null, undefined, now);
    });
    const lost = this.core.lost();
    this.lostState = lost === undefined ? null : lost;
    if (this.lostState !== null) this.started = { outcome: 'lost', reason: this.lostState, added: [], dropped: [] };
    else if (saved.kind !== 'first') this.started.outcome = 'restored';
  }

  newEngine() {
    const { Engine } = wasm.load();
    const engine = new Engine(this.config, {});
    if (this.core) wasm.release(this.core);
    this.core = engine;
    this.wire = new Wire(engine);
    const now = clock.now();
    this.call((e) => {
      for (const [handle, { spec }] of this.nodes) e.addNode(handle, spec, now);
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
    this.endCommon();
    this.statusPacer.stop();
    await this.committer.freeze();
    this.lifeStep('shutdown');
    this.carrier.stop();
    this.freeCore();
  }

  /** Its config node left the flows: waiting requests are withdrawn and the state written. */
  async retire() {
    if (this.ended) return;
    const ready = this.state === 'ready';
    this.endCommon();
    this.statusPacer.stop();
    if (ready) {
      this.lifeStep('retire');
      await this.committer.drain();
    }
    this.carrier.stop();
    this.freeCore();
  }

  endCommon() {
    super.endCommon();
    this.stopJournalWatch();
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

  quiescent() {
    return true;
  }

  /** New settings after the drain: a new engine takes the old one's state over (holds, waiting msgs, their deadlines). */
  swap(settings) {
    this.applySettings(settings);
    if (!this.takeConfig()) return;
    const old = this.core;
    try {
      this.guard(() => {
        const text = old ? old.stateText(clock.now(), {}) : null;
        this.core = null; // kept by newEngine() below from freeing it before it is read
        this.newEngine();
        this.call((e, now) => {
          if (text) e.handOver(text, now);
          else e.start(null, undefined, now);
          e.life('drain-begin', now);
        });
      });
      if (old) wasm.release(old);
      this.state = 'ready';
      this.failure = null;
    } catch (err) {
      this.fail(err);
      return;
    }
    this.listenChanged();
    this.refreshStatus();
  }

  /** After a wasm trap: back to the last saved state, as after a restart; what waited is refused. */
  rebuild() {
    if (this.state !== 'ready') return;
    this.committer.discard();
    this.carrier.stop();
    const error = SugarshackError.of('INTERNAL', 'interlockRebuilt');
    for (const [k, entry] of [...this.carrier.held]) {
      this.carrier.take(k);
      entry.reject(error);
    }
    for (const { reject } of this.replies.values()) reject(error);
    this.replies.clear();
    wasm.forget(this.core);
    this.core = null;
    try {
      this.open(this.readStore());
    } catch (err) {
      this.state = 'starting';
      this.fail(err);
      return;
    }
    this.listenChanged();
    this.refreshStatus();
  }

  // ---- nodes -----------------------------------------------------------------

  /** A node of a deploy binds to the engine under its handle (the same for its next instances). */
  addNodeSpec(node, spec) {
    let handle = this.nodeHandles.get(node.id);
    if (handle === undefined) {
      handle = this.nodeHandles.size + 1;
      this.nodeHandles.set(node.id, handle);
    }
    this.nodes.set(handle, { node, spec });
    this.call((e, now) => e.addNode(handle, spec, now));
  }

  heldEntries() {
    return [...this.carrier.held.values()];
  }

  closing(node) {
    const handle = this.nodeHandles.get(node.id);
    const bound = handle === undefined ? undefined : this.nodes.get(handle);
    if (handle === undefined || !bound || bound.node !== node) return;
    this.nodes.delete(handle);
    if (this.state === 'ready') this.call((e, now) => e.closeNode(handle, false, now));
  }

  /** A node restarted by a deploy that did not come back: the engine withdraws what it waited for. */
  withdrawOrphans(nodeId) {
    const handle = this.nodeHandles.get(nodeId);
    if (handle === undefined || this.nodes.has(handle)) return;
    this.call((e, now) => e.closeNode(handle, true, now));
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

  /** A msg into one of its nodes: held under a new handle, and handed to the engine. */
  input(node, msg, send, done, values) {
    const handle = /** @type {number} */ (this.nodeHandles.get(node.id));
    const bound = /** @type {{ spec: any }} */ (this.nodes.get(handle));
    const spec = /** @type {{ kind: keyof typeof KINDS }} */ (bound.spec);
    const kind = KINDS[spec.kind];
    const read = readMsg(() => kind.read(msg, values));
    const k = this.nextMsg;
    this.nextMsg = (this.nextMsg + 1) % HANDLES;
    const entry = new CarriedMsg(node, msg, send, done, kind.ports);
    // A Catch node's error stays the cause of the error a failed fault msg ends with.
    if (spec.kind === 'fault' && msg.error && typeof msg.error === 'object') entry.cause = msg.error;
    this.carrier.hold(k, entry);
    try {
      this.call((e, now) => kind.call(e, handle, k, read, now));
    } catch (err) {
      this.carrier.take(k);
      throw err;
    }
  }

  // ---- outputs with no msg of their own ----------------------------------------

  other(o, effect) {
    switch (o.kind) {
      case 'event':
        effect(() => this.events.publish([o.event]));
        break;
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
    this.counts = { holding, queued, faulted, lost };
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

  /** The engine is due: its deadlines (acquire timeouts, warnings, alarms). */
  tick() {
    if (this.state !== 'ready') return;
    try {
      this.call((e, now) => e.tick(now));
    } catch (err) {
      this.log('error', err.message);
    }
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
      const k = this.nextMsg;
      this.nextMsg = (this.nextMsg + 1) % HANDLES;
      this.replies.set(k, { resolve, reject });
      try {
        this.call((e, now) => e.operator(k, action, who, now));
      } catch (err) {
        this.replies.delete(k);
        reject(err);
      }
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
    if (this.state !== 'ready') return { failure: this.failure ? { code: this.failure.code, message: this.failure.message } : null };
    const view = this.core.view(clock.now());
    delete view.stage;
    return {
      ...view,
      // Each event with its one readable line, as the events nodes send it.
      recentEvents: view.recentEvents.map((e) => ({ ...e, summary: describeEvent(e) })),
      plant: null,
      routines: [],
      started: this.started,
      saved: { where: this.store.where, failing: this.committer.failing, writes: this.committer.writes },
      runs: [],
    };
  }
}

// The interlock layer's own time per msg, for the overhead figures.
timeLayer(EngineRuntime, 'interlock', ['input', 'operate']);

module.exports = { EngineRuntime };
