// @ts-check
'use strict';
// Hosts one run of a singular operation (the paper's §III-D). The sequence
// (acquire, steps, return to idle, release; fault and lockout on any failure
// after the grant) and the operator's ISA-88 commands (hold, restart, stop,
// abort, reset) are the core's OperationRun; this turns its effects into
// interlock calls, group commands, condition waits and timers, and reports
// what happened back to it. A run belongs to its interlock's runtime, not to
// a node: a deploy hands its msg over to the node's next instance, and a run
// held by an operator is saved with the interlock's state and comes back held
// after a restart.
const { SugarshackError, asSugarshackError } = require('../host/errors');
const { clock } = require('../host/clock');
const { stats } = require('../host/stats');
const { journal } = require('../journal/bus');
const { text } = require('../host/i18n');
const { heldMsg } = require('../interlock/pending');
const wasm = require('../wasm');

/** @typedef {import('../../wasm/sugarshack_wasm').OperationRun} OperationRun */
/** @typedef {import('../../wasm/sugarshack_wasm').RunEffect} RunEffect */
/** @typedef {import('../../wasm/sugarshack_wasm').RunOwner} RunOwner */
/** @typedef {import('../../wasm/sugarshack_wasm').RunState} RunState */
/**
 * @template {RunEffect['kind']} K
 * @typedef {Extract<RunEffect, { kind: K }>} EffectOf
 */
/**
 * Where a run reports. `owner` is kept with a held run's save; `waiting`
 * marks the port of a run restored held whose owner has not taken it yet.
 * `fail` gets the run's final state (none when no run started or its core failed).
 * @typedef {{
 *   owner: RunOwner, waiting?: boolean,
 *   progress: (what: 'queued' | 'step' | 'entered', index?: number | null, detail?: any) => void,
 *   finish: (result: object) => void, stop: (result: object) => void,
 *   fail: (err: SugarshackError, ended?: RunState) => void,
 *   abandon?: () => void, adopt?: (node: any) => void, detachNode?: (node: any) => void, nodeId?: string,
 * }} RunPort
 */

class RunHost {
  /** @param {{ interlock: any, plant: any, operation: string, msg: any, port: RunPort }} fields */
  constructor({ interlock, plant, operation, msg, port }) {
    this.interlock = interlock;
    this.plant = plant;
    this.operation = operation;
    this.msg = msg;
    this.port = port;
    /** @type {OperationRun | null} */
    this.run = null;
    this.granted = false;
    this.ended = false;
    /** @type {RunState | null} where it ended, once it did */
    this.endState = null;
    /** @type {Map<number, (reason: string) => void>} the step, hold or restore in progress, by its attempt: how to cancel it */
    this.inFlight = new Map();
    /** @type {RunState | null} the operator's state it last entered, as known without asking its core */
    this.entered = null;
  }

  start() {
    try {
      this.run = this.plant.guard(() => this.plant.t.operationRun(this.operation));
      // An aborted operation starts again only after a person's reset (the core's rule).
      this.interlock.guard(() => this.interlock.abortedOperations().checkStart(this.operation));
    } catch (err) {
      this.finishWith(() => this.port.fail(asSugarshackError(err)));
      return;
    }
    this.feed((r) => r.start(clock.now()));
  }

  /**
   * A run saved held, back after a restart: its lines kept by the interlock,
   * nothing commanded (the hold command goes out again if it was not
   * confirmed at the save). Its owner takes it over with `takePort`.
   * @param {{ run: OperationRun, effects: RunEffect[] }} restored
   */
  restored({ run, effects }) {
    this.run = run;
    this.granted = true;
    this.entered = /** @type {RunState} */ (run.state());
    this.apply(effects);
  }

  /** The owner of a run restored held takes it over: its status shows where it is. */
  /** @param {RunPort} port */
  takePort(port) {
    this.port = port;
    const state = this.state();
    if (state) port.progress('entered', this.run ? this.run.step() ?? null : null, state);
  }

  /** Its ISA-88 state (where it ended, once it did). @returns {RunState | null} */
  state() {
    if (this.run && !this.ended) return /** @type {RunState} */ (this.run.state());
    return this.endState;
  }

  /** The commands an operator may give it now. */
  commands() {
    return this.run && !this.ended ? this.run.commands() : [];
  }

