'use strict';
// An operator's ISA-88 commands (hold, restart, stop, abort, reset) to a
// running operation, through each surface that carries them: the editor's
// POST /sugarshack/runs/command, the palette API's command (OPC UA's methods
// call it) and the plant state node's topics. The core decides; each surface
// only carries the command and its refusal, coded. A fake panel that obeys
// commands and the manual clock.
const assert = require('node:assert/strict');
const helper = require('node-red-node-test-helper');
const {
  paletteNodes, TAB, sinkNode, collect, serverPerTest, runFor, runUntil, until, completions,
} = require('./support');
const { fakePanel, sensor, stopPanels, fakePlant, fakeValve, fakePump } = require('./fake-panel');
const { paletteApi } = require('../../node-red-contrib-sugarshack/lib/api');
const wasm = require('../../node-red-contrib-sugarshack/lib/wasm');

helper.init(require.resolve('node-red'));

let RED = null;
const keepRED = (red) => { RED = red; };

// Operation 10 fills: the valve opens and the pump runs until LT-3 reads 100, then the pump stops.
const DOC = {
  ...fakePlant([fakeValve('V101', 1, 'YEL'), fakeValve('V501', 5, 'RED'), fakePump('YEL')]),
  resources: [{ id: 'YEL' }, { id: 'RED' }],
  sensors: [{ id: 'LT-3', device: 'station-3', name: 'volume' }],
  operations: [{
    id: '10', description: 'fill the truck', priority: 20, resources: ['YEL'], steps: [
      { command: { pumps: { P1: true }, valves: { V101: 100 } }, timeoutMs: 3000 },
      { wait: '`LT-3` >= 100', sensors: ['LT-3'], timeoutMs: 60000 },
      { command: { pumps: { P1: false } }, timeoutMs: 3000 },
    ],
  }],
};

const SINKS = ['mqtt', 'out', 'caught', 'state'];

/** The flow under test; `il`: the interlock node's settings changed. */
const flow = (il = {}) => [
  TAB,
  // The surfaces under test: the operation node that starts 10, the plant state node, a Catch for refusals.
  { id: 'op10', z: 'f1', type: 'sugarshack-operation', interlock: 'il', operation: '10', wires: [['out']] },
  { id: 'st', z: 'f1', type: 'sugarshack-state', onChange: false, wires: [['state']] },
  { id: 'c1', z: 'f1', type: 'catch', scope: null, uncaught: false, wires: [['caught']] },
  { id: 'pl', type: 'sugarshack-plant', name: 'plant', plant: DOC },
  { id: 'il', type: 'sugarshack-interlock', name: 'lines', plant: 'pl', resources: [], policy: 'greedy', persist: false, ...il },
  { id: 'bus', z: 'f1', type: 'sugarshack-actuators', plant: 'pl', devices: '', wires: [['mqtt'], [], []] },
  ...SINKS.map(sinkNode),
];

async function start(il = {}) {
  await helper.load([...paletteNodes, keepRED], flow(il));
  const seen = Object.fromEntries(SINKS.map((id) => [id, collect(helper, id)]));
  const api = paletteApi(RED);
  await runUntil(helper, () => api.interlock('il') !== null, 'the interlock running');
  fakePanel(helper, DOC);
  return { api, seen };
}

const runOf = (api, operation) => (api.interlock('il').runs || []).find((r) => r.operation === operation);
const stateOf = (api, operation) => (runOf(api, operation) || {}).state;

/** Starts operation 10 and waits until it waits for LT-3 (mid-step, the pump running). */
async function fillingMidStep(api, seen, msg = { topic: 'fill' }) {
  helper.getNode('op10').receive(msg);
  await runUntil(helper, () => seen.mqtt.some((m) => m.topic === 'ctrl-1/pump/1/command' && m.payload === 'ON'), 'the pump started');
  await runFor(helper, 50);
  assert.equal(stateOf(api, '10'), 'running');
}

