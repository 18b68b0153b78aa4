// @ts-check
'use strict';
// The running interlock behind one interlock config node, for the whole life
// of the Node-RED process: one core Engine, and what Node-RED and the OS own
// around it. Its nodes turn msgs into inputs (one engine call each) and keep
// each msg under the handle they chose; this performs the outputs in order:
// sends and completions, writes (through the Committer: an effect leaves only
// once its state is on disk), events, status, and one timer from the
// engine's next deadline. Every rule is the engine's.
const { SugarshackError, asSugarshackError } = require('../errors');
const { HeldMsg, HeldCall } = require('./held');
const { EventFanout, describeEvent } = require('../events');
const { countsStatus, errorStatus, status: statusOf } = require('../status');
const { timeLayer } = require('../stats');
const { clock } = require('../clock');
const { FileStore, MemoryStore, Committer, stateDir } = require('../durable');
const { RuntimeBase, drainingStatus } = require('../runtime-base');
const { RunHost } = require('../operation-run');
const { RoutineHost } = require('../routine-host');
const { Wire } = require('../wasm/wire');
const wasm = require('../wasm');
const i18n = require('../i18n');
const { journal } = require('../journal/bus');
const { StatusPacer } = require('../status-pacer');

/** @typedef {import('../../wasm/sugarshack_wasm').Engine} Engine */

const LEGACY_KEY = (id) => `sugarshack-interlock:${id}`;
// The nodes of an operation run's requests (kinds the engine knows, no configuration of their own).
/** @type {[number, object][]} */
const RUN_NODES = [[1, { kind: 'acquire', timeoutMs: 0 }], [2, { kind: 'release' }], [3, { kind: 'cancel' }], [4, { kind: 'fault', byResources: false, failMsg: false }]];
const RUN = { acquire: 1, release: 2, cancel: 3, fault: 4 };
const FIRST_NODE = 16;

class InterlockRuntime extends RuntimeBase {
  /** settings: { config (the core's), persist, legacyStore, plantBound, error }; plant: the PlantRuntime it is bound to, or null. */
  constructor({ RED, id, settings, plant = null }) {
    super('interlock');
    this.RED = RED;
    this.id = id;
    this.swapOrder = 1; // after the plants it may be bound to
    this.plant = plant;
    this.applySettings(settings);
    /** @type {Engine | null} */
    this.engine = null;
    /** @type {Wire | null} */
    this.wire = null;
    /** @type {Map<number, HeldMsg | HeldCall>} */
    this.held = new Map();
    this.nextMsg = 0;
    /** @type {Map<string, number>} Node-RED node id -> the engine's handle */
    this.nodeHandles = new Map();
    /** @type {Map<number, object>} handle -> what the node was added as (a rebuilt engine gets them again) */
    this.nodeSpecs = new Map();
    this.events = new EventFanout();
    this.listening = false;
    this.runs = new Set();
    this.routines = new Map(); // routine id -> RoutineHost
    this.timer = null;
    this.timerAt = -1;
    this.store = settings.persist ? new FileStore(stateDir(RED), id) : new MemoryStore();
    this.committer = this.makeCommitter();
    this.statusPacer = new StatusPacer(() => this.refreshStatus(), () => this.state === 'ready');
    this.shown = { holding: 0, queued: 0, faulted: 0, lost: false };
    this.countsShown = null;
    /** @type {{ urgent: boolean, actions: (() => void)[], after?: boolean } | null} the effects of the last commit, while a batch is read */
    this.group = null;
    /** @type {{ port: number, msgs: any[] } | null} msgs emitted for the msg answered next */
    this.extra = null;
    this.storeFailing = false;
  }

  applySettings(settings) {
    this.settings = settings;
    this.config = settings.config;
    this.persist = settings.persist;
    this.legacyStore = settings.legacyStore;
    this.configError = settings.error || null;
  }

  /** The configuration in force: bound to a plant, its lines and lockouts come from the plant's document. */
  resolveConfig() {
    if (this.configError) throw this.configError;
    if (!this.settings.plantBound) return this.config;
    if (!this.plant) throw SugarshackError.of('NO_PLANT', 'noSuchPlant');
    if (this.plant.state !== 'ready') throw this.plant.failure || SugarshackError.of('NO_PLANT', 'plantNotRunning');
    return { ...this.settings.config, resources: this.plant.interlockResources() };
  }

