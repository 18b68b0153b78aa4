// @ts-check
'use strict';
// Hosts one routine of the plant document (the paper's §III-E) in its
// interlock's runtime: the core's state machine, its condition checks, and the
// run of the operation it dispatched. Its state is saved in the interlock's
// durable state, in the same write as the interlock's, so a restart never sees
// a routine and its lines disagree. A routine node is only its port: msgs in,
// events out; a deploy hands the routine to the node's next instance. An
// operator's ISA-88 command to the routine goes through its core machine,
// which says what its pending operation gets.
const { SugarshackError, asSugarshackError } = require('../host/errors');
const { errorStatus, status } = require('../host/status');
const { clock } = require('../host/clock');
const { stats } = require('../host/stats');
const { journal } = require('../journal/bus');
const wasm = require('../wasm');
const i18n = require('../host/i18n');

// The operator's states a routine's status shows: how each looks, and its text (`state`: the routine's state).
const OPERATOR_STATES = Object.freeze({
  holding: ['warning', (state) => i18n.text('runStatus.holding', { state })],
  held: ['warning', (state) => i18n.text('runStatus.held', { state })],
  restarting: ['running', (state) => i18n.text('runStatus.restarting', { state })],
  stopping: ['warning', (state) => i18n.text('runStatus.stopping', { state })],
  stopped: ['idle', (state) => i18n.text('runStatus.stopped', { state })],
  aborting: ['fault', (state) => i18n.text('runStatus.aborting', { state })],
  aborted: ['fault', (state) => i18n.text('runStatus.aborted', { state })],
});

class RoutineHost {
  constructor({ interlock, plant, id }) {
    this.interlock = interlock;
    this.plant = plant;
    this.id = id;
    /** @type {import('../../wasm/sugarshack_wasm').Routine | null} */
    this.machine = null;
    this.conditions = new Map(); // transition index -> Condition
    this.node = null; // the routine node of the current deploy
    this.run = null;
    this.rebuildAfterRun = false; // a deploy's swap came while its operation was still queued
    /** @type {(() => void)[] | null} events of its operation held back while a command is forwarded to it */
    this.commanding = null;
    this.lastFault = false;
    this.warned = new Set();
    /** @type {number | undefined} the machine's next deadline (epoch ms), kept for the interlock's one timer */
    this.dueAt = undefined;
    this.unwatch = []; // stops watching its conditions' sensors
    this.ended = false;
  }

  /** Builds the machine (throws UNKNOWN_ROUTINE) and restores `saved`, if any. */
  start(saved) {
    this.build(saved);
    this.checkConditions();
  }

  build(saved) {
    /** @type {import('../../wasm/sugarshack_wasm').Routine} */
    const machine = this.plant.guard(() => this.plant.t.routine(this.id));
    const conditions = new Map();
    try {
      for (const c of machine.conditions()) conditions.set(c.transition, this.plant.sensors.condition(c.when, c.sensors));
    } catch (err) {
      machine.free();
      throw err;
    }
    machine.gate(this.interlock.takesWork);
    this.machine = machine;
    this.conditions = conditions;
    this.watchInputs();
    // Its operation, saved held, came back held: still pending (see InterlockHost.restoreHeldRuns).
    const held = this.interlock.heldOperationsOf(this.id);
    this.takeHeldRun();
    if (!saved) return;
    try {
      const moved = machine.restore(saved, held);
      if (moved) {
        // Its operation was pending at the save and never returned: it counts as faulted.
        this.lastFault = true;
        this.interlock.changed(() => this.emit('interrupted', { operation: moved.operation, from: moved.from, to: moved.to }));
      }
    } catch (e) {
      this.interlock.log('warn', i18n.text('logs.routineStateUnfit', { id: this.id, message: e.message }));
    }
  }