  /** Held or holding: what is saved with the interlock's state so that it comes back held. */
  snapshot() {
    if (!this.run || this.ended) return undefined;
    return this.run.snapshot(this.port.owner);
  }

  /** How long the current hold has lasted (0 unless holding or held). */
  heldMs(now) {
    const saved = this.snapshot();
    return saved ? Math.max(0, now - saved.heldSinceMs) : 0;
  }

  /**
   * An operator's command by `who` ({ by, reason }): the core's refusal
   * (COMMAND_REFUSED...) throws and changes nothing; else its effects are
   * carried out and the state it entered is returned.
   * @param {string} command @param {{ by?: string, reason?: string }} who
   */
  command(command, who) {
    const run = /** @type {OperationRun} */ (this.run);
    const now = clock.now();
    const effects = this.interlock.guard(() => run.command(command, who.by || undefined, who.reason || undefined, now));
    // Recorded in the same write as its lockouts. Only an abort makes it wait, and nothing follows one but its end.
    if (run.awaitsReset()) this.interlock.operationAborted(this.operation, who, now);
    this.apply(effects);
    return this.state();
  }

  /**
   * Gives the core machine an input and acts on the effects it returns.
   * @param {(run: OperationRun) => RunEffect[]} input
   */
  feed(input) {
    if (this.ended) return;
    let effects;
    try {
      effects = this.interlock.guard(() => input(/** @type {OperationRun} */ (this.run)));
    } catch (err) {
      this.abandon(asSugarshackError(err));
      return;
    }
    this.apply(effects);
  }

  /**
   * Acts on effects in order. When the run entered an operator's state, that
   * state is saved before the step, hold or restore it sets off leaves: a
   * restart must never find a run saved held whose equipment was already
   * commanded on, nor lose one that was holding.
   * @param {RunEffect[]} effects
   */
  apply(effects) {
    const saveFirst = effects.some((e) => e.kind === 'entered');
    if (saveFirst) this.interlock.changed();
    for (const effect of effects) this.effect(effect, saveFirst);
  }

  /** @param {RunEffect} e @param {boolean} saveFirst */
  effect(e, saveFirst) {
    journal.event('operation', e.kind, this.operation, e.kind === 'entered' ? { ...e, note: e.state } : e);
    switch (e.kind) {
      case 'acquire':
        this.acquire(e);
        break;
      case 'startStep':
        this.startStep(e, saveFirst);
        break;
      case 'hold':
        // Like a lockout, the hold makes equipment safe: it leaves even if the state cannot be saved.
        this.launch(e.attempt, saveFirst ? 'unsaved' : 'now', (settle) => this.groupCommand(e, settle),
          (r, err) => (err ? r.holdFailed(e.attempt, err.code, err.message, clock.now()) : r.holdDone(e.attempt, clock.now())));
        break;
      case 'restore':
        this.launch(e.attempt, saveFirst ? 'saved' : 'now', (settle) => this.groupCommand(e, settle),
          (r, err) => (err ? r.restartFailed(e.attempt, err.code, err.message, clock.now()) : r.restartDone(e.attempt, clock.now())));
        break;
      case 'entered':
        this.entered = e.state;
        this.port.progress('entered', e.step, e.state);
        // Held, it no longer keeps a deploy's drain waiting.
        this.interlock.mayBeQuiet();
        break;
      case 'release': {
        // The interlock's refusal comes back thrown, or later through `refused`.
        const refused = (err) => this.feed((r) => r.releaseFailed(err.code, err.message, clock.now()));
        this.attempt(() => this.interlock.release(e.operation, () => this.feed((r) => r.released(clock.now())), refused), refused);
        break;
      }
      case 'fault': {
        const refused = (err) => {
          this.interlock.log('error', text('logs.faultNotApplied', { operation: e.operation, message: err.message }));
          this.feed((r) => r.faultRefused(clock.now()));
        };
        this.attempt(() => this.interlock.fault(e.operation, e.note, (lockouts) => {
          this.plant.issueLockouts(lockouts, e.operation);
          this.feed((r) => r.faultApplied(lockouts.map((l) => l.resource), clock.now()));
        }, refused), refused);
        break;
      }
      case 'cancelStep':
        this.cancel(e.attempt, text('labels.operationStopped'));
        break;
      case 'withdraw': {
        const refused = () => this.feed((r) => r.withdrawRefused(clock.now()));
        this.attempt(() => this.interlock.cancel(e.operation, () => this.feed((r) => r.withdrawn(clock.now())), refused), refused);
        break;
      }
      case 'finished':
        stats.add(`operation/run/${e.id}`, e.runMs);
        stats.add(`operation/queued/${e.id}`, e.queuedMs);
        this.finishWith(() => this.port.finish({ id: e.id, queuedMs: e.queuedMs, runMs: e.runMs, heldMs: e.heldMs, steps: e.steps }), 'complete');
        break;
      case 'stopped':
        // An orderly end an operator asked for: the msg goes on, marked stopped, not an error.
        this.finishWith(() => this.port.stop({
          id: e.id, queuedMs: e.queuedMs, runMs: e.runMs, heldMs: e.heldMs, steps: e.steps, stopped: true, step: e.step,
        }), 'stopped');
        break;
      case 'failed':
        this.finishWith(() => this.port.fail(failure(e, this.operation), e.state), e.state);
        break;
      default: {
        const unknown = /** @type {{ kind: string }} */ (e); // a kind a newer core added
        this.interlock.log('warn', text('logs.unknownRunEffect', { operation: this.operation, kind: unknown.kind }));
      }
    }
  }

