// @ts-check
'use strict';
// Performs an engine's outputs (read by lib/wasm/wire.js) by the state rule:
// what follows a `commit` leaves once the state it follows is written (an
// urgent group, a fault's lockouts, even when the write fails, unless the
// instance may not act at all), what follows an `after` leaves behind the
// writes before it, what comes before either leaves at once. Held msgs wait
// here under the handle their node chose; the engine answers each once.
// The one timer is here too, at the earliest of the engine's next deadline
// and its routines' (each the core's): it calls `due` (the engine's tick)
// and `routinesDue` (their condition checks) when they are due.
const { SugarshackError } = require('../host/errors');
const { HeldMsg } = require('./pending');
const { clock: systemClock } = require('../host/clock');
const i18n = require('../host/i18n');

// Node fires a longer timeout at once; woken early, the carrier sleeps again until the deadline.
const MAX_TIMER_MS = 2 ** 31 - 1;

/**
 * @typedef {import('./pending').HeldMsg & { ports?: number, cause?: any }} Held a held msg; `ports`: its node's outputs (1 unless told); `cause`: the error a failed msg's error keeps as its cause
 * @typedef {{ urgent: boolean, after: boolean, actions: (() => void)[] }} Group
 */

class EngineCarrier {
  /**
   * @param {object} o
   * @param {{ change(effect: (() => void) | null, options?: { evenUnsaved?: boolean }): void, after(effect: () => void): void, run(effect: (...args: any[]) => void, ...args: any[]): void, readonly idle: boolean }} o.committer
   * @param {(output: any, effect: (action: () => void) => void) => void} [o.other] an output with no msg of its own (an event, an alarm, a log, a node's error); `effect` keeps an action in order
   * @param {(holding: number, queued: number, faulted: number, lost: boolean) => void} [o.counts]
   * @param {() => void} [o.due] the engine is due: its owner calls its tick
   * @param {(now: number) => void} [o.routinesDue] a routine's deadline is due: its owner checks the routines due
   * @param {{ now(): number, setTimeout: Function, clearTimeout: Function }} [o.clock]
   */
  constructor({ committer, other, counts, due, routinesDue, clock = systemClock }) {
    this.committer = committer;
    this.due = due || (() => {});
    this.routinesDue = routinesDue || (() => {});
    this.clock = clock;
    /** @type {any} */
    this.timer = null;
    this.timerAt = -1;
    this.engineAt = -1; // the engine's next deadline (epoch ms; -1: none)
    this.routinesAt = -1; // its routines' earliest deadline (epoch ms; -1: none)
    this.otherOutput = other || (() => {});
    this.countsChanged = counts || (() => {});
    /** @type {Map<number, Held>} */
    this.table = new Map();
    // The msg held last waits apart: most are answered within the call that
    // held them, and spare the Map an entry made and deleted per msg.
    this.lastKey = -1;
    /** @type {Held | null} */
    this.last = null;
    /** @type {Group | null} */
    this.group = null;
    /** what follows a commit or an after runs as the committer runs effects (an error in it is reported, not thrown) */
    this.guarded = false;
    /** @type {{ port: number, msgs: any[] } | null} msgs a node sends beside the msg answered next */
    this.extra = null;
  }

  /** Every held msg by handle, in the order held. @returns {Map<number, Held>} */
  get held() {
    this.settleLast();
    return this.table;
  }

  settleLast() {
    if (this.lastKey === -1) return;
    this.table.set(this.lastKey, /** @type {Held} */ (this.last));
    this.lastKey = -1;
    this.last = null;
  }

  /** Keeps `entry` under handle `k` until the engine answers it. @param {number} k @param {Held} entry */
  hold(k, entry) {
    this.settleLast();
    this.lastKey = k;
    this.last = entry;
  }

  /** A node closes for a deploy: its held msgs are completed there, and wait for its next instance. @param {NodeRed.Node} node */
  detach(node) {
    for (const entry of this.held.values()) if (entry.node === node) entry.detach();
  }

  /** The next instance of a node restarted by a deploy sends its held msgs on. @param {NodeRed.Node} node */
  adopt(node) {
    for (const entry of this.held.values()) if (!entry.node && entry.nodeId === node.id) entry.adopt(node);
  }

  /** @param {number} k */
  take(k) {
    if (k === this.lastKey) {
      const entry = /** @type {Held} */ (this.last);
      this.lastKey = -1;
      this.last = null;
      return entry;
    }
    const entry = this.table.get(k);
    this.table.delete(k);
    return entry;
  }