  /** The run of its operation that came back held after a restart, if any: this routine supervises it again. */
  takeHeldRun() {
    if (this.run && this.run.ended) this.run = null; // suspended by a trap: it comes back held, or not at all
    const run = this.interlock.heldRunOf({ kind: 'routine', id: this.id });
    if (!run) return;
    this.run = run;
    run.takePort(this.runPort(run.operation));
  }

  /** Its core died (a wasm trap): the machine is dropped, never called again, until `rebuild`. */
  suspend() {
    wasm.forget(this.machine);
    this.machine = null;
  }

  /** Back on a new core (a swap or a trap): from `snapshot`, its own state or the saved one. */
  rebuild(snapshot) {
    if (this.ended) return;
    if (this.run && this.machine) {
      // A swap while its operation waits in the queue (the drain waited for every granted one): that
      // operation was not interrupted, it goes on; the machine is rebuilt once it returns.
      this.rebuildAfterRun = true;
      return;
    }
    this.rebuildAfterRun = false;
    wasm.release(this.machine);
    this.machine = null;
    try {
      this.build(snapshot);
    } catch (err) {
      this.interlock.log('error', i18n.text('logs.routineUnfit', { id: this.id, message: err.message }));
    }
    this.refresh();
    this.checkConditions();
  }

  snapshot() {
    if (!this.machine) return null;
    try {
      return this.machine.snapshot();
    } catch {
      return null;
    }
  }

  // ---- the routine node ------------------------------------------------------

  /** Its routine node; false when another node runs this routine already. */
  attach(node) {
    if (this.node && this.node !== node && this.node.id !== node.id) return false;
    this.node = node;
    this.refresh();
    return true;
  }

  detach(node) {
    if (this.node === node) this.node = null;
  }

  /** A msg's topic is its trigger. Throws the core's refusal. */
  onMsg(topic) {
    const machine = this.machine;
    if (!machine) throw SugarshackError.of('UNKNOWN_ROUTINE', 'routineNotRunning', { id: this.id });
    const d = stats.time('routine', () => machine.onMsg(topic));
    this.dispatch(d);
  }

  /** Its pending operation's ISA-88 state, if one is pending. */
  operationState() {
    return this.run ? this.run.state() ?? undefined : undefined;
  }

  /** Its ISA-88 state (its pending operation's hold, stop or abort shows here). */
  runState() {
    return this.machine ? this.machine.runState(this.operationState()) : null;
  }

  /**
   * An operator's command by `who`: the core's machine says whether it is
   * allowed (else its refusal throws, nothing changed) and what its pending
   * operation gets; a reset sends it back to its initial state and resets
   * the operations of it that wait for a reset after an abort. Returns its
   * state after.
   * @param {string} command @param {{ by?: string, reason?: string }} who
   */
  command(command, who) {
    const machine = this.machine;
    if (!machine) throw SugarshackError.of('UNKNOWN_ROUTINE', 'routineNotRunning', { id: this.id });
    const pending = machine.pending() || null;
    const { forward, moved } = machine.command(command, this.operationState());
    // What its operation reports meanwhile (an abort may end it at once) goes out after the command's own event.
    this.commanding = [];
    try {
      if (forward && this.run) this.run.command(forward, who);
    } finally {
      const after = this.commanding;
      this.commanding = null;
      if (moved) {
        this.lastFault = false;
        this.interlock.abortedOperations().resetRoutine(machine);
        this.interlock.changed(() => this.emit('reset', { from: moved.from, to: moved.to, by: who.by || null }));
      } else {
        const runState = this.runState();
        this.interlock.changed(() => this.emit(command, { operation: pending, by: who.by || null, runState }));
      }
      for (const event of after) this.interlock.changed(event);
    }
    this.refresh();
    this.checkConditions(); // a restart or a reset may let its conditions fire again
    return this.runState();
  }

  /** An event of its operation's end, once saved; held back while a command is being forwarded to it. */
  announce(event) {
    if (this.commanding) this.commanding.push(event);
    else this.interlock.changed(event);
  }

