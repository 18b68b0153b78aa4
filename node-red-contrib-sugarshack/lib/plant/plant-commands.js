// @ts-check
'use strict';
// A plant's group commands in flight: each one the core is carrying out, by
// its caller id, with what waits for its outcome (a msg held by a group command
// or actuators node, an operation step, a lockout) and the actuators that
// completed so far. The core says when one completes, fails or times out.
const { SugarshackError } = require('../host/errors');
const { heldMsg } = require('../interlock/pending');
const { refusalError } = require('./group');
const { readMsg } = require('../interlock/request');
const { clock } = require('../host/clock');
const i18n = require('../host/i18n');
const wasm = require('../wasm');

class GroupCommands {
  /** plant: the PlantRuntime (its core `t`, guard, effects pump and status). */
  constructor(plant) {
    this.plant = plant;
    this.pending = new Map(); // caller (the core's) -> held group command
  }

  /**
   * Issues msg.payload as a group command and holds the msg until it completes;
   * it then leaves `node` on output `output` (of `outputs`). Throws the core's refusal.
   * One call: the core reads the msg (a lockout; the lines it holds, which the command keeps within: C2), issues it and answers.
   */
  command({ node, msg, send, done, output = 0, outputs = 1, timeoutMs = 0 }) {
    const { plant } = this;
    // A getter or proxy that throws is the sender's error (INVALID_INPUT).
    const { topic, lockout, interlock, payload, faultAtMs } = readMsg(() => ({
      topic: msg.topic, lockout: msg.lockout, interlock: msg.interlock, payload: msg.payload, faultAtMs: msg.faultAtMs,
    }));
    // A msg from a fault node carries the fault's time: the core reports the fault lockout time from it.
    // `reading`: the facade reads the payload, whose getters may send a msg in at once.
    const answer = JSON.parse(wasm.reading(plant, () => plant.t.commandMsg(topic, lockout, interlock, payload, clock.now(), typeof faultAtMs === 'number' ? faultAtMs : undefined, timeoutMs)));
    if (answer.refusal) throw refusalError(answer.refusal);
    plant.statusView.dropRefusal(node);
    this.pending.set(answer.caller, msgEntry({ node, msg, send, done, output, outputs, lockout: answer.lockout }));
    plant.flush(null, answer);
  }

  /**
   * A group command of an operation's run (not gated by a drain: the run must
   * finish). `onDone(err)` gets the outcome; returns a function that withdraws it.
   */
  run({ payload, timeoutMs, within, onDone }) {
    const { plant } = this;
    const caller = plant.guard(() => plant.t.nextCaller());
    plant.guard(() => plant.t.command(payload, caller, false, clock.now(), within, undefined, timeoutMs));
    const entry = callbackEntry(onDone);
    this.pending.set(caller, entry);
    plant.flush(null);
    plant.followDeadline();
    return () => {
      if (this.pending.get(caller) !== entry) return;
      this.take(caller);
      plant.guard(() => plant.t.withdraw(caller));
      plant.followDeadline();
      plant.refreshStatus();
    };
  }

  /**
   * Sends lockout commands ([{ resource, command }]) of faulted lines. The core
   * keeps each one as a standing order until feedback confirms it, re-sending it
   * whatever happens to this call; a refusal here is logged.
   */
  lockouts(lockouts, operation) {
    const { plant } = this;
    const faultAtMs = clock.now();
    for (const { resource, command } of lockouts) {
      const onDone = (err) => {
        if (err) plant.log('warn', i18n.text('logs.lockoutUnconfirmed', { line: resource, message: err.message }));
      };
      try {
        const caller = plant.guard(() => plant.t.nextCaller());
        plant.guard(() => plant.t.command(command, caller, true, faultAtMs, undefined, faultAtMs));
        this.pending.set(caller, callbackEntry(onDone, true));
        plant.flush(null);
      } catch (err) {
        plant.log('error', i18n.text('logs.lockoutNotSent', { line: resource, message: err.message }));
      }
    }
  }

  /** The command waiting on `caller`, taken out: it no longer keeps a deploy's drain waiting. */
  take(caller) {
    this.pending.delete(caller);
    this.plant.mayBeQuiet();
  }

  // ---- what the held msgs are ----------------------------------------------

  entries() {
    return [...this.pending.values()];
  }

  /** Drained: nothing in flight but standing lockouts (the core's, sent again after a swap). */
  onlyLockouts() {
    return this.entries().every((entry) => entry.lockout);
  }

  /** The _msgid of the msg waiting on `caller`, or null. */
  msgId(caller) {
    const entry = this.pending.get(caller);
    return entry && entry.msg ? entry.msg._msgid : null;
  }

  /**
   * Every held command ends: completed unsent (a shutdown, a new document), or failed with `error` (the core that carried them is gone).
   * @param {Error | null} [error]
   */
  endAll(error = null) {
    const entries = this.entries();
    this.pending.clear();
    this.plant.mayBeQuiet();
    for (const entry of entries) if (error) entry.reject(error); else entry.abandon();
  }

  /** Withdraws the commands of node `nodeId` that no next instance took over. */
  withdrawOrphans(nodeId) {
    const { plant } = this;
    for (const [caller, entry] of this.pending) {
      if (entry.nodeId !== nodeId || entry.node) continue;
      this.take(caller);
      plant.guard(() => plant.t.withdraw(caller));
    }
    plant.followDeadline();
  }

  // ---- outcomes, from the core's effects -----------------------------------

  /**
   * A command's outcome (groupCompleted, groupFailed, groupTimedOut: the core
   * tells it by ids, with the actuators that reached their targets): the same msg goes on
   * from the node that holds it (a link call return stays intact), or ends
   * with an error a Catch node can turn into a fault of the operation.
   */
  settle(e) {
    const entry = this.pending.get(e.caller);
    if (!entry) return;
    this.take(e.caller);
    // `e.command`: the outcome by ids, as the core tells it to the msg.
    if (e.kind === 'groupCompleted') {
      entry.complete(e.command);
      return;
    }
    // The error (code and words) is the core's, a timeout's as a failure's.
    if (entry.msg) entry.msg.command = e.command;
    if (entry.node) this.plant.showError(entry.node, e.error.code);
    entry.reject(new SugarshackError(e.error.code, e.error.message));
  }
}

/** A group command msg held by a group command or actuators node until its command completes; then it leaves on `output`. */
function msgEntry({ node, msg, send, done, output, outputs, lockout }) {
  const entry = heldMsg({ node, msg, send, done, lockout });
  entry.complete = (result) => {
    msg.command = result;
    const out = new Array(outputs).fill(null);
    out[output] = msg;
    if (entry.send) entry.send(out);
    if (entry.done) entry.done();
  };
  return entry;
}

/**
 * A group command of the palette itself (an operation step, a lockout): no msg;
 * the outcome goes to `onDone` (once: an entry is answered as it leaves `pending`).
 * @param {(err: Error | null) => void} onDone
 */
function callbackEntry(onDone, lockout = false) {
  return { node: null, nodeId: null, msg: null, lockout, complete: () => onDone(null), reject: onDone, abandon: () => {} };
}

module.exports = { GroupCommands };
