'use strict';
// What a node's configuration means is the core's to say (engine/config.rs):
// a timeout typed as no number of seconds, or an operation or routine node
// without an id, is refused at deploy in the editor's words (logged, a red
// status, every msg ending with it for a Catch node), never read as "no
// timeout" and never a trap.
const assert = require('node:assert/strict');
const helper = require('node-red-node-test-helper');
const { fakePlant, fakeValve, fakePump, boundPlant, loadTruck } = require('./fake-panel');
const { paletteNodes, TAB, interlockConfig, acquire, sinkNode, collect, until, startServer, stopServer } = require('./support');

helper.init(require.resolve('node-red'));

const catchAll = { id: 'c1', z: 'f1', type: 'catch', scope: null, uncaught: false, wires: [['caught']] };
const lastStatus = (id) => helper.getNode(id).status.getCalls().map((c) => c.args[0]).at(-1);
const logged = (id) => helper.getNode(id).error.getCalls().map((c) => String(c.args[0]));

/** Sends a msg to each of `ids`; resolves with the errors a Catch node got, in order. */
async function refusals(ids, caught) {
  const errors = [];
  for (const id of ids) {
    const before = caught.length;
    helper.getNode(id).receive({ operation: 'x', payload: { valves: { V101: 100 } } });
    await until(() => caught.length > before, `the refusal of ${id}`);
    errors.push(caught[before].error);
  }
  return errors;
}

const plantDoc = () => ({
  ...fakePlant([fakeValve('V101', 1, 'YEL'), fakeValve('V102', 2, 'YEL'), fakePump('YEL')]),
  sensors: [{ id: 'LT-3', device: 'station-3', name: 'volume' }],
  resources: [{ id: 'YEL' }],
  operations: [loadTruck()],
});

describe("a node's configuration, read by the core", function () {
  beforeEach(startServer);
  afterEach(stopServer);

  it('a timeout that is no number of seconds is refused in words: negative, not a number, infinite or past a year', async function () {
    const bad = [['neg', '-5', '"-5"'], ['text', '20 s', '"20 s"'], ['nan', 'NaN', '"NaN"'], ['inf', Infinity, 'Infinity'], ['huge', 1e12, '1000000000000']];
    await helper.load(paletteNodes, [
      TAB, interlockConfig(), catchAll, sinkNode('caught'), sinkNode('out'),
      ...bad.map(([id, timeout]) => acquire(id, 'x', 0, 'YEL', 'out', { timeout })),
    ]);
    const caught = collect(helper, 'caught');
    const errors = await refusals(bad.map(([id]) => id), caught);
    for (const [i, [id, , got]] of bad.entries()) {
      assert.equal(errors[i].code, 'INVALID_CONFIG', id);
      const words = `the configured timeout must be a number of seconds from 0 to 31536000 (blank for none), got ${got}`;
      assert.equal(errors[i].message, `SugarshackError: ${words}`, id);
      assert.equal(lastStatus(id).fill, 'red', id);
      assert.ok(logged(id).includes(words), id);
    }
    assert.deepEqual(helper.getNode('il').runtime.core.counts(), { holding: 0, queued: 0, faulted: 0 }, 'nothing reached the interlock');
  });

  it("a group command's and a wait's timeout too; a wait without one is refused as before", async function () {
    await helper.load(paletteNodes, [
      TAB, ...boundPlant(plantDoc()), sinkNode('caught'), sinkNode('out'), sinkNode('mqtt'), sinkNode('ev'), sinkNode('events'),
      { id: 'gc', z: 'f1', type: 'sugarshack-group-command', plant: 'pl', timeout: '-1', wires: [['out']] },
      { id: 'w', z: 'f1', type: 'sugarshack-wait', plant: 'pl', condition: '`LT-3` > 1', sensors: 'LT-3', timeout: 'soon', wires: [['out']] },
      { id: 'w0', z: 'f1', type: 'sugarshack-wait', plant: 'pl', condition: '`LT-3` > 1', sensors: ' LT-3 , ', timeout: ' ', wires: [['out']] },
    ]);
    const caught = collect(helper, 'caught');
    const [gc, w, w0] = await refusals(['gc', 'w', 'w0'], caught);
    assert.equal(gc.code, 'INVALID_CONFIG');
    assert.match(gc.message, /the configured timeout must be a number of seconds .* got "-1"$/);
    assert.match(w.message, /the configured timeout must be a number of seconds .* got "soon"$/);
    assert.equal(w0.message, 'SugarshackError: a condition wait needs a timeout (seconds, above 0)');
    for (const id of ['gc', 'w', 'w0']) assert.equal(lastStatus(id).fill, 'red', id);
  });

  it('an operation or routine node with no id, or one that is no name, is refused at deploy', async function () {
    await helper.load(paletteNodes, [
      TAB, ...boundPlant(plantDoc()), sinkNode('caught'), sinkNode('mqtt'), sinkNode('ev'), sinkNode('events'),
      { id: 'op', z: 'f1', type: 'sugarshack-operation', interlock: 'il', operation: '   ', wires: [[]] },
      { id: 'rt', z: 'f1', type: 'sugarshack-routine', interlock: 'il', routine: ['truck'], wires: [[]] },
    ]);
    const caught = collect(helper, 'caught');
    const [op, rt] = await refusals(['op', 'rt'], caught);
    assert.equal(op.code, 'INVALID_CONFIG');
    assert.equal(op.message, 'SugarshackError: the configured operation is required: type it in the node');
    assert.equal(rt.message, 'SugarshackError: the configured routine must be text, got ["truck"]');
    assert.ok(logged('op').includes('the configured operation is required: type it in the node'));
    assert.equal(lastStatus('rt').fill, 'red');
  });
});