  dispatch(d) {
    // Saved with the operation pending: a restart meanwhile counts it as faulted.
    this.interlock.changed(() => this.emit('dispatched', { operation: d.operation, from: d.from, to: d.to }));
    const carrier = { _msgid: this.interlock.RED.util.generateId(), topic: `routine/${this.id}`, routine: this.id };
    const run = this.interlock.startRun(d.operation, carrier, this.runPort(d.operation));
    // Refused at once (an aborted operation waiting for its reset): it has reported already.
    if (!run.ended) this.run = run;
    this.refresh();
  }

  /** @returns {import('./operation-run').RunPort} */
  runPort(operation) {
    return {
      owner: { kind: 'routine', id: this.id },
      progress: () => this.refresh(), // queued, then its steps and operator's states: the status tells which
      finish: (result) => {
        this.run = null;
        const machine = this.machine;
        if (this.ended || !machine) return;
        const moved = stats.time('routine', () => machine.completed());
        this.lastFault = false;
        this.announce(() => this.emit('completed', {
          operation, from: moved.from, to: moved.to, queuedMs: result.queuedMs, runMs: result.runMs,
        }));
        this.afterRun();
      },
      // Stopped by an operator: the routine stays where it was, stopped until a reset.
      stop: (result) => {
        this.run = null;
        const machine = this.machine;
        if (this.ended || !machine) return;
        const moved = machine.operationStopped();
        this.announce(() => this.emit('stopped', { operation, from: moved.from, to: moved.to, runMs: result.runMs, step: result.step }));
        this.afterRun();
      },
      fail: (err, ended) => {
        this.run = null;
        if (this.ended || !this.machine) return;
        const e = asSugarshackError(err);
        // From the run's final state the routine says what the failure was (aborted, refused before the grant, faulted) and moves.
        const { outcome, moved } = this.machine.runFailed(ended);
        if (outcome === 'faulted') this.lastFault = true;
        const error = { code: e.code, message: e.message };
        this.announce(() => this.report(e, outcome, moved ? { operation, from: moved.from, to: moved.to, error } : { operation, error }));
        this.afterRun();
      },
      abandon: () => {},
    };
  }

  afterRun() {
    this.refresh();
    if (this.rebuildAfterRun) this.rebuild(this.snapshot());
    else this.checkConditions();
  }

  // ---- its conditions: checked when their sensors sample and at the machine's deadlines ----

  /** A value that did not change cannot make a condition hold: each is checked again once its sensors sample. */
  watchInputs() {
    this.stopWatching();
    for (const [t, condition] of this.conditions) {
      this.unwatch.push(this.plant.sensors.watch(condition.handles, () => this.inputChanged(t)));
    }
  }

  stopWatching() {
    for (const stop of this.unwatch.splice(0)) stop();
  }

  inputChanged(t) {
    const machine = this.machine;
    if (this.ended || !machine) return;
    machine.inputChanged(t);
    const next = machine.nextDeadline();
    if (next !== undefined && next <= clock.now()) this.checkConditions();
    else this.followDeadline();
  }

  /**
   * The machine's next deadline (the core's rule), for the interlock's one
   * timer, which checks this routine's conditions then; none while nothing
   * can fall due.
   */
  followDeadline() {
    const machine = this.machine;
    const next = this.ended || !machine || this.run ? undefined : machine.nextDeadline();
    if (next === this.dueAt) return;
    this.dueAt = next;
    this.interlock.routineDeadlinesChanged();
  }

  /** The interlock's timer at `now`: its conditions are checked if its deadline came. @param {number} now */
  checkIfDue(now) {
    if (this.dueAt === undefined || this.dueAt > now) return;
    this.dueAt = undefined;
    this.checkConditions();
  }

  /**
   * Its interlock's gate opened or closed (the interlock tells it: starting,
   * a deploy's drain, a failure): closed, its core hands out no condition and
   * keeps no deadline; open, its conditions are checked.
   * @param {boolean} open
   */
  gate(open) {
    const machine = this.machine;
    if (this.ended || !machine) return;
    machine.gate(open);
    if (open) this.checkConditions();
    else this.followDeadline();
  }