  /** The last engine call's outputs, performed in order, and its next deadline kept. @param {{ read(visitor: any): void, nextDeadline(): number }} wire */
  perform(wire) {
    this.group = null;
    this.guarded = false;
    this.extra = null;
    wire.read(this);
    this.closeGroup();
    this.engineAt = wire.nextDeadline();
    this.arm();
  }

  /** The routines' earliest deadline changed (-1: none). @param {number} at */
  followRoutines(at) {
    this.routinesAt = at;
    this.arm();
  }

  /** The one timer, set for the earliest deadline (none when neither has one). */
  arm() {
    const { engineAt, routinesAt } = this;
    const at = engineAt < 0 ? routinesAt : routinesAt < 0 ? engineAt : Math.min(engineAt, routinesAt);
    if (at === this.timerAt) return;
    this.clearTimer();
    this.timerAt = at;
    if (at < 0) return;
    this.timer = this.clock.setTimeout(() => this.fire(), Math.min(Math.max(0, at - this.clock.now()), MAX_TIMER_MS));
  }

  /** The timer: the engine's tick and the routines' checks, each when due; then the timer again. */
  fire() {
    this.timer = null;
    this.timerAt = -1;
    const now = this.clock.now();
    if (this.engineAt >= 0 && this.engineAt <= now) {
      this.engineAt = -1; // the tick's perform sets the next
      this.due();
    }
    if (this.routinesAt >= 0 && this.routinesAt <= now) this.routinesDue(now);
    this.arm();
  }

  clearTimer() {
    if (this.timer) this.clock.clearTimeout(this.timer);
    this.timer = null;
    this.timerAt = -1;
  }

  /** No timer any more (a shutdown, a standby, a rebuild): the deadlines come again with the next engine call and routine. */
  stop() {
    this.clearTimer();
    this.engineAt = -1;
    this.routinesAt = -1;
  }

  /** @param {boolean} urgent */
  commit(urgent) {
    this.closeGroup();
    // Nothing to write and nothing waiting: what follows runs as it comes, with no group to keep.
    this.group = this.committer.idle ? null : { urgent, after: false, actions: [] };
    this.guarded = this.group === null;
  }

  after() {
    this.closeGroup();
    this.group = this.committer.idle ? null : { urgent: false, after: true, actions: [] };
    this.guarded = this.group === null;
  }

  closeGroup() {
    const group = this.group;
    this.group = null;
    if (!group) return;
    const run = group.actions.length ? () => group.actions.forEach((action) => action()) : null;
    if (group.after) {
      if (run) this.committer.after(run);
    } else this.committer.change(run, { evenUnsaved: group.urgent });
  }

  /** `action` now, or once the state it follows is written. @param {() => void} action */
  effect(action) {
    this.effectOf(action);
  }

  /**
   * `fn(a, b, c, d)` now, or once the state it follows is written: a closure
   * is made only for what waits (most msgs are answered at once).
   * @template A, B, C, D @param {(a: A, b: B, c: C, d: D) => void} fn @param {A} [a] @param {B} [b] @param {C} [c] @param {D} [d]
   */
  effectOf(fn, a, b, c, d) {
    if (this.group) this.group.actions.push(() => fn(/** @type {A} */ (a), /** @type {B} */ (b), /** @type {C} */ (c), /** @type {D} */ (d)));
    else if (this.guarded) this.committer.run(fn, a, b, c, d);
    else fn(/** @type {A} */ (a), /** @type {B} */ (b), /** @type {C} */ (c), /** @type {D} */ (d));
  }

  /** @param {number} k @param {number} port @param {any} set */
  send(k, port, set) {
    const entry = this.take(k);
    const extra = this.extra;
    this.extra = null;
    if (entry) this.effectOf(sendOn, entry, port, set, extra);
  }

  /** @param {number} k @param {number} port @param {any[]} msgs */
  emit(k, port, msgs) {
    this.extra = { port, msgs };
  }

  /** @param {number} k @param {any} refusal */
  complete(k, refusal) {
    const entry = this.take(k);
    const extra = this.extra;
    this.extra = null;
    if (!entry) return;
    this.effectOf(answer, entry, null, extra, refusal ? refusalError(refusal) : null);
  }

  /** @param {number} holding @param {number} queued @param {number} faulted @param {boolean} lost */
  counts(holding, queued, faulted, lost) {
    this.countsChanged(holding, queued, faulted, lost);
  }

  /** @param {any} output */
  other(output) {
    this.otherOutput(output, (action) => this.effect(action));
  }
}

