'use strict';
// Runs the shipped example flow (with its work delays shortened) and checks
// what its comments tell the user to watch.
const assert = require('node:assert/strict');
const fs = require('fs');
const path = require('path');
const helper = require('node-red-node-test-helper');
const { PALETTE, paletteNodes, catchNode, until } = require('./support');

helper.init(require.resolve('node-red'));

const coreNodesDir = path.dirname(require.resolve('@node-red/nodes/package.json'));
const coreNodes = ['common/20-inject.js', 'common/90-comment.js', 'function/89-delay.js']
  .map((f) => require(path.join(coreNodesDir, 'core', f)));
const EXAMPLES = path.join(PALETTE, 'examples');
const CONFIG_TYPES = { 'sugarshack-interlock': true, 'sugarshack-plant': true };

/** The example with debug nodes as helper nodes and each second of work as 20 ms. */
function exampleFlow(policy) {
  const flow = JSON.parse(fs.readFileSync(path.join(EXAMPLES, 'interlock-yel-contention.json'), 'utf8'));
  return flow.map((n) => {
    if (n.type === 'debug') return { id: n.id, z: n.z, type: 'helper', name: n.name };
    if (n.type === 'delay') return { ...n, timeout: String(Number(n.timeout) * 20), timeoutUnits: 'milliseconds' };
    if (n.type === 'sugarshack-interlock') return { ...n, policy };
    return n;
  });
}

const byName = (flow, type, name) => flow.find((n) => n.type === type && n.name === name).id;
const acquireOf = (flow, op) => flow.find((n) => n.type === 'sugarshack-acquire' && n.operation === op).id;

describe('example: interlock-yel-contention', function () {
  beforeEach(function (done) {
    helper.startServer(done);
  });

  afterEach(async function () {
    await helper.unload();
    await new Promise((resolve) => helper.stopServer(resolve));
  });

  it('every example flow uses only configured nodes, and together they use every node type', function () {
    const pkg = JSON.parse(fs.readFileSync(path.join(PALETTE, 'package.json'), 'utf8'));
    const files = fs.readdirSync(EXAMPLES).filter((f) => f.endsWith('.json'));
    const used = new Set();
    for (const file of files) {
      const flow = JSON.parse(fs.readFileSync(path.join(EXAMPLES, file), 'utf8'));
      // Each node of the palette names its config node (interlock or plant) through the property of that name.
      const configs = new Map(flow.filter((n) => CONFIG_TYPES[n.type]).map((n) => [n.id, n.type]));
      for (const n of flow) {
        used.add(n.type);
        if (n.type.startsWith('sugarshack-') && !CONFIG_TYPES[n.type]) {
          const property = n.interlock !== undefined ? 'interlock' : 'plant';
          assert.equal(configs.get(n[property]), `sugarshack-${property}`, `${file}: ${n.type} ${n.id} has its ${property} in the file`);
        }
        for (const [key, value] of Object.entries(n)) {
          if (key === 'broker' && n.type !== 'mqtt-broker') assert.ok(flow.some((c) => c.id === value && c.type === 'mqtt-broker'), `${file}: ${n.id} has its broker in the file`);
        }
      }
    }
    const types = Object.keys(pkg['node-red'].nodes).map((set) => `sugarshack-${set}`);
    for (const type of types) assert.ok(used.has(type), `${type} appears in an example`);
  });

  for (const [policy, order] of [['greedy', ['10', '51', '12', '18']], ['no-overtaking', ['10', '18', '12', '51']]]) {
    it(`"start all" grants in the order the comment describes (${policy})`, async function () {
      const flow = exampleFlow(policy);
      await helper.load([...paletteNodes, catchNode, ...coreNodes], flow);
      const granted = [];
      const returned = [];
      const refusals = [];
      helper.getNode(byName(flow, 'helper', 'granted')).on('input', (m) => granted.push(m.interlock.operation));
      helper.getNode(byName(flow, 'helper', 'returned')).on('input', (m) => returned.push(m.interlock.operation));
      helper.getNode(byName(flow, 'helper', 'refusals')).on('input', (m) => refusals.push(m.error));
      helper.getNode(byName(flow, 'inject', 'start all')).receive({});
      await until(() => returned.length === 4, 'all four operations to return');
      assert.deepEqual(granted, order);
      assert.deepEqual(refusals, []);
    });
  }

  it('fault op 12 locks YEL out, refuses its release, and clear resumes the queue', async function () {
    const flow = exampleFlow('greedy');
    await helper.load([...paletteNodes, catchNode, ...coreNodes], flow);
    const seen = { granted: [], returned: [], refusals: [], 'lockout commands': [], cleared: [] };
    for (const name of Object.keys(seen)) {
      helper.getNode(byName(flow, 'helper', name)).on('input', (m) => seen[name].push(m));
    }
    helper.getNode(byName(flow, 'inject', 'start op 12 (unload truck)')).receive({});
    await until(() => seen.granted.length === 1, 'op 12 granted');
    helper.getNode(byName(flow, 'inject', 'fault op 12')).receive({});
    await until(() => seen['lockout commands'].length === 1, 'the YEL lockout');
    const lockout = seen['lockout commands'][0];
    assert.equal(lockout.topic, 'lockout/YEL');
    assert.deepEqual(lockout.payload, { valves: { V10: 0, V11: 0, V12: 0, V13: 0 }, pumps: { P1: false } });
    assert.equal(lockout.note, 'pump P1 ran dry');
    await until(() => seen.refusals.length === 1, 'the refused release of 12');
    assert.equal(seen.refusals[0].error.code, 'NOT_HOLDING');

    helper.getNode(acquireOf(flow, '10')).receive({ payload: 'load truck' });
    helper.getNode(byName(flow, 'inject', 'start op 51 (drain silo)')).receive({});
    await until(() => seen.granted.length === 2, 'op 51 granted on RED');
    assert.equal(seen.granted[1].interlock.operation, '51');
    helper.getNode(byName(flow, 'inject', 'clear all faulted')).receive({});
    await until(() => seen.granted.length === 3, 'op 10 granted after the clear');
    assert.deepEqual(seen.cleared[0].cleared, ['YEL']);
    assert.equal(seen.granted[2].interlock.operation, '10');
  });
});
