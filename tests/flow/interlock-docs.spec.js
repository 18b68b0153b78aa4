'use strict';
// Six places where an independent model of the documented interlock rules once
// disagreed with the nodes. Each test drives the nodes and asserts what the
// docs say: the fault node's help (the note), the README's refusals, the
// interlock's and the cancel node's help (unknown operations), the events
// help (events leave once saved) and "Status texts" (a lost state's status).
const assert = require('node:assert/strict');
const fs = require('fs');
const path = require('path');
const helper = require('node-red-node-test-helper');
const {
  paletteNodes, TAB, interlockConfig, acquire, release, sinkNode, collect, until, startServer, stopServer, settled, userDir,
} = require('./support');

helper.init(require.resolve('node-red'));

const runtimeOf = () => helper.getNode('il').runtime;
const snapshot = () => runtimeOf().core.snapshot(0);
const lineOf = (name) => snapshot().resources.find((r) => r.name === name).state;
const quiet = () => settled(helper, 'il');
const lastStatus = (id) => {
  const calls = helper.getNode(id).status.getCalls().filter((c) => c.thisValue.id === id);
  return calls.length ? calls[calls.length - 1].args[0] : undefined;
};
const stateFile = () => path.join(userDir(), 'sugarshack', 'interlock-il.json');

const estop = (id, line) => ({
  id, z: 'f1', type: 'sugarshack-fault', interlock: 'il', mode: 'resources', operation: '', resources: line, wires: [['back'], ['lockout']],
});
const faultOp = { id: 'flt', z: 'f1', type: 'sugarshack-fault', interlock: 'il', mode: 'operation', operation: '', resources: '', wires: [['back'], ['lockout']] };
const cancel = { id: 'can', z: 'f1', type: 'sugarshack-cancel', interlock: 'il', operation: '', wires: [['cancelled']] };
const clear = { id: 'clr', z: 'f1', type: 'sugarshack-clear', interlock: 'il', mode: 'resources', resources: '', wires: [['cleared']] };
const eventsNode = { id: 'ev', z: 'f1', type: 'sugarshack-interlock-events', interlock: 'il', wires: [['events']] };
const catchAll = { id: 'c1', z: 'f1', type: 'catch', scope: null, uncaught: false, wires: [['caught']] };

function flow(config = {}, extra = []) {
  return [
    TAB, interlockConfig(config),
    acquire('a10', '10', 20, 'YEL', 'out'), acquire('a12', '12', 22, 'YEL', 'out'), acquire('any', '', 5, '', 'out'),
    release('rel', 'out'), estop('stopGRN', 'GRN'), faultOp, cancel, clear, eventsNode, catchAll,
    ...['out', 'back', 'lockout', 'cancelled', 'cleared', 'events', 'caught'].map(sinkNode),
    ...extra,
  ];
}

/** Sends `msg` to node `id` and waits for the Catch node's error; resolves with its code and message. */
async function refusal(caught, id, msg) {
  const n = caught.length;
  helper.getNode(id).receive(msg);
  await until(() => caught.length > n, `an error from ${id}`);
  return { code: caught[n].error.code, message: caught[n].error.message };
}

