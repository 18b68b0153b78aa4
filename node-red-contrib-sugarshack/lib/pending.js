// @ts-check
'use strict';
// Msgs held while they wait: by acquire nodes until their operation is granted,
// keyed by operation handle (an operation waits at most once); by group command
// and actuators nodes until their group command completes, keyed by caller id.

const { clock } = require('./clock');

class PendingRegistry {
  constructor() {
    this.byHandle = new Map();
  }

  get size() {
    return this.byHandle.size;
  }

  /** entry: { node, msg, send, done, timer, ... } (acquire: operation, priority, resources, sinceMs) */
  add(handle, entry) {
    this.byHandle.set(handle, entry);
  }

  get(handle) {
    return this.byHandle.get(handle);
  }

  has(handle) {
    return this.byHandle.has(handle);
  }

  /** Removes and returns the entry (its timer cleared), or undefined. */
  take(handle) {
    const entry = this.byHandle.get(handle);
    if (!entry) return undefined;
    this.byHandle.delete(handle);
    if (entry.timer) clock.clearTimeout(entry.timer);
    entry.timer = null;
    return entry;
  }

  entries() {
    return [...this.byHandle.values()];
  }

  /** Handles of the entries held by `node`, or of all entries. */
  handles(node) {
    const out = [];
    for (const [handle, entry] of this.byHandle) if (!node || entry.node === node) out.push(handle);
    return out;
  }
}

/**
 * A held msg (see `heldMsg`). `grant` and `refuse` are set by whoever answers
 * an acquire; `cancel` by whoever runs a command's wait.
 * @typedef {{
 *   node: NodeRed.Node | null, nodeId: string | null, msg: NodeRed.Message | null,
 *   send: NodeRed.Send | null, done: NodeRed.Done | null, sinceMs: number,
 *   timer: unknown, [key: string]: any,
 *   reject(err: Error): void, abandon(): void, detach(): void,
 *   adopt(next: NodeRed.Node): void, stopTimer(): void,
 *   grant?: () => void, refuse?: (err: { code: string, message: string }) => void,
 * }} HeldMsg
 */

/**
 * A msg held by a node until its work is answered. Between a deploy's restart
 * of that node and its next instance taking the msg over (`adopt`), `node`,
 * `send` and `done` are null: the first instance completed the msg when it
 * closed (`detach`), and the next one sends it on.
 * @param {{ node: NodeRed.Node | null, msg: NodeRed.Message | null, send: NodeRed.Send | null,
 *   done: NodeRed.Done | null, sinceMs: number, [key: string]: any }} fields
 * @returns {HeldMsg}
 */
function heldMsg({ node, msg, send, done, sinceMs, ...rest }) {
  /** @type {HeldMsg} */
  const held = {
    node,
    nodeId: node ? node.id : null,
    msg,
    send,
    done,
    sinceMs,
    timer: null,
    ...rest,
    /** The work failed: the msg ends with the error (a Catch node gets it). */
    reject(err) {
      held.stopTimer();
      if (held.done) held.done(err);
      else if (held.node) held.node.error(err, held.msg);
      held.done = null;
    },
    /** Completed without being sent on (withdrawn, or the flows stop). */
    abandon() {
      held.stopTimer();
      if (held.done) held.done();
      held.done = null;
    },
    detach() {
      if (held.done) held.done();
      held.node = null;
      held.send = null;
      held.done = null;
    },
    adopt(next) {
      held.node = next;
      held.send = (m) => next.send(m);
    },
    stopTimer() {
      if (held.timer) clock.clearTimeout(held.timer);
      held.timer = null;
    },
  };
  return held;
}

module.exports = { PendingRegistry, heldMsg };