  makeCommitter() {
    return new Committer({
      store: this.store,
      clock,
      snapshot: () => this.live().stateText(clock.now(), this.routineStates()),
      onError: (err) => {
        this.log('error', i18n.text('logs.stateNotSaved', { where: this.store.where, message: err.message || err }));
        if (!this.storeFailing) this.call((e) => e.storeFailing(this.store.where, clock.now()));
        this.storeFailing = true;
        this.refreshStatus();
      },
      onSaved: () => {
        if (this.storeFailing) this.call((e) => e.storeFailing(null, clock.now()));
        this.storeFailing = false;
        this.statusPacer.request();
      },
    });
  }

  /** The engine, which is there once the settings are good. @returns {Engine} */
  live() {
    if (!this.engine) throw this.failure || SugarshackError.of('NO_INTERLOCK', 'noInterlockConfigured');
    return this.engine;
  }

  /** The routines' states, saved in the same write as the interlock's. @returns {Record<string, unknown>} */
  routineStates() {
    /** @type {Record<string, unknown>} */
    const routines = {};
    for (const [id, host] of this.routines) {
      const snapshot = host.snapshot();
      if (snapshot) routines[id] = snapshot;
    }
    return routines;
  }

  /** The core's tracker of the plant bound to this interlock, when running: a clear is checked against it. */
  get tracker() {
    return this.plant && this.plant.state === 'ready' ? this.plant.t : null;
  }

  // ---- lifecycle -----------------------------------------------------------

  async start() {
    let saved;
    try {
      this.config = this.resolveConfig();
      this.makeEngine();
      saved = this.readStore();
    } catch (err) {
      this.fail(err);
      return;
    }
    if (saved.kind === 'first' && this.persist) {
      const legacy = await this.legacySnapshot();
      if (legacy) saved = { kind: 'saved', doc: { interlock: legacy, routines: {} } };
    }
    if (this.ended) return;
    this.begin(saved, 'atStart');
  }

  /** A new engine with every node added (a start, new settings, or a rebuild after a trap). */
  makeEngine() {
    const { Engine } = wasm.load();
    const engine = this.guard(() => new Engine(this.config, { plantBound: Boolean(this.plant) }));
    this.engine = engine;
    this.wire = new Wire(engine);
    this.timerAt = NaN; // the new engine's deadline is armed anew
    const now = clock.now();
    for (const [handle, spec] of [...RUN_NODES, ...this.nodeSpecs]) this.call((e) => e.addNode(handle, spec, now));
    this.listening = false;
  }

  readStore() {
    try {
      return this.store.read();
    } catch (err) {
      return { kind: 'lost', why: err.message };
    }
  }

  /** The engine takes what was saved and runs; faulted lines send their lockouts again once the flows run. */
  begin(saved, why) {
    try {
      this.store.markRan();
    } catch (err) {
      // Its state cannot be written either: grants will wait for it (status "state not saved").
      this.log('error', i18n.text('logs.markerNotWritten', { where: this.store.where, message: err.message }));
    }
    this.state = 'ready';
    const doc = saved.kind === 'saved' ? saved.doc : null;
    const lost = saved.kind === 'lost' ? saved.why : undefined;
    const tracker = this.tracker;
    this.call((e) => (tracker ? e.startAgainst(doc, lost, clock.now(), tracker) : e.start(doc, lost, clock.now())));
    if (tracker) this.plantConditions(this.plant.alarmConditions());
    this.refreshStatus();
    if (this.palette) this.palette.whenStarted(() => this.state === 'ready' && this.call((e) => e.resendLockouts(why, clock.now())));
    this.replayParked();
  }

  /** An interlock saved by an earlier version, in the global context store: read once, then the file takes over. */
  legacySnapshot() {
    const owner = this.owner;
    if (!owner) return Promise.resolve(null);
    return new Promise((resolve) => {
      try {
        owner.context().global.get(LEGACY_KEY(this.id), this.legacyStore, (err, value) => resolve(err ? null : value || null));
      } catch {
        resolve(null);
      }
    });
  }

  /** A shutdown: nothing changes the saved state any more; held msgs are completed unsent. */
  async shutdown() {
    if (this.ended) return;
    const wasReady = this.state === 'ready';
    this.endCommon();
    this.stopTimer();
    await this.committer.freeze();
    if (wasReady) this.call((e) => e.life('shutdown', clock.now()));
    this.endHosts();
  }

