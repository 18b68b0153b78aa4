'use strict';
// Durations in node settings are seconds; flows saved while some were ms carry
// them under the old names and still load: the shared reader, the state
// node's interval from either name, and errors that name the setting and unit.
const assert = require('node:assert/strict');
const path = require('path');
const helper = require('node-red-node-test-helper');
const {
  PALETTE, paletteNodes, TAB, sinkNode, collect, until, startServer, stopServer, clock, settled,
} = require('./support');
const { configDurationMs, configDurationListMs } = require(path.join(PALETTE, 'lib', 'control'));
const { paletteOf } = require(path.join(PALETTE, 'lib', 'host', 'lifecycle.js'));

helper.init(require.resolve('node-red'));

describe('duration settings: seconds, or ms under the old name', function () {
  it('reads seconds under the new name before the ms of the old one, without float noise', function () {
    assert.equal(configDurationMs({ tsS: '1.1', ts: '200' }, 'tsS', 'ts', 'Ts'), 1100);
    assert.equal(configDurationMs({ tsS: 0.05 }, 'tsS', 'ts', 'Ts'), 50);
    assert.equal(configDurationMs({ tsS: ' ', ts: '200' }, 'tsS', 'ts', 'Ts'), 200, 'blank new: the old ms');
    assert.equal(configDurationMs({ ts: 200 }, 'tsS', 'ts', 'Ts'), 200, 'a flow without the new name');
    assert.equal(configDurationMs({}, 'tsS', 'ts', 'Ts', { fallbackMs: 750 }), 750);
    assert.equal(configDurationMs({ tsS: '', ts: '' }, 'tsS', 'ts', 'Ts', { fallbackMs: null }), null);
    assert.deepEqual(configDurationListMs({ thresholdsS: '0.2, 0.4,0.6' }, 'thresholdsS', 'thresholds', 'D'), [200, 400, 600]);
    assert.deepEqual(configDurationListMs({ thresholdsS: '', thresholds: '200, 400' }, 'thresholdsS', 'thresholds', 'D'), [200, 400]);
    assert.deepEqual(configDurationListMs({ thresholdsS: '1, 2', thresholds: '5, 6' }, 'thresholdsS', 'thresholds', 'D'), [1000, 2000]);
  });

  it('refuses text and a missing required duration, naming the setting and its unit', function () {
    assert.throws(() => configDurationMs({ tsS: 'fast' }, 'tsS', 'ts', 'sampling period Ts'),
      { code: 'INVALID_CONFIG', message: "sampling period Ts (tsS, s) must be a number, got 'fast'" });
    assert.throws(() => configDurationMs({ tsS: '', ts: 'fast' }, 'tsS', 'ts', 'sampling period Ts'),
      { code: 'INVALID_CONFIG', message: "sampling period Ts (ts, ms) must be a number, got 'fast'" });
    assert.throws(() => configDurationMs({}, 'tsS', 'ts', 'sampling period Ts', { required: true }),
      { code: 'INVALID_CONFIG', message: 'sampling period Ts (tsS, s) is required' });
    assert.throws(() => configDurationListMs({ thresholdsS: '', thresholds: '1, x' }, 'thresholdsS', 'thresholds', 'D'),
      { code: 'INVALID_CONFIG', message: "D (thresholds, ms) (item 2) must be a number, got 'x'" });
  });
});

describe('state and journal nodes: durations in seconds, or ms from older flows', function () {
  beforeEach(startServer);
  afterEach(stopServer);

  for (const [settings, interval] of [['intervalS in s', { intervalS: '0.5' }], ['intervalMs of older flows', { intervalS: '', intervalMs: 500 }]]) {
    it(`state (${settings}): sends a change at most once per interval`, async function () {
      await helper.load(paletteNodes, [TAB, sinkNode('out'), { id: 's', z: 'f1', type: 'sugarshack-state', onChange: true, ...interval, wires: [['out']] }]);
      const out = collect(helper, 'out');
      helper.getNode('s').receive({ topic: 'state?' });
      await until(() => out.length === 1, 'the answer to a request');
      const changes = paletteOf({ events: helper._events }).changes;
      assert.equal(changes.listenerCount('changed'), 1, 'the state node listens to the palette\'s changes');
      changes.touch();
      await settled(helper);
      await clock().advance(499);
      await settled(helper);
      assert.equal(out.length, 1, 'not within 0.5 s of the last one');
      await clock().advance(1);
      await until(() => out.length === 2, 'the change, 0.5 s after the last send');
      assert.equal(out[1].trigger, 'change');
    });
  }

  it('state: an interval that is not a number is reported with its setting and unit, and it sends every 1 s', async function () {
    await helper.load(paletteNodes, [TAB, { id: 's', z: 'f1', type: 'sugarshack-state', onChange: true, intervalS: 'often', wires: [[]] }]);
    assert.match(String(helper.getNode('s').error.firstCall.args[0]), /the send interval \(intervalS, s\) must be a number, got 'often'; sending every 1 s/);
  });

  it('journal: a flush interval outside 0.05..60 s is refused with its setting and unit', async function () {
    await helper.load(paletteNodes, [TAB, { id: 'j', z: 'f1', type: 'sugarshack-journal', target: 'files', plantId: 'p1', flushS: '120' }]);
    assert.match(String(helper.getNode('j').error.firstCall.args[0]), /the flush interval \(flushS\) must be from 0.05 to 60 s, got 120 s/);
  });
});
