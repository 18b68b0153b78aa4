'use strict';
// Deploys while operations run, against the fake panel of the operation tests
// and a persisted interlock bound to the plant. A deploy that keeps the plant's
// and the interlock's settings hands everything over: running operations and
// routines go on, each msg leaves from the next instance of its node, nothing
// faults. A deploy that changes the plant document drains: new work waits
// ("draining"), running operations finish on the old document, then the new
// one applies and what waited runs on it.
const assert = require('node:assert/strict');
const helper = require('node-red-node-test-helper');
const {
  paletteNodes, TAB, sinkNode, until, trackCompletions, trackDeliveries, untrackCompletions,
  startServer, stopServer, settled, clock, runFor, runUntil, settings,
} = require('./support');
const { fakePanel, sensor, stopPanels, fakePlant, fakeValve, fakePump, boundPlant } = require('./fake-panel');

helper.init(require.resolve('node-red'));

const command = (valves, timeoutMs = 3000) => ({ command: { valves }, timeoutMs });

function plantDocument() {
  return {
    ...fakePlant([
      fakeValve('V101', 1, 'YEL'), fakeValve('V102', 2, 'YEL'), fakeValve('V201', 3, 'GRN'), fakeValve('V202', 4, 'GRN'),
      fakeValve('V501', 5, 'RED'), fakeValve('V502', 6, 'RED'),
      fakePump('YEL'),
    ]),
    sensors: [
      { id: 'LT-3', device: 'station-3', name: 'volume', staleMs: 400 },
      { id: 'LT-7', device: 'station-3', name: 'level', staleMs: 400 },
    ],
    resources: [{ id: 'YEL' }, { id: 'GRN' }, { id: 'RED' }],
    operations: [
      {
        id: '10', description: 'load truck', priority: 20, resources: ['YEL'], steps: [
          command({ V101: 100, V102: 100 }),
          { command: { pumps: { P1: true } }, timeoutMs: 3000 },
          { wait: '`LT-3` >= 100', sensors: ['LT-3'], timeoutMs: 60000 },
          { command: { pumps: { P1: false } }, timeoutMs: 3000 },
        ],
      },
      { id: '20', description: 'rinse', priority: 10, resources: ['GRN'], steps: [command({ V201: 100 }), command({ V202: 100 })] },
      { id: '21', description: 'flush', priority: 11, resources: ['GRN'], steps: [command({ V201: 50 })] },
      {
        id: '51', description: 'drain silo', priority: 1, resources: ['RED'], steps: [
          command({ V501: 100 }),
          { wait: '`LT-7` < 50', sensors: ['LT-7'], timeoutMs: 60000 },
          command({ V502: 30 }),
        ],
      },
      { id: '52', description: 'fill silo', priority: 1, resources: ['RED'], steps: [command({ V502: 100 })] },
    ],
    routines: [{
      id: 'silo', states: ['full', 'empty', 'fault'], initial: 'full', errorState: 'fault',
      transitions: [
        { from: 'full', to: 'empty', operation: '51', trigger: { msg: 'drain' } },
        { from: 'empty', to: 'full', operation: '52', trigger: { msg: 'fill' } },
      ],
    }],
  };
}

/** The document of a deploy that changes the plant: op 51 ends with V502 at 70, and a new op 30 on GRN. */
function changedDocument() {
  const doc = plantDocument();
  doc.operations.find((o) => o.id === '51').steps[2] = command({ V502: 70 });
  doc.operations.push({ id: '30', description: 'top up', priority: 5, resources: ['GRN'], steps: [command({ V202: 80 })] });
  return doc;
}

const OPERATIONS = ['10', '20', '21'];
const SINKS = ['mqtt', 'ev', 'out', 'caught', 'events', 'rt'];

