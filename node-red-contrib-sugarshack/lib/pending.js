'use strict';
// Msgs held by acquire nodes while their operation waits in the queue, keyed by
// operation handle (an operation waits at most once).

class PendingRegistry {
  constructor() {
    this.byOperation = new Map();
  }

  get size() {
    return this.byOperation.size;
  }

  /** entry: { node, msg, send, done, operation, priority, resources, sinceMs, timer } */
  add(handle, entry) {
    this.byOperation.set(handle, entry);
  }

  has(handle) {
    return this.byOperation.has(handle);
  }

  /** Removes and returns the entry (its timer cleared), or undefined. */
  take(handle) {
    const entry = this.byOperation.get(handle);
    if (!entry) return undefined;
    this.byOperation.delete(handle);
    if (entry.timer) clearTimeout(entry.timer);
    entry.timer = null;
    return entry;
  }

  /** Handles of the entries held by `node`, or of all entries. */
  handles(node) {
    const out = [];
    for (const [handle, entry] of this.byOperation) if (!node || entry.node === node) out.push(handle);
    return out;
  }
}

module.exports = { PendingRegistry };
