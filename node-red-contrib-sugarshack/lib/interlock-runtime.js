// @ts-check
'use strict';
// The running interlock behind one interlock config node, for the whole life
// of the Node-RED process: one core Interlock, the operations running on it and
// the routines dispatching them, plus what Node-RED owns around it (held msgs,
// status, event fan-out, the durable state). Every rule is the core's; this
// calls it and acts on what it returns, and every effect of a state change
// (a grant sent, a lockout, an event) leaves only once that state is on disk.
const { SugarshackError, asSugarshackError } = require('./errors');
const { PendingRegistry, heldMsg } = require('./pending');
const { deliver, grantedBy, takeGrants } = require('./grants');
const { EventFanout, describeWarning, describeEvent } = require('./events');
const { AlarmBook, conditionsOf } = require('./alarms');
const { countsStatus, errorStatus, status: statusOf } = require('./status');
const { stats, timeLayer } = require('./stats');
const { clock } = require('./clock');
const { FileStore, MemoryStore, Committer, stateDir } = require('./durable');
const { RuntimeBase, drainingStatus, standbyStatus } = require('./runtime-base');
const { RunHost, waitingPort } = require('./operation-run');
const { RoutineHost } = require('./routine-host');
const wasm = require('./wasm');
const i18n = require('./i18n');
const { journal } = require('./journal/bus');
const { StatusPacer } = require('./status-pacer');
const { clusterOf, EtcdStore } = require('./cluster');

const TICK_MS = 1000;
const ALARM_CHECK_MS = 1000;
const LEGACY_KEY = (id) => `sugarshack-interlock:${id}`;

class InterlockRuntime extends RuntimeBase {
  /**
   * settings: { config (the core's), persist, legacyStore, error }; plant: the
   * PlantRuntime it is bound to, or null.
   */
  constructor({ RED, id, settings, plant = null }) {
    super('interlock');
    this.RED = RED;
    this.id = id;
    this.swapOrder = 1; // after the plants it may be bound to
    this.plant = plant;
    this.applySettings(settings);
    this.core = null;
    this.pending = new PendingRegistry(); // operation handle -> waiting entry
    this.events = new EventFanout();
    this.runs = new Set();
    this.routines = new Map(); // routine id -> RoutineHost
    this.savedRoutines = {}; // routine snapshots not yet taken up by a host
    this.savedAlarms = undefined; // the alarms saved with the state, for the next AlarmBook
    /** @type {import('../wasm/sugarshack_wasm').RunSnapshot[]} held runs saved with the state, restored once it runs */
    this.savedRuns = [];
    /** @type {import('../wasm/sugarshack_wasm').AbortedOperations | null} operations aborted and not reset, with the core */
    this.aborted = null;
    this.heldBack = []; // waiting requests taken out of the queue while a deploy drains
    this.lostState = null; // why the state was unknown at start, until those lines are cleared
    this.started = null; // how it last started: { outcome: 'new' | 'restored' | 'lost', reason, added, dropped }
    this.tickTimer = null;
    this.alarms = null; // AlarmBook, with the core
    this.alarmTimer = null;
    // In a hot-standby cluster the state is in etcd whatever `persist` says: a standby without it would start every line faulted.
    this.stopFollowing = null;
    /** @type {EtcdStore | null} */
    this.etcdStore = null;
    try {
      this.cluster = clusterOf(RED);
    } catch (err) {
      // Never alone by mistake: a cluster misconfigured refuses every msg instead of acting as a single instance.
      this.cluster = null;
      this.configError = err;
    }
    if (this.cluster) this.etcdStore = new EtcdStore(this.cluster, id);
    /** @type {FileStore | MemoryStore | EtcdStore} */
    this.store = this.etcdStore || (settings.persist ? new FileStore(stateDir(RED), id) : new MemoryStore());
    this.committer = this.makeCommitter();
    // Counts on nodes change with every grant: shown paced, the last state always (after each window).
    this.statusPacer = new StatusPacer(() => this.refreshStatus(), () => this.state === 'ready');
    this.countsShown = null; // { holding, queued, faulted, lost, status }: the counts status last made
    // The core's handles by name (see handles()).
    this.handlesOf = null;
    this.handlesEpoch = -1;
    /** @type {Map<string, number>} */
    this.opHandles = new Map();
    /** @type {Map<string, number>} */
    this.setHandles = new Map();
    /** @type {Map<string, number>} */
    this.multiSetHandles = new Map();
  }

  applySettings(settings) {
    this.settings = settings;
    this.config = settings.config;
    this.persist = settings.persist;
    this.legacyStore = settings.legacyStore;
    this.configError = settings.error || null;
  }