  /** Its config node left the flows: running operations stop as faults, waiting msgs are completed, the state written. */
  async retire() {
    if (this.ended) return;
    if (this.state === 'ready') {
      for (const run of [...this.runs]) run.abort('its interlock was removed from the flows');
      this.call((e) => e.life('retire', clock.now()));
      await this.committer.drain();
    }
    this.endCommon();
    this.stopTimer();
    this.endHosts();
  }

  endHosts() {
    for (const run of this.runs) run.shutdown();
    for (const host of this.routines.values()) host.shutdown();
    this.releaseEngine();
  }

  releaseEngine() {
    wasm.release(this.engine);
    this.engine = null;
  }

  // ---- deploys -------------------------------------------------------------

  onGateClosed() {
    if (this.state === 'ready') this.call((e) => e.life('drain-begin', clock.now()));
  }

  onGateOpened() {
    if (this.state === 'ready') this.call((e) => e.life('drain-end', clock.now()));
  }

  deployBegins() {
    if (this.state === 'ready') this.call((e) => e.life('deploy-begin', clock.now()));
  }

  deployEnds() {
    if (this.state === 'ready') this.call((e) => e.life('deploy-end', clock.now()));
  }

  /** Drained when no operation holds a grant through a run of ours (waiting ones are held back). */
  quiescent() {
    for (const run of this.runs) if (run.granted) return false;
    return true;
  }

  /** New settings after the drain: a new engine takes the state over (holds and waiting msgs go on). */
  swap(settings) {
    this.applySettings(settings);
    try {
      this.config = this.resolveConfig();
    } catch (err) {
      this.releaseEngine();
      this.state = 'starting';
      this.fail(err);
      return;
    }
    if (!this.engine) {
      this.state = 'starting';
      this.failure = null;
      this.start();
      return;
    }
    const old = this.engine;
    try {
      const state = this.live().stateText(clock.now(), this.routineStates());
      this.makeEngine();
      this.call((e) => e.life('drain-begin', clock.now()));
      this.call((e) => e.handOver(state, clock.now()));
    } catch (err) {
      this.engine = old;
      this.fail(err);
      return;
    }
    wasm.release(old);
    this.state = 'ready';
    this.failure = null;
    for (const host of this.routines.values()) host.rebuild(host.snapshot());
    this.refreshStatus();
    // A new plant tracker knows no standing lockout yet.
    if (this.palette) this.palette.whenStarted(() => this.state === 'ready' && this.call((e) => e.resendLockouts('plantChanged', clock.now())));
  }

  /** After a wasm trap: a new engine from the last saved state, as after a restart (held lines faulted, waiting msgs refused). */
  rebuild() {
    if (this.state !== 'ready') return;
    this.committer.discard();
    for (const host of this.routines.values()) host.suspend();
    const error = SugarshackError.of('INTERNAL', 'interlockRebuilt');
    for (const entry of this.held.values()) entry.answer(null, null, error);
    this.held.clear();
    for (const run of [...this.runs]) run.abandon(error);
    wasm.forget(this.engine);
    this.engine = null;
    const saved = this.readStore();
    try {
      this.makeEngine();
    } catch (err) {
      this.state = 'starting';
      this.fail(err);
      return;
    }
    this.begin(saved, 'afterRebuild');
    const routines = saved.kind === 'saved' && saved.doc.routines ? saved.doc.routines : {};
    for (const [id, host] of this.routines) host.rebuild(routines[id]);
  }

  // ---- nodes using this interlock ------------------------------------------

  /** The engine's handle of a node (the same across deploys), and what it is. */
  addNode(node, spec) {
    let handle = this.nodeHandles.get(node.id);
    if (handle === undefined) {
      handle = FIRST_NODE + this.nodeHandles.size;
      this.nodeHandles.set(node.id, handle);
    }
    this.nodeSpecs.set(handle, spec);
    this.call((e) => e.addNode(handle, spec, clock.now()));
    return handle;
  }

  addEventsNode(node) {
    this.events.add(node);
  }

  removeUser(node) {
    super.removeUser(node);
    this.events.remove(node);
  }

  heldEntries() {
    return [...this.held.values()];
  }

  adopted(node) {
    for (const run of this.runs) run.adopt(node);
  }

