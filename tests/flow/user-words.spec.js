'use strict';
// A value of the wrong kind, in a plant document or in a msg, is refused in the
// words of the person who wrote it: the field, what it takes, what it got;
// never serde's `expected i32` or JSON.stringify's TypeError.
const assert = require('node:assert/strict');
const helper = require('node-red-node-test-helper');
const { paletteNodes, TAB, sinkNode, collect, until, startServer, stopServer } = require('./support');
const { everyNodeFlow, plantDocument } = require('./every-node');

helper.init(require.resolve('node-red'));

function plant() {
  return plantDocument({
    actuatorStaleMs: 60000, retries: 0, sensorStaleMs: 5000,
    operations: [{ id: '10', priority: 20, resources: ['YEL'], steps: [{ command: { valves: { V101: 100 } }, timeoutMs: 3000 }] }],
    routines: [{ id: 'truck', states: ['a'], initial: 'a', transitions: [] }],
  });
}

describe('errors in the user\'s words', function () {
  beforeEach(startServer);
  afterEach(stopServer);

  it('a plant document field of the wrong kind names the field, what it takes and what it got', async function () {
    await helper.load(paletteNodes, [TAB, { id: 'pl', type: 'sugarshack-plant', name: 'plant', plant: plant() }]);
    const validate = (doc) => helper.request().post('/sugarshack/plant/validate').send({ plant: doc });
    const cases = [
      [(d) => { d.operations[0].priority = 'high'; }, { path: 'operations[0]', message: "priority must be a whole number, like 5; got 'high'" }],
      [(d) => { d.actuators[0].io = -1; }, { path: 'actuators[0]', message: 'io must be a whole number from 0 to 4294967295; got -1' }],
      [(d) => { d.devices[0].profile = 'zigbee'; }, { path: 'devices[0]', message: "profile must be one of 'sugarshack', 'esphome', 'tasmota', 'shelly-gen2', 'custom', 'modbus'; got 'zigbee'" }],
      [(d) => { d.operations[0].steps[0].timeoutMs = '3 s'; }, { path: 'operations[0].steps[0]', message: "timeoutMs must be a non-negative number of milliseconds; got '3 s'" }],
      [(d) => { d.operations[0].resources = 'YEL'; }, { path: 'operations[0]', message: "resources must be a list in brackets, [...]; got 'YEL'" }],
    ];
    for (const [breaks, expected] of cases) {
      const doc = plant();
      breaks(doc);
      const res = await validate(JSON.stringify(doc));
      assert.equal(res.body.valid, false);
      assert.equal(res.body.errors.length, 1, res.text);
      assert.equal(res.body.errors[0].path, expected.path);
      assert.match(res.body.errors[0].message, new RegExp(`^${expected.message.replace(/[.*+?^${}()|[\]\\]/g, '\\$&')}`));
    }
  });

  it('a msg priority that is not a whole number, and a group command holding a BigInt, say which field', async function () {
    await helper.load(paletteNodes, [
      ...everyNodeFlow(plant()),
      { id: 'c1', z: 'f1', type: 'catch', scope: null, uncaught: false, wires: [['caught']] },
      sinkNode('caught'),
    ]);
    const caught = collect(helper, 'caught');
    helper.getNode('acq').receive({ operation: '77', resources: 'YEL', priority: 'high' });
    await until(() => caught.length === 1, 'the priority refusal');
    assert.equal(caught[0].error.code, 'INVALID_PRIORITY');
    assert.equal(caught[0].error.message, 'SugarshackError: msg.priority must be a whole number, like 5 (higher is more urgent); got "high"');

    helper.getNode('gc').receive({ payload: { valves: { V101: 100n } } });
    await until(() => caught.length === 2, 'the BigInt refusal');
    assert.equal(caught[1].error.code, 'INVALID_INPUT');
    assert.match(caught[1].error.message, /valves\.V101 is a BigInt \(100n\), which JSON cannot carry: send it as a plain number$/);
    assert.doesNotMatch(caught[1].error.message, /TypeError|serialize/);
  });
});