  /** The core configuration in force: bound to a plant, its lines and lockouts come from the plant's document. */
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
      snapshot: () => this.document(),
      collect: () => {
        if (!this.core) return null;
        // The alarms are made with the core and always listen: with no other reader they keep the abnormal records only.
        const records = this.events.listened() ? this.core.drainEvents() : this.core.drainAbnormalEvents();
        // The alarms a fault or a clear raises or ends go into this same write.
        if (records.length && this.alarms && this.alarms.noteEvents(records, describeEvent)) this.observeAlarms({ inWrite: true });
        if (!this.events.listened() || !records.length) return null;
        // In a cluster each event names the instance and the fencing token it was committed under.
        const { cluster } = this;
        const stamped = cluster ? records.map((r) => ({ ...r, instance: cluster.instance, token: cluster.token })) : records;
        return () => this.events.publish(stamped);
      },
      mayAct: () => !this.cluster || this.cluster.mayAct(),
      onError: (err) => {
        this.log('error', i18n.text('logs.stateNotSaved', { where: this.store.where, message: err.message || err }));
        this.refreshStatus();
      },
      onSaved: () => this.statusPacer.request(),
    });
  }

  /**
   * The durable document, sealed as one by the core: the interlock's
   * snapshot, its routines' states, its alarms, the runs an operator held
   * (each with its owner) and the operations aborted and not reset.
   */
  document() {
    const routines = { ...this.savedRoutines };
    for (const [id, host] of this.routines) {
      const snapshot = host.snapshot();
      if (snapshot) routines[id] = snapshot;
    }
    const alarms = this.alarms ? this.alarms.snapshot() : undefined;
    const runs = [];
    for (const run of this.runs) {
      const held = run.snapshot();
      if (held) runs.push(held);
    }
    const aborted = this.aborted ? this.aborted.snapshot() : undefined;
    return this.core.seal(this.id, this.settings.plantId || undefined, { routines, alarms, runs, aborted }, clock.now());
  }

  // ---- lifecycle -----------------------------------------------------------

  async start() {
    try {
      this.config = this.resolveConfig();
    } catch (err) {
      this.fail(err);
      return;
    }
    if (this.cluster && this.etcdStore && !(await this.loadCommitted(this.cluster, this.etcdStore))) return;
    const saved = await this.readSaved();
    if (this.ended) return;
    try {
      this.core = this.guard(() => this.build(saved, clock.now()));
      this.alarms = this.guard(() => this.alarmBook());
    } catch (err) {
      this.fail(err);
      return;
    }
    this.markRan();
    this.state = 'ready';
    this.restoreHeldRuns();
    this.committer.change(); // the state as started is the first one on disk
    this.startTicking();
    this.refreshStatus();
    this.resendLockouts(i18n.text('labels.resentAtStart'));
    this.replayParked();
  }

  /** What was saved: its state file, or on a first run a state an earlier version kept in a context store. */
  async readSaved() {
    const saved = this.readStore();
    if (saved.kind === 'first' && this.persist && !this.cluster) {
      const legacy = await this.legacySnapshot();
      if (legacy) return { kind: 'carried-over', snapshot: legacy };
    }
    return saved;
  }

  /** The state file as read, or lost when it cannot be read. */
  readStore() {
    try {
      return this.store.read();
    } catch (err) {
      return { kind: 'lost', why: err.message };
    }
  }

  /** It ran here: from now on a missing state file is a lost state. */
  markRan() {
    try {
      this.store.markRan();
    } catch (err) {
      // Its state cannot be written either: grants will wait for it (status "state not saved").
      this.log('error', i18n.text('logs.markerNotWritten', { where: this.store.where, message: err.message }));
    }
  }

  // ---- hot standby (lib/cluster) ----------------------------------------------

  /**
   * In a cluster: true once the committed state is read under this instance's
   * fencing token, as a restart reads its file; false (standby) when this
   * instance is not the leader.
   */
  async loadCommitted(cluster, store) {
    if (!this.stopFollowing) this.stopFollowing = cluster.follow(this);
    if (cluster.active) {
      try {
        await store.unfollow();
        await store.load();
        // Deposed while it read: standDown() has made it standby already.
        if (this.ended || this.state === 'standby') return false;
        if (cluster.active) return true;
      } catch (err) {
        this.log('warn', i18n.text('logs.standbyNotTaken', { message: err.message }));
      }
    }
    if (!this.ended) this.becomeStandby();
    return false;
  }

  /** Elected: the committed state is opened as after a restart (held lines faulted, lockouts sent again). */
  activate() {
    if (this.ended || this.state !== 'standby') return;
    this.state = 'starting';
    this.refreshStatus();
    this.start();
  }

  /** Deposed: nothing more leaves, as at a shutdown; what waited here is completed unsent, and the state followed again. */
  async standDown() {
    if (this.ended || this.state === 'standby') return;
    const wasReady = this.state === 'ready';
    this.stopTimers();
    await this.committer.freeze();
    for (const handle of this.pending.handles()) this.pending.take(handle).abandon();
    for (const entry of this.heldBack) entry.abandon();
    this.heldBack = [];
    for (const run of this.runs) run.shutdown();
    this.runs.clear();
    for (const host of this.routines.values()) host.shutdown();
    this.routines.clear();
    this.savedRoutines = {};
    if (wasReady) this.freeCore();
    this.lostState = null;
    this.committer = this.makeCommitter();
    this.becomeStandby();
  }

  becomeStandby() {
    this.state = 'standby';
    this.parked.completeAll();
    this.refreshStatus();
    if (this.etcdStore) this.etcdStore.follow().catch((err) => this.log('warn', i18n.text('logs.standbyNotFollowing', { message: err.message })));
  }

  /**
   * The core interlock from what was saved: opened from its document by the
   * core (restored, or all faulted when it is not this interlock's usable
   * state), carried over from a context store, all faulted when the file was
   * lost, or new. Notes how it started, the routines' and alarms' states saved
   * with it.
   */
  build(saved, now) {
    const { Interlock, AbortedOperations } = wasm.load();
    this.savedRoutines = {};
    this.savedAlarms = undefined;
    this.savedRuns = [];
    if (this.aborted) wasm.release(this.aborted);
    this.aborted = new AbortedOperations(undefined);
    this.started = { outcome: 'new', reason: null, added: [], dropped: [] };
    if (saved.kind === 'saved') {
      // Bound to its plant, a run saved held comes back held when the plant still has its plan.
      const tracker = this.plant && this.plant.state === 'ready' ? this.plant.t : null;
      const plantId = this.settings.plantId || undefined;
      const opened = tracker
        ? Interlock.openBound(this.config, this.id, plantId, this.store.where, saved.text, now, tracker)
        : Interlock.open(this.config, this.id, plantId, this.store.where, saved.text, now);
      // An abort stands until a person resets it, even when the rest of the state was lost.
      wasm.release(this.aborted);
      this.aborted = new AbortedOperations(opened.aborted);
      if (opened.lost) this.startedLost(opened.lost);
      else this.startedRestored(opened);
      return opened.interlock;
    }
    if (saved.kind === 'carried-over') {
      try {
        const core = Interlock.restore(this.config, saved.snapshot, false, false, now);
        this.started.outcome = 'restored';
        return core;
      } catch (err) {
        if (wasm.isTrap(err)) throw err;
        saved = { kind: 'lost', why: asSugarshackError(err).message };
      }
    }
    if (saved.kind === 'lost') {
      this.startedLost(saved.why);
      return Interlock.unknownState(this.config, i18n.text('labels.stateUnknown', { why: saved.why }), now);
    }
    return new Interlock(this.config);
  }

  startedLost(why) {
    this.lostState = why;
    this.started = { outcome: 'lost', reason: why, added: [], dropped: [] };
    this.log('error', i18n.text('logs.stateUnknown', { why }));
  }

  startedRestored({ added, dropped, routines, alarms, runs, runsInterrupted }) {
    this.started = { outcome: 'restored', reason: null, added, dropped };
    this.savedRoutines = routines;
    this.savedAlarms = alarms || undefined;
    this.savedRuns = runs;
    for (const line of added) this.log('warn', i18n.text('logs.lineAdded', { line }));
    for (const line of dropped) this.log('warn', i18n.text('logs.lineDropped', { line }));
    for (const why of runsInterrupted) this.log('warn', i18n.text('logs.heldRunNotRestored', { why }));
  }

  /**
   * The runs saved held come back held, their lines kept and nothing
   * commanded, each waiting for its owner (its operation node, or its
   * routine) to take it over; an operator restarts or aborts it.
   */
  restoreHeldRuns() {
    const saved = this.savedRuns;
    this.savedRuns = [];
    for (const snapshot of saved) {
      const owner = snapshot.owner || { kind: 'node', id: '' };
      try {
        const restored = this.guard(() => this.plant.t.restoreRun(snapshot));
        const run = new RunHost({ interlock: this, plant: this.plant, operation: snapshot.operation, msg: null, port: waitingPort(this, owner) });
        this.runs.add(run);
        run.restored(restored);
      } catch (err) {
        // The core kept its lines for it: with no run to supervise them, they lock out.
        const why = asSugarshackError(err).message;
        this.log('error', i18n.text('logs.heldRunNotRestored', { why }));
        this.fault(snapshot.operation, why, (lockouts) => this.plant.issueLockouts(lockouts, snapshot.operation));
      }
    }
  }

  /**
   * The run restored held that `owner` left, for it to take over with its
   * own port; null when there is none.
   * @param {import('../wasm/sugarshack_wasm').RunOwner} owner
   */
  heldRunOf(owner) {
    for (const run of this.runs) {
      if (run.port.waiting && run.port.owner.kind === owner.kind && run.port.owner.id === owner.id) return run;
    }
    return null;
  }

  /** The operations of runs restored held for routine `id` (its saved state takes them as still pending). */
  heldOperationsOf(id) {
    return [...this.runs].filter((run) => run.port.waiting && run.port.owner.kind === 'routine' && run.port.owner.id === id).map((run) => run.operation);
  }

  /** The alarms as saved with the state (acknowledgements and shelves survive a restart), or none yet. */
  alarmBook() {
    return new AlarmBook(this.savedAlarms, (text) => this.log('warn', text));
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

  /** Lockouts of every faulted line go out again once the flows run (a device may have lost its retained one). */
  resendLockouts(note) {
    if (!this.plant) return;
    this.palette.whenStarted(() => {
      if (this.state !== 'ready') return;
      const faulted = this.core.faultedResources();
      if (faulted.length === 0) return;
      try {
        this.guard(() => this.faultResources(faulted, note, (lockouts) => this.plant.issueLockouts(lockouts, null)));
      } catch (err) {
        this.log('error', i18n.text('logs.lockoutsNotResent', { lines: faulted.join(', '), message: err.message }));
      }
    });
  }

  /**
   * A shutdown: nothing changes the saved state any more. A write in flight
   * completes; held msgs are completed unsent; the restart sees the last state
   * whose effects went out.
   */
  async shutdown() {
    if (this.ended) return;
    const wasReady = this.state === 'ready';
    this.leaveCluster();
    this.endCommon();
    this.stopTimers();
    await this.committer.freeze();
    for (const handle of this.pending.handles()) this.pending.take(handle).abandon();
    for (const run of this.runs) run.shutdown();
    for (const host of this.routines.values()) host.shutdown();
    if (wasReady) this.freeCore();
  }

  /** Its config node left the flows: running operations are stopped as faults, the state written, the core freed. */
  async retire() {
    if (this.ended) return;
    if (this.state === 'ready') {
      for (const run of [...this.runs]) run.interrupt('its interlock was removed from the flows');
      for (const handle of this.pending.handles()) {
        const entry = this.pending.take(handle);
        this.guard(() => this.core.cancel(handle, clock.now()));
        entry.abandon();
      }
      this.committer.change();
      await this.committer.drain();
    }
    const wasReady = this.state === 'ready';
    this.leaveCluster();
    this.endCommon();
    this.stopTimers();
    for (const run of this.runs) run.shutdown();
    for (const host of this.routines.values()) host.shutdown();
    if (wasReady) this.freeCore();
  }

  leaveCluster() {
    if (this.stopFollowing) this.stopFollowing();
    this.stopFollowing = null;
    if (this.etcdStore) this.etcdStore.unfollow();
  }

  /** Elapsed-time warnings are checked once a second when the configuration sets any. */
  startTicking() {
    this.stopTimers();
    if (this.config.warnQueuedMs || this.config.warnHeldMs) this.tickTimer = clock.setInterval(() => this.tick(), TICK_MS);
    this.alarmTimer = clock.setInterval(() => this.observeAlarms(), ALARM_CHECK_MS);
  }

  stopTimers() {
    if (this.tickTimer) clock.clearInterval(this.tickTimer);
    this.tickTimer = null;
    if (this.alarmTimer) clock.clearInterval(this.alarmTimer);
    this.alarmTimer = null;
    this.statusPacer.stop();
  }

  freeCore() {
    wasm.release(this.core);
    this.core = null;
    wasm.release(this.aborted);
    this.aborted = null;
    if (this.alarms) this.alarms.free();
    this.alarms = null;
  }

  // ---- deploys -------------------------------------------------------------

  /** New work waits; waiting requests leave the core's queue so releases grant nobody until the swap. */
  onGateClosed() {
    if (this.state !== 'ready') return;
    const now = clock.now();
    this.heldBack = [];
    for (const handle of Array.from(this.core.queuedOperations()).reverse()) {
      const entry = this.pending.take(handle);
      this.guard(() => this.core.cancel(handle, now));
      if (entry) this.heldBack.unshift(entry);
    }
    this.committer.change();
  }

  /**
   * After the swap: the held-back requests queue again, in their old order, each
   * with what is left of its timeout. An operation run that was only waiting
   * starts again on the document now in force.
   */
  onGateOpened() {
    const heldBack = this.heldBack;
    this.heldBack = [];
    for (const entry of heldBack) {
      try {
        if (entry.run) entry.run.restart();
        else this.guard(() => this.requeue(entry));
      } catch (err) {
        entry.refuse(asSugarshackError(err));
      }
    }
  }

  /**
   * Drained when no operation holds a grant through a run of ours that is
   * doing something (waiting ones are held back; a held one commands
   * nothing and is handed over as it is).
   */
  quiescent() {
    for (const run of this.runs) if (run.granted && run.state() !== 'held') return false;
    return true;
  }

  /** New settings after the drain: the core is rebuilt from its own state, holds kept (the process did not stop). */
  swap(settings) {
    this.applySettings(settings);
    // A standby has no state of its own: it takes the new settings when it is elected.
    if (this.state === 'standby') return;
    if (!this.takeConfig()) return;
    const now = clock.now();
    const { Interlock } = wasm.load();
    try {
      const next = this.guard(() => {
        const snapshot = this.core ? this.core.snapshot(now) : null;
        return snapshot ? Interlock.restore(this.config, snapshot, false, true, now) : new Interlock(this.config);
      });
      if (this.core) wasm.release(this.core);
      this.core = next;
      if (!this.alarms) this.alarms = new AlarmBook(undefined, (text) => this.log('warn', text));
      this.state = 'ready';
      this.failure = null;
    } catch (err) {
      this.fail(err);
      return;
    }
    this.startTicking();
    for (const host of this.routines.values()) host.rebuild(host.snapshot());
    this.committer.change();
    this.refreshStatus();
    // A new plant tracker knows no standing lockout yet.
    this.resendLockouts(i18n.text('labels.resentPlantChanged'));
  }

  /** New settings' configuration in force; false (failed, its core freed) when it cannot run. */
  takeConfig() {
    try {
      this.config = this.resolveConfig();
      return true;
    } catch (err) {
      if (this.core) this.freeCore();
      this.state = 'starting';
      this.fail(err);
      return false;
    }
  }

  /** After a wasm trap: back to the last saved state, as after a restart (held lines faulted, waiting dropped). */
  rebuild() {
    if (this.state !== 'ready') return;
    this.committer.discard();
    for (const host of this.routines.values()) host.suspend();
    const error = SugarshackError.of('INTERNAL', 'interlockRebuilt');
    for (const handle of this.pending.handles()) this.pending.take(handle).refuse(error);
    // A held run comes back held from the saved state: its owner's port waits for it.
    const heldPorts = [];
    for (const run of [...this.runs]) {
      if (run.heldBeforeTrap) heldPorts.push(run.suspend());
      else run.abandon(error);
    }
    for (const entry of this.heldBack) entry.refuse(error);
    this.heldBack = [];
    wasm.forget(this.core);
    this.core = null;
    wasm.forget(this.aborted);
    this.aborted = null;
    if (this.alarms) wasm.forget(this.alarms.core);
    this.alarms = null;
    const saved = this.readStore();
    try {
      this.core = this.build(saved, clock.now());
      this.alarms = this.alarmBook();
    } catch (err) {
      this.state = 'starting';
      this.fail(err);
      return;
    }
    this.restoreHeldRuns();
    // A routine's is taken by the routine as it rebuilds (below).
    for (const port of heldPorts.filter((p) => p.owner.kind === 'node')) {
      const run = this.heldRunOf(port.owner);
      if (run) run.takePort(port);
      else port.fail(error);
    }
    for (const [id, host] of this.routines) {
      host.rebuild(this.savedRoutines[id]);
      delete this.savedRoutines[id];
    }
    this.committer.change();
    this.refreshStatus();
    this.resendLockouts(i18n.text('labels.resentAfterRebuild'));
  }

  // ---- nodes using this interlock ------------------------------------------

  addEventsNode(node) {
    this.events.add(node);
  }

  removeUser(node) {
    super.removeUser(node);
    this.events.remove(node);
  }

  heldEntries() {
    return [...this.pending.entries(), ...this.heldBack];
  }

  adopted(node) {
    for (const run of this.runs) run.adopt(node);
  }

  closing(node) {
    for (const run of this.runs) run.detachNode(node);
  }

  withdrawOrphans(nodeId) {
    const now = clock.now();
    const answers = [];
    let withdrawn = 0;
    for (const handle of Array.from(this.core.queuedOperations()).reverse()) {
      const entry = this.pending.get(handle);
      if (!entry || entry.nodeId !== nodeId || entry.node) continue;
      this.pending.take(handle);
      const count = this.guard(() => this.core.cancel(handle, now));
      answers.push(...this.grantsOf(count, now));
      withdrawn++;
    }
    this.heldBack = this.heldBack.filter((entry) => entry.nodeId !== nodeId || entry.node);
    // A withdrawal is a change: saved, and its `cancelled` event sent, now.
    if (withdrawn) this.changed(() => answers.forEach((answer) => answer()));
    else this.refreshStatus();
  }

  // ---- interlock calls from nodes (each throws the core's refusal unchanged) --

  /** Grants and sends the msg on (once saved), or holds it until a grant. */
  acquire({ node, msg, send, done, operation, priority, resources, timeoutMs }) {
    const entry = msgEntry({ node, msg, send, done, operation, priority, resources, sinceMs: clock.now() });
    entry.timeoutMs = timeoutMs;
    this.request(entry);
  }

  /**
   * The core's handles of operation names and resource sets, remembered for
   * the core that made them: a msg names its operation and lines as text on
   * every acquire, and text crossing into wasm costs more than the call. The
   * core forgets idle names past a bound (a flow may name a new operation
   * per msg) and drops set handles past a bound; it says so by a new
   * handleEpoch(), and the handles are asked again. So these maps are no
   * larger than the core's own tables.
   */
  handles() {
    if (this.handlesOf !== this.core) this.forgetHandles();
    return this;
  }

  forgetHandles() {
    this.handlesOf = this.core;
    this.handlesEpoch = this.core.handleEpoch();
    this.opHandles = new Map();
    this.setHandles = new Map(); // one line, by its name
    this.multiSetHandles = new Map(); // several, by their names' JSON
  }

  /** After asking the core for a handle: the other handles kept may be stale. */
  checkEpoch() {
    if (this.core.handleEpoch() !== this.handlesEpoch) this.forgetHandles();
  }

  /** @param {string} name */
  opHandle(name) {
    const known = this.handles().opHandles.get(name);
    if (known !== undefined) return known;
    const handle = this.core.operation(name);
    this.checkEpoch();
    this.opHandles.set(name, handle);
    return handle;
  }

  /** @param {string[]} names */
  setHandle(names) {
    const key = names.length === 1 ? names[0] : JSON.stringify(names);
    const known = (names.length === 1 ? this.handles().setHandles : this.handles().multiSetHandles).get(key);
    if (known !== undefined) return known;
    const handle = this.core.resourceSet(names);
    this.checkEpoch();
    (names.length === 1 ? this.setHandles : this.multiSetHandles).set(key, handle);
    return handle;
  }

  /** Acquire for any waiting entry: granted now (answered once saved) or queued. */
  request(entry) {
    const now = clock.now();
    const handle = this.opHandle(entry.operation);
    const set = this.setHandle(entry.resources);
    if (this.core.acquire(handle, entry.priority, set, now)) {
      this.changed(() => entry.grant(now));
      return;
    }
    this.pending.add(handle, entry);
    if (entry.timeoutMs > 0 && !entry.timer) {
      const left = Math.max(0, entry.sinceMs + entry.timeoutMs - now);
      entry.timer = clock.setTimeout(() => this.expire(handle, entry), left);
    }
    this.changed();
  }

  requeue(entry) {
    if (entry.timer) clock.clearTimeout(entry.timer);
    entry.timer = null;
    this.request(entry);
  }

  /** Releases by name; `then` runs once saved. An operation that holds nothing is refused (NOT_HOLDING). */
  release(operation, then) {
    const now = clock.now();
    const name = requireName(operation);
    // A name this core never saw holds nothing: releaseNamed refuses it without registering it.
    const handle = this.handles().opHandles.get(name);
    const count = handle === undefined ? this.core.releaseNamed(name, now) : this.core.release(handle, now);
    const answers = this.grantsOf(count, now);
    this.changed(() => {
      if (then) then();
      answers.forEach((answer) => answer());
    });
  }

  /** Withdraws a waiting request; its held msg is completed without being sent. */
  cancel(operation, then) {
    const now = clock.now();
    const name = requireName(operation);
    const heldBack = this.heldBack.find((entry) => entry.operation === name);
    if (heldBack) {
      // Taken out of the queue while a deploy drains: it is withdrawn here.
      this.heldBack = this.heldBack.filter((entry) => entry !== heldBack);
      this.committer.after(() => {
        heldBack.abandon();
        if (then) then();
      });
      this.refreshStatus();
      return;
    }
    const count = this.core.cancelNamed(name, now);
    const handle = this.core.findOperation(name);
    const entry = this.pending.take(handle);
    const answers = this.grantsOf(count, now);
    this.changed(() => {
      if (entry) entry.abandon();
      if (then) then();
      answers.forEach((answer) => answer());
    });
  }

  /** Faults an operation; `then(lockouts)` runs once saved (or, if saving fails, at once: isolation first). */
  fault(operation, note, then) {
    const now = clock.now();
    const handle = this.core.findOperation(requireName(operation));
    const outcome = this.core.fault(handle, note, now);
    const dropped = outcome.dropped ? this.pending.take(handle) : null;
    const answers = this.answer(outcome.grants, now);
    this.committer.change(() => then(outcome.lockouts), { evenUnsaved: true });
    this.changed(() => {
      if (dropped) dropped.abandon();
      answers.forEach((answer) => answer());
    });
  }

  /** An emergency stop of lines, owned or not, by `who` ({ by, reason }); `then(lockouts)` as for `fault`. */
  faultResources(names, note, then, who = {}) {
    const now = clock.now();
    const outcome = this.core.faultResources(this.core.resourceSet(names), note, who.by || null, who.reason || null, now);
    const answers = this.answer(outcome.grants, now);
    this.committer.change(() => then(outcome.lockouts), { evenUnsaved: true });
    this.changed(() => answers.forEach((answer) => answer()));
  }

  /**
   * Clears the named lines, or every faulted one when `names` is null, by
   * `who` ({ by, reason, force }); `then(cleared)` once saved. Bound to a
   * plant, the core refuses (CLEAR_REFUSED, every reason in `err.lines`)
   * until the plant shows each line isolated, unless forced.
   */
  clear(names, then, who = {}) {
    const now = clock.now();
    const targets = names === null ? this.core.faultedResources() : names;
    if (names === null && targets.length === 0) {
      this.committer.after(() => then([]));
      return;
    }
    const set = this.core.resourceSet(targets);
    const by = who.by || null;
    const reason = who.reason || null;
    const force = who.force === true;
    const tracker = this.plant && this.plant.state === 'ready' ? this.plant.t : null;
    const count = tracker
      ? this.core.clearAgainst(set, tracker, by, reason, force, now)
      : this.core.clear(set, by, reason, force, now);
    const answers = this.grantsOf(count, now);
    if (this.lostState && !this.hasUnknownLines(now)) this.lostState = null;
    this.changed(() => {
      then(targets);
      answers.forEach((answer) => answer());
    });
  }

  /** Why each faulted line may not be cleared now, per line (empty: it may). */
  clearBlockers() {
    if (this.state !== 'ready') return [];
    const faulted = this.core.faultedResources();
    const tracker = this.plant && this.plant.state === 'ready' ? this.plant.t : null;
    if (faulted.length === 0 || !tracker) return faulted.map((line) => ({ line, reasons: [] }));
    return this.core.clearBlockers(this.core.resourceSet(faulted), tracker);
  }

  faultedResources() {
    return this.core.faultedResources();
  }

  // ---- alarms (the core keeps their states; see alarms.js) ------------------

  /**
   * Tells the core which conditions hold now. A change is saved with the next
   * write; `inWrite` when called while that write is being made.
   */
  observeAlarms({ inWrite = false } = {}) {
    if (this.state !== 'ready' || !this.alarms) return;
    const now = clock.now();
    let changes;
    try {
      changes = this.guard(() => {
        const plant = this.plant && this.plant.state === 'ready'
          ? { devices: this.plant.t.alarmConditions(), buses: this.plant.buses.map((b) => ({ node: (b.node && b.node.name) || b.nodeId, connected: b.connected })) }
          : null;
        const conditions = conditionsOf({
          interlock: this.core.alarmConditions(now), saveFailing: this.committer.failing, store: this.store.where, plant,
          cluster: this.cluster ? this.cluster.alarmConditions() : [],
        });
        return this.alarms.observe(conditions, now);
      });
    } catch (err) {
      this.log('error', i18n.text('logs.alarmsNotUpdated', { message: err.message }));
      return;
    }
    if (changes.length === 0) return;
    if (!inWrite) this.committer.change();
    // No node's status shows alarms: only the state's readers hear of it.
    if (this.palette) this.palette.changes.touch(this);
  }

  /** Acknowledges alarms (`ids`, or every unacknowledged one when null) by `who`; `then(changes)` once saved. */
  acknowledgeAlarms(ids, who, then) {
    this.alarmAction('alarm-ack', who, () => this.alarms.acknowledge(ids, who, clock.now()), then);
  }

  /** Shelves alarm `id` until `untilMs` (and, `oneShot`, until its condition ends) by `who`; `then(changes)` once saved. */
  shelveAlarm(id, untilMs, who, then, { oneShot = false } = {}) {
    this.alarmAction('alarm-shelve', who, () => this.alarms.shelve(id, untilMs, who, clock.now(), oneShot), then);
  }

  unshelveAlarm(id, who, then) {
    this.alarmAction('alarm-unshelve', who, () => this.alarms.unshelve(id, who, clock.now()), then);
  }

  /** The alarm states as of now first, so a person acts on what the page shows; journaled like a clear. */
  alarmAction(action, who, act, then) {
    this.observeAlarms();
    const changes = act();
    const done = changes.filter((c) => c.action !== 'shelf-expired');
    if (done.length) journal.action(action, who, [...new Set(done.map((c) => c.id))]);
    this.committer.change(() => then(changes));
    if (this.palette) this.palette.changes.touch(this);
  }

  hasAlarm(id) {
    return Boolean(this.alarms) && this.alarms.has(id);
  }

  // ---- operations run from the plant document ------------------------------

  /** Starts an operation's run; `port` gets its progress, result or error. */
  startRun(operation, msg, port) {
    if (!this.plant) {
      throw SugarshackError.of('NO_PLANT', 'noPlantForOperations');
    }
    const run = new RunHost({ interlock: this, plant: this.plant, operation, msg, port });
    this.runs.add(run);
    run.start();
    return run;
  }

  runEnded(run) {
    this.runs.delete(run);
    if (this.palette && this.palette.draining) this.palette.pokeDrain();
  }

  /** An operator aborted `operation` at `now`: it refuses every start until a person resets it (saved with the state). */
  operationAborted(operation, who, now) {
    this.abortedOperations().ended(operation, 'aborted', who.by || undefined, who.reason || undefined, now);
  }

  /** The aborted operations, made with the core (so there while it is ready). */
  abortedOperations() {
    if (!this.aborted) throw SugarshackError.of('INTERNAL', 'interlockRebuilt');
    return this.aborted;
  }

  /**
   * An operator's ISA-88 command (`hold`, `restart`, `stop`, `abort`,
   * `reset`) to the run of an operation (`target.operation`, also an
   * operation waiting for a reset) or to a routine (`target.routine`), by
   * `who` ({ by, reason }); `then(state)` once the state it entered is
   * saved. Throws, changing nothing, the core's refusal (COMMAND_REFUSED
   * naming the state and what it allows, ROUTINE_BUSY...), UNKNOWN_RUN when
   * nothing of that id runs or waits for a reset here, INVALID_INPUT for
   * what is not a command.
   * @param {{ operation?: string, routine?: string }} target
   * @param {string} command
   * @param {{ by?: string, reason?: string }} who
   * @param {(state: string | null) => void} then
   */
  command(target, command, who, then) {
    const commands = wasm.load().operatorCommands();
    if (typeof command !== 'string' || !commands.includes(/** @type {any} */ (command))) {
      throw SugarshackError.of('INVALID_INPUT', 'notACommand', { command: String(command), commands: commands.join(', ') });
    }
    let state;
    if (target && typeof target.routine === 'string') {
      const host = this.routines.get(target.routine);
      if (!host || !host.machine) throw SugarshackError.of('UNKNOWN_RUN', 'noSuchRoutineRun', { id: target.routine });
      state = host.command(command, who);
    } else if (target && typeof target.operation === 'string') {
      const id = target.operation;
      const run = [...this.runs].find((r) => r.operation === id && !r.ended);
      if (run) state = run.command(command, who);
      else if (this.abortedOperations().state(id) === 'aborted') state = this.abortedOperations().command(id, command);
      else throw SugarshackError.of('UNKNOWN_RUN', 'noSuchOperationRun', { id });
    } else {
      throw SugarshackError.of('INVALID_INPUT', 'commandTarget');
    }
    this.changed(() => then(state));
  }

  /** The runs as an operator reads them: state, step, the commands allowed now, who drives each. */
  describeRuns(now) {
    return [...this.runs].map((run) => {
      const step = run.run && !run.ended ? run.run.step() : undefined;
      return {
        operation: run.operation,
        granted: run.granted,
        state: run.state(),
        step: step ?? null,
        commands: run.commands(),
        heldMs: run.heldMs(now),
        routine: run.port.owner.kind === 'routine' ? run.port.owner.id : null,
      };
    });
  }

  /** The operations aborted and not reset: each refuses a start until a person resets it. */
  describeAborted() {
    if (!this.aborted) return [];
    return this.aborted.list().map((a) => ({ operation: a.operation, sinceMs: a.sinceMs, by: a.by.by, reason: a.by.reason ?? null, commands: ['reset'] }));
  }

  /** The host of routine `id`, made (and restored from the saved state) on first use. */
  routineHost(id) {
    let host = this.routines.get(id);
    if (!host) {
      if (!this.plant) {
        throw SugarshackError.of('NO_PLANT', 'noPlantForRoutines');
      }
      host = new RoutineHost({ interlock: this, plant: this.plant, id });
      const saved = this.savedRoutines[id];
      delete this.savedRoutines[id];
      host.start(saved); // throws UNKNOWN_ROUTINE before it is kept
      this.routines.set(id, host);
    }
    return host;
  }

  // ---- internals -----------------------------------------------------------

  /** A state change: status now; `effect` once the change is on disk (at once without persistence: after the status, which it may override). */
  changed(effect) {
    if (this.palette) this.palette.changes.touch(this);
    this.statusPacer.request();
    this.committer.change(effect);
  }

  grantsOf(count, now) {
    return takeGrants(this.core, this.pending, grantedBy(this.core, count), { nowMs: now, warn: (text) => this.log('warn', text) });
  }

  answer(grantHandles, now) {
    return takeGrants(this.core, this.pending, grantHandles, { nowMs: now, warn: (text) => this.log('warn', text) });
  }

  expire(handle, entry) {
    if (this.state !== 'ready' || this.pending.get(handle) !== entry) return;
    const now = clock.now();
    this.pending.take(handle);
    let answers = [];
    try {
      answers = this.grantsOf(this.guard(() => this.core.cancel(handle, now)), now);
    } catch (err) {
      this.log('warn', i18n.text('logs.timedOutNotQueued', { operation: entry.operation, message: err.message }));
    }
    this.changed(() => {
      answers.forEach((answer) => answer());
      entry.refuse(SugarshackError.of('ACQUIRE_TIMEOUT', 'acquireTimeout', {
        operation: entry.operation, resources: entry.resources.join(', '), seconds: entry.timeoutMs / 1000,
      }));
    });
  }

  hasUnknownLines(now) {
    return this.core.snapshot(now).resources.some((r) => r.state.state === 'faulted' && r.state.cause === 'unknown');
  }

  tick() {
    if (this.state !== 'ready') return;
    try {
      const warnings = this.guard(() => this.core.tick(clock.now()));
      for (const warning of warnings) this.log('warn', describeWarning(warning));
      if (warnings.length) this.committer.change();
    } catch (err) {
      this.log('error', err.message);
    }
  }

  /**
   * The state as a person (or a dashboard) reads it: every line (free, held by
   * an operation since when, or faulted with its cause and since when, and why
   * it may not be cleared yet), the queue with priorities and waited times,
   * the routines and their pending operations, whether it was lost at start.
   */
  describe() {
    // A standby shows which committed state it follows (the etcd revision of its last write).
    if (this.state === 'standby' && this.etcdStore) return { failure: null, following: { where: this.etcdStore.where, revision: this.etcdStore.held.revision } };
    if (this.state !== 'ready') return { failure: this.failure ? { code: this.failure.code, message: this.failure.message } : null };
    const now = clock.now();
    const snapshot = this.core.snapshot(now);
    const queue = snapshot.queue
      .concat(this.heldBack.map((e) => ({ operation: e.operation, priority: e.priority, resources: e.resources, sinceMs: e.sinceMs })))
      .map((q) => ({ ...q, waitedMs: Math.max(0, now - q.sinceMs) }));
    // Each reason with the core's words for it (`text`).
    const blockers = new Map(this.clearBlockers().map((b) => [b.line, b.reasons.map((r, i) => ({ ...r, text: b.texts[i] }))]));
    const lines = snapshot.resources.map(({ name, state }) => {
      const hold = state.state === 'held' ? snapshot.holds.find((h) => h.operation === state.operation) : null;
      return {
        name,
        state,
        holder: hold ? { operation: hold.operation, priority: hold.priority, sinceMs: hold.sinceMs, heldMs: Math.max(0, now - hold.sinceMs) } : null,
        fault: state.state === 'faulted'
          ? { cause: state.cause, operation: state.operation || null, note: state.note || null, sinceMs: state.sinceMs }
          : null,
        waiting: queue.filter((q) => q.resources.includes(name)).map((q) => q.operation),
        clearBlockers: blockers.get(name) || [],
      };
    });
    return {
      atMs: now,
      // Its plant's id in the same document (`plants[].id`): where its lines' actuators and operations' names are.
      plant: this.plant ? this.plant.id : null,
      lines,
      holds: snapshot.holds,
      queue,
      routines: [...this.routines.values()].map((host) => host.describe()),
      lostState: this.lostState,
      started: this.started,
      alarms: this.alarms ? this.alarms.list() : [],
      alarmChanges: this.alarms ? this.alarms.changes : [],
      recentEvents: this.alarms ? this.alarms.events : [],
      saved: { where: this.store.where, failing: this.committer.failing, writes: this.committer.writes },
      runs: this.describeRuns(now),
      aborted: this.describeAborted(),
    };
  }

  /** Resolves once every change so far is saved and its effects have run (tests, benchmarks). */
  settled() {
    return this.committer.settled();
  }

  /** The counts as a status; the same object while they do not change, so unchanged nodes cost nothing. */
  countsStatus() {
    const { holding, queued, faulted } = this.core.counts();
    const lost = Boolean(this.lostState);
    const seen = this.countsShown;
    if (seen && seen.holding === holding && seen.queued === queued && seen.faulted === faulted && seen.lost === lost) return seen.status;
    const status = countsStatus({ holding, queued, faulted, lost });
    this.countsShown = { holding, queued, faulted, lost, status };
    return status;
  }

  refreshStatus(only) {
    if (this.palette) this.palette.changes.touch(this);
    let status;
    if (this.state === 'ready') {
      if (!this.gateOpen) status = drainingStatus();
      else if (this.committer.failing) status = statusOf('error', i18n.text('status.stateNotSaved'));
      else status = this.countsStatus();
    } else if (this.state === 'standby') status = standbyStatus();
    else if (this.state === 'failed') status = errorStatus(this.failure ? this.failure.code : 'INTERNAL');
    else if (this.state === 'starting') status = statusOf('idle', i18n.text('status.starting'));
    else return;
    for (const node of only ? [only] : this.users) this.setStatus(node, status);
  }
}

// The interlock layer's own time per call, for the overhead figures.
timeLayer(InterlockRuntime, 'interlock', ['acquire', 'release', 'cancel', 'fault', 'faultResources', 'clear']);

function requireName(name) {
  if (!name) throw SugarshackError.of('MISSING_OPERATION', 'operationRequired');
  return name;
}


/** A msg held by an acquire node until its operation is granted. */
function msgEntry({ node, msg, send, done, operation, priority, resources, sinceMs }) {
  const entry = heldMsg({ node, msg, send, done, sinceMs, operation, priority, resources, timeoutMs: 0 });
  entry.grant = (nowMs) => {
    if (entry.send) deliver(entry, nowMs);
  };
  entry.refuse = (err) => {
    if (entry.node && entry.done) entry.node.status(errorStatus(err.code));
    entry.reject(err);
  };
  return entry;
}

module.exports = { InterlockRuntime, msgEntry };