  closing(node) {
    for (const run of this.runs) run.detachNode(node);
  }

  nodeClosed(node, removed) {
    super.nodeClosed(node, removed);
    const handle = this.nodeHandles.get(node.id);
    if (handle !== undefined && this.state === 'ready') this.call((e) => e.closeNode(handle, removed, clock.now()));
  }

  withdrawOrphans() {}

  // ---- inputs ----------------------------------------------------------------

  /**
   * A msg into one of this interlock's nodes: held under a new handle while
   * `call(engine, handle, now)` gives it to the engine; the engine's outputs
   * are performed. `ports`: the node's outputs; `words(text)`: how the node words a fault it made.
   */
  input(node, msg, send, done, ports, call, words = null) {
    if (this.ended) {
      done();
      return;
    }
    if (!this.engine) {
      done(this.failure || SugarshackError.of('NO_INTERLOCK', 'noInterlockConfigured'));
      return;
    }
    const entry = new HeldMsg(node, msg, send, done, ports);
    if (words) entry.words = words;
    this.hold(entry, call);
  }

  /** A request of an operation run (see RunHost): `kind` acquire, release, cancel or fault. */
  request(kind, fields, answers) {
    if (!this.engine) throw this.failure || SugarshackError.of('NO_INTERLOCK', 'noInterlockConfigured');
    const node = RUN[kind];
    this.hold(new HeldCall(answers), (e, k, now) => {
      if (kind === 'acquire') e.acquireNamed(node, k, fields.operation, fields.priority, fields.resources, now);
      else if (kind === 'release') e.release(node, k, fields.operation, undefined, now);
      else if (kind === 'cancel') e.cancel(node, k, fields, now);
      else e.fault(node, k, fields, now);
    });
  }

  hold(entry, call) {
    this.nextMsg = this.nextMsg >= 0xfffffff0 ? 1 : this.nextMsg + 1;
    const k = this.nextMsg;
    this.held.set(k, entry);
    try {
      this.call((e) => call(e, k, clock.now()));
    } catch (err) {
      if (this.held.delete(k)) entry.answer(null, null, asSugarshackError(err));
    }
  }

  /**
   * One engine call, its outputs performed and its deadline kept.
   * @param {(engine: Engine) => void} fn
   */
  call(fn) {
    const { engine } = this;
    if (!engine) return;
    const listened = this.events.listened();
    if (listened !== this.listening) {
      this.listening = listened;
      this.guard(() => engine.listen(listened, clock.now()));
      this.performOutputs();
    }
    this.guard(() => fn(engine));
    this.performOutputs();
  }

  /**
   * An operator's action from the editor or a dashboard (see the facade's
   * OperatorRequest), by `who` ({ user, reason, force }); `reply(answer)`, or `reply(error)`.
   */
  operator(action, who, reply) {
    if (!this.engine) throw this.failure || SugarshackError.of('NO_INTERLOCK', 'noInterlockConfigured');
    this.hold(new HeldCall({ answered: reply, refused: reply }), (e, k, now) => {
      const tracker = this.tracker;
      if (tracker) e.operatorAgainst(k, action, who, now, tracker);
      else e.operator(k, action, who, now);
    });
  }

  // ---- outputs ---------------------------------------------------------------

  performOutputs() {
    this.group = null;
    /** @type {Wire} */ (this.wire).read(this);
    this.closeGroup();
    this.armTimer();
  }

  /** What follows waits for the state's write (done at once when nothing waits and the store is memory). */
  commit(urgent) {
    this.closeGroup();
    if (!this.store.durable && this.committer.waiting === 0) {
      this.committer.change(null);
      return;
    }
    this.group = { urgent, actions: [] };
  }

  after() {
    this.closeGroup();
    this.group = { urgent: false, actions: [], after: true };
  }

  closeGroup() {
    const group = this.group;
    this.group = null;
    if (!group) return;
    const run = () => group.actions.forEach((a) => a());
    if (group.after) this.committer.after(run);
    else this.committer.change(run, { evenUnsaved: group.urgent });
  }

  /** `action` now, or once the state it follows is written. */
  effect(action) {
    if (this.group) this.group.actions.push(action);
    else action();
  }

  take(k) {
    const entry = this.held.get(k);
    this.held.delete(k);
    return entry;
  }

