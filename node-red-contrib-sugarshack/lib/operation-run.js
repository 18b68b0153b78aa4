// @ts-check
'use strict';
// Hosts one run of a singular operation (the paper's §III-D). The sequence
// (acquire, steps, return to idle, release; fault and lockout on any failure
// after the grant) is the core's OperationRun; this turns its effects into
// interlock calls, group commands, condition waits and timers, and reports
// what happened back to it. A run belongs to its interlock's runtime, not to
// a node: a deploy hands its msg over to the node's next instance.
const { SugarshackError, asSugarshackError } = require('./errors');
const { clock } = require('./clock');
const { stats } = require('./stats');
const { journal } = require('./journal/bus');
const { text } = require('./i18n');
const { heldMsg } = require('./pending');
const wasm = require('./wasm');

/** @typedef {import('../wasm/sugarshack_wasm').OperationRun} OperationRun */
/** @typedef {import('../wasm/sugarshack_wasm').RunEffect} RunEffect */
/**
 * @template {RunEffect['kind']} K
 * @typedef {Extract<RunEffect, { kind: K }>} EffectOf
 */

class RunHost {
  /** port: where progress, the result and the error go ({ progress, finish, fail, abandon, adopt, detachNode }). */
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
    this.current = null; // the step in progress: { index, cancel() }
  }

  start() {
    try {
      this.run = this.plant.guard(() => this.plant.operationRun(this.operation));
    } catch (err) {
      this.finishWith(() => this.port.fail(asSugarshackError(err)));
      return;
    }
    this.feed((r) => r.start(clock.now()));
  }

  /**
   * A run that was only waiting for its grant when a deploy drained: it starts
   * again with the plan of the document now in force (nothing of it ran).
   */
  restart() {
    if (this.ended || this.granted) return;
    this.free();
    this.start();
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
    for (const effect of effects) this.effect(effect);
  }

  /** @param {RunEffect} e */
  effect(e) {
    journal.event('operation', e.kind, this.operation, e);
    switch (e.kind) {
      case 'acquire':
        this.acquire(e);
        break;
      case 'startStep':
        this.startStep(e);
        break;
      case 'release':
        this.attempt(
          () => this.interlock.release(e.operation, () => this.feed((r) => r.released(clock.now()))),
          (err) => this.feed((r) => r.releaseFailed(err.code, err.message, clock.now())),
        );
        break;
      case 'fault':
        this.attempt(
          () => this.interlock.fault(e.operation, e.note, (lockouts) => {
            this.plant.issueLockouts(lockouts, e.operation);
            this.feed((r) => r.faultApplied(lockouts.map((l) => l.resource), clock.now()));
          }),
          (err) => {
            this.interlock.log('error', text('logs.faultNotApplied', { operation: e.operation, message: err.message }));
            this.feed((r) => r.faultApplied([], clock.now()));
          },
        );
        break;
      case 'cancelStep':
        this.cancelStep();
        break;
      case 'withdraw':
        this.attempt(
          () => this.interlock.cancel(e.operation, () => this.feed((r) => r.withdrawn(clock.now()))),
          () => this.feed((r) => r.withdrawn(clock.now())),
        );
        break;
      case 'finished':
        stats.add(`operation/run/${e.id}`, e.runMs);
        stats.add(`operation/queued/${e.id}`, e.queuedMs);
        this.finishWith(() => this.port.finish({ id: e.id, queuedMs: e.queuedMs, runMs: e.runMs, steps: e.steps }));
        break;
      case 'failed':
        this.finishWith(() => this.port.fail(failure(e, this.operation)));
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
      node: null, msg: null, send: null, done: null, sinceMs: clock.now(), run: this,
      operation: e.operation, priority: e.priority, resources: e.resources, timeoutMs: 0,
    });
    entry.grant = () => {
      this.granted = true;
      this.feed((r) => r.granted(clock.now()));
    };
    entry.refuse = (err) => this.feed((r) => r.refused(err.code, err.message));
    // Taken out of the queue by someone else (a cancel node, a fault while it waits): the run ends
    // as refused, nothing ran. Its own withdrawal ends through `withdrawn`; a shutdown through `shutdown`.
    entry.abandon = () => {
      if (this.interlock.ended) return;
      this.feed((r) => [
        ...r.refused('ABORTED', text('errors.takenOutOfQueue', { operation: e.operation })),
        ...r.withdrawn(clock.now()),
      ]);
    };
    this.attempt(() => this.interlock.request(entry), (err) => this.feed((r) => r.refused(err.code, err.message)));
  }

  /** @param {EffectOf<'startStep'>} effect */
  startStep({ index, step, within }) {
    this.port.progress('step', index, step);
    const done = (err) => {
      if (this.current !== token) return; // a late answer for a step already left
      this.current = null;
      if (err) {
        const e = asSugarshackError(err);
        this.feed((r) => r.stepFailed(index, e.code, e.message, clock.now()));
      } else {
        this.feed((r) => r.stepDone(index, clock.now()));
      }
    };
    /** @type {{ index: number, cancel: (reason: string) => void }} */
    const token = { index, cancel: () => {} };
    this.current = token;
    try {
      if (step.kind === 'wait') {
        const signal = {};
        token.cancel = (reason) => signal.cancel && signal.cancel(reason);
        this.plant.condition(step.condition, step.sensors)
          .waitUntil(step.timeoutMs, signal)
          .then(() => done(null), (err) => done(err));
      } else {
        token.cancel = this.plant.runCommand({
          payload: step.command,
          timeoutMs: step.timeoutMs,
          within,
          onDone: done,
        });
      }
    } catch (err) {
      done(err);
    }
  }

  cancelStep() {
    const token = this.current;
    this.current = null;
    if (token) token.cancel(text('labels.operationStopped'));
  }

  finishWith(report) {
    if (this.ended) return;
    this.ended = true;
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

  /** Stopped by its interlock (removed from the flows): a granted run faults, a waiting one withdraws. */
  interrupt(reason) {
    this.feed((r) => r.interrupt(reason, clock.now()));
  }

  /** Shutdown: everything stays as it is (the saved state decides the restart); the msg is completed unsent. */
  shutdown() {
    if (this.ended) return;
    this.ended = true;
    const token = this.current;
    this.current = null;
    if (token) token.cancel(text('labels.nodeRedStopping'));
    this.free();
    if (this.port.abandon) this.port.abandon();
  }

  /** Its core is gone (a wasm trap): the run ends with the error, touching nothing. */
  abandon(err) {
    if (this.ended) return;
    const token = this.current;
    this.current = null;
    if (token) token.cancel(text('labels.coreFailed'));
    this.finishWith(() => this.port.fail(err));
  }
}

/**
 * The core's `failed` effect as the error a Catch node gets. A run that failed
 * after its grant (a step, its release, or stopped while running) carries
 * msg.operation-style details: { id, step, kind, lockedOut, aborted }.
 */
/**
 * @param {EffectOf<'failed'>} e
 * @param {string} operation
 */
function failure(e, operation) {
  const error = new SugarshackError(e.code, e.message);
  if (e.stage !== 'acquire') {
    error.operation = { id: e.id || operation, step: e.step, kind: e.stage, lockedOut: e.lockedOut || [], aborted: Boolean(e.aborted) };
  } else if (e.aborted) {
    error.operation = { id: e.id || operation, step: null, kind: 'acquire', lockedOut: [], aborted: true };
  }
  return error;
}

module.exports = { RunHost };
