'use strict';
// Starter flows for a plant of one's own (scripts/starter-flows.js, what
// `npm start -- --plant` seeds): made from the document, they deploy, every
// operation and routine has its node, the field bus reads every device under
// its profile's topics on the broker asked for; and once made they are the
// user's: a changed document reaches their plant node only while the editor
// left it alone.
const assert = require('node:assert/strict');
const fs = require('fs');
const os = require('os');
const path = require('path');
const helper = require('node-red-node-test-helper');
const { paletteNodes, startServer, stopServer, settled, until } = require('./support');
const { starterFlows, sync, deviceTopics } = require('../../scripts/starter-flows');

helper.init(require.resolve('node-red'));

const ROOT = path.join(__dirname, '..', '..');
const RIG = JSON.parse(fs.readFileSync(path.join(ROOT, 'flows', 'example-rig.json'), 'utf8'));
const coreNodesDir = path.dirname(require.resolve('@node-red/nodes/package.json'));
const coreNodes = ['common/20-inject.js', 'common/21-debug.js', 'common/90-comment.js', 'network/10-mqtt.js', 'function/15-change.js', 'function/10-switch.js']
  .map((f) => require(path.join(coreNodesDir, 'core', f)));

describe('starter flows for a plant of one\'s own', function () {
  before(startServer);
  after(stopServer);

  it('deploy: an operation node and a button per operation, a routine node per routine, the interlock on the document\'s lines', async function () {
    // The HMI's Dashboard 2 nodes are the browser test's; here, the palette's and core nodes.
    const { flows, plantId } = starterFlows(RIG, 'example-rig', 'mqtt://127.0.0.1:18830');
    const deployable = flows.filter((n) => !n.type.startsWith('ui-') && n.type !== 'subflow' && !n.type.startsWith('subflow:') && !flows.some((s) => s.type === 'subflow' && s.id === n.z));
    await helper.load([...paletteNodes, ...coreNodes], deployable);
    const interlock = flows.find((n) => n.type === 'sugarshack-interlock');
    await until(() => helper.getNode(interlock.id).runtime.state !== 'starting', 'the interlock to start');
    await settled(helper, interlock.id);
    assert.equal(helper.getNode(interlock.id).runtime.state, 'ready');
    assert.equal(interlock.plant, plantId);
    assert.deepEqual(helper.getNode(interlock.id).runtime.config.resources.map((r) => r.name), ['YEL', 'RED']);
    const manual = flows.filter((n) => n.type === 'sugarshack-operation' && !n.name);
    assert.deepEqual(manual.map((n) => n.operation), RIG.operations.map((o) => o.id));
    for (const op of RIG.operations) assert.ok(flows.some((n) => n.type === 'inject' && n.name.startsWith(`${op.id} ${op.description}`)), `a button for ${op.id}`);
    assert.deepEqual(flows.filter((n) => n.type === 'sugarshack-routine').map((n) => n.routine), RIG.routines.map((r) => r.id));
    // The faults offered: each line's first valve stuck, the first station dead, and the operation that moves the first.
    const names = flows.filter((n) => n.type === 'inject').map((n) => n.name);
    for (const name of ['stuck V101 (YEL)', 'stuck V501 (RED)', 'rig-station-2 dead (sensors stale)', 'clear simulator faults', 'run op 10 now', 'clear YEL', 'clear RED']) assert.ok(names.includes(name), name);
    assert.deepEqual(flows.filter((n) => n.type === 'mqtt-broker').map((n) => [n.broker, n.port]), [['127.0.0.1', '18830']]);
    assert.ok(flows.some((n) => n.type === 'ui-base' && n.path === '/dashboard'), 'the HMI');
  });

  it('the field bus reads each device under its prefix and profile', function () {
    assert.deepEqual(deviceTopics(RIG), ['rig/ctrl-1/#', 'rig/ctrl-5/#', 'rig/station-2/#', 'rig/station-3/#', 'rig/station-7/#']);
    const devices = [{ id: 'a', profile: 'tasmota' }, { id: 'b', profile: 'shelly-gen2', prefix: 'shellies/b' }, { id: 'c' }];
    assert.deepEqual(deviceTopics({ devices }), ['tele/a/#', 'stat/a/#', 'shellies/b/#', 'c/#']);
    assert.deepEqual(deviceTopics({ devices: [...devices, { id: 'z', profile: 'custom' }] }), ['#'], 'a custom device\'s topics are its own templates');
  });

  describe('once made, the flows are the user\'s', function () {
    let dir;
    beforeEach(function () {
      dir = fs.mkdtempSync(path.join(os.tmpdir(), 'sugarshack-starter-'));
    });
    afterEach(function () {
      fs.rmSync(dir, { recursive: true, force: true });
    });
    const quietly = (fn) => {
      const log = console.log;
      const said = [];
      console.log = (line) => said.push(line);
      try {
        fn();
      } finally {
        console.log = log;
      }
      return said.join('\n');
    };

    it('a document changed since reaches their plant node; one changed in the editor is kept and the difference said', function () {
      const plantFile = path.join(dir, 'my-plant.json');
      const flowsFile = path.join(dir, 'flows.json');
      const readFlows = () => JSON.parse(fs.readFileSync(flowsFile, 'utf8'));
      const { plantId } = starterFlows(RIG, 'my-plant');
      const plantNode = () => readFlows().find((n) => n.id === plantId);
      fs.writeFileSync(plantFile, JSON.stringify(RIG));
      assert.match(quietly(() => sync(plantFile, flowsFile)), /starter flows made from my-plant\.json \(4 operation\(s\), 1 routine\(s\), the HMI\)/);
      assert.deepEqual(plantNode().plant, RIG);

      // The user edits the file: its plant node follows.
      const edited = { ...RIG, name: 'rig, renamed in the file' };
      fs.writeFileSync(plantFile, JSON.stringify(edited));
      assert.match(quietly(() => sync(plantFile, flowsFile)), /changed since the flows were made: their plant node now holds it/);
      assert.deepEqual(plantNode().plant, edited);
      assert.match(quietly(() => sync(plantFile, flowsFile)), /keeping .*flows\.json/);

      // The user edits the plant node in the editor too: the flows keep theirs, and it says so.
      const flows = readFlows();
      flows.find((n) => n.id === plantId).plant = { ...edited, name: 'renamed in the editor' };
      fs.writeFileSync(flowsFile, JSON.stringify(flows));
      fs.writeFileSync(plantFile, JSON.stringify({ ...edited, name: 'renamed in the file again' }));
      assert.match(quietly(() => sync(plantFile, flowsFile)), /was changed in the editor and differs from my-plant\.json: Node-RED runs the flows' copy, the simulator the file; --reset-flows makes new flows from the file/);
      assert.equal(plantNode().plant.name, 'renamed in the editor');
      quietly(() => sync(plantFile, flowsFile, { reset: true }));
      assert.equal(plantNode().plant.name, 'renamed in the file again');
    });
  });
});
