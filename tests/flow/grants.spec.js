'use strict';
const assert = require('node:assert/strict');
const path = require('path');
const { PALETTE } = require('./support');
const { takeGrants } = require(path.join(PALETTE, 'lib', 'grants.js'));
const { msgEntry } = require(path.join(PALETTE, 'lib', 'interlock-runtime.js'));
const { PendingRegistry } = require(path.join(PALETTE, 'lib', 'pending.js'));

describe('grant routing', function () {
  function waiter(log, name, sinceMs) {
    return msgEntry({
      node: { id: name, status() {} },
      msg: { payload: name },
      operation: name,
      priority: 1,
      resources: ['YEL'],
      sinceMs,
      send: (msg) => log.push(['send', name, msg]),
      done: (err) => log.push(['done', name, err]),
    });
  }

  it('takes each granted entry at once and answers it later, with its own send then done, in grant order', function () {
    const log = [];
    const pending = new PendingRegistry();
    pending.add(4, waiter(log, 'a', 100));
    pending.add(7, waiter(log, 'b', 250));
    const answers = takeGrants({}, pending, Uint32Array.from([7, 4]), { nowMs: 1000, warn: assert.fail });
    assert.equal(pending.size, 0, 'taken from the waiting entries at once');
    assert.deepEqual(log, [], 'nothing sent before the answers run (after the state is saved)');
    answers.forEach((answer) => answer());
    assert.deepEqual(log.map(([what, who]) => `${what} ${who}`), ['send b', 'done b', 'send a', 'done a']);
    assert.deepEqual(log[0][2].interlock, { operation: 'b', priority: 1, resources: ['YEL'], waitedMs: 750 });
  });

  it('releases a grant that nothing waits for, and takes what that release grants', function () {
    const log = [];
    const warnings = [];
    const pending = new PendingRegistry();
    pending.add(9, waiter(log, 'c', 0));
    const released = [];
    const lastGranted = [];
    const interlock = {
      operationName: (h) => `op${h}`,
      release: (h) => { released.push(h); lastGranted.splice(0, Infinity, 9); return lastGranted.length; },
      granted: (i) => lastGranted[i],
    };
    const answers = takeGrants(interlock, pending, [3], { nowMs: 10, warn: (w) => warnings.push(w) });
    assert.deepEqual(released, [3]);
    assert.deepEqual(warnings, ["operation 'op3' was granted but nothing waits for it; releasing it"]);
    answers.forEach((answer) => answer());
    assert.deepEqual(log.map(([what, who]) => `${what} ${who}`), ['send c', 'done c']);
  });
});
