// @ts-check
'use strict';
// The palette's state as one document, for the admin API, the state node, a
// dashboard and the editor's sidebar: every interlock (lines, holders, queue,
// routines) and every plant (devices, sensors, lockouts), as now. A change
// anywhere is announced once per turn of the event loop, so a burst of
// feedback is one notice, naming the runtimes that changed; listeners
// throttle further as they like.
const { EventEmitter } = require('events');
const { clock } = require('./host/clock');
const { clusterOf } = require('./cluster');

/** { atMs, interlocks: [...], plants: [...], cluster? } of every runtime of `palette`; `cluster` in a hot-standby cluster. */
function stateOf(palette) {
  const interlocks = [];
  const plants = [];
  for (const [id, runtime] of palette.runtimes) {
    const base = { id, name: runtime.owner ? runtime.owner.name || '' : '', state: runtime.state, draining: !runtime.gateOpen };
    (runtime.kind === 'plant' ? plants : interlocks).push({ ...base, ...runtime.described() });
  }
  let cluster = null;
  try {
    cluster = clusterOf(palette.RED);
  } catch {
    cluster = null; // misconfigured: every runtime reports the error
  }
  return cluster ? { atMs: clock.now(), interlocks, plants, cluster: cluster.describe() } : { atMs: clock.now(), interlocks, plants };
}

/** Announces 'changed' (with the Set of runtimes that changed) at most once per turn of the event loop. */
class ChangeNotices extends EventEmitter {
  constructor() {
    super();
    this.setMaxListeners(0); // one per state node and editor session
    this.due = false;
    this.sources = new Set();
  }

  /** `source`: the runtime that changed. */
  touch(source = null) {
    if (this.listenerCount('changed') === 0) return;
    if (source) this.sources.add(source);
    if (this.due) return;
    this.due = true;
    setImmediate(() => {
      const sources = this.sources;
      this.due = false;
      this.sources = new Set();
      this.emit('changed', sources);
    });
  }
}

module.exports = { stateOf, ChangeNotices };