/** A msg held under its handle, with its node's outputs and, for a fault msg, the error it carried. */
class CarriedMsg extends HeldMsg {
  /**
   * @param {NodeRed.Node} node @param {NodeRed.Message} msg @param {NodeRed.Send} send @param {NodeRed.Done} done
   * @param {number} ports its node's outputs
   */
  constructor(node, msg, send, done, ports) {
    super(node, msg, send, done);
    this.ports = ports;
    /** @type {any} */
    this.cause = null;
  }
}

/**
 * Sets what the engine says on the msg, sends it on output `port` and `extra` msgs on theirs, then completes it.
 * @param {Held} entry @param {number} port @param {any} set @param {{ port: number, msgs: any[] } | null} extra
 */
function sendOn(entry, port, set, extra) {
  if (set && entry.msg) applySet(entry.msg, set);
  answer(entry, port, extra, null);
}

/**
 * Sends the msg on output `port` (null: none) and `extra` msgs on theirs, then completes it.
 * @param {Held} entry @param {number | null} port @param {{ port: number, msgs: any[] } | null} extra @param {Error | null} err
 */
function answer(entry, port, extra, err) {
  try {
    handOver(entry, port, extra, err);
  } catch (thrown) {
    // Node-RED's own send or done threw (it cannot clone a 10,000-deep msg for a Catch
    // node or a second wire): logged on the node; the outputs after this one still go.
    if (entry.node) entry.node.warn(i18n.text('logs.notHandedOver', { message: thrown && thrown.message }));
  }
}

/** @param {Held} entry @param {number | null} port @param {any} extra @param {Error | null} err */
function handOver(entry, port, extra, err) {
  const ports = entry.ports || 1;
  if (entry.send && (port !== null || extra)) {
    if (ports === 1) entry.send(entry.msg);
    else {
      /** @type {any[]} */
      const out = new Array(ports).fill(null);
      if (port !== null) out[port] = entry.msg;
      if (extra) out[extra.port] = extra.msgs;
      entry.send(out);
    }
  }
  if (err) {
    // A failed fault msg keeps the Catch's error it carried as the cause.
    if (entry.cause) /** @type {any} */ (err).cause = entry.cause;
    entry.reject(err);
  } else entry.abandon();
}

/** What the engine sets on a msg it sends on. @param {any} msg @param {any} set */
function applySet(msg, set) {
  if (set.kind === 'interlock') {
    msg.interlock = { operation: set.operation, priority: set.priority, resources: set.resources, waitedMs: set.waitedMs };
  } else if (set.kind === 'cleared') {
    msg.cleared = set.cleared;
    msg.clearedBy = { by: set.by, reason: set.reason, forced: set.forced };
  } else if (set.kind === 'refused') {
    const err = refusalError(set.refusal);
    msg.refused = { code: err.code, message: err.message, lines: set.refusal.lines || [] };
  }
}

/** A refusal as the error a Catch node gets. @param {any} refusal */
function refusalError(refusal) {
  const err = new SugarshackError(refusal.code, render(refusal.text));
  if (refusal.lines && refusal.lines.length) /** @type {any} */ (err).lines = refusal.lines;
  return err;
}

/** Words the engine chose, from the catalogs (the keys it may name are its catalogTexts()). @param {any} t */
function render(t) {
  if (t.kind === 'plain') return t.text;
  if (t.kind === 'faulted') return faultedText(t);
  /** @type {Record<string, any>} */
  const subs = {};
  for (const [name, p] of t.params) subs[name] = p.kind === 'label' ? i18n.textOf(`labels.${p.value}`) : p.value;
  return i18n.textOf(t.key, subs);
}

/** What a failed fault msg says: what was faulted and what locked out, with the fault's note. @param {any} t */
function faultedText(t) {
  const lines = t.lines.join(', ');
  let what;
  if (t.operation === null || t.operation === undefined) {
    what = i18n.typeText('sugarshack-fault', 'errors.stopped', { lines: lines || i18n.typeText('sugarshack-fault', 'errors.nothing', {}) });
  } else if (lines) what = i18n.typeText('sugarshack-fault', 'errors.faultedLocked', { operation: t.operation, lines });
  else what = i18n.typeText('sugarshack-fault', 'errors.faultedHeldNothing', { operation: t.operation });
  return t.note ? i18n.typeText('sugarshack-fault', 'errors.withNote', { what, note: t.note }) : what;
}

module.exports = { EngineCarrier, CarriedMsg, refusalError, render };
