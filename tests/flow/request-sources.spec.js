'use strict';
// Where an acquire's operation, priority and resources come from: typed in
// (as every flow saved before the sources existed), or read for each msg from
// flow context, an environment variable or a JSONata expression, as Node-RED's
// trigger node reads its values; msg.operation and the like still come first.
// And the queue of held msgs keeps within Node-RED's nodeMessageBufferMaxLength.
const assert = require('node:assert/strict');
const helper = require('node-red-node-test-helper');
const { boundPlant, fakePlant, fakeValve, fakePump } = require('./fake-panel');
const {
  paletteNodes, TAB, interlockConfig, acquire, release, sinkNode, collect, until, startServer, stopServer, settings, settled,
} = require('./support');

helper.init(require.resolve('node-red'));

const catchAll = { id: 'c1', z: 'f1', type: 'catch', scope: null, uncaught: false, wires: [['caught']] };
const counts = () => helper.getNode('il').runtime.core.counts();

function flow(nodes, config = {}) {
  return [TAB, interlockConfig(config), ...nodes, release('rel', 'released'), catchAll, sinkNode('out'), sinkNode('released'), sinkNode('caught')];
}

/** Sends `msg` to `id`; resolves with the msg it granted, or the error a Catch node got. */
async function answer(id, msg, out, caught) {
  const [sent, failed] = [out.length, caught.length];
  helper.getNode(id).receive(msg);
  await until(() => out.length > sent || caught.length > failed, `an answer from ${id}`);
  return out.length > sent ? { granted: out[sent].interlock } : { error: caught[failed].error };
}

