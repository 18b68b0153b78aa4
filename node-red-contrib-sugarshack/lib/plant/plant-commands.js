// @ts-check
'use strict';
// A plant's group commands in flight: each one the core is carrying out, by
// its caller id, with what waits for its outcome (a msg held by a group command
// or actuators node, an operation step, a lockout) and the actuators that
// completed so far. The core says when one completes, fails or times out.
const { SugarshackError } = require('../host/errors');
const { PendingRegistry, heldMsg } = require('../interlock/pending');
const { seconds } = require('./plant');
const { refusalError } = require('./group');
const { readMsg } = require('../interlock/request');
const { stats } = require('../host/stats');
const { clock } = require('../host/clock');
const i18n = require('../host/i18n');

const MAX_CALLER = 0xffffffff;

class GroupCommands {
  /** plant: the PlantRuntime (its core `t`, guard, effects pump and status). */
  constructor(plant) {
    this.plant = plant;
    this.pending = new PendingRegistry(); // caller -> held group command
    this.nextCaller = 0;
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
    const caller = this.newCaller();
    const now = clock.now();
    // A msg from a fault node carries the fault's time: the core reports the fault lockout time from it.
    const answer = JSON.parse(plant.t.commandMsg(topic, lockout, interlock, payload, caller, now, typeof faultAtMs === 'number' ? faultAtMs : undefined, timeoutMs));
    if (answer.refusal) throw refusalError(answer.refusal);
    plant.statusView.dropRefusal(node);
    this.pending.add(caller, msgEntry({ node, msg, send, done, output, outputs, lockout: answer.lockout, sinceMs: now }));
    plant.flush(null, answer);
  }

