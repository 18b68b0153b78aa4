// @ts-check
'use strict';
// What an interlock's runtime keeps around its engine for the whole life of
// the Node-RED process: its settings and stores (a file, memory, or etcd in a
// hot-standby cluster), the operation runs and routines of the plant bound
// to it (hosted here, each asking the engine for its lines), the events
// nodes, and the status its nodes show. The engine itself is driven by
// lib/interlock/engine-runtime.js.
const { SugarshackError, asSugarshackError } = require('../host/errors');
const { EventFanout } = require('./events');
const { errorStatus, status: statusOf } = require('../host/status');
const { FileStore, MemoryStore, stateDir } = require('../host/durable');
const { RuntimeBase, drainingStatus, standbyStatus } = require('../host/runtime-base');
const { RunHost, waitingPort } = require('../operations/operation-run');
const { RoutineHost } = require('../operations/routine-host');
const wasm = require('../wasm');
const i18n = require('../host/i18n');
const { StatusPacer } = require('../host/status-pacer');
const { clusterOf, EtcdStore } = require('../cluster');

const LEGACY_KEY = (id) => `sugarshack-interlock:${id}`;

class InterlockHost extends RuntimeBase {
  /**
   * settings: { config (the core's), persist, plantBound, plantId, legacyStore, error }; plant: the
   * PlantRuntime it is bound to, or null.
   */
  constructor({ RED, id, settings, plant = null }) {
    super('interlock');
    this.RED = RED;
    this.id = id;
    this.swapOrder = 1; // after the plants it may be bound to
    this.plant = plant;
    this.applySettings(settings);
    /** @type {any} the core Engine (tests and the state page read it as the interlock) */
    this.core = null;
    this.events = new EventFanout();
    /** @type {Set<RunHost>} */
    this.runs = new Set();
    /** @type {Map<string, RoutineHost>} routine id -> its host */
    this.routines = new Map();
    /** @type {Record<string, any>} routine states saved with the state, not yet taken up by a host */
    this.savedRoutines = {};
    /** @type {import('../../wasm/sugarshack_wasm').RunSnapshot[]} held runs saved with the state, restored once it runs */
    this.savedRuns = [];
    this.lostState = null; // why the state was unknown at start, until those lines are cleared
    this.started = null; // how it last started: { outcome: 'new' | 'restored' | 'lost', reason, added, dropped }
    /** @type {(() => void) | null} stops following its plant's and cluster's alarm conditions */
    this.unwatchPlant = null;
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
  }

  // ---- what the engine runtime provides ---------------------------------------

  /** @returns {any} the committer of its state */
  makeCommitter() {
    throw new Error('abstract');
  }

  /** @returns {Promise<void>} */
  async start() {}

  /** @param {string} _operation @param {string} _note @param {(lockouts: any[]) => void} _then */
  fault(_operation, _note, _then) {}

  freeCore() {}

  /** Its routines' conditions are due only while its gate is open. @param {boolean} open */
  gateMoved(open) {
    for (const host of [...this.routines.values()]) host.gate(open);
  }

  /** A routine's deadline changed (the engine runtime's one timer follows them). */
  routineDeadlinesChanged() {}

  /** @returns {any} */
  abortedOperations() {
    return null;
  }

  /** @returns {any} */
  countsStatus() {
    return null;
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
    return { ...this.settings.config, resources: this.plant.t.interlockResources() };
  }

  /** Its view is read against its plant's tracker: refused while that reads a msg too. */
  described() {
    if (this.plant) wasm.entering(this.plant);
    return super.described();
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

  /**
   * In a cluster: true once the committed state is read under this instance's
   * fencing token, as a restart reads its file; false (standby) when this
   * instance is not the leader, or (changing nothing) when `latest()` says a
   * later start overtook this one.
   */
  async loadCommitted(cluster, store, latest = () => true) {
    if (!this.stopFollowing) this.stopFollowing = cluster.follow(this);
    if (cluster.active) {
      try {
        await store.unfollow();
        await store.load();
        // Deposed while it read: standDown() has made it standby already.
        if (this.ended || this.state === 'standby' || !latest()) return false;
        if (cluster.active) return true;
      } catch (err) {
        // Deposed and elected again meanwhile: this read's refusal is not the later start's.
        if (!latest()) return false;
        this.log('warn', i18n.text('logs.standbyNotTaken', { message: err.message }));
      }
    }
    if (!this.ended) this.becomeStandby();
    return false;
  }

  /** Elected: the committed state is opened as after a restart (held lines faulted, lockouts sent again). */
  activate() {
    if (this.ended || this.state !== 'standby') return;
    this.step('activate');
    this.refreshStatus();
    this.start();
  }

  becomeStandby() {
    this.step('stand-down');
    this.parked.completeAll();
    this.refreshStatus();
    if (this.etcdStore) this.etcdStore.follow().catch((err) => this.log('warn', i18n.text('logs.standbyNotFollowing', { message: err.message })));
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
        const restored = this.plant.guard(() => this.plant.t.restoreRun(snapshot));
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
   * @param {import('../../wasm/sugarshack_wasm').RunOwner} owner
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

  leaveCluster() {
    if (this.stopFollowing) this.stopFollowing();
    this.stopFollowing = null;
    if (this.etcdStore) this.etcdStore.unfollow();
  }

  stopTimers() {
    if (this.unwatchPlant) this.unwatchPlant();
    this.unwatchPlant = null;
    this.statusPacer.stop();
  }

  /** New settings' configuration in force; false (failed, its core freed) when it cannot run. */
  takeConfig() {
    try {
      this.config = this.resolveConfig();
      return true;
    } catch (err) {
      // Failed first: an engine still starting hands the msgs it kept to the failure.
      this.fail(err);
      if (this.core) this.freeCore();
      return false;
    }
  }

  addEventsNode(node) {
    this.events.add(node);
  }

  removeUser(node) {
    super.removeUser(node);
    this.events.remove(node);
  }

  adopted(node) {
    for (const run of this.runs) run.adopt(node);
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
    this.mayBeQuiet();
  }

  /** An operator aborted `operation` at `now`: it refuses every start until a person resets it (saved with the state). */
  operationAborted(operation, who, now) {
    this.abortedOperations().ended(operation, 'aborted', who.by || undefined, who.reason || undefined, now);
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
      this.routineDeadlinesChanged();
    }
    return host;
  }

  /** A state change: status now; `effect` once the change is on disk (at once without persistence: after the status, which it may override). */
  changed(effect) {
    if (this.palette) this.palette.changes.touch(this);
    this.statusPacer.request();
    this.committer.change(effect);
  }

  /** Resolves once every change so far is saved and its effects have run (tests, benchmarks). */
  settled() {
    return this.committer.settled();
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

module.exports = { InterlockHost };