function flowOf(doc = plantDocument(), { operations = OPERATIONS } = {}) {
  return [
    TAB,
    ...boundPlant(doc, { persist: true }),
    { id: 'r', z: 'f1', type: 'sugarshack-routine', interlock: 'il', routine: 'silo', wires: [['rt']] },
    ...operations.map((op) => ({ id: `op${op}`, z: 'f1', type: 'sugarshack-operation', interlock: 'il', operation: op, wires: [['out']] })),
    ...SINKS.map(sinkNode),
  ];
}

const runtime = () => helper.getNode('il').runtime;
const quiet = () => settled(helper, 'il');
const run = (ms) => runFor(helper, ms);
const runTill = (predicate, what) => runUntil(helper, predicate, what);
const statusCalls = (id) => helper.getNode(id).status.getCalls().filter((c) => c.thisValue.id === id);
const statusOf = (id) => statusCalls(id).map((c) => c.args[0]).at(-1);
const lines = () => Object.fromEntries(runtime().core.snapshot(0).resources.map((r) => [r.name, r.state.state]));

describe('sugarshack deploys while operations run', function () {
  let field;
  let delivered;
  let completions;
  /** What reached helper node `id` so far, across deploys. */
  const to = (id) => delivered.filter((d) => d.nodeId === id).map((d) => d.msg);
  const returned = (op) => to('out').filter((m) => m.operation && m.operation.id === op);
  const routineEvents = () => to('rt').map((m) => m.payload);
  const levels = { volume: 0, level: 100 };

  beforeEach(async function () {
    await new Promise((resolve) => startServer(resolve));
    delivered = trackDeliveries();
    completions = trackCompletions();
  });

  afterEach(async function () {
    stopPanels();
    field = null;
    untrackCompletions();
    await stopServer();
  });

  /** Deploys `flow`, starts the panel and the station (LT-3 and LT-7 every 100 ms of clock time). */
  async function start(flow) {
    await helper.load(paletteNodes, flow);
    levels.volume = 0;
    levels.level = 100;
    field = fakePanel(helper, plantDocument());
    const station = () => {
      sensor(helper, levels.volume, { name: 'volume' });
      sensor(helper, levels.level, { name: 'level' });
    };
    station();
    clock().setInterval(station, 100);
    await quiet();
  }

  /**
   * Op 10 in its wait (step 3 of 5), op 20 with its first command in flight,
   * op 21 waiting for GRN in the interlock's queue, and the silo routine with
   * op 51 pending (its first command in flight).
   */
  async function busyPlant() {
    helper.getNode('op10').receive({ topic: 'load', payload: 10 });
    await run(50);
    helper.getNode('op20').receive({ topic: 'rinse', payload: 20 });
    helper.getNode('op21').receive({ topic: 'flush', payload: 21 });
    helper.getNode('r').receive({ topic: 'drain' });
    await run(10);
    assert.equal(statusOf('op10').text, '3/5 wait');
    assert.equal(statusOf('op20').text, '1/3 command');
    assert.equal(statusOf('op21').text, 'queued');
    assert.deepEqual(runtime().describe().runs.map((r) => [r.operation, r.granted]).sort(),
      [['10', true], ['20', true], ['21', false], ['51', true]]);
    assert.deepEqual(runtime().core.counts(), { holding: 3, queued: 1, faulted: 0 });
    const pending = routineEvents().at(-1);
    assert.deepEqual([pending.event, pending.operation, pending.state, pending.pending], ['dispatched', '51', 'full', '51']);
    return Object.fromEntries(['op10', 'op20', 'op21', 'r'].map((id) => [id, helper.getNode(id)]));
  }

  /** Lets the waits pass and runs the clock until ops 10, 20, 21 and 51 have returned. */
  async function finishAll() {
    levels.volume = 150;
    levels.level = 10;
    await runTill(() => ['10', '20', '21'].every((op) => returned(op).length === 1)
      && routineEvents().some((e) => e.event === 'completed' && e.operation === '51'), 'every operation to return');
    await quiet();
  }

  /** Nothing faulted, locked out or interrupted, nothing logged as an error; every line free. */
  function assertNothingFaulted() {
    const log = helper.log();
    assert.deepEqual(log.args.map((a) => a[0]).filter((e) => e && e.level === log.ERROR).map((e) => `${e.id}: ${e.msg}`), []);
    assert.deepEqual(to('caught').map((m) => m.error.message), [], 'no error reached the Catch node');
    assert.deepEqual(to('events').filter((m) => ['faulted', 'interrupted', 'dropped'].includes(m.payload.kind)).map((m) => m.payload), []);
    assert.deepEqual(routineEvents().filter((e) => ['faulted', 'interrupted', 'refused'].includes(e.event)), []);
    assert.deepEqual(field.commands.filter((c) => c.retain), [], 'no lockout was sent');
    assert.deepEqual(lines(), { YEL: 'free', GRN: 'free', RED: 'free' });
    assert.deepEqual(runtime().core.counts(), { holding: 0, queued: 0, faulted: 0 });
  }

  /** Each operation node's msg went on once, from its current instance, with its run's figures; none completed with an error. */
  function assertReturnedFrom(before, ops) {
    for (const op of ops) {
      const id = `op${op}`;
      const [msg] = returned(op);
      assert.equal(msg.payload, Number(op), `op ${op} returns its own msg`);
      assert.equal(msg.operation.steps.at(-1).kind, 'returnToIdle');
      assert.notEqual(helper.getNode(id), before[id], `${id} was restarted`);
      const done = statusCalls(id).filter((c) => /^done /.test(c.args[0].text));
      assert.deepEqual(done.map((c) => c.thisValue === helper.getNode(id)), [true], `${id} shows its result on its new instance`);
      const ended = completions.filter((c) => c.msgid === msg._msgid);
      assert.ok(ended.length >= 1 && ended.every((c) => c.error === undefined), `${id}: ${JSON.stringify(ended)}`);
    }
  }

  it('a full deploy of unchanged flows hands every running operation and routine to the new nodes', async function () {
    const flow = flowOf();
    await start(flow);
    const before = await busyPlant();
    const core = runtime().core;
    const plant = helper.getNode('pl').runtime;

    await helper.setFlows(flow, 'full');
    await quiet();
    assert.equal(runtime().core, core, 'the same interlock goes on');
    assert.equal(helper.getNode('pl').runtime, plant, 'the same plant goes on');
    assert.equal(runtime().gateOpen, true, 'nothing to drain: the settings are unchanged');
    assert.deepEqual(runtime().core.counts(), { holding: 3, queued: 1, faulted: 0 });
    assert.equal(statusOf('op10').text, '3/5 wait', 'the new instance shows the run');
    assert.equal(statusCalls('op10').at(-1).thisValue, helper.getNode('op10'));

    await finishAll();
    assertReturnedFrom(before, ['10', '20', '21']);
    assert.equal(to('out').length, 3, 'one return per operation');
    const r = routineEvents();
    assert.deepEqual(r.map((e) => [e.event, e.operation, e.state]), [['dispatched', '51', 'full'], ['completed', '51', 'empty']]);
    assert.equal(statusCalls('r').at(-1).thisValue, helper.getNode('r'), 'the routine reports through its new node');
    assert.deepEqual(statusOf('r'), { fill: 'green', shape: 'dot', text: 'empty' });
    // Each operation ran its document's steps: op 21 after op 20 released GRN.
    assert.deepEqual(returned('20')[0].operation.steps.map((s) => s.ms), [20, 20, 20]);
    assert.equal(returned('21')[0].operation.queuedMs, 60, 'granted when op 20 released GRN');
    assertNothingFaulted();
    assert.deepEqual(to('events').map((m) => m.payload.kind).filter((k) => k === 'granted').length, 4);

    // The routine goes on: it takes its next trigger.
    helper.getNode('r').receive({ topic: 'fill' });
    await runTill(() => routineEvents().some((e) => e.event === 'completed' && e.operation === '52'), 'op 52');
    assert.equal(routineEvents().at(-1).state, 'full');
  });

  it('a deploy of modified nodes that only restarts an operation node hands its run to the new instance', async function () {
    const flow = flowOf();
    await start(flow);
    const before = await busyPlant();
    const core = runtime().core;

    await helper.setFlows(flow.map((n) => (n.id === 'op10' ? { ...n, name: 'load truck' } : n)), 'nodes');
    await quiet();
    assert.equal(runtime().core, core);
    assert.notEqual(helper.getNode('op10'), before.op10, 'op 10 was restarted');
    assert.equal(helper.getNode('op20'), before.op20, 'op 20 was not');
    assert.deepEqual(runtime().core.counts(), { holding: 3, queued: 1, faulted: 0 });
    assert.equal(statusCalls('op10').at(-1).thisValue, helper.getNode('op10'), 'the new instance shows the run');

    await finishAll();
    assertReturnedFrom(before, ['10']);
    for (const op of ['20', '21']) assert.equal(returned(op)[0].payload, Number(op));
    assert.equal(to('out').length, 3);
    assert.deepEqual(routineEvents().map((e) => e.event), ['dispatched', 'completed']);
    assertNothingFaulted();
  });

  it('a deploy that changes the plant document drains: new work waits, the running operation finishes on the old document, then the new one applies', async function () {
    await start(flowOf(plantDocument(), { operations: ['10', '20'] }));
    helper.getNode('op20').receive({ topic: 'rinse', payload: 20 });
    helper.getNode('r').receive({ topic: 'drain' });
    await run(30);
    assert.equal(statusOf('op20').text, '2/3 command');
    const before = { op20: helper.getNode('op20') };

    await helper.setFlows(flowOf(changedDocument(), { operations: ['10', '20', '30'] }), 'full');
    await quiet();
    assert.equal(runtime().gateOpen, false, 'draining');
    for (const id of ['bus', 'ilev']) assert.deepEqual(statusOf(id), { fill: 'yellow', shape: 'ring', text: 'draining' }, id);
    // A start of the new operation and a msg to the routine wait meanwhile.
    helper.getNode('op30').receive({ topic: 'top up', payload: 30 });
    helper.getNode('r').receive({ topic: 'fill' });
    await quiet();
    assert.equal(runtime().parked.length, 2, 'both held at the interlock');
    assert.equal(to('caught').length, 0);

    // Op 20 and the routine's op 51 run on: op 20 returns, op 51 waits for LT-7.
    await runTill(() => returned('20').length === 1, 'op 20 to return');
    assert.equal(runtime().gateOpen, false, 'op 51 still runs');
    assert.equal(returned('30').length, 0, 'the new operation waits for the drain');
    levels.level = 10;
    await runTill(() => returned('30').length === 1, 'op 51 to finish, the drain, then op 30');
    assert.equal(runtime().gateOpen, true);
    assert.notEqual(statusOf('bus').text, 'draining');

    // Op 51 finished on the old document (V502 to 30); op 30 exists only in the new one and ran after the drain.
    const commandsOf = (topic) => field.commands.filter((c) => c.topic === topic).map((c) => [c.payload, c.atMs]);
    const v502 = commandsOf('ctrl-1/valve/6/command');
    assert.equal(v502[0][0], '30', 'op 51 ends as the document it started with says');
    const completed51 = routineEvents().find((e) => e.event === 'completed' && e.operation === '51');
    assert.ok(completed51, 'the routine moved on');
    const at = (kind, op) => to('events').find((m) => m.payload.kind === kind && m.payload.operation === op).payload.atMs;
    assert.ok(at('granted', '30') >= at('released', '51'), 'op 30 granted once op 51 had released RED: the drain was over');
    assert.ok(field.commands.find((c) => c.payload === '80').atMs >= at('released', '51'));
    assert.deepEqual(returned('30')[0].operation.steps.map((s) => s.kind), ['command', 'returnToIdle']);
    assertReturnedFrom(before, ['20']);

    // The parked routine msg ran after the drain: op 52 fills the silo.
    await runTill(() => routineEvents().some((e) => e.event === 'completed' && e.operation === '52'), 'op 52');
    assert.deepEqual(routineEvents().map((e) => [e.event, e.operation]), [
      ['dispatched', '51'], ['completed', '51'], ['dispatched', '52'], ['completed', '52'],
    ]);

    // The new document is in force: op 51 now ends with V502 at 70.
    levels.level = 100;
    helper.getNode('r').receive({ topic: 'drain' });
    await run(100);
    levels.level = 10;
    await runTill(() => routineEvents().filter((e) => e.event === 'completed' && e.operation === '51').length === 2, 'op 51 again');
    assert.deepEqual(commandsOf('ctrl-1/valve/6/command').map(([p]) => p).filter((p) => p !== '0'), ['30', '100', '70']);
    assertNothingFaulted();
  });

  it('msgs held while a deploy drains keep within nodeMessageBufferMaxLength: the one past it is refused (QUEUE_FULL), those held run after', async function () {
    settings({ nodeMessageBufferMaxLength: 2 });
    await start(flowOf(plantDocument(), { operations: ['10', '20'] }));
    helper.getNode('op20').receive({ topic: 'rinse', payload: 20 });
    await run(30);
    await helper.setFlows(flowOf(changedDocument(), { operations: ['10', '20', '30'] }), 'full');
    await quiet();
    assert.equal(runtime().draining, true);
    helper.getNode('op30').receive({ topic: 'top up', payload: 30 });
    helper.getNode('op10').receive({ topic: 'load truck', payload: 10 });
    helper.getNode('op30').receive({ topic: 'top up again', payload: 31 });
    await quiet();
    assert.equal(runtime().parked.length, 2, 'two held, as the setting allows');
    const refused = completions.filter((c) => c.error);
    assert.equal(refused.length, 1, 'the third is completed with an error');
    assert.deepEqual([refused[0].nodeId, refused[0].error.code], ['op30', 'QUEUE_FULL']);
    assert.match(refused[0].error.message, /holds 2 msgs already .*nodeMessageBufferMaxLength/);
    assert.equal(to('caught').length, 1, 'a Catch node gets it');
    await runTill(() => returned('30').length === 1, 'the drain to end and the held op 30 to run');
    assert.equal(returned('30')[0].payload, 30);
    assert.ok(runtime().describe().runs.some((r) => r.operation === '10'), 'the held op 10 started too');
    assert.equal(completions.filter((c) => c.error).length, 1, 'nothing else refused');
  });

  it('an acquire that comes while a deploy drains waits in the engine, its timeout running: it times out before the drain ends', async function () {
    const withAcquire = (flow) => [...flow, {
      id: 'acq', z: 'f1', type: 'sugarshack-acquire', interlock: 'il', operation: 'by hand', priority: 0, resources: 'YEL', timeout: 1, wires: [['out']],
    }];
    await start(withAcquire(flowOf(plantDocument(), { operations: ['10', '20'] })));
    helper.getNode('r').receive({ topic: 'drain' }); // op 51 runs until LT-7 falls
    await run(30);
    await helper.setFlows(withAcquire(flowOf(changedDocument(), { operations: ['10', '20'] })), 'full');
    await quiet();
    assert.equal(runtime().draining, true);
    helper.getNode('acq').receive({ payload: 'by hand' });
    await quiet();
    assert.equal(runtime().parked.length, 0, 'not held in JS: the engine holds it back');
    await run(1100);
    assert.equal(runtime().draining, true, 'the drain still goes on');
    const refused = completions.filter((c) => c.nodeId === 'acq' && c.error);
    assert.deepEqual(refused.map((c) => c.error.code), ['ACQUIRE_TIMEOUT']);
    assert.equal(to('caught').length, 1, 'a Catch node gets it');
    levels.level = 10;
    await runTill(() => !runtime().draining, 'op 51 to finish and the drain to end');
    assert.equal(to('out').filter((m) => m.payload === 'by hand').length, 0, 'the timed-out request is not granted after the drain');
  });

  it('a routine whose operation waits in the queue through a draining deploy moves on when it returns', async function () {
    await start(flowOf(plantDocument(), { operations: ['52'] }));
    helper.getNode('op52').receive({ topic: 'fill by hand', payload: 52 });
    await run(10);
    helper.getNode('r').receive({ topic: 'drain' });
    await quiet();
    assert.equal(statusOf('r').text, 'full › wait 51');
    const brief = (runs) => runs.map(({ operation, granted, state, routine }) => ({ operation, granted, state, routine }));
    assert.deepEqual(brief(runtime().describe().runs), [
      { operation: '52', granted: true, state: 'running', routine: null }, { operation: '51', granted: false, state: 'queued', routine: 'silo' },
    ]);

    await helper.setFlows(flowOf(changedDocument(), { operations: ['52'] }), 'full');
    await quiet();
    assert.equal(runtime().gateOpen, false, 'draining while op 52 runs');
    levels.level = 10;
    await runTill(() => routineEvents().some((e) => e.event !== 'dispatched'), 'the routine to hear from op 51');
    assert.equal(runtime().gateOpen, true);
    assert.deepEqual(routineEvents().map((e) => [e.event, e.operation, e.state, e.pending]), [
      ['dispatched', '51', 'full', '51'], ['completed', '51', 'empty', null],
    ]);
    assert.equal(returned('52').length, 1);
    assert.deepEqual(to('events').filter((m) => m.payload.operation === '51').map((m) => m.payload.kind),
      ['queued', 'cancelled', 'granted', 'released'], 'held back during the drain, queued again after it');
    assert.deepEqual(statusOf('r'), { fill: 'green', shape: 'dot', text: 'empty' });
    await quiet();
    assertNothingFaulted();
  });

  it('a deploy that removes an operation node while its operation runs: the interlock sees it to its release, nothing faults', async function () {
    const flow = flowOf();
    await start(flow);
    helper.getNode('op10').receive({ topic: 'load', payload: 10 });
    await run(50);
    assert.equal(statusOf('op10').text, '3/5 wait');
    const msgid = to('op10')[0]._msgid;

    await helper.setFlows(flow.filter((n) => n.id !== 'op10'), 'nodes');
    await quiet();
    assert.equal(helper.getNode('op10'), null);
    assert.deepEqual(runtime().describe().runs.map(({ operation, granted, state }) => ({ operation, granted, state })),
      [{ operation: '10', granted: true, state: 'running' }], 'the run goes on without its node');
    assert.deepEqual(lines(), { YEL: 'held', GRN: 'free', RED: 'free' });
    assert.equal(completions.filter((c) => c.msgid === msgid && c.error === undefined).length, 1, 'the removed node completed its msg');

    levels.volume = 150;
    await runTill(() => runtime().describe().runs.length === 0, 'op 10 to finish');
    await quiet();
    assert.deepEqual(field.commands.slice(-3).map((c) => [c.topic, c.payload]).sort(), [
      ['ctrl-1/pump/1/command', 'OFF'], ['ctrl-1/valve/1/command', '0'], ['ctrl-1/valve/2/command', '0'],
    ], 'back to idle');
    assert.deepEqual(to('events').map((m) => [m.payload.kind, m.payload.operation]), [['granted', '10'], ['released', '10']]);
    assert.equal(to('out').length, 0, 'nobody to send the msg on');
    assertNothingFaulted();
  });
});
