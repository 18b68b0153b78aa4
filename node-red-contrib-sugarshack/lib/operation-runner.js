'use strict';
// Runs a singular operation from the plant document (the paper's §III-D):
// acquire its resources, run its steps (group commands and condition waits,
// each with its timeout), return every commanded actuator to idle (the plan's
// last step, C3), release. Any error or timeout after the grant faults the
// operation at the interlock, and its lines' lockout commands go out. Every
// rule (plans, C2, staleness, the interlock's) is the core's; this sequences.
const { SugarshackError, asSugarshackError } = require('./errors');
const { Condition } = require('./condition');
const { stats } = require('./stats');

// C1 (one instance of an operation at a time) is the interlock's rule: it refuses
// a request of an operation already holding or queued. Here it is only named.
const ALREADY_RUNNING = new Set(['ALREADY_HOLDING', 'ALREADY_QUEUED']);

/** The plant an interlock is bound to, or a refusal that says how to bind one. */
function plantOf(interlock) {
  if (!interlock.plant) {
    throw new SugarshackError('NO_PLANT', 'this interlock has no plant: choose the plant in the interlock config node to run operations from its document');
  }
  return interlock.plant;
}

/** The plant runtime if it runs; else throws why not (its document's error). */
function readyPlant(plant) {
  if (plant.state !== 'ready') throw plant.failure || new SugarshackError('NO_PLANT', 'the plant is not running');
  return plant;
}

/** Plans and compiled conditions of an operation, checked at deploy. Throws on any problem. */
function prepareOperation(RED, node, interlock, id) {
  const plant = readyPlant(plantOf(interlock));
  const plan = plant.plan(id);
  const conditions = plan.steps.map((step) => (step.kind === 'wait'
    ? new Condition(RED, node, step.condition, step.sensors, plant, 'operation')
    : null));
  return { plan, conditions, plant };
}

const describeStep = (step, i) => `step ${i + 1} (${step.kind === 'returnToIdle' ? 'return to idle' : step.kind})`;

/**
 * Sends lockout commands ([{ resource, command }]) through the plant's actuators
 * nodes; a lockout that cannot complete is reported on `node`.
 */
function issueLockouts(node, plant, lockouts, operation = null) {
  const faultAtMs = Date.now();
  for (const { resource, command } of lockouts) {
    const carrier = { topic: `lockout/${resource}`, payload: command, resource, operation, faultAtMs };
    const done = (err) => {
      if (err) node.error(`lockout of ${resource} did not complete: ${err.message}`);
    };
    if (plant.state === 'ready') plant.submit(node, done, (rt) => rt.command({ node, msg: carrier, send: () => {}, done }));
  }
}

class OperationRun {
  /** prepared: from prepareOperation; msg: carries msg.interlock and msg.command as the steps go. */
  constructor({ node, interlock, prepared, msg, onStep = () => {} }) {
    this.node = node;
    this.interlock = interlock;
    this.plant = prepared.plant;
    this.plan = prepared.plan;
    this.conditions = prepared.conditions;
    this.msg = msg;
    this.onStep = onStep;
    this.phase = 'new'; // -> queued -> running -> done | faulted | aborted
    this.wait = {};
    this.steps = [];
  }

  get id() {
    return this.plan.id;
  }

  /** Resolves with { id, queuedMs, runMs, steps }; rejects with the error (after faulting, once granted). */
  start() {
    return this.execute();
  }

