'use strict';
// Calls into wasm per msg on an interlock bound to no plant (the core's
// Engine) and on the plant (a feedback msg, a group command), counted through
// the nodes as tests/bench/crossings.js counts them. One call per acquire, per
// release granting three waiters, per feedback msg and per group command, no
// follow-up: a rule that slips back into JS and asks the core again fails here.
const assert = require('node:assert/strict');
const path = require('path');
const helper = require('node-red-node-test-helper');
const { PALETTE, startServer, stopServer } = require('./support');
const { measure, Crossings } = require('../bench/crossings');

const wasm = require(path.join(PALETTE, 'lib', 'wasm', 'index.js'));

helper.init(require.resolve('node-red'));

// As measured since the core's Engine runs an interlock alone: an upper bound.
const MAX_CALLS_PER_MSG = 1;

describe('crossings into wasm per msg, interlock alone and plant', function () {
  beforeEach(startServer);
  afterEach(stopServer);

  /** Counts msgs of each kind of `ids` through the nodes; each crosses in at most once, with no follow-up. */
  async function crossOnce(ids) {
    const rows = await measure(ids, { msgs: 20, warmup: 16 });
    assert.deepEqual(rows.map((r) => r.id), ids);
    for (const row of rows) {
      const calls = row.top.map((t) => `${t.key} ${t.perMsg}`).join(', ');
      assert.ok(row.perMsg > 0, `${row.label}: no call counted (is the facade wrapped?)`);
      assert.ok(row.perMsg <= MAX_CALLS_PER_MSG, `${row.label}: ${row.perMsg} calls per msg (${calls}), at most ${MAX_CALLS_PER_MSG}`);
      assert.equal(row.followUpsPerMsg, 0, `${row.label}: follow-up calls (${calls})`);
    }
  }

  it('an acquire and a release granting three waiters each cross in once, with no follow-up', () => crossOnce(['acquire', 'release3']));

  it('a feedback msg (text or object) and a group command (either node) each cross in once on the plant, with no follow-up',
    () => crossOnce(['feedback-text', 'feedback-object', 'gc-command', 'bus-command']));

  it('counts a msg\'s second call on a wasm object as a follow-up, and nothing outside a msg', async function () {
    const { Engine } = wasm.load();
    const engine = new Engine({ resources: [{ name: 'YEL', lockout: null }] }, { wire: 'typed' });
    const crossings = new Crossings();
    try {
      engine.headerPtr();
      await crossings.during(() => { engine.headerPtr(); engine.headerPtr(); });
      assert.deepEqual(crossings.take(1), { perMsg: 2, followUpsPerMsg: 1, top: [{ key: 'Engine.headerPtr', perMsg: 2 }] });
    } finally {
      crossings.restore();
      engine.free();
    }
  });
});