  attempt(call, onRefusal) {
    try {
      this.interlock.guard(call);
    } catch (err) {
      onRefusal(asSugarshackError(err));
    }
  }

  /** @param {EffectOf<'acquire'>} e */
  acquire(e) {
    this.port.progress('queued');
    // Held for the run, not for a node: no node takes it over in a deploy.
    const entry = heldMsg({
      node: null, msg: null, send: null, done: null, run: this,
      operation: e.operation, priority: e.priority, resources: e.resources, timeoutMs: 0,
    });
    entry.grant = () => {
      this.granted = true;
      this.feed((r) => r.granted(clock.now()));
    };
    entry.refuse = (err) => this.feed((r) => r.refused(err.code, err.message));
    // Taken out of the queue by someone else (a cancel node, a fault while it waits); a shutdown ends through `shutdown`.
    entry.abandon = () => {
      if (this.interlock.ended) return;
      this.feed((r) => r.takenOutOfQueue(clock.now()));
    };
    this.attempt(() => this.interlock.request(entry), (err) => this.feed((r) => r.refused(err.code, err.message)));
  }

  /**
   * A step with the time the core gives it (after a hold, what was left).
   * @param {EffectOf<'startStep'>} effect @param {boolean} saveFirst
   */
  startStep({ index, attempt, step, within, timeoutMs }, saveFirst) {
    this.port.progress('step', index, step);
    this.launch(attempt, saveFirst ? 'saved' : 'now', (settle) => {
      if (step.kind === 'wait') {
        const signal = {};
        this.plant.sensors.condition(step.condition, step.sensors)
          .waitUntil(timeoutMs, signal)
          .then(() => settle(null), (err) => settle(err));
        return (reason) => signal.cancel && signal.cancel(reason);
      }
      return this.plant.commands.run({ payload: step.command, timeoutMs, within, onDone: settle });
    }, (r, err) => (err ? r.stepFailed(attempt, err.code, err.message, clock.now()) : r.stepDone(attempt, clock.now())));
  }

  /** A hold or restore group command within the run's lines. @param {EffectOf<'hold' | 'restore'>} e */
  groupCommand(e, settle) {
    return this.plant.commands.run({ payload: e.command, timeoutMs: e.timeoutMs, within: e.within, onDone: settle });
  }

  /**
   * Starts an action (a step, a hold or restore command), attempt `attempt`
   * of the core: `now`, once the state is saved (`saved`), or once saved or
   * the save failed (`unsaved`). Cancelled before it started, it never does.
   * Its outcome goes to the core with its attempt, however late: the core
   * ignores an answer to an attempt that is no longer its current one.
   * @param {number} attempt
   * @param {'now' | 'saved' | 'unsaved'} when
   * @param {(settle: (err: any) => void) => ((reason: string) => void)} begin returns its cancel
   * @param {(run: OperationRun, err: SugarshackError | null) => RunEffect[]} outcome
   */
  launch(attempt, when, begin, outcome) {
    this.inFlight.set(attempt, () => {});
    const settle = (err) => {
      this.inFlight.delete(attempt);
      const e = err ? asSugarshackError(err) : null;
      this.feed((r) => outcome(r, e));
    };
    const go = () => {
      if (!this.inFlight.has(attempt) || this.ended) return;
      try {
        const cancel = begin(settle);
        if (this.inFlight.has(attempt)) this.inFlight.set(attempt, cancel);
      } catch (err) {
        settle(err);
      }
    };
    if (when === 'now') go();
    else this.interlock.committer.change(go, { evenUnsaved: when === 'unsaved' });
  }