  async execute() {
    const requestedAt = Date.now();
    this.phase = 'queued';
    await this.acquire();
    const grantedAt = Date.now();
    this.phase = 'running';
    let index = 0;
    try {
      for (; index < this.plan.steps.length; index++) {
        if (this.phase !== 'running') throw new SugarshackError('ABORTED', this.abortReason);
        const step = this.plan.steps[index];
        this.onStep('step', index, step);
        const startedAt = Date.now();
        await this.runStep(step, index);
        this.steps.push({ kind: step.kind, ms: Date.now() - startedAt });
      }
      if (this.phase !== 'running') throw new SugarshackError('ABORTED', this.abortReason);
      this.interlock.release(this.id);
    } catch (err) {
      throw this.fail(asSugarshackError(err), index);
    }
    this.phase = 'done';
    const result = { id: this.id, queuedMs: grantedAt - requestedAt, runMs: Date.now() - grantedAt, steps: this.steps };
    stats.add(`operation/run/${this.id}`, result.runMs);
    stats.add(`operation/queued/${this.id}`, result.queuedMs);
    return result;
  }

  acquire() {
    return new Promise((resolve, reject) => {
      let settled = false;
      const done = (err) => {
        if (settled) return;
        settled = true;
        if (err && ALREADY_RUNNING.has(err.code)) {
          reject(new SugarshackError('OPERATION_RUNNING', `operation '${this.id}' is already running (C1: one instance at a time); this start was refused and the running one goes on`));
        } else {
          reject(err || new SugarshackError('ABORTED', `operation '${this.id}' was withdrawn from the queue (its node closed)`));
        }
      };
      const send = () => {
        settled = true;
        resolve();
      };
      this.interlock.submit(this.node, done, (rt) => rt.acquire({
        node: this.node,
        msg: this.msg,
        send,
        done,
        operation: this.id,
        priority: this.plan.priority,
        resources: this.plan.resources,
        timeoutMs: 0,
      }));
      if (!settled) this.onStep('queued');
    });
  }

  runStep(step, index) {
    if (step.kind === 'wait') return this.conditions[index].waitUntil(step.timeoutMs, this.wait);
    return new Promise((resolve, reject) => {
      const carrier = { payload: step.command };
      const done = (err) => (err ? reject(err) : resolve(carrier.command));
      this.plant.submit(this.node, done, (rt) => rt.command({
        node: this.node,
        msg: carrier,
        send: () => {},
        done,
        timeoutMs: step.timeoutMs,
        within: this.plan.resources,
      }));
    });
  }

  /** Faults the operation at the interlock and sends its lockouts; returns the error to report. */
  fail(err, index) {
    const step = this.plan.steps[index];
    const where = step ? describeStep(step, index) : 'its release';
    const aborted = this.phase === 'aborted';
    this.phase = 'faulted';
    const lockouts = this.lockouts || this.lockOut(`${where}: ${err.message}`);
    const lines = lockouts.map((l) => l.resource);
    const error = new SugarshackError(err.code, `operation '${this.id}' faulted at ${where}: ${err.message}`
      + (lines.length ? `; ${lines.join(', ')} locked out until cleared` : ''));
    error.operation = { id: this.id, step: index, kind: step ? step.kind : 'release', lockedOut: lines, aborted };
    return error;
  }

  lockOut(note) {
    if (this.interlock.state !== 'ready') return [];
    let lockouts;
    try {
      lockouts = this.interlock.fault(this.id, note);
    } catch (err) {
      this.node.error(`cannot fault operation '${this.id}' at the interlock: ${err.message}`);
      return [];
    }
    issueLockouts(this.node, this.plant, lockouts, this.id);
    return lockouts;
  }

  /** Its node closes: a granted operation is faulted (nobody supervises it any more); a queued one is withdrawn by the interlock. */
  abort(reason) {
    const wasRunning = this.phase === 'running';
    if (!wasRunning && this.phase !== 'queued') return;
    this.abortReason = reason;
    this.phase = 'aborted';
    // The lockout goes out now; the step in progress then ends in error (a command
    // taken over by the lockout, or the wait cancelled) and the run finishes.
    if (wasRunning) this.lockouts = this.lockOut(`interrupted: ${reason}`);
    if (this.wait.cancel) this.wait.cancel(reason);
  }
}

module.exports = { OperationRun, prepareOperation, plantOf, readyPlant, describeStep, issueLockouts };