describe('the interlock does what its docs say', function () {
  beforeEach(startServer);
  afterEach(stopServer);

  it('an e-stop keeps msg.error.message as the fault note (fault help), with msg.reason recorded beside it', async function () {
    await helper.load(paletteNodes, flow());
    const [lockout, events] = ['lockout', 'events'].map((id) => collect(helper, id));
    helper.getNode('stopGRN').receive({ error: { message: 'pressure switch PS-4 tripped' }, reason: 'foam in the pan', by: 'ana', payload: 'E-STOP' });
    await until(() => lockout.length === 1 && events.length === 1, 'the lockout and its event');
    assert.equal(lineOf('GRN').note, 'pressure switch PS-4 tripped');
    assert.equal(lockout[0].note, 'pressure switch PS-4 tripped');
    assert.deepEqual([events[0].payload.kind, events[0].payload.note, events[0].payload.reason, events[0].payload.by],
      ['resource-faulted', 'pressure switch PS-4 tripped', 'foam in the pan', 'ana']);
    // Without an error, the operator's reason is the note; without either, a text payload.
    helper.getNode('clr').receive({ resources: 'GRN', force: true });
    await until(() => lineOf('GRN').state === 'free', 'GRN cleared');
    helper.getNode('stopGRN').receive({ reason: 'foam in the pan', payload: 'E-STOP' });
    await until(() => lineOf('GRN').state === 'faulted', 'GRN e-stopped again');
    assert.equal(lineOf('GRN').note, 'foam in the pan');
    helper.getNode('clr').receive({ resources: 'GRN', force: true });
    await until(() => lineOf('GRN').state === 'free', 'GRN cleared again');
    helper.getNode('stopGRN').receive({ payload: 'E-STOP' });
    await until(() => lineOf('GRN').state === 'faulted', 'GRN e-stopped a third time');
    assert.equal(lineOf('GRN').note, 'E-STOP');
  });

  it('an acquire refused with UNKNOWN_RESOURCE or QUEUE_FULL changes nothing: a fault of its id is UNKNOWN_OPERATION (README, interlock help)', async function () {
    await helper.load(paletteNodes, flow({ queueBound: '1' }));
    const [out, back, caught] = ['out', 'back', 'caught'].map((id) => collect(helper, id));
    helper.getNode('a10').receive({});
    helper.getNode('a12').receive({});
    await until(() => out.length === 1, 'op 10 granted');
    await quiet();
    const before = JSON.stringify(snapshot());
    assert.equal((await refusal(caught, 'any', { operation: 'blk-op', resources: 'BLK' })).code, 'UNKNOWN_RESOURCE');
    assert.equal((await refusal(caught, 'any', { operation: 'late-op', resources: 'YEL' })).code, 'QUEUE_FULL');
    for (const operation of ['blk-op', 'late-op']) {
      const { code, message } = await refusal(caught, 'flt', { operation });
      assert.equal(code, 'UNKNOWN_OPERATION', operation);
      assert.match(message, new RegExp(`unknown operation '${operation}': it neither holds, waits for, nor faulted lines`));
    }
    await quiet();
    assert.equal(back.length, 0, 'no refused fault sends its msg on');
    assert.equal(JSON.stringify(snapshot()), before, 'the interlock did not change');
  });

  it('cancel of an id that is not waiting (never seen, or released) is NOT_QUEUED; a fault of it is UNKNOWN_OPERATION (cancel and interlock help)', async function () {
    await helper.load(paletteNodes, flow());
    const [out, caught] = ['out', 'caught'].map((id) => collect(helper, id));
    helper.getNode('a10').receive({});
    await until(() => out.length === 1, 'op 10 granted');
    helper.getNode('rel').receive({ operation: '10' });
    await until(() => out.length === 2, 'op 10 released');
    for (const operation of ['ghost', '10']) {
      assert.equal((await refusal(caught, 'can', { operation })).code, 'NOT_QUEUED', `cancel ${operation}`);
      assert.equal((await refusal(caught, 'flt', { operation })).code, 'UNKNOWN_OPERATION', `fault ${operation}`);
    }
  });

  it('an operation that released is unknown to a fault the same way before a restart, after it and after a redeploy', async function () {
    const f = flow({ persist: true });
    await helper.load(paletteNodes, f);
    let [out, caught] = ['out', 'caught'].map((id) => collect(helper, id));
    helper.getNode('a10').receive({});
    await until(() => out.length === 1, 'op 10 granted');
    helper.getNode('rel').receive({ operation: '10' });
    await until(() => out.length === 2, 'op 10 released');
    helper.getNode('a12').receive({});
    await until(() => out.length === 3, 'op 12 granted');
    await quiet();
    assert.equal((await refusal(caught, 'flt', { operation: '10' })).code, 'UNKNOWN_OPERATION', 'before the restart');

    await helper.unload();
    await helper.load(paletteNodes, f);
    [out, caught] = ['out', 'caught'].map((id) => collect(helper, id));
    await quiet();
    assert.equal((await refusal(caught, 'flt', { operation: '10' })).code, 'UNKNOWN_OPERATION', 'after the restart');
    // Op 12 held YEL at the restart: its line came back faulted under it, so it is known, and a fault re-sends its lockout.
    const lockout = collect(helper, 'lockout');
    helper.getNode('flt').receive({ operation: '12' });
    await until(() => lockout.length === 1, 'op 12 faulted again');
    assert.equal(lockout[0].topic, 'lockout/YEL');

    await helper.setFlows(f.map((n) => (n.id === 'il' ? { ...n, policy: 'no-overtaking' } : n)), 'full');
    await until(() => runtimeOf().gateOpen && runtimeOf().config.policy === 'no-overtaking', 'the new settings');
    caught = collect(helper, 'caught');
    assert.equal((await refusal(caught, 'flt', { operation: '10' })).code, 'UNKNOWN_OPERATION', 'after a redeploy');
  });

  it('a deploy that removes a waiting acquire node sends its cancelled event as soon as the withdrawal is saved (events help)', async function () {
    const f = flow({ persist: true });
    await helper.load(paletteNodes, f);
    const [out, events] = ['out', 'events'].map((id) => collect(helper, id));
    helper.getNode('a10').receive({});
    await until(() => out.length === 1, 'op 10 granted');
    helper.getNode('a12').receive({});
    await quiet();
    assert.deepEqual(snapshot().queue.map((q) => q.operation), ['12']);
    const seen = events.length;
    await helper.setFlows(f.filter((n) => n.id !== 'a12'), 'nodes');
    // Nothing else happens: YEL stays held, so the withdrawal grants nobody.
    await until(() => events.length > seen, 'the cancelled event');
    assert.deepEqual(events.slice(seen).map((e) => [e.payload.kind, e.payload.operation]), [['cancelled', '12']]);
    const saved = JSON.parse(fs.readFileSync(stateFile(), 'utf8'));
    assert.deepEqual(saved.state.interlock.queue, [], 'the saved state no longer has it');
  });

  it('after a lost state the status takes short forms, then letters, beside "lost", never cut (Status texts)', async function () {
    const f = flow({ persist: true });
    await helper.load(paletteNodes, f);
    await quiet();
    await helper.unload();
    fs.rmSync(stateFile());
    await helper.load(paletteNodes, f);
    const out = collect(helper, 'out');
    await quiet();
    const shown = [lastStatus('a10').text];
    helper.getNode('clr').receive({ resources: 'GRN,BLU', force: true });
    await until(() => lineOf('BLU').state === 'free', 'two lines cleared');
    await quiet();
    shown.push(lastStatus('a10').text);
    helper.getNode('any').receive({ operation: 'g', resources: 'GRN' });
    await until(() => out.length === 1, 'GRN granted');
    await quiet();
    shown.push(lastStatus('a10').text);
    helper.getNode('any').receive({ operation: 'q', resources: 'GRN' });
    await quiet();
    shown.push(lastStatus('a10').text);
    assert.deepEqual(shown, ['lost · faulted 5', 'lost · faulted 3', 'lost · flt 3·hld 1', 'lost · F3 H1 Q1']);
    assert.ok(shown.every((text) => text.length < 20 && !text.includes('…')));
  });
});
