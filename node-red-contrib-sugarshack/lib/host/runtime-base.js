// @ts-check
'use strict';
// What the interlock and plant runtimes share: the config node that owns them
// (replaced on each deploy), the nodes showing their status, their life (the
// core's one state machine: which stage each step leads to, and what each
// stage does with a msg; this keeps the stage it said and carries msgs), and
// the guard that turns a wasm trap into a rebuild instead of a dead process.
const { SugarshackError, asSugarshackError } = require('./errors');
const { errorStatus, status, StatusBoard } = require('./status');
const wasm = require('../wasm');
const i18n = require('./i18n');
const { UntilReady } = require('./until-ready');

/** @typedef {import('../interlock/pending').HeldMsg} HeldMsg */
/** @typedef {{ node: NodeRed.Node | null, done: NodeRed.Done, work: (runtime: any) => void, urgent: boolean, passive: boolean, engine?: boolean }} ParkedWork */
/** @typedef {import('../../wasm/sugarshack_wasm').LifeView} LifeView */
/** @typedef {import('../../wasm/sugarshack_wasm').LifeStep} LifeStep */

class RuntimeBase {
  /** kind: 'interlock' | 'plant', for messages. @param {'interlock' | 'plant'} kind */
  constructor(kind) {
    this.kind = kind;
    this.owner = null; // the config node instance of the current deploy
    this.key = null; // settings key, set by the palette
    this.palette = null;
    /** @type {LifeView} its stage as the core said it at its last step, and what it does with msgs there */
    this.life = wasm.load().lifeView('starting');
    this.failure = null;
    this.users = new Set();
    this.statusBoard = new StatusBoard();
    /**
     * Work held while starting or draining (`ParkedWork` each), within Node-RED's
     * msg buffer bound: a plant's (it has no engine), and an interlock's that is
     * no engine input (an operation or routine node's run, hosted here). An
     * interlock node's msg waits in the engine instead (see `EngineRuntime.park`).
     */
    this.parked = new UntilReady();
    this.bufferMax = 0; // Node-RED's nodeMessageBufferMaxLength in force (0: no bound)
    /** @type {(() => void)[]} run once ready with the gate open */
    this.openWaiters = [];
    this.generation = wasm.currentGeneration();
    /** a core call of its reads a msg's values (see wasm.reading) */
    this.reading = false;
    this.stopTrapWatch = wasm.onTrap((err, generation) => this.afterTrap(err, generation));
  }

  // ---- owner and users -----------------------------------------------------

  /** Its config node of this deploy, and Node-RED's msg buffer bound as this deploy reads it (0: none). */
  attach(owner, bufferMax = 0) {
    this.owner = owner;
    this.bufferMax = bufferMax;
  }

  /** Takes `step` of its life: the core says the stage it leads to; work that waits for the gate hears it close. @param {LifeStep} step */
  step(step) {
    const wasOpen = this.takesWork;
    this.life = wasm.load().lifeStep(this.life.stage, step);
    if (wasOpen && !this.takesWork) this.gateMoved(false);
  }

  /** What its stage does now with work (`life.admit`): urgent work does not wait for a drain, passive work runs on a standby too. */
  admits(urgent = false, passive = false) {
    return this.life.admit[(urgent ? 1 : 0) | (passive ? 2 : 0) | (this.standby ? 4 : 0)];
  }

  /** Its stage takes plain work now: started, no drain, not failed, on standby or stopped. */
  get takesWork() {
    return this.admits() === 'take';
  }

  /**
   * Its gate closed (a step) or opened (held work resumes, after the step
   * and its engine's): what runs by the gate follows (an interlock's routines).
   * @param {boolean} _open
   */
  gateMoved(_open) {}

  /** 'starting' | 'ready' | 'failed' | 'standby' | 'stopped': its stage as the state API names it. */
  get state() {
    return this.life.state;
  }

  /** Shut down or retired: it changes nothing any more. */
  get ended() {
    return this.life.stopped;
  }

  /** A deploy's drain goes on (new work waits unless urgent). */
  get draining() {
    return this.life.draining;
  }