  send(k, port, set) {
    const entry = this.take(k);
    const extra = this.extra;
    this.extra = null;
    if (!entry) return;
    if (entry instanceof HeldCall) {
      this.effect(() => (set && set.kind === 'interlock' && entry.answers.granted ? entry.answers.granted(set) : entry.answer(port, extra, null)));
      return;
    }
    const { msg } = entry;
    this.effect(() => {
      if (set) applySet(msg, set, this);
      entry.answer(port, extra, null);
    });
  }

  emit(k, port, msgs) {
    this.extra = { port, msgs };
  }

  complete(k, refusal) {
    const entry = this.take(k);
    const extra = this.extra;
    this.extra = null;
    if (!entry) return;
    const err = refusal ? this.error(refusal, entry) : null;
    this.effect(() => entry.answer(null, extra, err));
  }

  counts(holding, queued, faulted, lost) {
    this.shown = { holding, queued, faulted, lost };
    if (this.palette) this.palette.changes.touch();
    this.statusPacer.request();
  }

  other(o) {
    switch (o.kind) {
      case 'reply': {
        const entry = this.take(o.msg);
        if (!entry) break;
        const err = o.answer.Err ? this.error(o.answer.Err, null) : null;
        this.effect(() => entry.answer(err ? null : 0, err ? null : { port: 0, msgs: o.answer.Ok }, err));
        break;
      }
      case 'event': this.effect(() => this.events.publish([o.event])); break;
      case 'journal': this.effect(() => journal.action(o.action, { by: o.by, reason: o.reason }, o.target)); break;
      case 'nodeError': this.showError(this.nodeOf(o.node), o.code); break;
      case 'alarm': this.effect(() => this.palette && this.palette.changes.touch()); break;
      case 'log': this.log(o.level, this.render(o.text)); break;
      case 'lockouts': this.effect(() => this.plant && this.plant.issueLockouts(o.lockouts, null)); break;
      case 'counts': break;
      default: this.log('warn', `engine output ${o.kind} not performed`);
    }
  }

  /** The node instance now holding handle `handle`, if any. */
  nodeOf(handle) {
    for (const node of this.users) if (this.nodeHandles.get(node.id) === handle) return node;
    return null;
  }

  /** A refusal as the error a Catch node gets (in the reader's language). */
  error(refusal, entry) {
    const err = new SugarshackError(refusal.code, this.render(refusal.text, entry));
    if (refusal.lines && refusal.lines.length) /** @type {any} */ (err).lines = refusal.lines;
    if (refusal.text.kind === 'faulted' && entry && entry.msg && entry.msg.error && typeof entry.msg.error === 'object') err.cause = entry.msg.error;
    return err;
  }

  /**
   * Words the engine chose, in the reader's language (a fault node words its own fault).
   * @param {any} t @param {{ words?: ((text: any) => string) | null } | null} [entry]
   */
  render(t, entry = null) {
    if (t.kind === 'plain') return t.text;
    if (t.kind === 'faulted') return entry && entry.words ? entry.words(t) : t.lines.join(', ');
    const subs = {};
    for (const [name, p] of t.params) subs[name] = p.kind === 'label' ? i18n.textOf(`labels.${p.value}`) : p.value;
    return i18n.textOf(t.key, subs);
  }

  armTimer() {
    const at = /** @type {Wire} */ (this.wire).nextDeadline();
    if (at === this.timerAt) return;
    this.stopTimer();
    this.timerAt = at;
    if (at < 0) return;
    this.timer = clock.setTimeout(() => {
      this.timer = null;
      this.timerAt = -1;
      if (this.state === 'ready') this.call((e) => e.tick(clock.now()));
    }, Math.max(0, at - clock.now()));
  }

  stopTimer() {
    if (this.timer) clock.clearTimeout(this.timer);
    this.timer = null;
    this.timerAt = -1;
    this.statusPacer.stop();
  }

  // ---- operations and routines from the plant document -----------------------

  /** Starts an operation's run; `port` gets its progress, result or error. */
  startRun(operation, msg, port) {
    if (!this.plant) throw SugarshackError.of('NO_PLANT', 'noPlantForOperations');
    const run = new RunHost({ interlock: this, plant: this.plant, operation, msg, port });
    this.runs.add(run);
    run.start();
    return run;
  }

