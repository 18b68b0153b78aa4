'use strict';
// Runs the shipped actuators example without a broker: mqtt in/out become
// helper nodes, feedback is fed to the actuators node as mqtt in delivers it.
const assert = require('node:assert/strict');
const fs = require('fs');
const path = require('path');
const helper = require('node-red-node-test-helper');
const {
  PALETTE, paletteNodes, until, startServer, stopServer, clock,
} = require('./support');

helper.init(require.resolve('node-red'));

const coreNodesDir = path.dirname(require.resolve('@node-red/nodes/package.json'));
const coreNodes = ['common/20-inject.js', 'common/90-comment.js'].map((f) => require(path.join(coreNodesDir, 'core', f)));
const FILE = path.join(PALETTE, 'examples', 'actuators-group-command.json');

function exampleFlow() {
  const flow = JSON.parse(fs.readFileSync(FILE, 'utf8'));
  return flow
    .filter((n) => n.type !== 'mqtt-broker')
    .map((n) => {
      if (n.type === 'debug' || n.type === 'mqtt out') return { id: n.id, z: n.z, type: 'helper', name: n.name };
      if (n.type === 'mqtt in') return { id: n.id, z: n.z, type: 'helper', name: n.name, wires: n.wires };
      return n;
    });
}

const byName = (flow, type, name) => flow.find((n) => n.type === type && n.name === name).id;

describe('example: actuators-group-command', function () {
  beforeEach(startServer);
  afterEach(stopServer);

  it('opens line 1 from its inject, returns on "completed", refuses the bad command at the Catch', async function () {
    const flow = exampleFlow();
    await helper.load([...paletteNodes, ...coreNodes], flow);
    const seen = { 'device commands': [], completed: [], errors: [], 'actuator events': [] };
    for (const name of Object.keys(seen)) helper.getNode(byName(flow, 'helper', name)).on('input', (m) => seen[name].push(m));
    const bus = helper.getNode(flow.find((n) => n.type === 'sugarshack-actuators').id);
    // The rig's panel speaks ESPHome: each valve's position in whole percent and the pump's relay, on change.
    const feedback = (topic, payload) => bus.receive({ topic: `rig/ctrl-1/${topic}`, payload, qos: 0, retain: false });
    const state = (valves, pump) => {
      for (const [valve, position] of Object.entries(valves)) feedback(`valve/v10${valve}/position/state`, String(position));
      feedback('switch/p1/state', pump ? 'ON' : 'OFF');
    };

    bus.receive({ topic: 'rig/ctrl-1/status', payload: 'online', retain: true });
    state({ 1: 0, 2: 0, 3: 0, 4: 0, 5: 0 }, false);
    helper.getNode(byName(flow, 'inject', 'open line 1')).receive({});
    await until(() => seen['device commands'].length === 3, 'three device commands');
    assert.deepEqual(seen['device commands'].map((m) => [m.topic, m.payload, m.retain, m.qos]), [
      ['rig/ctrl-1/valve/v101/position/command', '100', false, 1],
      ['rig/ctrl-1/valve/v102/position/command', '100', false, 1],
      ['rig/ctrl-1/switch/p1/command', 'ON', false, 1],
    ]);
    await clock().advance(1000);
    state({ 1: 50, 2: 50, 3: 0, 4: 0 }, true);
    await clock().advance(1000);
    state({ 1: 100, 2: 99, 3: 0, 4: 0 }, true);
    await until(() => seen.completed.length === 1, 'the open command completes');
    assert.deepEqual(seen.completed[0].command.actuators.map((a) => [a.actuator, a.issueToMotionMs, a.completionMs]).sort(),
      [['P1', 1000, 1000], ['V101', 1000, 2000], ['V102', 1000, 2000]]);
    assert.equal(seen.completed[0].command.completionMs, 2000);
    // ESPHome states carry no device time: no time of flight.
    assert.ok(seen['actuator events'].some((m) => m.topic === 'actuator/changed/V101' && m.payload.timeOfFlightMs === null));

    helper.getNode(byName(flow, 'inject', 'bad command')).receive({});
    await until(() => seen.errors.length === 1, 'the refusal');
    assert.equal(seen.errors[0].error.code, 'UNKNOWN_ACTUATOR');
    assert.equal(seen['device commands'].length, 3, 'nothing sent for the bad command');

    helper.getNode(byName(flow, 'inject', 'lockout (from a fault)')).receive({});
    await until(() => seen['device commands'].length === 8, 'the retained lockout');
    assert.ok(seen['device commands'].slice(3).every((m) => m.retain === true));
  });
});