describe('sugarshack acquire: values from msg, flow, global, env or JSONata', function () {
  beforeEach(startServer);
  afterEach(async function () {
    delete process.env.SUGARSHACK_TEST_OP;
    await stopServer();
  });

  it('a flow saved before the sources reads its fields as typed values, msg first, as before', async function () {
    // "payload" here is an operation id typed in, not msg.payload: the flow has no operationType.
    await helper.load(paletteNodes, flow([acquire('a', ' payload ', '7', 'YEL', 'out')]));
    const [out, caught] = ['out', 'caught'].map((id) => collect(helper, id));
    assert.deepEqual((await answer('a', { payload: 'x' }, out, caught)).granted,
      { operation: 'payload', priority: 7, resources: ['YEL'], waitedMs: 0 });
    helper.getNode('rel').receive({ operation: 'payload' });
    await until(() => counts().holding === 0, 'released');
    assert.deepEqual((await answer('a', { operation: '12', priority: '3', resources: 'GRN' }, out, caught)).granted,
      { operation: '12', priority: 3, resources: ['GRN'], waitedMs: 0 });
    const refused = await answer('a', { operation: '13', priority: 'urgent' }, out, caught);
    assert.equal(refused.error.code, 'INVALID_PRIORITY');
    assert.match(refused.error.message, /msg\.priority must be a whole number/);
  });

  it('a priority from flow context, read for each msg (a bad one refused as the node\'s)', async function () {
    await helper.load(paletteNodes, flow([acquire('a', '10', 'urgency', 'YEL', 'out', { priorityType: 'flow' })]));
    const [out, caught] = ['out', 'caught'].map((id) => collect(helper, id));
    const flowContext = helper.getNode('a').context().flow;
    flowContext.set('urgency', 42);
    assert.equal((await answer('a', {}, out, caught)).granted.priority, 42);
    helper.getNode('rel').receive({ operation: '10' });
    await until(() => counts().holding === 0, 'released');
    flowContext.set('urgency', '-5');
    assert.equal((await answer('a', {}, out, caught)).granted.priority, -5);
    helper.getNode('rel').receive({ operation: '10' });
    await until(() => counts().holding === 0, 'released again');
    // msg.priority still comes first.
    assert.equal((await answer('a', { priority: 9 }, out, caught)).granted.priority, 9);
    helper.getNode('rel').receive({ operation: '10' });
    await until(() => counts().holding === 0, 'released a third time');
    flowContext.set('urgency', 'soon');
    const refused = await answer('a', {}, out, caught);
    assert.equal(refused.error.code, 'INVALID_PRIORITY');
    assert.match(refused.error.message, /the configured priority must be a whole number.*"soon"/);
    assert.deepEqual(counts(), { holding: 0, queued: 0, faulted: 0 });
  });

  it('an operation id from an environment variable, trimmed by the core', async function () {
    process.env.SUGARSHACK_TEST_OP = ' 12 ';
    await helper.load(paletteNodes, flow([acquire('a', 'SUGARSHACK_TEST_OP', 0, 'RED', 'out', { operationType: 'env' })]));
    const [out, caught] = ['out', 'caught'].map((id) => collect(helper, id));
    assert.deepEqual((await answer('a', {}, out, caught)).granted, { operation: '12', priority: 0, resources: ['RED'], waitedMs: 0 });
    // The variable unset: no operation id anywhere.
    delete process.env.SUGARSHACK_TEST_OP;
    const refused = await answer('a', {}, out, caught);
    assert.equal(refused.error.code, 'MISSING_OPERATION');
  });

  it('resources from a JSONata expression over the msg', async function () {
    await helper.load(paletteNodes, flow([
      acquire('a', '10', 0, '$join(["YEL", payload.line], ",")', 'out', { resourcesType: 'jsonata' }),
      acquire('b', '11', 0, '$notAFunction(payload)', 'out', { resourcesType: 'jsonata' }),
      acquire('c', '12', 0, '$join([', 'out', { resourcesType: 'jsonata' }),
    ]));
    const [out, caught] = ['out', 'caught'].map((id) => collect(helper, id));
    assert.deepEqual((await answer('a', { payload: { line: ' RED ' } }, out, caught)).granted.resources, ['YEL', 'RED']);
    assert.deepEqual(counts(), { holding: 1, queued: 0, faulted: 0 });
    helper.getNode('rel').receive({ operation: '10' });
    await until(() => counts().holding === 0, 'released');
    const refused = await answer('a', { payload: { line: 'PINK' } }, out, caught);
    assert.equal(refused.error.code, 'UNKNOWN_RESOURCE');
    // An expression that fails refuses the msg with its reason.
    const failed = await answer('b', { payload: 1 }, out, caught);
    assert.equal(failed.error.code, 'INVALID_INPUT');
    assert.match(failed.error.message, /could not read the msg: the configured resources: .*non-function/);
    assert.equal((await answer('c', { payload: 1 }, out, caught)).error.code, 'INVALID_INPUT', 'an expression that does not parse');
    assert.deepEqual(counts(), { holding: 0, queued: 0, faulted: 0 });
  });

  it('msgs whose values are read by JSONata queue in the order they came, however long each read takes', async function () {
    // Over a long array the expression resolves after the same one over a short array sent later.
    await helper.load(paletteNodes, flow([acquire('a', '', '$count(payload.$string())', 'YEL', 'out', { priorityType: 'jsonata' })]));
    const [out, caught] = ['out', 'caught'].map((id) => collect(helper, id));
    helper.getNode('a').receive({ operation: 'first', payload: Array.from({ length: 200 }, (_, i) => i) });
    helper.getNode('a').receive({ operation: 'second', payload: [] });
    await until(() => out.length + caught.length > 0 && counts().queued === 1, 'one granted, one queued');
    assert.deepEqual(out.map((m) => m.interlock.operation), ['first']);
    assert.equal(out[0].interlock.priority, 200);
    helper.getNode('rel').receive({ operation: 'first' });
    await until(() => out.length === 2, 'the second granted');
    assert.deepEqual(out[1].interlock, { operation: 'second', priority: 0, resources: ['YEL'], waitedMs: 0 });
    assert.equal(caught.length, 0);
  });

  it('the queue of held msgs keeps within nodeMessageBufferMaxLength, as the delay node\'s buffer does', async function () {
    settings({ nodeMessageBufferMaxLength: 2 });
    await helper.load(paletteNodes, flow([acquire('a', '', 0, 'YEL', 'out')], { queueBound: '1024' }));
    const [out, caught] = ['out', 'caught'].map((id) => collect(helper, id));
    await answer('a', { operation: 'holder' }, out, caught);
    for (const op of ['w1', 'w2']) helper.getNode('a').receive({ operation: op });
    await settled(helper, 'il');
    assert.deepEqual(counts(), { holding: 1, queued: 2, faulted: 0 });
    const refused = await answer('a', { operation: 'w3' }, out, caught);
    assert.equal(refused.error.code, 'QUEUE_FULL');
    assert.match(refused.error.message, /\b2\b/);
    assert.deepEqual(counts(), { holding: 1, queued: 2, faulted: 0 });
  });

  it('without the setting, the interlock\'s own queue bound holds', async function () {
    await helper.load(paletteNodes, flow([acquire('a', '', 0, 'YEL', 'out')], { queueBound: '3' }));
    const [out, caught] = ['out', 'caught'].map((id) => collect(helper, id));
    await answer('a', { operation: 'holder' }, out, caught);
    for (const op of ['w1', 'w2', 'w3']) helper.getNode('a').receive({ operation: op });
    await settled(helper, 'il');
    assert.deepEqual(counts(), { holding: 1, queued: 3, faulted: 0 });
    assert.equal((await answer('a', { operation: 'w4' }, out, caught)).error.code, 'QUEUE_FULL');
  });

  it('on an interlock bound to a plant too: a priority from global context, an operation from env, resources by JSONata', async function () {
    process.env.SUGARSHACK_TEST_OP = ' 77 ';
    const doc = { ...fakePlant([fakeValve('V101', 1, 'YEL'), fakeValve('V501', 5, 'RED'), fakePump('YEL')]), resources: [{ id: 'YEL' }, { id: 'RED' }], operations: [] };
    await helper.load(paletteNodes, [
      TAB, ...boundPlant(doc),
      acquire('a', 'SUGARSHACK_TEST_OP', 'urgency', 'payload.lines', 'out', { operationType: 'env', priorityType: 'global', resourcesType: 'jsonata' }),
      acquire('old', ' 5 ', '3', 'RED', 'out'),
      ...['out', 'caught', 'mqtt', 'ev', 'events'].map(sinkNode),
    ]);
    const [out, caught] = ['out', 'caught'].map((id) => collect(helper, id));
    helper.getNode('a').context().global.set('urgency', '8');
    assert.deepEqual((await answer('a', { payload: { lines: ['YEL'] } }, out, caught)).granted,
      { operation: '77', priority: 8, resources: ['YEL'], waitedMs: 0 });
    assert.deepEqual((await answer('old', {}, out, caught)).granted, { operation: '5', priority: 3, resources: ['RED'], waitedMs: 0 });
    helper.getNode('a').context().global.set('urgency', 1.5);
    const refused = await answer('a', { operation: '78', payload: { lines: 'RED' } }, out, caught);
    assert.equal(refused.error.code, 'INVALID_PRIORITY');
    assert.match(refused.error.message, /the configured priority must be a whole number.*1\.5/);
  });
});