  /** Stops attempt `attempt` if it is still in progress. @param {number} attempt @param {string} reason */
  cancel(attempt, reason) {
    const cancel = this.inFlight.get(attempt);
    this.inFlight.delete(attempt);
    if (cancel) cancel(reason);
  }

  /** Stops whatever is in progress (the run ends without its core). @param {string} reason */
  cancelAll(reason) {
    for (const attempt of [...this.inFlight.keys()]) this.cancel(attempt, reason);
  }

  /** @param {() => void} report @param {RunState} [state] */
  finishWith(report, state) {
    if (this.ended) return;
    this.ended = true;
    if (state) this.endState = state;
    this.free();
    this.interlock.runEnded(this);
    report();
  }

  free() {
    wasm.release(this.run);
    this.run = null;
  }

  // ---- the run's owner comes and goes --------------------------------------

  /** A node of a new deploy with the id of this run's node takes its msg over. */
  adopt(node) {
    if (this.port.adopt) this.port.adopt(node);
  }

  detachNode(node) {
    if (this.port.detachNode) this.port.detachNode(node);
  }

  /** Its supervisor is gone (its interlock removed from the flows): a granted run faults, a waiting one withdraws. */
  interrupt(reason) {
    this.feed((r) => r.interrupt(reason, clock.now()));
  }

  /** Shutdown: everything stays as it is (the saved state decides the restart); the msg is completed unsent. */
  shutdown() {
    if (this.ended) return;
    this.ended = true;
    this.cancelAll(text('labels.nodeRedStopping'));
    this.free();
    if (this.port.abandon) this.port.abandon();
  }

  /** Held (or holding) when last heard of: it comes back held from the saved state. */
  get heldBeforeTrap() {
    return this.entered === 'held' || this.entered === 'holding';
  }

  /**
   * Its core is gone (a wasm trap) while it was held: it ends quietly and
   * its port waits for the run that comes back held from the saved state.
   */
  suspend() {
    this.ended = true;
    this.cancelAll(text('labels.coreFailed'));
    wasm.forget(this.run);
    this.run = null;
    this.interlock.runEnded(this);
    return this.port;
  }

  /** Its core is gone (a wasm trap): the run ends with the error, touching nothing. */
  abandon(err) {
    if (this.ended) return;
    this.cancelAll(text('labels.coreFailed'));
    this.finishWith(() => this.port.fail(err));
  }
}

/**
 * The port of a run restored held until its owner takes it: it shows nothing,
 * and how the run ends, should an operator end it first, goes to the log.
 * @param {any} interlock @param {RunOwner} owner @returns {RunPort}
 */
function waitingPort(interlock, owner) {
  const log = (err) => interlock.log('warn', text('logs.heldRunEnded', { owner: owner.id, message: err.message }));
  return {
    owner,
    waiting: true,
    progress: () => {},
    finish: () => {},
    stop: () => {},
    fail: log,
  };
}

/**
 * The core's `failed` effect as the error a Catch node gets. A run that failed
 * after its grant (a step, its release, or stopped while running) carries
 * msg.operation-style details: { id, step, kind, lockedOut, aborted, state }.
 */
/**
 * @param {EffectOf<'failed'>} e
 * @param {string} operation
 */
function failure(e, operation) {
  const error = new SugarshackError(e.code, e.message);
  if (e.stage !== 'acquire') {
    error.operation = { id: e.id || operation, step: e.step, kind: e.stage, lockedOut: e.lockedOut || [], aborted: Boolean(e.aborted), state: e.state };
  } else if (e.aborted) {
    error.operation = { id: e.id || operation, step: null, kind: 'acquire', lockedOut: [], aborted: true, state: e.state };
  }
  return error;
}

module.exports = { RunHost, waitingPort };
