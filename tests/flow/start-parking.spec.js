'use strict';
// Msgs that reach an interlock's nodes while it reads its saved state wait in
// its engine, made before that read: an acquire's timeout runs from its
// arrival, the wait keeps within nodeMessageBufferMaxLength, and a start
// that fails, stands down, or takes new settings answers each msg once.
// The read is held back by a context store that answers when told (the
// state an earlier version kept there, read on a first run).
const assert = require('node:assert/strict');
const path = require('path');
const helper = require('node-red-node-test-helper');
const {
  paletteNodes, TAB, interlockConfig, acquire, sinkNode, collect, until, serverPerTest, completions, settings, clock, memoryStore, runFor,
} = require('./support');
const { errorStatus } = require('../../node-red-contrib-sugarshack/lib/host/status');
const wasm = require('../../node-red-contrib-sugarshack/lib/wasm');
const { fakePanel, stopPanels, fakePlant, fakeValve, fakePump } = require('./fake-panel');

helper.init(require.resolve('node-red'));

const contextModule = require(require.resolve('@node-red/runtime/lib/nodes/context', { paths: [path.dirname(require.resolve('node-red'))] }));
const runtimeOf = () => helper.getNode('il').runtime;
const run = (ms) => runFor(helper, ms);
const lastStatus = (id) => helper.getNode(id).status.getCalls().filter((c) => c.thisValue.id === id).map((c) => c.args[0]).at(-1);
const errorsOf = (id) => helper.getNode(id).error.getCalls().filter((c) => c.thisValue.id === id).map((c) => c.args[0]);

function flow(config = {}) {
  return [
    TAB, interlockConfig({ persist: true, store: 'slow', ...config }),
    // Op 10 waits 1 s at most; op 12 has no timeout.
    acquire('a10', '10', 20, 'YEL', 'out', { timeout: 1 }), acquire('a12', '12', 22, 'GRN', 'out'),
    sinkNode('out'),
  ];
}

/** Loads `f` with the saved state's read held back; returns the function that lets it end. */
async function loadHeld(f, extra = {}) {
  let answer = null;
  const data = { global: {} };
  settings({ contextStorage: { slow: { module: memoryStore(data, (scope, key, cb) => { answer = () => cb(null, undefined); }) } }, ...extra });
  await helper.load([...paletteNodes, () => contextModule.load()], f);
  await until(() => answer !== null, 'the read of the saved state');
  assert.equal(runtimeOf().state, 'starting');
  return async () => {
    answer();
    await until(() => runtimeOf().state !== 'starting', 'the start');
    await run(0);
  };
}

const doneOf = (msg) => completions().filter((c) => c.msgid === msg._msgid);

/**
 * A running interlock whose GRN an e-stop faulted, deposed, then put in a
 * hot-standby cluster whose committed state (a stand-in etcd store) is read
 * when told. Returns the state before the e-stop and after it, and the reads.
 */
async function deposedWithGrnFaulted() {
  await helper.load(paletteNodes, [
    TAB, interlockConfig({ persist: true }),
    { id: 'stop', z: 'f1', type: 'sugarshack-fault', interlock: 'il', mode: 'resources', operation: '', resources: '', wires: [[], []] },
  ]);
  await until(() => runtimeOf().state === 'ready', 'the start');
  const runtime = runtimeOf();
  await run(0);
  const free = runtime.store.read();
  helper.getNode('stop').receive({ resources: 'GRN', payload: 'e-stop GRN' });
  await until(() => runtime.core.counts().faulted === 1, 'GRN faulted');
  await run(0);
  const faulted = runtime.store.read();
  const loads = [];
  const store = {
    where: 'etcd', durable: true, held: faulted, read: () => store.held, markRan() {}, write: async () => {}, unfollow: async () => {}, follow: async () => {},
    load: () => new Promise((resolve, reject) => loads.push({ answer: (doc) => { store.held = doc; resolve(); }, reject })),
  };
  const cluster = { active: true, instance: 'a', token: '2', leader: null, mayAct: () => true, follow: () => () => {}, on() {}, removeListener() {}, alarmConditions: () => [] };
  await runtime.standDown();
  Object.assign(runtime, { cluster, etcdStore: store, store });
  return { runtime, loads, free, faulted };
}

/** Elected, deposed while it reads the committed state, and elected again: two starts, the first one's read not answered yet. */
async function electedTwice(runtime, loads) {
  runtime.activate();
  await until(() => loads.length === 1, 'the first read of the committed state');
  await runtime.standDown();
  runtime.activate();
  await until(() => loads.length === 2, 'the second read');
}