describe('operators\' ISA-88 commands through every surface', function () {
  serverPerTest();
  afterEach(stopPanels);

  it('POST /sugarshack/runs/command: a restart of a running operation refused (409 COMMAND_REFUSED), hold, held keeps its line and commands nothing, restart, complete', async function () {
    const { api, seen } = await start();
    await fillingMidStep(api, seen);
    const post = (body) => helper.request().post('/sugarshack/runs/command').send(body);

    let res = await post({ interlock: 'il', operation: '10', command: 'restart', reason: 'too early' });
    assert.equal(res.status, 409, res.text);
    assert.equal(res.body.code, 'COMMAND_REFUSED');
    assert.match(res.body.message, /running/, 'names the state it is in');
    assert.equal(stateOf(api, '10'), 'running', 'refused whole');

    res = await post({ interlock: 'il', operation: '10', command: 'hold', reason: 'gasket check' });
    assert.equal(res.status, 200, res.text);
    assert.deepEqual([res.body.operation, res.body.command, res.body.by], ['10', 'hold', 'unknown']);
    assert.ok(['holding', 'held'].includes(res.body.state), res.text);
    await runUntil(helper, () => stateOf(api, '10') === 'held', 'operation 10 held');
    assert.ok(runOf(api, '10').commands.includes('restart'), 'a held operation lists restart');
    assert.ok(!runOf(api, '10').commands.includes('hold'));
    assert.equal(api.interlock('il').lines.find((l) => l.name === 'YEL').holder.operation, '10', 'a held operation keeps its line');

    // Its wait would pass now, but a held run commands nothing.
    const sent = seen.mqtt.length;
    sensor(helper, 150);
    await runFor(helper, 300);
    assert.equal(seen.mqtt.length, sent, 'nothing commanded while held');
    assert.equal(seen.out.length, 0, 'not complete while held');

    res = await post({ interlock: 'il', operation: '10', command: 'restart', reason: 'gasket fine' });
    assert.equal(res.status, 200, res.text);
    assert.equal(res.body.command, 'restart');
    sensor(helper, 150);
    await runUntil(helper, () => seen.out.length === 1, 'operation 10 completes after the restart');
    assert.equal(seen.out[0].topic, 'fill', 'its own msg, its normal result');
    assert.equal(seen.caught.length, 0, JSON.stringify(seen.caught.map((m) => m.error)));
  });

  it('POST /sugarshack/runs/command: what it is asked in the wrong shape or of what is not there, coded', async function () {
    const { api } = await start();
    const post = (body) => helper.request().post('/sugarshack/runs/command').send(body);
    const refusal = async (body) => {
      const res = await post(body);
      return [res.status, res.body.code];
    };
    assert.deepEqual(await refusal({ interlock: 'il', operation: '10', command: 'pause' }), [409, 'INVALID_INPUT']);
    assert.deepEqual(await refusal({ interlock: 'il', operation: '10', routine: 'truck', command: 'hold' }), [409, 'INVALID_INPUT']);
    assert.deepEqual(await refusal({ interlock: 'il', command: 'hold' }), [409, 'INVALID_INPUT']);
    assert.deepEqual(await refusal({ interlock: 'il', operation: { id: '10' }, command: 'hold' }), [409, 'INVALID_INPUT']);
    assert.deepEqual(await refusal({ interlock: 'nope', operation: '10', command: 'hold' }), [404, 'NO_INTERLOCK']);
    const res = await post({ interlock: 'il', operation: '99', command: 'hold' });
    assert.equal(res.status, 409);
    assert.equal(res.body.code, 'UNKNOWN_RUN', res.text);
    assert.deepEqual(api.interlock('il').runs, [], 'nothing started');
  });

  it('the palette API: abort as a person locks the line out at once, the operation stays aborted until reset', async function () {
    const { api, seen } = await start();
    await fillingMidStep(api, seen);
    await assert.rejects(api.command('il', { operation: '10' }, 'restart', { by: 'ann' }), (err) => err.code === 'COMMAND_REFUSED');
    await assert.rejects(api.command('nope', { operation: '10' }, 'abort', { by: 'ann' }), (err) => err.code === 'NO_INTERLOCK');
    await assert.rejects(api.command('il', { operation: '10' }, 'pause', { by: 'ann' }), (err) => err.code === 'INVALID_INPUT');
    const answer = await api.command('il', { operation: '10' }, 'abort', { by: 'ann', reason: 'leak at the pump' });
    assert.deepEqual([answer.operation, answer.command, answer.by], ['10', 'abort', 'ann']);
    const yel = () => api.interlock('il').lines.find((l) => l.name === 'YEL');
    await runUntil(helper, () => yel().state.state === 'faulted', 'YEL locked out');
    await runUntil(helper, () => (api.interlock('il').aborted || []).some((a) => a.operation === '10'), 'operation 10 listed aborted');
    const aborted = api.interlock('il').aborted.find((a) => a.operation === '10');
    assert.deepEqual(aborted.commands, ['reset']);
    assert.deepEqual([aborted.by, aborted.reason], ['ann', 'leak at the pump']);
    const reset = await api.command('il', { operation: '10' }, 'reset', { by: 'bo', reason: 'pump fixed' });
    assert.deepEqual([reset.command, reset.by], ['reset', 'bo']);
    assert.ok(!(api.interlock('il').aborted || []).some((a) => a.operation === '10'), 'no longer aborted');
  });

  it("the palette API's answer names who acted as the core attributes it: trimmed, unknown when nobody said", async function () {
    const { api, seen } = await start();
    await fillingMidStep(api, seen);
    const aborted = await api.command('il', { operation: '10' }, 'abort', { by: ' \t', reason: 'leak' });
    assert.equal(aborted.by, 'unknown');
    const reset = await api.command('il', { operation: '10' }, 'reset', { by: ' bo ' });
    assert.equal(reset.by, 'bo');
  });

  it('the plant state node: hold and restart by topic as msg.by, answered with the state; a refused restart fails the msg for a Catch node', async function () {
    const { api, seen } = await start();
    await fillingMidStep(api, seen);
    const st = helper.getNode('st');

    st.receive({ topic: 'restart', operation: '10', by: 'bo' });
    await runUntil(helper, () => seen.caught.length === 1, 'the refusal caught');
    assert.equal(seen.caught[0].error.code, 'COMMAND_REFUSED');
    assert.match(seen.caught[0].error.message, /running/);
    assert.equal(seen.state.length, 0, 'no answer for a refusal');
    const lastStatus = () => st.status.getCalls().map((c) => c.args[0]).at(-1);
    assert.equal(lastStatus().fill, 'red');

    st.receive({ topic: 'hold', operation: '10', by: 'bo', reason: 'gasket check', interlock: 'il' });
    await runUntil(helper, () => seen.state.length === 1, 'the answer');
    const [answer] = seen.state;
    assert.equal(answer.topic, 'hold');
    assert.deepEqual([answer.commanded.operation, answer.commanded.command, answer.commanded.by], ['10', 'hold', 'bo']);
    assert.ok(answer.payload.interlocks[0].runs.some((r) => r.operation === '10'), 'the state rides along');
    await runUntil(helper, () => stateOf(api, '10') === 'held', 'operation 10 held');

    st.receive({ topic: 'restart', operation: 10, by: 'bo' });
    await runUntil(helper, () => seen.state.length === 2, 'the restart answered');
    assert.equal(seen.state[1].commanded.command, 'restart');
    sensor(helper, 150);
    await runUntil(helper, () => seen.out.length === 1, 'operation 10 completes');

    st.receive({ topic: 'hold', routine: 'nope', operation: '10' });
    await runUntil(helper, () => seen.caught.length === 2, 'two targets refused');
    assert.equal(seen.caught[1].error.code, 'INVALID_INPUT');
    st.receive({ topic: 'hold', operation: '10', interlock: 'nope' });
    await runUntil(helper, () => seen.caught.length === 3, 'no such interlock');
    assert.equal(seen.caught[2].error.code, 'NO_INTERLOCK');
  });
  it('a held operation through a deploy that refuses the interlock settings and one that fixes them: one run of it, held, as after a restart', async function () {
    const { api, seen } = await start({ persist: true });
    await fillingMidStep(api, seen);
    const runtime = helper.getNode('il').runtime;
    await api.command('il', { operation: '10' }, 'hold', { by: 'bo' });
    await runUntil(helper, () => stateOf(api, '10') === 'held', 'operation 10 held');
    await helper.setFlows(flow({ persist: true, policy: 'bogus' }), 'nodes');
    await runUntil(helper, () => runtime.state === 'failed', 'the refused settings');
    await helper.setFlows(flow({ persist: true }), 'nodes');
    await runUntil(helper, () => runtime.state === 'ready', 'the start from the saved state');
    await runFor(helper, 100);
    assert.equal(api.interlock('il').lines.find((l) => l.name === 'YEL').holder.operation, '10', 'it keeps its line');
    const runs = api.interlock('il').runs.filter((r) => r.operation === '10');
    assert.deepEqual(runs.map((r) => r.state), ['held'], 'one run of operation 10, a person restarts or aborts it');
  });
  it('a held operation whose interlock cannot be rebuilt after a wasm trap (its saved state refused): the operation node\'s msg ends with the reason', async function () {
    const { api, seen } = await start({ persist: true });
    const msg = { topic: 'fill' };
    await fillingMidStep(api, seen, msg);
    await api.command('il', { operation: '10' }, 'hold', { by: 'bo' });
    await runUntil(helper, () => stateOf(api, '10') === 'held', 'operation 10 held');
    const runtime = helper.getNode('il').runtime;
    const generation = wasm.currentGeneration();
    runtime.open = () => {
      throw new Error('the saved state cannot be opened');
    };
    runtime.core.__wbg_ptr = 0x7ffffff0; // eslint-disable-line no-underscore-dangle
    assert.throws(() => runtime.described(), (err) => err.code === 'INTERNAL');
    await until(() => wasm.currentGeneration() === generation + 1, 'the new instance');
    await runFor(helper, 100);
    assert.equal(runtime.state, 'failed');
    const ended = completions().filter((c) => c.nodeId === 'op10' && c.msgid === msg._msgid);
    assert.deepEqual(ended.map((c) => c.error && c.error.message), ['the saved state cannot be opened'], 'answered once, with the reason');
  });
});
