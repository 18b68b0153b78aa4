'use strict';
const assert = require('node:assert/strict');
const helper = require('node-red-node-test-helper');
const {
  paletteNodes, catchNode, linkNodes, lockoutOf, TAB, interlockConfig, acquire, release, sinkNode,
  collect, until, trackCompletions, trackDeliveries, untrackCompletions, startServer, stopServer, settings, settled, clock, userDir,
} = require('./support');

const { WINDOW_MS } = require('../../node-red-contrib-sugarshack/lib/host/status-pacer');

helper.init(require.resolve('node-red'));

const runtimeOf = () => helper.getNode('il').runtime;
const counts = () => runtimeOf().core.counts();
const snapshot = () => JSON.stringify(runtimeOf().core.snapshot(0));
const lastStatus = (id) => {
  const calls = helper.getNode(id).status.getCalls().filter((c) => c.thisValue.id === id);
  return calls.length ? calls[calls.length - 1].args[0] : undefined;
};

/**
 * Loads `nodes` with sinks 'out' and 'caught' and a Catch node of `scope` (all
 * nodes when null) wired to 'caught', then sends op 10's msg to node a10 and
 * waits for its grant; resolves with what the sinks got.
 */
async function grantingTen(scope, nodes) {
  await helper.load(paletteNodes, [
    ...nodes,
    { id: 'c1', z: 'f1', type: 'catch', scope, uncaught: false, wires: [['caught']] },
    sinkNode('out'), sinkNode('caught'),
  ]);
  const [out, caught] = ['out', 'caught'].map((id) => collect(helper, id));
  helper.getNode('a10').receive({});
  await until(() => out.length === 1, 'op 10 granted');
  return { out, caught };
}