  /**
   * A group command of an operation's run (not gated by a drain: the run must
   * finish). `onDone(err)` gets the outcome; returns a function that withdraws it.
   */
  run({ payload, timeoutMs, within, onDone }) {
    const { plant } = this;
    const caller = this.newCaller();
    const now = clock.now();
    plant.guard(() => plant.t.command(payload, caller, false, now, within, undefined, timeoutMs));
    const entry = callbackEntry({ onDone, sinceMs: now });
    this.pending.add(caller, entry);
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
      const carrier = { topic: plant.t.lockoutTopic(resource), payload: command, resource, operation, faultAtMs };
      try {
        const caller = this.newCaller();
        plant.guard(() => plant.t.command(command, caller, true, faultAtMs, undefined, faultAtMs));
        this.pending.add(caller, callbackEntry({ onDone, sinceMs: faultAtMs, msg: carrier, lockout: true }));
        plant.flush(null);
      } catch (err) {
        plant.log('error', i18n.text('logs.lockoutNotSent', { line: resource, message: err.message }));
      }
    }
  }

  /** The command waiting on `caller`, taken out: it no longer keeps a deploy's drain waiting. */
  take(caller) {
    const entry = this.pending.take(caller);
    this.plant.mayBeQuiet();
    return entry;
  }

  newCaller() {
    do {
      this.nextCaller = this.nextCaller >= MAX_CALLER ? 1 : this.nextCaller + 1;
    } while (this.pending.has(this.nextCaller));
    return this.nextCaller;
  }

  /** Its caller waited its timeout: the core withdrew the command. */
  timedOut(e) {
    const { plant } = this;
    const entry = this.take(e.caller);
    if (!entry) return;
    const waiting = e.waiting.map((handle) => plant.actuators[handle].id);
    if (entry.msg) entry.msg.command = { waiting, actuators: entry.completed };
    if (entry.node) plant.showError(entry.node, 'COMMAND_TIMEOUT');
    entry.refuse(SugarshackError.of('COMMAND_TIMEOUT', 'commandTimeout', { within: seconds(e.timeoutMs), waiting: waiting.join(', ') }));
  }

  // ---- what the held msgs are ----------------------------------------------

  entries() {
    return this.pending.entries();
  }

  /** Drained: nothing in flight but standing lockouts (the core's, sent again after a swap). */
  onlyLockouts() {
    return this.pending.entries().every((entry) => entry.lockout);
  }

  /** The _msgid of the msg waiting on `caller`, or null. */
  msgId(caller) {
    const entry = this.pending.get(caller);
    return entry && entry.msg ? entry.msg._msgid : null;
  }

  /** Every held command completed unsent (a shutdown, a new document). */
  abandonAll() {
    for (const caller of this.pending.handles()) this.take(caller).abandon();
  }

  /** Every held command fails with `error` (the core that carried them is gone). */
  refuseAll(error) {
    for (const caller of this.pending.handles()) this.take(caller).refuse(error);
  }

  /** Withdraws the commands of node `nodeId` that no next instance took over. */
  withdrawOrphans(nodeId) {
    const { plant } = this;
    for (const caller of this.pending.handles()) {
      const entry = this.pending.get(caller);
      if (entry.nodeId !== nodeId || entry.node) continue;
      this.take(caller);
      plant.guard(() => plant.t.withdraw(caller));
    }
    plant.followDeadline();
  }

  // ---- outcomes, from the core's effects -----------------------------------

  recordCompleted(e) {
    const entry = this.pending.get(e.caller);
    if (!entry) return;
    if (e.timed) {
      stats.add('command/issueToMotion', e.issueToMotionMs);
      stats.add('command/completion', e.completionMs);
    }
    entry.completed.push({
      actuator: this.plant.actuators[e.actuator].id,
      target: e.target,
      issueToMotionMs: e.issueToMotionMs,
      completionMs: e.completionMs,
      retries: e.retries,
    });
  }

  /** The same msg goes on from the node that holds it (a link call return stays intact). */
  complete(e) {
    const entry = this.take(e.caller);
    if (!entry) return;
    const result = { completionMs: e.completionMs, actuators: entry.completed };
    // A lockout from a fault node: the paper's fault lockout time, fault to isolation.
    if (e.faultLockoutMs !== undefined) {
      result.faultLockoutMs = e.faultLockoutMs;
      stats.add('fault/lockout', e.faultLockoutMs);
    }
    entry.complete(result);
  }

  /** The msg ends with an error a Catch node can turn into a fault of the operation. */
  fail(e) {
    const { plant } = this;
    const entry = this.take(e.caller);
    if (!entry) return;
    const a = plant.actuators[e.actuator];
    const { code, message, retries } = e;
    if (entry.msg) {
      entry.msg.command = {
        failed: { actuator: a.id, device: a.device, fault: e.fault, retries },
        actuators: entry.completed,
      };
    }
    if (entry.node) plant.showError(entry.node, code);
    entry.refuse(new SugarshackError(code, message));
  }
}

/** A group command msg held by a group command or actuators node until its command completes. */
function msgEntry({ node, msg, send, done, output, outputs, lockout, sinceMs }) {
  const entry = heldMsg({ node, msg, send, done, sinceMs, output, outputs, lockout, completed: [] });
  entry.complete = (result) => {
    msg.command = result;
    if (entry.send) {
      if (outputs === 1) {
        entry.send(msg);
      } else {
        const out = new Array(outputs).fill(null);
        out[output] = msg;
        entry.send(out);
      }
    }
    if (entry.done) entry.done();
  };
  entry.refuse = entry.reject;
  return entry;
}

/**
 * A group command of the palette itself (an operation step, a lockout): the outcome goes to `onDone`, once.
 * @param {{ onDone: (err: Error | null) => void, sinceMs: number, msg?: NodeRed.Message | null, lockout?: boolean }} args
 */
function callbackEntry({ onDone, sinceMs, msg = null, lockout = false }) {
  const entry = heldMsg({ node: null, msg, send: null, done: null, sinceMs, lockout, completed: [] });
  let answered = false;
  const answer = (err) => {
    if (answered) return;
    answered = true;
    onDone(err || null);
  };
  entry.complete = () => answer(null);
  entry.refuse = (err) => answer(err);
  return entry;
}

module.exports = { GroupCommands };