  runEnded(run) {
    this.runs.delete(run);
    if (this.palette && this.palette.draining) this.palette.pokeDrain();
  }

  /** The host of routine `id`, made (and restored from the saved state) on first use. */
  routineHost(id) {
    let host = this.routines.get(id);
    if (!host) {
      if (!this.plant) throw SugarshackError.of('NO_PLANT', 'noPlantForRoutines');
      host = new RoutineHost({ interlock: this, plant: this.plant, id });
      const saved = this.engine ? this.engine.savedRoutines()[id] : undefined;
      host.start(saved); // throws UNKNOWN_ROUTINE before it is kept
      this.routines.set(id, host);
    }
    return host;
  }

  /** A routine's state changed: it is saved with the next write, `effect` after it. */
  changed(effect) {
    if (this.palette) this.palette.changes.touch();
    this.committer.change(effect);
  }

  /** The plant's abnormal conditions changed (a device, a broker): the alarms hear of it. */
  plantConditions(conditions) {
    if (this.state === 'ready') this.call((e) => e.plantConditions(conditions, clock.now()));
  }

  // ---- alarms, state -----------------------------------------------------------

  hasAlarm(id) {
    return this.engine !== null && this.engine.alarmIds().includes(id);
  }

  faultedResources() {
    return this.engine ? this.engine.faultedResources() : [];
  }

  /** The core interlock's counts and snapshot, for tests and tools. */
  get core() {
    return this.engine;
  }

  get lostState() {
    return this.engine ? this.engine.lost() || null : null;
  }

  /** The state as a person (or a dashboard) reads it (see the engine's view), with the routines and runs. */
  describe() {
    if (this.state !== 'ready') return { failure: this.failure ? { code: this.failure.code, message: this.failure.message } : null };
    const now = clock.now();
    const tracker = this.tracker;
    const engine = this.live();
    const view = this.guard(() => (tracker ? engine.viewAgainst(now, tracker) : engine.view(now)));
    return {
      ...view,
      recentEvents: view.recentEvents.map((r) => ({ ...r, summary: describeEvent(r) })),
      routines: [...this.routines.values()].map((host) => host.describe()),
      saved: { where: this.store.where, failing: this.committer.failing, writes: this.committer.writes },
      runs: [...this.runs].map((run) => ({ operation: run.operation, granted: run.granted })),
    };
  }

  /** Resolves once every change so far is saved and its effects have run (tests, benchmarks). */
  settled() {
    return this.committer.settled();
  }

  /** The counts as a status; the same object while they do not change, so unchanged nodes cost nothing. */
  countsStatus() {
    const c = this.shown;
    const seen = this.countsShown;
    if (seen && seen.holding === c.holding && seen.queued === c.queued && seen.faulted === c.faulted && seen.lost === c.lost) return seen.status;
    const status = countsStatus(c);
    this.countsShown = { ...c, status };
    return status;
  }

  refreshStatus(only) {
    if (this.palette) this.palette.changes.touch();
    let status;
    if (this.state === 'ready') {
      if (!this.gateOpen) status = drainingStatus();
      else if (this.committer.failing) status = statusOf('error', i18n.text('status.stateNotSaved'));
      else status = this.countsStatus();
    } else if (this.state === 'failed') status = errorStatus(this.failure ? this.failure.code : 'INTERNAL');
    else if (this.state === 'starting') status = statusOf('idle', i18n.text('status.starting'));
    else return;
    for (const node of only ? [only] : this.users) this.setStatus(node, status);
  }

  showError(node, code) {
    if (node) super.showError(node, code);
  }
}

// The interlock layer's own time per call, for the overhead figures.
timeLayer(InterlockRuntime, 'interlock', ['input', 'request', 'operator']);

/** What the engine sets on a msg before it goes on. */
function applySet(msg, set, runtime) {
  if (set.kind === 'interlock') {
    msg.interlock = { operation: set.operation, priority: set.priority, resources: set.resources, waitedMs: set.waitedMs };
  } else if (set.kind === 'cleared') {
    msg.cleared = set.cleared;
    msg.clearedBy = { by: set.by, reason: set.reason, forced: set.forced };
  } else if (set.kind === 'refused') {
    const err = runtime.error(set.refusal, null);
    msg.refused = { code: err.code, message: err.message, lines: set.refusal.lines || [] };
  }
}

module.exports = { InterlockRuntime };