describe('sugarshack interlock nodes', function () {
  beforeEach(startServer);

  afterEach(async function () {
    untrackCompletions();
    await stopServer();
  });

  const quiet = () => settled(helper, 'il');

  it('grants a free line at once and sends the same msg on with msg.interlock', async function () {
    await helper.load(paletteNodes, [TAB, interlockConfig(), acquire('a10', '10', 20, 'YEL', 'out'), sinkNode('out')]);
    const out = collect(helper, 'out');
    const msg = { payload: 'load truck', _linkSource: [{ id: 'x', node: 'caller' }] };
    helper.getNode('a10').receive(msg);
    await until(() => out.length === 1, 'the grant');
    assert.equal(out[0], msg, 'the very msg object that came in goes on');
    assert.deepEqual(out[0]._linkSource, [{ id: 'x', node: 'caller' }]);
    assert.equal(out[0].interlock.operation, '10');
    assert.equal(out[0].interlock.priority, 20);
    assert.deepEqual(out[0].interlock.resources, ['YEL']);
    assert.equal(out[0].interlock.waitedMs, 0);
    assert.deepEqual(counts(), { holding: 1, queued: 0, faulted: 0 });
    assert.deepEqual(lastStatus('a10'), { fill: 'green', shape: 'dot', text: 'held 1' });
  });

  it('queues a request for a held line and grants it on release', async function () {
    const completions = trackCompletions();
    await helper.load(paletteNodes, [
      TAB, interlockConfig(),
      acquire('a10', '10', 20, 'YEL', 'out10'), acquire('a12', '12', 22, 'YEL', 'out12'),
      release('rel', 'relout'),
      sinkNode('out10'), sinkNode('out12'), sinkNode('relout'),
    ]);
    const [out10, out12, relout] = ['out10', 'out12', 'relout'].map((id) => collect(helper, id));
    helper.getNode('a10').receive({ payload: 1 });
    await until(() => out10.length === 1, 'op 10 granted');
    const waiting = { payload: 2 };
    helper.getNode('a12').receive(waiting);
    await quiet();
    assert.equal(out12.length, 0, 'op 12 waits while YEL is held');
    assert.deepEqual(counts(), { holding: 1, queued: 1, faulted: 0 });
    assert.equal(completions.some((c) => c.msgid === waiting._msgid), false, 'a held msg is not done yet');
    assert.equal(lastStatus('a12').text, 'held 1 · queued 1');

    await clock().advance(40);
    helper.getNode('rel').receive(out10[0]); // release takes the op from msg.interlock.operation
    await until(() => out12.length === 1 && relout.length === 1, 'grant and release return');
    assert.equal(out12[0], waiting);
    assert.equal(out12[0].interlock.operation, '12');
    assert.equal(out12[0].interlock.waitedMs, 40);
    assert.equal(relout[0], out10[0], 'the release node sends its msg back on');
    assert.deepEqual(counts(), { holding: 1, queued: 0, faulted: 0 });
    await until(() => completions.some((c) => c.nodeId === 'a12' && c.msgid === waiting._msgid), 'done of op 12');
    assert.equal(completions.filter((c) => c.msgid === waiting._msgid && c.nodeId === 'a12').length, 1);
  });

  it('grants waiting operations in priority order, highest first', async function () {
    const ops = [['51', 1], ['10', 20], ['12', 22], ['11', 23]];
    await helper.load(paletteNodes, [
      TAB, interlockConfig(),
      acquire('a18', '18', 92, 'YEL', 'out'),
      ...ops.map(([op, prio]) => acquire(`a${op}`, op, prio, 'YEL', 'out')),
      release('rel'), sinkNode('out'),
    ]);
    const out = collect(helper, 'out');
    helper.getNode('a18').receive({});
    await until(() => out.length === 1, 'op 18 granted');
    for (const [op] of ops) helper.getNode(`a${op}`).receive({});
    await quiet();
    assert.equal(out.length, 1);
    assert.deepEqual(counts(), { holding: 1, queued: 4, faulted: 0 });
    for (let i = 0; i < 4; i++) {
      helper.getNode('rel').receive({ operation: out[out.length - 1].interlock.operation });
      await until(() => out.length === i + 2, `grant ${i + 1}`);
    }
    assert.deepEqual(out.map((m) => m.interlock.operation), ['18', '11', '12', '10', '51']);
  });

  it('sends every msg granted by one release from its own acquire node', async function () {
    await helper.load(paletteNodes, [
      TAB, interlockConfig(),
      acquire('a18', '18', 92, 'YEL,RED', 'out18'),
      acquire('a10', '10', 20, 'YEL', 'out10'),
      acquire('a51', '51', 1, 'RED', 'out51'),
      release('rel'),
      sinkNode('out18'), sinkNode('out10'), sinkNode('out51'),
    ]);
    const [out18, out10, out51] = ['out18', 'out10', 'out51'].map((id) => collect(helper, id));
    helper.getNode('a18').receive({ payload: 'flit downstock' });
    await until(() => out18.length === 1, 'op 18 granted');
    const m10 = { payload: 'load truck' };
    const m51 = { payload: 'drain silo' };
    helper.getNode('a10').receive(m10);
    helper.getNode('a51').receive(m51);
    await quiet();
    assert.equal(out10.length + out51.length, 0);
    helper.getNode('rel').receive({ operation: '18' });
    await until(() => out10.length === 1 && out51.length === 1, 'both grants');
    assert.equal(out10[0], m10);
    assert.equal(out51[0], m51);
    assert.deepEqual(out51[0].interlock.resources, ['RED']);
    assert.deepEqual(counts(), { holding: 2, queued: 0, faulted: 0 });
  });

  it('faults an operation: lockouts out, line blocked until cleared, then the queue resumes', async function () {
    await helper.load(paletteNodes, [
      TAB, interlockConfig(),
      acquire('a12', '12', 22, 'YEL', 'out12'), acquire('a10', '10', 20, 'YEL', 'out10'),
      { id: 'flt', z: 'f1', type: 'sugarshack-fault', interlock: 'il', mode: 'operation', operation: '', resources: '', wires: [['back'], ['lockout']] },
      { id: 'clr', z: 'f1', type: 'sugarshack-clear', interlock: 'il', mode: 'all', resources: '', wires: [['cleared']] },
      { id: 'ev', z: 'f1', type: 'sugarshack-interlock-events', interlock: 'il', wires: [['events']] },
      ...['out12', 'out10', 'back', 'lockout', 'cleared', 'events'].map(sinkNode),
    ]);
    const [out12, out10, back, lockout, cleared, events] =
      ['out12', 'out10', 'back', 'lockout', 'cleared', 'events'].map((id) => collect(helper, id));
    helper.getNode('a12').receive({ payload: 'unload truck' });
    await until(() => out12.length === 1, 'op 12 granted');

    // What a Catch node hands on: a clone of the operation's msg with msg.error.
    helper.getNode('flt').receive({ ...out12[0], error: { message: 'pump P1 ran dry' } });
    await until(() => back.length === 1 && lockout.length === 1, 'fault outputs');
    assert.deepEqual(back[0].interlock.operation, '12');
    assert.deepEqual(lockout[0].topic, 'lockout/YEL');
    assert.deepEqual(lockout[0].payload, lockoutOf('YEL'));
    assert.equal(lockout[0].resource, 'YEL');
    assert.equal(lockout[0].operation, '12');
    assert.equal(lockout[0].note, 'pump P1 ran dry');
    assert.equal(lockout[0].faultAtMs, clock().now(), 'lockouts carry the fault time');
    assert.deepEqual(counts(), { holding: 0, queued: 0, faulted: 1 });

    helper.getNode('a10').receive({ payload: 'load truck' });
    await quiet();
    assert.equal(out10.length, 0, 'a faulted line grants nobody');
    assert.deepEqual(counts(), { holding: 0, queued: 1, faulted: 1 });
    assert.deepEqual(lastStatus('a10'), { fill: 'red', shape: 'dot', text: 'flt 1 · q 1' });

    helper.getNode('clr').receive({ payload: 'operator cleared YEL' });
    await until(() => out10.length === 1 && cleared.length === 1, 'grant after clear');
    assert.deepEqual(cleared[0].cleared, ['YEL']);
    assert.equal(out10[0].interlock.operation, '10');
    assert.deepEqual(counts(), { holding: 1, queued: 0, faulted: 0 });

    await until(() => events.some((e) => e.topic === 'interlock/cleared'), 'cleared event');
    const kinds = events.map((e) => e.payload.kind);
    assert.deepEqual(kinds, ['granted', 'faulted', 'queued', 'cleared', 'granted']);
    assert.deepEqual(events.map((e) => e.topic), kinds.map((k) => `interlock/${k}`));
    assert.equal(events[1].payload.note, 'pump P1 ran dry');
  });

  it('an emergency stop faults resources directly and a dropped waiter completes unsent', async function () {
    const completions = trackCompletions();
    await helper.load(paletteNodes, [
      TAB, interlockConfig(),
      acquire('a18', '18', 92, 'YEL,RED', 'out'), acquire('a51', '51', 1, 'RED', 'out'),
      { id: 'estop', z: 'f1', type: 'sugarshack-fault', interlock: 'il', mode: 'resources', operation: '', resources: 'YEL', wires: [['back'], ['lockout']] },
      { id: 'flt', z: 'f1', type: 'sugarshack-fault', interlock: 'il', mode: 'operation', operation: '51', resources: '', wires: [['back'], ['lockout']] },
      sinkNode('out'), sinkNode('back'), sinkNode('lockout'),
    ]);
    const [out, back, lockout] = ['out', 'back', 'lockout'].map((id) => collect(helper, id));
    helper.getNode('a18').receive({});
    await until(() => out.length === 1, 'op 18 granted');
    const waiter = { payload: 'drain silo' };
    helper.getNode('a51').receive(waiter);
    await quiet();

    // Faulting the queued op 51 drops its request: its msg is done, never sent.
    helper.getNode('flt').receive({ payload: 'silo valve stuck' });
    await until(() => back.length === 1, 'fault returns');
    assert.equal(lockout.length, 0, 'nothing was latched for a waiting op');
    await until(() => completions.some((c) => c.nodeId === 'a51' && c.msgid === waiter._msgid), 'dropped msg done');
    assert.equal(completions.find((c) => c.msgid === waiter._msgid && c.nodeId === 'a51').error, undefined);

    // E-stop on YEL takes the whole of op 18 (YEL and RED): its line state is unknown.
    helper.getNode('estop').receive({ payload: 'e-stop button' });
    await until(() => lockout.length === 2, 'two lockouts');
    assert.deepEqual(lockout.map((m) => m.topic).sort(), ['lockout/RED', 'lockout/YEL']);
    assert.deepEqual(lockout.find((m) => m.resource === 'RED').payload, lockoutOf('RED'));
    assert.equal(lockout[0].operation, null);
    assert.equal(lockout[0].note, 'e-stop button');
    assert.deepEqual(counts(), { holding: 0, queued: 0, faulted: 2 });
    assert.equal(out.length, 1);
  });

  it('cancel withdraws a waiting request: the held msg completes unsent, the cancel msg goes on', async function () {
    const completions = trackCompletions();
    await helper.load(paletteNodes, [
      TAB, interlockConfig(),
      acquire('a10', '10', 20, 'YEL', 'out'), acquire('a12', '12', 22, 'YEL', 'out'),
      { id: 'can', z: 'f1', type: 'sugarshack-cancel', interlock: 'il', operation: '', wires: [['canout']] },
      release('rel'), sinkNode('out'), sinkNode('canout'),
    ]);
    const [out, canout] = ['out', 'canout'].map((id) => collect(helper, id));
    helper.getNode('a10').receive({});
    await until(() => out.length === 1, 'op 10 granted');
    const waiter = { payload: 'unload' };
    helper.getNode('a12').receive(waiter);
    await quiet();
    assert.equal(counts().queued, 1);

    helper.getNode('can').receive({ operation: 12 }); // numeric ids are accepted
    await until(() => canout.length === 1, 'cancel returns');
    await until(() => completions.some((c) => c.nodeId === 'a12' && c.msgid === waiter._msgid), 'withdrawn msg done');
    assert.deepEqual(counts(), { holding: 1, queued: 0, faulted: 0 });

    helper.getNode('rel').receive({ operation: '10' });
    await quiet();
    assert.equal(out.length, 1, 'the withdrawn request is not granted later');
    assert.deepEqual(counts(), { holding: 0, queued: 0, faulted: 0 });
  });

  it('refuses bad input through a Catch node with the core code, red ring, nothing sent, state unchanged', async function () {
    const { out, caught } = await grantingTen(null, [
      TAB, interlockConfig(),
      acquire('a10', '10', 20, 'YEL', 'out'),
      acquire('aBad', '', 5, '', 'out'),
      release('rel', 'out'),
      { id: 'can', z: 'f1', type: 'sugarshack-cancel', interlock: 'il', operation: '', wires: [['out']] },
      { id: 'clr', z: 'f1', type: 'sugarshack-clear', interlock: 'il', mode: 'resources', resources: '', wires: [['out']] },
    ]);
    const before = snapshot();

    const cases = [
      ['aBad', { operation: '20', resources: ['YEL', 'BLK'] }, 'UNKNOWN_RESOURCE', /unknown resource 'BLK'/, 'unknown resource'],
      ['aBad', { resources: 'YEL' }, 'MISSING_OPERATION', /operation id is required/, 'no operation id'],
      ['a10', {}, 'ALREADY_HOLDING', /'10' already holds/, 'already holding'],
      ['aBad', { operation: '21', priority: 'urgent', resources: 'GRN' }, 'INVALID_PRIORITY', /whole number/, 'bad priority'],
      ['aBad', { operation: '21', resources: 'GRN', priority: 1.5 }, 'INVALID_PRIORITY', /whole number/, 'bad priority'],
      ['aBad', { operation: '22' }, 'EMPTY_RESOURCE_SET', /names no resource/, 'no resources'],
      ['rel', { operation: '12' }, 'NOT_HOLDING', /'12' holds nothing/, 'holds nothing'],
      ['can', { operation: '10' }, 'NOT_QUEUED', /not waiting/, 'not queued'],
      ['clr', { resources: 'YEL' }, 'NOT_FAULTED', /'YEL' is not faulted/, 'not faulted'],
    ];
    for (const [nodeId, msg, code, message, reason] of cases) {
      const n = caught.length;
      helper.getNode(nodeId).receive({ payload: 'bad', ...msg });
      await until(() => caught.length === n + 1, `the ${code} error`);
      const { error } = caught[n];
      assert.equal(error.code, code, `${nodeId} ${JSON.stringify(msg)}`);
      assert.match(error.message, message);
      assert.equal(error.source.id, nodeId);
      assert.deepEqual(lastStatus(nodeId), { fill: 'red', shape: 'ring', text: reason });
      assert.equal(snapshot(), before, `state unchanged after ${code}`);
    }
    // A release of an op that holds nothing: known op, nothing held.
    helper.getNode('rel').receive({ operation: '10' });
    await until(() => out.length === 2, 'release');
    helper.getNode('rel').receive({ operation: '10' });
    await until(() => caught.length === cases.length + 1, 'NOT_HOLDING');
    assert.equal(caught[cases.length].error.code, 'NOT_HOLDING');
    assert.equal(out.length, 2, 'refused msgs are never sent');
  });

  it('works through link call: a queued acquire returns to the calling link call', async function () {
    await helper.load([...paletteNodes, linkNodes], [
      TAB, interlockConfig(),
      acquire('a18', '18', 92, 'YEL', 'out18'),
      { id: 'call', z: 'f1', type: 'link call', links: ['lin'], linkType: 'static', timeout: '5', wires: [['returned']] },
      { id: 'lin', z: 'f1', type: 'link in', name: 'op 12', links: [], wires: [['a12']] },
      acquire('a12', '12', 22, 'YEL', null, { wires: [['inside', 'lout']] }),
      { id: 'lout', z: 'f1', type: 'link out', mode: 'return', links: [], wires: [] },
      release('rel'),
      sinkNode('out18'), sinkNode('inside'), sinkNode('returned'),
    ]);
    const [out18, inside, returned] = ['out18', 'inside', 'returned'].map((id) => collect(helper, id));
    helper.getNode('a18').receive({});
    await until(() => out18.length === 1, 'op 18 granted');

    const call = { payload: 'unload truck', topic: 'op12' };
    helper.getNode('call').receive(call);
    await quiet();
    assert.equal(returned.length + inside.length, 0, 'queued behind op 18');
    helper.getNode('rel').receive({ operation: '18' });
    await until(() => returned.length === 1, 'the link call return');
    assert.equal(inside.length, 1);
    assert.equal(inside[0]._msgid, call._msgid);
    assert.equal(inside[0]._linkSource.length, 1, 'msg._linkSource intact after the wait');
    assert.equal(inside[0]._linkSource[0].node, 'call');
    assert.equal(returned[0]._msgid, call._msgid);
    assert.equal(returned[0].payload, 'unload truck');
    assert.equal(returned[0].interlock.operation, '12');
    assert.equal(returned[0]._linkSource, undefined, 'link call consumed its return address');
  });

  it('an acquire timeout withdraws the request and reaches a Catch node', async function () {
    const { out, caught } = await grantingTen(['a12'], [
      TAB, interlockConfig(),
      acquire('a10', '10', 20, 'YEL', 'out'),
      acquire('a12', '12', 22, 'YEL', 'out', { timeout: 0.15 }),
      release('rel'),
    ]);
    helper.getNode('a12').receive({ payload: 'unload' });
    await quiet();
    await clock().advance(149);
    assert.equal(caught.length, 0, 'still waiting 1 ms before its timeout');
    await clock().advance(1);
    await until(() => caught.length === 1, 'timeout error');
    assert.equal(caught[0].error.code, 'ACQUIRE_TIMEOUT');
    assert.match(caught[0].error.message, /operation '12' was not granted YEL within 0.15 s/);
    assert.equal(caught[0].payload, 'unload');
    assert.deepEqual(counts(), { holding: 1, queued: 0, faulted: 0 });
    assert.equal(lastStatus('a12').text, 'timed out');
    helper.getNode('rel').receive({ operation: '10' });
    await quiet();
    assert.equal(out.length, 1, 'the timed-out request is not granted');
  });

  it('a deploy that removes a line a request waits for refuses that request (a Catch node gets it), never drops it', async function () {
    const lines = (names) => names.map((name) => ({ name, lockout: '' }));
    const flow = (names) => [
      TAB, interlockConfig({ resources: lines(names) }), acquire('a', '', 0, '', 'out'),
      { id: 'c1', z: 'f1', type: 'catch', scope: null, uncaught: false, wires: [['caught']] }, sinkNode('out'), sinkNode('caught'),
    ];
    await helper.load(paletteNodes, flow(['YEL', 'GRN']));
    const out = collect(helper, 'out');
    helper.getNode('a').receive({ operation: 'holder', resources: 'YEL' });
    await until(() => out.length === 1, 'the holder granted');
    helper.getNode('a').receive({ operation: 'waiter', resources: 'YEL, GRN' });
    await settled(helper, 'il');
    assert.equal(counts().queued, 1);
    // The Catch node of the new flows gets it: what reaches a node is followed across the deploy.
    const delivered = trackDeliveries();
    await helper.setFlows(flow(['YEL']), 'full');
    await until(() => delivered.some((d) => d.nodeId === 'caught'), 'the waiter refused');
    const refused = delivered.find((d) => d.nodeId === 'caught').msg;
    assert.deepEqual([refused.operation, refused.error.code], ['waiter', 'UNKNOWN_RESOURCE']);
    assert.equal(runtimeOf().carrier.held.size, 0, 'nothing held for it any more');
    assert.deepEqual(counts(), { holding: 1, queued: 0, faulted: 0 });
  });

  it('an invalid configuration shows "config error" and fails every msg', async function () {
    await helper.load(paletteNodes, [
      TAB, interlockConfig({ resources: [{ name: 'YEL', lockout: '{"valves": ' }] }),
      acquire('a10', '10', 20, 'YEL', 'out'), release('rel', 'out'),
      { id: 'c1', z: 'f1', type: 'catch', scope: null, uncaught: false, wires: [['caught']] },
      sinkNode('out'), sinkNode('caught'),
    ]);
    const [out, caught] = ['out', 'caught'].map((id) => collect(helper, id));
    const logged = helper.getNode('il').error.getCalls().filter((c) => c.thisValue.id === 'il').map((c) => String(c.args[0]));
    assert.ok(logged.some((m) => /lockout command of resource 'YEL' is not valid JSON/.test(m)), logged.join('; '));
    assert.deepEqual(lastStatus('a10'), { fill: 'red', shape: 'ring', text: 'config error' });
    assert.deepEqual(lastStatus('rel'), { fill: 'red', shape: 'ring', text: 'config error' });
    helper.getNode('a10').receive({});
    helper.getNode('rel').receive({ operation: '10' });
    await until(() => caught.length === 2, 'two errors');
    assert.deepEqual(caught.map((m) => m.error.code), ['INVALID_CONFIG', 'INVALID_CONFIG']);
    assert.equal(out.length, 0);
  });

  it('the core refuses a configuration without resources', async function () {
    await helper.load(paletteNodes, [TAB, interlockConfig({ resources: [] }), acquire('a10', '10', 20, 'YEL', 'out'), sinkNode('out')]);
    const logged = helper.getNode('il').error.getCalls().filter((c) => c.thisValue.id === 'il').map((c) => String(c.args[0]));
    assert.ok(logged.some((m) => /no resources are configured/.test(m)), logged.join('; '));
    assert.equal(runtimeOf().failure.code, 'INVALID_CONFIG');
    assert.deepEqual(lastStatus('a10'), { fill: 'red', shape: 'ring', text: 'config error' });
  });

  it('warns about long waits through the events node', async function () {
    await helper.load(paletteNodes, [
      TAB, interlockConfig({ warnQueued: '0.2' }),
      acquire('a10', '10', 20, 'YEL', 'out'), acquire('a12', '12', 22, 'YEL', 'out'),
      { id: 'ev', z: 'f1', type: 'sugarshack-interlock-events', interlock: 'il', wires: [['events']] },
      sinkNode('out'), sinkNode('events'),
    ]);
    const events = collect(helper, 'events');
    helper.getNode('a10').receive({});
    helper.getNode('a12').receive({});
    await quiet();
    await clock().advance(999);
    await quiet();
    assert.equal(events.some((e) => e.topic === 'interlock/warn-queued'), false, 'checked once a second');
    await clock().advance(1);
    await until(() => events.some((e) => e.topic === 'interlock/warn-queued'), 'warn-queued');
    const warning = events.find((e) => e.topic === 'interlock/warn-queued').payload;
    assert.equal(warning.operation, '12');
    assert.equal(warning.waitedMs, 1000);
    // The same long wait is an alarm, worded by the core.
    await until(() => runtimeOf().describe().alarms.some((a) => a.id === 'waiting-long:12'), 'the waiting-long alarm');
    const alarm = runtimeOf().describe().alarms.find((a) => a.id === 'waiting-long:12');
    assert.equal(alarm.text, 'op 12 waiting for YEL for 1 s');
    assert.equal(alarm.state, 'active-unacknowledged');
    const warned = helper.getNode('il').warn.getCalls().filter((c) => c.thisValue.id === 'il').map((c) => c.args[0]);
    assert.ok(warned.some((w) => /operation '12' has waited \d+ s for YEL/.test(w)), warned.join('; '));
  });

  /** Ops 10 and 12 on YEL, a release, an e-stop of RED and its clear: one of each kind of event. */
  const eventFlow = (...extra) => [
    TAB, interlockConfig(),
    acquire('a10', '10', 20, 'YEL', 'out'), acquire('a12', '12', 22, 'YEL', 'out'),
    { id: 'rel', z: 'f1', type: 'sugarshack-release', interlock: 'il', wires: [['out']] },
    { id: 'estop', z: 'f1', type: 'sugarshack-fault', interlock: 'il', mode: 'resources', operation: '', resources: 'RED', wires: [[], []] },
    { id: 'clr', z: 'f1', type: 'sugarshack-clear', interlock: 'il', mode: 'resources', resources: 'RED', wires: [[]] },
    sinkNode('out'),
    ...extra,
  ];

  it('gives each event one readable line in msg.summary, for a debug node set to show it', async function () {
    await helper.load(paletteNodes, eventFlow(
      { id: 'ev', z: 'f1', type: 'sugarshack-interlock-events', interlock: 'il', wires: [['events']] },
      sinkNode('events'),
    ));
    const events = collect(helper, 'events');
    helper.getNode('a10').receive({});
    helper.getNode('a12').receive({});
    await until(() => events.length === 2, 'granted and queued');
    await clock().advance(31000);
    helper.getNode('rel').receive({ operation: '10' });
    await until(() => events.some((e) => e.payload.kind === 'granted' && e.payload.operation === '12'), 'op 12 granted');
    helper.getNode('estop').receive({ by: 'ana', reason: 'leak' });
    await until(() => events.some((e) => e.payload.kind === 'resource-faulted'), 'the e-stop');
    // A signed-in dashboard user outranks msg.by: a page cannot clear under another name.
    helper.getNode('clr').receive({ by: 'ana', reason: 'fixed', _client: { user: { username: 'bo' } } });
    await until(() => events.some((e) => e.payload.kind === 'cleared'), 'the clear');
    assert.deepEqual(events.map((e) => e.summary), [
      'granted 10 (YEL)',
      'queued 12 (YEL), prio 22',
      'released 10 (YEL) after 31 s',
      'granted 12 (YEL) after 31 s',
      'e-stop RED by ana: leak',
      'cleared RED by bo: fixed',
    ]);
  });

  it('keeps the abnormal events for the alarms when no events node listens, and not the grants of normal work', async function () {
    await helper.load(paletteNodes, eventFlow());
    helper.getNode('a10').receive({});
    helper.getNode('a12').receive({});
    helper.getNode('rel').receive({ operation: '10' });
    helper.getNode('estop').receive({ by: 'ana', reason: 'leak' });
    await quiet();
    helper.getNode('clr').receive({ by: 'bo', reason: 'fixed' });
    await quiet();
    assert.deepEqual(runtimeOf().describe().recentEvents.map((e) => [e.kind, e.summary]), [
      ['resource-faulted', 'e-stop RED by ana: leak'],
      ['cleared', 'cleared RED by bo: fixed'],
    ]);
  });

  it('keeps every status text under 20 characters, even with a long queue', async function () {
    const ops = Array.from({ length: 120 }, (_, i) => `op${i}`);
    await helper.load(paletteNodes, [
      TAB, interlockConfig(),
      acquire('a', '', 0, 'YEL', 'out'),
      { id: 'estop', z: 'f1', type: 'sugarshack-fault', interlock: 'il', mode: 'resources', operation: '', resources: 'RED', wires: [[], []] },
      sinkNode('out'),
    ]);
    helper.getNode('estop').receive({});
    for (const op of ops) helper.getNode('a').receive({ operation: op, priority: 1 });
    await until(() => counts().queued === ops.length - 1, 'the queue');
    // Statuses are paced: the last state shows once the window ends.
    await clock().advance(WINDOW_MS);
    const texts = helper.getNode('a').status.getCalls().map((c) => c.args[0].text);
    assert.ok(texts.length < ops.length, `${texts.length} statuses for ${ops.length} changes: not paced`);
    assert.equal(texts[texts.length - 1], 'flt 1·hld 1·q 119');
    for (const text of texts) assert.ok(text.length < 20, `"${text}" is ${text.length} characters`);
  });

  it('completes every held msg (done) without sending it when the flows stop', async function () {
    const completions = trackCompletions();
    await helper.load(paletteNodes, [
      TAB, interlockConfig(),
      acquire('a10', '10', 20, 'YEL', 'out'), acquire('a12', '12', 22, 'YEL', 'out'), acquire('a11', '11', 23, 'YEL', 'out'),
      sinkNode('out'),
    ]);
    const out = collect(helper, 'out');
    helper.getNode('a10').receive({});
    await until(() => out.length === 1, 'op 10 granted');
    const held = [{ payload: 12 }, { payload: 11 }];
    helper.getNode('a12').receive(held[0]);
    helper.getNode('a11').receive(held[1]);
    await until(() => counts().queued === 2, 'two waiting');
    await helper.unload();
    for (const msg of held) {
      const done = completions.filter((c) => c.msgid === msg._msgid);
      assert.equal(done.length, 1, `msg ${msg.payload} done once`);
      assert.equal(done[0].error, undefined);
    }
    assert.equal(out.length, 1, 'nothing sent while stopping');
  });
});