  /** No deploy's drain goes on. */
  get gateOpen() {
    return !this.life.draining;
  }

  /** It cannot run (its settings, its document or its saved state refused): every msg gets the reason. */
  fail(err) {
    const e = asSugarshackError(err);
    this.failure = e;
    this.step('fail');
    this.log('error', e.message);
    this.refreshStatus();
    this.parked.completeAll(e);
  }

  log(level, text) {
    const target = this.owner;
    if (target) target[level](text);
    else if (this.palette && this.palette.RED.log) this.palette.RED.log[level](`[sugarshack ${this.kind}] ${text}`);
  }

  addUser(node) {
    this.users.add(node);
    this.refreshStatus(node);
  }

  removeUser(node) {
    this.users.delete(node);
  }

  // ---- held msgs across deploys ----------------------------------------------

  /** The msgs this runtime holds for nodes (each a `heldMsg`); a runtime lists its own. */
  /** @returns {HeldMsg[]} */
  heldEntries() {
    return [];
  }

  /** A node of a new deploy with the id of one that held msgs here takes them over. */
  adopt(node) {
    for (const entry of this.heldEntries()) if (entry.nodeId === node.id && !entry.node) entry.adopt(node);
    this.adopted(node);
  }

  /** @param {NodeRed.Node} _node */
  adopted(_node) {}

  /**
   * A node closes in a deploy (not a shutdown). Restarted, its held msgs are
   * completed now and go on from its next instance; removed, what it waits for
   * is withdrawn. A restarted node that has not come back by the end of the
   * deploy counts as removed (each runtime says how: see `closing`).
   */
  nodeClosed(node, removed) {
    this.dropParked(node);
    for (const entry of this.heldEntries()) if (entry.node === node) entry.detach();
    this.closing(node, removed);
  }

  /** @param {NodeRed.Node} _node @param {boolean} _removed */
  closing(_node, _removed) {}

  /** A deploy stops the flows (the palette tells each runtime). */
  deployBegins() {
    this.step('deploy-begin');
  }

  /** The deploy's flows started. */
  deployEnds() {
    this.step('deploy-end');
  }

  // ---- work from nodes -----------------------------------------------------

  /**
   * Runs `work(this)` when the runtime can take it, as its stage says
   * (`life.admit`): at once when ready, held (in arrival order) while it
   * starts or a deploy drains, refused when it failed, completed unsent when
   * stopped or on standby. `urgent` work (a fault, a lockout, a clear, a
   * release, device feedback) does not wait for a drain: the drain itself
   * may wait for it; `passive` work runs on a standby too. A refusal thrown
   * by `work` completes the msg with the error, so a Catch node gets it.
   */
  submit(node, done, work, { urgent = false, passive = false, engine = false } = {}) {
    switch (this.admits(urgent, passive)) {
      case 'take':
        this.perform(node, done, work);
        break;
      case 'park':
        this.park({ node, done, work, urgent, passive, engine });
        break;
      case 'refuse':
        done(this.failure);
        break;
      case 'standby':
        this.standbyDone(node, done);
        break;
      default:
        done();
    }
  }

  /** Held until it starts or the drain ends; past Node-RED's msg buffer bound, refused (QUEUE_FULL). */
  /** @param {ParkedWork} task */
  park(task) {
    const max = this.bufferMax;
    if (max > 0 && this.parked.length >= max) {
      this.refuse(task.node, task.done, SugarshackError.of('QUEUE_FULL', 'parkedFull', { kind: this.kind, max }));
    } else {
      this.parked.hold(task);
    }
  }

  perform(node, done, work) {
    try {
      this.guard(() => work(this));
    } catch (err) {
      this.refuse(node, done, err);
    }
  }

  /** Work that threw completes its msg with the error (a Catch node gets it), shown on the node. */
  refuse(node, done, err) {
    const e = asSugarshackError(err);
    if (node) this.showError(node, e.code);
    done(e);
  }