describe('sugarshack msgs while an interlock starts', function () {
  serverPerTest();
  afterEach(async function () {
    await contextModule.close();
  });

  it('an acquire with a 1 s timeout that arrives while the state is read is refused ACQUIRE_TIMEOUT 1 s after it came, the read still going on', async function () {
    const readEnds = await loadHeld(flow());
    const out = collect(helper, 'out');
    await run(200);
    const late = { payload: 'late' };
    helper.getNode('a10').receive(late);
    await run(999);
    assert.deepEqual(doneOf(late), [], 'still waiting 999 ms after it came');
    await run(1);
    assert.equal(runtimeOf().state, 'starting', 'the read has not ended');
    const [done] = doneOf(late);
    assert.equal(done.error.code, 'ACQUIRE_TIMEOUT');
    assert.match(done.error.message, /10.*YEL.*1 s/);
    assert.deepEqual(lastStatus('a10'), errorStatus('ACQUIRE_TIMEOUT'), 'shown on its node');
    await readEnds();
    assert.equal(doneOf(late).length, 1, 'answered once');
    assert.equal(out.length, 0, 'never granted after its timeout');
  });

  it('past nodeMessageBufferMaxLength while it starts a msg is refused QUEUE_FULL; one that timed out makes room', async function () {
    const readEnds = await loadHeld(flow(), { nodeMessageBufferMaxLength: 2 });
    const out = collect(helper, 'out');
    const [first, second, third] = [{ n: 1 }, { n: 2 }, { n: 3 }];
    helper.getNode('a10').receive(first);
    helper.getNode('a12').receive(second);
    helper.getNode('a12').receive(third);
    await run(0);
    const [refused] = doneOf(third);
    assert.equal(refused.error.code, 'QUEUE_FULL');
    assert.match(refused.error.message, /holds 2 msgs already .*nodeMessageBufferMaxLength/);
    // The first times out while the read goes on: it no longer counts.
    await run(1000);
    assert.equal(doneOf(first)[0].error.code, 'ACQUIRE_TIMEOUT');
    const fourth = { n: 4, operation: '13' };
    helper.getNode('a12').receive(fourth);
    await run(0);
    assert.deepEqual(doneOf(fourth), [], 'kept for the start');
    await readEnds();
    assert.deepEqual(out.map((m) => m.n), [2], 'op 12 holds GRN; op 13 waits for it');
    assert.deepEqual([first, second, third, fourth].map((m) => doneOf(m).length), [1, 1, 1, 0]);
  });

  it('a start that fails completes every msg kept for it once, with the reason', async function () {
    const readEnds = await loadHeld(flow());
    const msgs = [{ n: 1 }, { n: 2 }, { n: 3 }];
    helper.getNode('a10').receive(msgs[0]);
    helper.getNode('a12').receive(msgs[1]);
    helper.getNode('a12').receive(msgs[2]);
    await run(0);
    const runtime = runtimeOf();
    runtime.open = () => {
      throw new Error('the saved state cannot be opened');
    };
    await readEnds();
    assert.equal(runtime.state, 'failed');
    assert.equal(runtime.core, null, 'its engine freed');
    for (const msg of msgs) {
      assert.deepEqual(doneOf(msg).map((c) => c.error && c.error.message), ['the saved state cannot be opened']);
    }
    await run(2000);
    assert.deepEqual(msgs.map((m) => doneOf(m).length), [1, 1, 1], 'the timeout of the first does not answer it again');
  });

  // Deposed while it reads (standDown), or found on standby by the read of the cluster's committed state (becomeStandby).
  for (const how of ['standDown', 'becomeStandby']) {
    it(`on standby while it starts (${how}) it completes every msg kept unsent once, its nodes showing standby`, async function () {
      const readEnds = await loadHeld(flow());
      const msgs = [{ n: 1 }, { n: 2 }];
      helper.getNode('a10').receive(msgs[0]);
      helper.getNode('a12').receive(msgs[1]);
      await run(0);
      const runtime = runtimeOf();
      await runtime[how]();
      assert.equal(runtime.state, 'standby');
      assert.equal(runtime.core, null, 'its engine freed, never started');
      for (const msg of msgs) assert.deepEqual(doneOf(msg).map((c) => c.error), [undefined]);
      assert.equal(lastStatus('a10').text, 'standby');
      await readEnds();
      await run(2000);
      assert.deepEqual(msgs.map((m) => doneOf(m).length), [1, 1]);
      assert.equal(runtime.state, 'standby', 'the read ending starts nothing');
    });
  }

  it('a wasm trap while it starts: the msg that trapped and those kept end INTERNAL once, a new engine keeps those after for the start', async function () {
    const readEnds = await loadHeld(flow());
    const out = collect(helper, 'out');
    const kept = { n: 1 };
    helper.getNode('a12').receive(kept);
    await run(0);
    const generation = wasm.currentGeneration();
    const core = runtimeOf().core;
    core.__wbg_ptr = 0x7ffffff0; // eslint-disable-line no-underscore-dangle
    const trapping = { n: 2 };
    helper.getNode('a12').receive(trapping);
    await until(() => wasm.currentGeneration() === generation + 1, 'the new instance');
    await run(0);
    assert.equal(runtimeOf().state, 'starting');
    assert.notEqual(runtimeOf().core, core, 'a new engine on the new instance');
    for (const msg of [kept, trapping]) assert.deepEqual(doneOf(msg).map((c) => c.error.code), ['INTERNAL']);
    const after = { n: 3 };
    helper.getNode('a12').receive(after);
    await readEnds();
    assert.deepEqual(out.map((m) => m.n), [3]);
    assert.deepEqual([kept, trapping, after].map((m) => doneOf(m).length), [1, 1, 1]);
  });

  it('new settings deployed while it starts: a new engine takes the msgs kept, each timing out from its arrival', async function () {
    const f = flow();
    const readEnds = await loadHeld(f);
    const early = { payload: 'early' };
    helper.getNode('a10').receive(early);
    await run(300);
    const before = runtimeOf().core;
    await helper.setFlows(f.map((n) => (n.id === 'il' ? { ...n, policy: 'no-overtaking' } : n)), 'full');
    await until(() => runtimeOf().core !== before && runtimeOf().gateOpen, 'the new settings applied');
    assert.equal(runtimeOf().state, 'starting');
    assert.equal(runtimeOf().config.policy, 'no-overtaking');
    await run(699);
    assert.deepEqual(errorsOf('a10'), [], '999 ms after it came');
    await run(1);
    // Its first instance completed it when the deploy restarted the node; the refusal comes on the next.
    assert.equal(errorsOf('a10').length, 1);
    assert.equal(errorsOf('a10')[0].code, 'ACQUIRE_TIMEOUT');
    await readEnds();
    assert.equal(doneOf(early).length, 1);
  });
  it('deposed and elected again while it reads the committed state: the first read, answered late with an older state, does not start it; the second does (GRN stays faulted)', async function () {
    const { runtime, loads, free, faulted } = await deposedWithGrnFaulted();
    await electedTwice(runtime, loads);
    loads[0].answer(free);
    await run(0);
    loads[1].answer(faulted);
    await until(() => runtime.state !== 'starting', 'the start');
    await run(0);
    assert.equal(runtime.state, 'ready');
    assert.equal(runtime.core.counts().faulted, 1, 'GRN faulted, as committed');
  });

  it('deposed and elected again while it reads the committed state: the first read refused late (fenced out) leaves the second start going on', async function () {
    const { runtime, loads, faulted } = await deposedWithGrnFaulted();
    await electedTwice(runtime, loads);
    loads[0].reject(new Error('fenced out'));
    await run(0);
    loads[1].answer(faulted);
    await until(() => runtime.state !== 'starting', 'the start');
    await run(0);
    assert.equal(runtime.state, 'ready', 'the elected instance runs its interlock');
    assert.equal(runtime.core.counts().faulted, 1);
  });
  it('an operation node\'s run that asked for a line before an acquire msg while the state is read is granted first, as they came', async function () {
    const doc = {
      ...fakePlant([fakeValve('V101', 1, 'YEL'), fakePump('YEL')]),
      resources: [{ id: 'YEL' }],
      operations: [{ id: '10', priority: 20, resources: ['YEL'], steps: [{ command: { valves: { V101: 100 } }, timeoutMs: 3000 }] }],
    };
    const readEnds = await loadHeld([
      TAB,
      { id: 'pl', type: 'sugarshack-plant', name: 'plant', plant: doc },
      { id: 'il', type: 'sugarshack-interlock', name: 'lines', plant: 'pl', resources: [], policy: 'greedy', persist: true, store: 'slow' },
      { id: 'bus', z: 'f1', type: 'sugarshack-actuators', plant: 'pl', devices: '', wires: [['mqtt'], [], []] },
      { id: 'op10', z: 'f1', type: 'sugarshack-operation', interlock: 'il', operation: '10', wires: [['out']] },
      acquire('hand', 'by hand', 20, 'YEL', 'out'),
      sinkNode('out'), sinkNode('mqtt'),
    ]);
    try {
      fakePanel(helper, doc);
      const out = collect(helper, 'out');
      helper.getNode('op10').receive({ topic: 'fill' });
      helper.getNode('hand').receive({ payload: 'by hand' });
      await run(0);
      await readEnds();
      await run(50);
      // Op 10 runs its one step and releases YEL; only then is the acquire granted (it never releases).
      assert.deepEqual(out.map((m) => (m.operation ? `op ${m.operation.id} done` : m.payload)), ['op 10 done', 'by hand'], 'granted as they came');
      assert.equal(runtimeOf().describe().lines.find((l) => l.name === 'YEL').holder.operation, 'by hand');
    } finally {
      stopPanels();
    }
  });
});
