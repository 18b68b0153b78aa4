'use strict';
// Algorithms 1 (Acquire) and 2 (Release) of the paper, held the way a
// Node-RED function node holds them in global context: O maps each resource
// name to its owner (null when free), Q is an array of waiting requests that
// Release sorts by priority on every call before walking it. Like the paper's
// interlock it stamps when a request is queued and when it is granted, which
// its elapsed-time warnings need. Deliberately literal: this is the baseline
// the interlock core is measured against.

class BaselineInterlock {
  /** @param {string[]} resources the names in R */
  constructor(resources) {
    this.R = resources.slice();
    this.O = {};
    for (const r of this.R) this.O[r] = null;
    this.Q = [];
    this.grantedAt = {};
  }

  /**
   * Algorithm 1. `p` is P[op]. Returns msgId when granted, else null (the
   * request waits in Q unless the operation already waits there).
   */
  acquire(op, Rp, p, msgId, now) {
    const { O, Q } = this;
    if (Rp.every((r) => O[r] === null)) {
      for (const r of Rp) O[r] = op;
      this.grantedAt[op] = now;
      return msgId;
    }
    if (!Q.some((q) => q.op === op)) Q.push({ op, R: Rp, p, msgId, since: now });
    return null;
  }

  /** Algorithm 2. Returns the msgIds of the requests granted, in grant order. */
  release(op, now) {
    const { O, Q } = this;
    for (const r of this.R) {
      if (O[r] === op) O[r] = null;
    }
    // Array.prototype.sort is stable, so equal priorities stay first come, first served.
    Q.sort((a, b) => b.p - a.p);
    const granted = [];
    for (let i = 0; i < Q.length; ) {
      const q = Q[i];
      if (q.R.every((r) => O[r] === null)) {
        for (const r of q.R) O[r] = q.op;
        this.grantedAt[q.op] = now;
        Q.splice(i, 1);
        granted.push(q.msgId);
      } else {
        i++;
      }
    }
    return granted;
  }
}

module.exports = { BaselineInterlock };