  /**
   * A hot standby acts on nothing: a msg is completed without an error (the
   * active instance got the same msg and answers it; an error here would fire
   * every Catch node of the standby), and the node shows `standby`.
   */
  get standby() {
    return this.life.state === 'standby';
  }

  standbyDone(node, done) {
    if (node) this.setStatus(node, standbyStatus());
    done();
  }

  /** Runs `fn`, a core call: refused while its core reads a msg (see wasm.reading); a wasm trap in it starts the rebuild and surfaces as INTERNAL. */
  guard(fn) {
    wasm.entering(this);
    try {
      return fn();
    } catch (err) {
      throw this.trapped(err);
    }
  }

  /** What `err` thrown by a core call surfaces as: a wasm trap starts the rebuild and is INTERNAL; anything else is itself. */
  trapped(err) {
    if (!wasm.isTrap(err)) return err;
    const generation = this.generation;
    setImmediate(() => wasm.recover(err, generation));
    return SugarshackError.of('INTERNAL', 'coreTrapped', { kind: this.kind, message: err.message });
  }

  /** What `describe()` says, read from its core through `guard`. */
  described() {
    return this.guard(() => this.describe());
  }

  afterTrap(err, generation) {
    if (this.ended) return;
    this.generation = generation;
    this.log('error', i18n.text('logs.trapped', { message: err && err.message }));
    this.rebuild();
  }

  /** Runs `fn` once the runtime is ready and no deploy is draining (checks against the settings in force). */
  whenOpen(fn) {
    if (this.life.waits) this.openWaiters.push(fn);
    else fn();
  }

  /** Releases held work in order (ready, or a drain finished). */
  replayParked() {
    if (this.takesWork) this.gateMoved(true);
    for (const fn of this.openWaiters.splice(0)) {
      try {
        fn();
      } catch (err) {
        this.log('error', err.message);
      }
    }
    for (const task of this.parked.take()) this.submit(task.node, task.done, task.work, task);
  }

  /** A closing node's held work is completed unsent. */
  dropParked(node) {
    this.parked.completeOf(node);
  }

  /** A deploy's drain begins. */
  closeGate() {
    if (this.life.draining) return;
    this.step('drain-begin');
    if (!this.life.draining) return; // stopped: nothing drains
    this.onGateClosed();
    this.refreshStatus();
  }

  /** The drain ended. */
  openGate() {
    if (!this.life.draining) return;
    this.step('drain-end');
    this.refreshStatus();
    this.onGateOpened();
    this.replayParked();
  }

  onGateClosed() {}

  onGateOpened() {}

  /** What kept a deploy's drain waiting may have ended here (see Palette.pokeDrain). */
  mayBeQuiet() {
    if (this.palette && this.palette.draining) this.palette.pokeDrain();
  }

  // ---- endings ----------------------------------------------------------------

  /** Completes held work unsent and stops watching for traps. @param {'shutdown' | 'retire'} [step] */
  endCommon(step = 'shutdown') {
    this.step(step);
    this.stopTrapWatch();
    this.parked.completeAll();
  }

  // ---- status -----------------------------------------------------------------

  /**
   * Shows the runtime's state on `only`, or on every user; each runtime says how.
   * @param {NodeRed.Node} [_only]
   */
  refreshStatus(_only) {
    throw new Error(`the ${this.kind} runtime does not show a status`);
  }

  /** Its state as a person reads it; each runtime says how. @returns {object} */
  describe() {
    throw new Error(`the ${this.kind} runtime does not describe itself`);
  }

  /** Makes its core objects again from its last durable state, after a trap; each runtime says how. */
  rebuild() {
    throw new Error(`the ${this.kind} runtime cannot rebuild`);
  }

  showError(node, code) {
    this.statusBoard.set(node, errorStatus(code));
  }

  setStatus(node, status) {
    this.statusBoard.set(node, status);
  }
}

const drainingStatus = () => status('warning', i18n.text('status.draining'));
const standbyStatus = () => status('idle', i18n.text('status.standby'));

module.exports = { RuntimeBase, drainingStatus, standbyStatus };
