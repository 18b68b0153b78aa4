'use strict';
// The case-study flows (flows/case-study.json): in step with the plant
// document, and deployable: the plant validates, the interlock takes its lines
// from it, every operation and routine node starts without an error, and the
// routines start in their initial states. No broker: the MQTT nodes only retry.
const assert = require('node:assert/strict');
const path = require('path');
const { execFileSync } = require('child_process');
const helper = require('node-red-node-test-helper');
const {
  paletteNodes, startServer, stopServer, settled, until,
} = require('./support');

helper.init(require.resolve('node-red'));

const ROOT = path.join(__dirname, '..', '..');
const coreNodesDir = path.dirname(require.resolve('@node-red/nodes/package.json'));
const coreNodes = ['common/20-inject.js', 'common/21-debug.js', 'common/90-comment.js', 'network/10-mqtt.js']
  .map((f) => require(path.join(coreNodesDir, 'core', f)));
const FLOW = require(path.join(ROOT, 'flows', 'case-study.json'));
const PLANT = require(path.join(ROOT, 'flows', 'plant.json'));

const errorsOf = (node) => node.error.getCalls().filter((c) => c.thisValue.id === node.id).map((c) => String(c.args[0]));

describe('case-study flows', function () {
  before(startServer);
  after(stopServer);

  it('are generated from the current plant document', function () {
    execFileSync(process.execPath, [path.join(ROOT, 'scripts', 'case-study-flow.js'), '--check'], { stdio: 'pipe' });
  });

  it('deploy: every operation and routine of the document gets a node that starts without an error', async function () {
    // The helper loads the core catch node itself (once, though each tab has a Catch node).
    await helper.load([...paletteNodes, ...coreNodes], FLOW);
    const interlockId = FLOW.find((n) => n.type === 'sugarshack-interlock').id;
    await until(() => helper.getNode(interlockId).runtime.state !== 'starting', 'the interlock to start');
    await settled(helper, interlockId);
    const ofType = (type) => FLOW.filter((n) => n.type === type).map((n) => helper.getNode(n.id));
    const operations = ofType('sugarshack-operation');
    const routines = ofType('sugarshack-routine');
    // Op 10 has a second node on the faults tab (the walkthrough's "run op 10 now").
    const started = operations.map((n) => n && FLOW.find((f) => f.id === n.id).operation);
    assert.deepEqual([...new Set(started)].sort(), PLANT.operations.map((o) => o.id).sort());
    assert.equal(started.length, PLANT.operations.length + 1);
    assert.deepEqual(routines.map((n) => n && FLOW.find((f) => f.id === n.id).routine).sort(), PLANT.routines.map((r) => r.id).sort());
    for (const node of [...operations, ...routines, ...ofType('sugarshack-actuators'), ...ofType('sugarshack-clear')]) {
      assert.deepEqual(errorsOf(node), [], `${node.type} ${node.id}`);
    }
    const interlock = helper.getNode(interlockId);
    assert.equal(interlock.runtime.state, 'ready');
    assert.deepEqual(interlock.runtime.config.resources.map((r) => r.name), PLANT.resources.map((r) => r.id));
    for (const r of PLANT.routines) {
      const node = routines.find((n) => FLOW.find((f) => f.id === n.id).routine === r.id);
      const status = node.status.getCalls().filter((c) => c.thisValue.id === node.id).at(-1).args[0];
      assert.equal(status.text, r.initial, `routine ${r.id} starts in ${r.initial}`);
    }
  });
});
