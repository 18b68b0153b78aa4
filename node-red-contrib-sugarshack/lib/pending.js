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

module.exports = { PendingRegistry };
