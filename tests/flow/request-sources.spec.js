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
  paletteNodes, TAB, interlockConfig, acquire, release, sinkNode, collect, until, startServer, stopServer, settings, settled, onInterlock,
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

// The release, cancel, fault and clear nodes' own values, read the same ways.
const cancel = (id, operation, extra = {}) => ({ id, z: 'f1', type: 'sugarshack-cancel', interlock: 'il', operation, wires: [['done']], ...extra });
const fault = (id, mode, value, extra = {}) => ({
  id, z: 'f1', type: 'sugarshack-fault', interlock: 'il', mode, operation: mode === 'operation' ? value : '', resources: mode === 'resources' ? value : '',
  after: 'send', wires: [['done'], ['lockouts']], ...extra,
});
const clear = (id, resources, extra = {}) => ({ id, z: 'f1', type: 'sugarshack-clear', interlock: 'il', mode: 'resources', resources, wires: [['done'], []], ...extra });

describe('sugarshack release, cancel, fault and clear: values from msg, flow, global, env or JSONata', function () {
  beforeEach(startServer);
  afterEach(async function () {
    delete process.env.SUGARSHACK_TEST_OP;
    delete process.env.SUGARSHACK_TEST_LINES;
    await stopServer();
  });

  /** Loads `nodes` beside acquire `a` (on YEL, its operation from the msg); `send` waits for the interlock to settle. */
  async function load(nodes) {
    await helper.load(paletteNodes, [TAB, interlockConfig(), acquire('a', '', 0, 'YEL', 'out'), ...nodes, catchAll, ...['out', 'done', 'lockouts', 'caught'].map(sinkNode)]);
    const [out, done, lockouts, caught] = ['out', 'done', 'lockouts', 'caught'].map((id) => collect(helper, id));
    const send = async (id, msg) => {
      helper.getNode(id).receive(msg);
      await settled(helper, 'il');
    };
    const faulted = () => helper.getNode('il').runtime.core.faultedResources();
    return { out, done, lockouts, caught, send, faulted };
  }

  it('a release whose operation comes from flow context releases that operation; msg.operation first; literals as before', async function () {
    const { out, done, send } = await load([
      acquire('b', '', 0, 'GRN', 'out'),
      release('rel', 'done', { operation: 'op', operationType: 'flow' }),
      release('typed', 'done', { operation: ' 12 ', operationType: 'str' }),
      release('old', 'done', { operation: 'op' }),
    ]);
    helper.getNode('rel').context().flow.set('op', '10');
    await send('a', { operation: '10' });
    await send('b', { operation: '11' });
    assert.deepEqual(counts(), { holding: 2, queued: 0, faulted: 0 });
    // msg.operation comes before the node's: op 11 goes, op 10 stays.
    await send('rel', { operation: '11' });
    assert.deepEqual(counts(), { holding: 1, queued: 0, faulted: 0 });
    await send('b', { operation: '13' });
    await send('rel', {});
    assert.deepEqual(counts(), { holding: 1, queued: 0, faulted: 0 }, 'op 10 released, op 13 holds');
    await send('a', { operation: '12' });
    await send('typed', {});
    // A flow saved before the types: "op" is the operation's id as typed, not a context key.
    await send('a', { operation: 'op' });
    await send('old', {});
    assert.deepEqual(counts(), { holding: 1, queued: 0, faulted: 0 });
    assert.deepEqual(out.map((m) => m.interlock.operation), ['10', '11', '13', '12', 'op']);
    assert.equal(done.length, 4);
  });

  it('a cancel whose operation comes from env withdraws that request; msg.operation first', async function () {
    process.env.SUGARSHACK_TEST_OP = ' 12 ';
    const { out, send } = await load([cancel('can', 'SUGARSHACK_TEST_OP', { operationType: 'env' })]);
    await send('a', { operation: '10' });
    for (const operation of ['12', '13']) await send('a', { operation });
    assert.deepEqual(counts(), { holding: 1, queued: 2, faulted: 0 });
    await send('can', { operation: '13' });
    assert.deepEqual(counts(), { holding: 1, queued: 1, faulted: 0 });
    await send('can', {});
    assert.deepEqual(counts(), { holding: 1, queued: 0, faulted: 0 });
    assert.deepEqual(out.map((m) => m.interlock.operation), ['10'], 'the withdrawn requests were never granted');
  });

  it('a fault whose operation comes from JSONata faults its lines; an e-stop\'s lines from JSONata; msg first; a literal as before', async function () {
    const { send, faulted, lockouts } = await load([
      fault('flt', 'operation', '"op-" & payload.n', { operationType: 'jsonata' }),
      fault('stop', 'resources', 'payload.lines', { resourcesType: 'jsonata' }),
      fault('old', 'resources', 'payload'),
    ]);
    await send('a', { operation: 'op-7' });
    await send('flt', { payload: { n: 7 } });
    assert.deepEqual(faulted(), ['YEL']);
    await send('stop', { payload: { lines: ['BLU', ' RED '] } });
    assert.deepEqual(faulted(), ['YEL', 'BLU', 'RED']);
    await send('stop', { resources: 'PUR', payload: { lines: ['GRN'] } });
    assert.deepEqual(faulted(), ['YEL', 'BLU', 'PUR', 'RED'], 'msg.resources first');
    // A flow saved before the types: "payload" is a line's name as typed, which the interlock does not know.
    await send('old', { payload: 'GRN' });
    assert.deepEqual(faulted(), ['YEL', 'BLU', 'PUR', 'RED']);
    assert.deepEqual(lockouts.map((m) => m.topic), ['lockout/YEL', 'lockout/BLU', 'lockout/RED', 'lockout/PUR']);
  });

  it('a clear whose lines come from env clears those; msg.resources first; a literal as before', async function () {
    process.env.SUGARSHACK_TEST_LINES = 'BLU, RED';
    const { send, faulted } = await load([
      fault('stop', 'resources', 'YEL,GRN,BLU,PUR,RED'),
      clear('clr', 'SUGARSHACK_TEST_LINES', { resourcesType: 'env' }),
      clear('old', 'GRN'),
    ]);
    await send('stop', {});
    assert.deepEqual(faulted(), ['YEL', 'GRN', 'BLU', 'PUR', 'RED']);
    await send('clr', { resources: ['PUR'] });
    assert.deepEqual(faulted(), ['YEL', 'GRN', 'BLU', 'RED'], 'msg.resources first');
    await send('clr', {});
    assert.deepEqual(faulted(), ['YEL', 'GRN']);
    await send('old', {});
    assert.deepEqual(faulted(), ['YEL']);
  });

  it('a value JSONata cannot read completes the msg with INVALID_INPUT and a red status, for each node', async function () {
    const nodes = [
      release('rel', 'done', { operation: '$notAFunction(payload)', operationType: 'jsonata' }),
      cancel('can', '$join([', { operationType: 'jsonata' }),
      fault('flt', 'operation', '$notAFunction(payload)', { operationType: 'jsonata' }),
      fault('stop', 'resources', '$join([', { resourcesType: 'jsonata' }),
      clear('clr', '$notAFunction(payload)', { resourcesType: 'jsonata' }),
    ];
    const { done, caught } = await load(nodes);
    const { statusOf } = onInterlock(helper);
    for (const { id } of nodes) {
      const before = caught.length;
      helper.getNode(id).receive({ payload: 1 });
      await until(() => caught.length > before, `${id} refused`);
      assert.equal(caught[before].error.code, 'INVALID_INPUT', id);
      assert.match(caught[before].error.message, /could not read the msg: the configured (operation|resources): /, id);
      assert.deepEqual(statusOf(id), { fill: 'red', shape: 'ring', text: 'invalid input' }, id);
    }
    assert.equal(done.length, 0);
    assert.deepEqual(counts(), { holding: 0, queued: 0, faulted: 0 });
  });
});