  checkConditions() {
    const machine = this.machine;
    if (this.ended || !machine || this.run) return;
    const now = clock.now();
    let due;
    try {
      due = this.interlock.guard(() => stats.time('routine', () => machine.due(now)));
    } catch (err) {
      this.interlock.log('error', i18n.text('logs.routineError', { id: this.id, message: err.message }));
      return;
    }
    for (const t of due) {
      const condition = this.conditions.get(t);
      if (!condition) continue;
      let outcome;
      try {
        outcome = condition.check(now);
      } catch (err) {
        if (!this.warned.has(t)) this.interlock.log('error', i18n.text('logs.routineError', { id: this.id, message: err.message }));
        this.warned.add(t);
        if (this.machine) this.machine.inputChanged(t); // tried again after its everyMs
        continue;
      }
      const current = this.machine;
      if (!outcome.met || this.ended || !current) continue;
      // Held back by a run dispatched meanwhile (or the closed gate), the core makes it due again.
      const d = stats.time('routine', () => current.conditionMet(t));
      if (d) this.dispatch(d);
    }
    this.followDeadline();
  }

  // ---- events and status -----------------------------------------------------

  /** An event msg from the routine node: { routine, event, state, pending, halted, ... }. */
  emit(event, details) {
    if (!this.machine) return null;
    const msg = {
      topic: `routine/${this.id}`,
      payload: {
        routine: this.id,
        event,
        state: this.machine.state(),
        pending: this.machine.pending() || null,
        halted: this.machine.halted(),
        runState: this.runState(),
        ...details,
      },
    };
    if (this.node) this.node.send(msg);
    journal.event('routine', event, this.id, { note: details && details.from !== undefined ? `${details.from}>${details.to}` : details && details.operation });
    this.refresh();
    return msg;
  }

  /** An event that is also an error for Catch nodes. */
  report(error, event, details) {
    const msg = this.emit(event, details);
    if (this.node && msg) this.node.error(error, msg);
    else this.interlock.log('error', i18n.text('logs.routineError', { id: this.id, message: error.message }));
  }

  refresh() {
    if (!this.node || !this.machine || this.ended) return;
    const state = this.machine.state();
    const pending = this.machine.pending();
    const runState = this.runState();
    const shown = runState ? OPERATOR_STATES[runState] : undefined;
    if (this.machine.halted()) this.node.status(status('error', i18n.text('status.halted', { state })));
    else if (shown) this.node.status(status(shown[0], shown[1](state)));
    else if (pending) {
      const running = Boolean(this.run && this.run.granted);
      this.node.status(status(running ? 'running' : 'waiting', i18n.text(running ? 'status.running' : 'status.waiting', { state, operation: pending })));
    }
    else this.node.status(status(this.lastFault ? 'fault' : 'ok', state));
  }

  /**
   * The routine as an operator reads it: its state in its plant document
   * (`state`), its ISA-88 state (`runState`) and the commands it takes now,
   * and the operation it waits for or runs, with that operation's ISA-88 state.
   */
  describe() {
    if (!this.machine) return { id: this.id, state: null, halted: false, pending: null, runState: null, commands: [] };
    const pending = this.machine.pending();
    const operation = this.operationState();
    return {
      id: this.id,
      state: this.machine.state(),
      halted: this.machine.halted(),
      pending: pending ? { operation: pending, phase: this.run && this.run.granted ? 'running' : 'queued', state: operation ?? null } : null,
      runState: this.runState(),
      commands: this.machine.commands(operation),
    };
  }

  showError(code) {
    if (this.node) this.node.status(errorStatus(code));
  }

  shutdown() {
    this.ended = true;
    this.stopWatching();
    this.dueAt = undefined;
    wasm.release(this.machine);
    this.machine = null;
  }
}

module.exports = { RoutineHost };
