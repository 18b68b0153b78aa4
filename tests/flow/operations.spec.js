'use strict';
// Operations, condition waits and routines from a plant document, against a
// fake panel that obeys commands (no broker): success, timeout -> fault ->
// lockout -> blocked -> clear -> resumes, C1 and C2 refusals, stale sensors,
// a routine stepping through its states with one pending operation, its
// state kept in the interlock's durable file. Time is the manual clock's.
const assert = require('node:assert/strict');
const fs = require('fs');
const path = require('path');
const helper = require('node-red-node-test-helper');
const {
  paletteNodes, linkNodes, TAB, sinkNode, collect, until, trackCompletions, trackDeliveries, untrackCompletions,
  startServer, stopServer, settled, clock, userDir, runFor, runUntil,
} = require('./support');
const {
  fakePanel: panelOf, sensor: sensorOf, stopPanels, fakePlant, fakeValve, fakePump, truckRoutine, loadTruck, unloadTruck, boundPlant,
} = require('./fake-panel');

helper.init(require.resolve('node-red'));


function plantDocument() {
  return {
    ...fakePlant([
      fakeValve('V101', 1, 'YEL'), fakeValve('V102', 2, 'YEL'), fakeValve('V501', 5, 'RED'),
      fakePump('YEL'),
    ]),
    sensors: [{ id: 'LT-3', device: 'station-3', name: 'volume', staleMs: 400 }],
    resources: [{ id: 'YEL' }, { id: 'RED' }],
    operations: [
      loadTruck(),
      unloadTruck(),
      { id: '18', description: 'flit downstock', priority: 92, resources: ['YEL', 'RED'], steps: [{ command: { valves: { V102: 100, V501: 100 } }, timeoutMs: 3000 }] },
    ],
    routines: [truckRoutine(
      { from: 'full', to: 'empty', operation: '12', trigger: { when: '`LT-3` >= 100', sensors: ['LT-3'], everyMs: 100 } },
    )],
  };
}

const SINKS = ['mqtt', 'ev', 'out', 'caught', 'events', 'rt', 'w'];

function flowOf(extra, doc, { persist = false } = {}) {
  return [
    TAB,
    ...boundPlant(doc, { persist }),
    ...SINKS.map(sinkNode),
    ...extra,
  ];
}

async function start(extra = [], doc = plantDocument(), options = {}) {
  await helper.load([...paletteNodes, linkNodes], flowOf(extra, doc, options));
  return collectAll();
}

function collectAll() {
  const seen = {};
  for (const id of SINKS) seen[id] = collect(helper, id);
  return seen;
}

/** The panel of the fake field (lib: ./fake-panel.js): ctrl-1 reaches each command 20 ms of clock time after it. */
const fakePanel = (options) => panelOf(helper, plantDocument(), options);
const sensor = (value) => sensorOf(helper, value);

/** Sends `value()` as LT-3 every `everyMs` of clock time (a station's 1 Hz datapoint, faster). */
function sensorEvery(everyMs, value) {
  sensor(value());
  const timer = clock().setInterval(() => sensor(value()), everyMs);
  return () => clock().clearInterval(timer);
}

const quiet = () => settled(helper, 'il');
const run = (ms) => runFor(helper, ms);
const runTill = (predicate, what) => runUntil(helper, predicate, what);
const stateFile = () => path.join(userDir(), 'sugarshack', 'interlock-il.json');
const savedRoutine = (id) => JSON.parse(fs.readFileSync(stateFile(), 'utf8')).state.routines[id];

const operationNode = (id, operation, wire = 'out') => ({ id, z: 'f1', type: 'sugarshack-operation', interlock: 'il', operation, wires: [[wire]] });
const routineNode = { id: 'r', z: 'f1', type: 'sugarshack-routine', interlock: 'il', routine: 'truck', wires: [['rt']] };
const statusOf = (id) => helper.getNode(id).status.getCalls().filter((c) => c.thisValue.id === id).map((c) => c.args[0]).at(-1);

describe('sugarshack operations and routines', function () {
  beforeEach(startServer);

  afterEach(async function () {
    untrackCompletions();
    stopPanels();
    await stopServer();
  });

  it('runs an operation: acquire, steps, return to idle, release; the msg returns with its statistics', async function () {
    const seen = await start([operationNode('op10', '10')]);
    fakePanel();
    const msg = { topic: 'go' };
    helper.getNode('op10').receive(msg);
    await quiet();
    assert.deepEqual(seen.mqtt.map((m) => m.topic), ['ctrl-1/valve/1/command', 'ctrl-1/valve/2/command'], 'granted at once: step 1');
    await run(40); // the valves reach 100 after 20 ms, the pump runs 20 ms later
    assert.ok(seen.mqtt.some((m) => m.topic === 'ctrl-1/pump/1/command' && m.payload === 'ON'), 'the pump start');
    await run(60);
    assert.equal(seen.out.length, 0, 'waits for LT-3');
    assert.equal(statusOf('op10').text, '3/5 wait');
    sensor(150);
    await run(40); // the pump stops after 20 ms, the valves are back at idle 20 ms later
    await until(() => seen.out.length === 1, 'the return');
    assert.equal(seen.out[0], msg);
    const { operation } = seen.out[0];
    assert.equal(operation.id, '10');
    assert.deepEqual(operation.steps, [
      { kind: 'command', ms: 20 }, { kind: 'command', ms: 20 }, { kind: 'wait', ms: 60 }, { kind: 'command', ms: 20 }, { kind: 'returnToIdle', ms: 20 },
    ]);
    assert.equal(operation.runMs, 140, 'grant to release, on the clock');
    assert.equal(operation.queuedMs, 0);
    // C3: the last commands put every commanded actuator back to idle.
    const last = seen.mqtt.slice(-3).map((m) => [m.topic, m.payload]);
    assert.deepEqual(last.sort(), [['ctrl-1/pump/1/command', 'OFF'], ['ctrl-1/valve/1/command', '0'], ['ctrl-1/valve/2/command', '0']]);
    // Interlock events are published once per turn of the event loop: the release may follow the msg.
    const kinds = () => seen.events.map((e) => e.payload.kind).filter((k) => ['granted', 'released'].includes(k));
    await until(() => kinds().length === 2, 'the granted and released events');
    assert.deepEqual(kinds(), ['granted', 'released']);
    assert.equal(seen.caught.length, 0);
    assert.deepEqual(statusOf('op10'), { fill: 'green', shape: 'dot', text: 'done 0.14 s' });
  });

  it('an operation id read for each msg: from env and from a msg property, as typed values are; one that is none or unknown fails its msg', async function () {
    process.env.SUGARSHACK_TEST_OP = ' 18 ';
    try {
      const seen = await start([
        { ...operationNode('byEnv', 'SUGARSHACK_TEST_OP'), operationType: 'env' },
        { ...operationNode('byMsg', 'payload.op'), operationType: 'msg' },
      ]);
      fakePanel();
      helper.getNode('byEnv').receive({ topic: 'env' });
      await quiet();
      assert.equal(statusOf('byEnv').text, '1/2 command', 'the steps of operation 18');
      await runTill(() => seen.out.length === 1, 'operation 18 from env');
      assert.deepEqual([seen.out[0].topic, seen.out[0].operation.id], ['env', '18']);
      helper.getNode('byMsg').receive({ topic: 'msg', payload: { op: '12' } });
      await runTill(() => seen.out.length === 2, 'operation 12 from the msg');
      assert.deepEqual([seen.out[1].topic, seen.out[1].operation.id], ['msg', '12']);
      helper.getNode('byMsg').receive({ payload: {} });
      await until(() => seen.caught.length === 1, 'no id');
      assert.equal(seen.caught[0].error.code, 'INVALID_CONFIG');
      assert.match(seen.caught[0].error.message, /the configured operation is required/);
      assert.equal(statusOf('byMsg').fill, 'red');
      helper.getNode('byMsg').receive({ payload: { op: '99' } });
      await until(() => seen.caught.length === 2, 'an unknown id');
      assert.equal(seen.caught[1].error.code, 'UNKNOWN_OPERATION');
      assert.equal(seen.out.length, 2);
    } finally {
      delete process.env.SUGARSHACK_TEST_OP;
    }
  });

  it('a wait that times out faults the operation: lockout goes out, the line is blocked until cleared, then resumes', async function () {
    const completions = trackCompletions();
    const seen = await start([
      operationNode('op10', '10'), operationNode('op12', '12'),
      { id: 'clr', z: 'f1', type: 'sugarshack-clear', interlock: 'il', resources: 'YEL', wires: [[]] },
    ]);
    fakePanel();
    const msg = { topic: 'go' };
    helper.getNode('op10').receive(msg);
    await run(639); // the wait starts 40 ms after the grant and may last 600 ms
    assert.equal(seen.caught.length, 0, 'still waiting 1 ms before the timeout');
    await run(1);
    await until(() => seen.caught.length === 1, 'the fault reaching the Catch node');
    const err = seen.caught[0].error;
    assert.ok(err.message.includes("operation '10' faulted at step 3 (wait): condition `LT-3` >= 100 did not hold within 0.6 s"), err.message);
    assert.match(err.message, /sensor 'LT-3' has sent no value yet/);
    assert.match(err.message, /YEL locked out until cleared/);
    assert.equal(seen.caught[0].operation.lockedOut[0], 'YEL');
    assert.equal(completions.find((c) => c.nodeId === 'op10').error.code, 'CONDITION_TIMEOUT');
    // The lockout: retained commands to every YEL actuator.
    await until(() => seen.mqtt.filter((m) => m.retain).length === 3, 'the lockout publishes');
    assert.deepEqual(seen.mqtt.filter((m) => m.retain).map((m) => [m.topic, m.payload]).sort(),
      [['ctrl-1/pump/1/command', 'OFF'], ['ctrl-1/valve/1/command', '0'], ['ctrl-1/valve/2/command', '0']]);
    await until(() => seen.events.some((e) => e.payload.kind === 'faulted'), 'the faulted event');

    helper.getNode('op12').receive({ topic: 'unload' });
    await run(100);
    assert.equal(seen.out.length, 0, 'the faulted line is not granted');
    assert.equal(statusOf('op12').text, 'queued');
    helper.getNode('clr').receive({});
    await runTill(() => seen.out.length === 1, 'op 12 after the clear');
    assert.equal(seen.out[0].operation.id, '12');
    assert.equal(seen.out[0].operation.queuedMs, 100);
    assert.equal(seen.out[0].operation.runMs, 40);
  });

  it('C1: a second start of a running operation is refused and the first goes on', async function () {
    const seen = await start([operationNode('op10', '10'), operationNode('op10b', '10')]);
    fakePanel();
    helper.getNode('op10').receive({ topic: 'first' });
    await until(() => seen.mqtt.length > 0, 'the first command');
    helper.getNode('op10b').receive({ topic: 'second' });
    await until(() => seen.caught.length === 1, 'the refusal');
    assert.equal(seen.caught[0].error.code, 'OPERATION_RUNNING');
    assert.match(seen.caught[0].error.message, /C1/);
    sensor(200);
    await runTill(() => seen.out.length === 1, 'the first completes');
    assert.equal(seen.out[0].topic, 'first');
  });

  it('C2: a group command outside the resources its msg acquired is refused and sends nothing', async function () {
    const seen = await start([
      { id: 'acq', z: 'f1', type: 'sugarshack-acquire', interlock: 'il', operation: '77', priority: 5, resources: 'YEL', timeout: 0, wires: [['gc']] },
      { id: 'gc', z: 'f1', type: 'sugarshack-group-command', plant: 'pl', timeout: 0, wires: [['out']] },
    ]);
    fakePanel();
    const before = seen.mqtt.length;
    helper.getNode('acq').receive({ payload: { valves: { V501: 100 } } });
    await until(() => seen.caught.length === 1, 'the refusal');
    assert.equal(seen.caught[0].error.code, 'OUTSIDE_RESOURCES');
    assert.match(seen.caught[0].error.message, /'V501' is on resource 'RED', outside the resources held \(YEL\)/);
    assert.equal(seen.mqtt.length, before);
    helper.getNode('acq').receive({ payload: { valves: { V101: 100 } } });
    await until(() => seen.caught.length === 2, 'the interlock refusing the second acquire of 77');
    assert.equal(seen.caught[1].error.code, 'ALREADY_HOLDING');
  });

  it('a condition over a stale sensor never passes, even when its last value would', async function () {
    const seen = await start([
      { id: 'wt', z: 'f1', type: 'sugarshack-wait', plant: 'pl', condition: '`LT-3` >= 100', sensors: 'LT-3', timeout: 0.8, wires: [['w']] },
    ]);
    sensor(500);
    await run(399);
    helper.getNode('wt').receive({ topic: 'fresh' });
    await until(() => seen.w.length === 1, 'a value 399 ms old passing');
    await run(1); // LT-3's staleMs of 400
    helper.getNode('wt').receive({ topic: 'a' });
    await run(799);
    assert.equal(seen.caught.length, 0, 'still waiting 1 ms before the timeout');
    await run(1);
    await until(() => seen.caught.length === 1, 'the timeout');
    assert.equal(seen.w.length, 1);
    assert.equal(seen.caught[0].error.code, 'CONDITION_TIMEOUT');
    assert.match(seen.caught[0].error.message, /sensor 'LT-3' is stale/);
    helper.getNode('wt').receive({ topic: 'b' });
    await run(100);
    sensor(500);
    await until(() => seen.w.length === 2, 'a fresh value passing');
    assert.deepEqual(seen.w[1].condition, { values: { 'LT-3': 500 }, waitedMs: 100 });
  });

  it('a routine steps through its states, one pending operation at a time, and keeps its state in the interlock\'s file', async function () {
    const seen = await start([routineNode], plantDocument(), { persist: true });
    fakePanel();
    let level = 50;
    sensorEvery(100, () => level);
    await run(50);
    helper.getNode('r').receive({ topic: 'load' });
    await until(() => seen.rt.some((m) => m.payload.event === 'dispatched'), 'the dispatch');
    await quiet();
    assert.deepEqual(savedRoutine('truck'), { routine: 'truck', state: 'empty', pending: '10', halted: false },
      'saved with its operation pending before the operation starts');
    assert.equal(statusOf('r').text, 'empty › run 10');
    helper.getNode('r').receive({ topic: 'load' });
    await until(() => seen.caught.length === 1, 'the busy refusal');
    assert.equal(seen.caught[0].error.code, 'ROUTINE_BUSY');
    await run(300);
    assert.equal(seen.rt.filter((m) => m.payload.event === 'completed').length, 0, 'op 10 waits for LT-3 >= 100');
    level = 150;
    await runTill(() => seen.rt.filter((m) => m.payload.event === 'completed').length === 2, 'op 10 then op 12');
    const trail = seen.rt.map((m) => [m.payload.event, m.payload.operation, m.payload.state]);
    assert.deepEqual(trail.slice(0, 4), [
      ['dispatched', '10', 'empty'], ['completed', '10', 'full'], ['dispatched', '12', 'full'], ['completed', '12', 'empty'],
    ]);
    await quiet();
    const last = seen.rt.at(-1).payload;
    assert.deepEqual(savedRoutine('truck'), { routine: 'truck', state: last.state, pending: last.pending, halted: false });
    assert.equal(seen.caught.length, 1);
  });

  it('a routine\'s condition is checked when its sensor samples, not on a poll: the sample that makes it hold fires it at once', async function () {
    const seen = await start([routineNode]);
    fakePanel();
    sensor(150); // op 10's wait holds
    helper.getNode('r').receive({ topic: 'load' });
    await runTill(() => seen.mqtt.some((m) => m.topic === 'ctrl-1/pump/1/command' && m.payload === 'OFF'), 'op 10 past its wait');
    sensor(50);
    await runTill(() => seen.rt.some((m) => m.payload.event === 'completed'), 'op 10');
    await run(2000);
    assert.deepEqual(seen.rt.map((m) => m.payload.event), ['dispatched', 'completed'], 'checked on entering \'full\', then never again without a sample');
    assert.equal(statusOf('r').text, 'full');
    const at = clock().now();
    sensor(150);
    await quiet(); // no clock time passes: nothing polls, the sample itself is the check
    const dispatched = seen.rt.filter((m) => m.payload.event === 'dispatched').map((m) => m.payload.operation);
    assert.deepEqual(dispatched, ['10', '12'], 'dispatched on the sample');
    assert.equal(clock().now(), at);
  });

  it('a routine trigger whose operation is already running is refused and the routine stays where it was', async function () {
    const seen = await start([operationNode('op10', '10'), routineNode]);
    fakePanel();
    await until(() => statusOf('r') && statusOf('r').text === 'empty', 'the routine ready');
    helper.getNode('op10').receive({ topic: 'manual' });
    await until(() => seen.mqtt.length > 0, 'op 10 started by hand');
    helper.getNode('r').receive({ topic: 'load' });
    await until(() => seen.rt.some((m) => m.payload.event === 'refused'), 'the refusal');
    const refused = seen.rt.find((m) => m.payload.event === 'refused').payload;
    assert.deepEqual([refused.operation, refused.state, refused.pending, refused.error.code], ['10', 'empty', null, 'OPERATION_RUNNING']);
    assert.equal(seen.caught.filter((m) => m.error.code === 'OPERATION_RUNNING').length, 1);
    sensor(150);
    await runTill(() => seen.out.length === 1, 'the manual run completes');
    const stop = sensorEvery(100, () => 150);
    helper.getNode('r').receive({ topic: 'load' });
    await runTill(() => seen.rt.some((m) => m.payload.event === 'completed'), 'the routine runs it now');
    stop();
    assert.equal(seen.events.filter((e) => e.payload.kind === 'faulted').length, 0, 'nothing was faulted');
  });

  it('a restart while a routine waits for its operation: the routine comes back in its error state and the lines lock out', async function () {
    const flow = () => flowOf([routineNode], plantDocument(), { persist: true });
    await helper.load([...paletteNodes, linkNodes], flow());
    let seen = collectAll();
    fakePanel();
    await until(() => statusOf('r') && statusOf('r').text === 'empty', 'the routine ready');
    helper.getNode('r').receive({ topic: 'load' });
    await run(40);
    assert.ok(seen.mqtt.some((m) => m.topic === 'ctrl-1/pump/1/command'), 'op 10 running (pump on)');
    await quiet();
    assert.deepEqual(savedRoutine('truck'), { routine: 'truck', state: 'empty', pending: '10', halted: false });
    await helper.unload();

    const delivered = trackDeliveries();
    await helper.load([...paletteNodes, linkNodes], flow());
    seen = collectAll();
    const to = (id) => delivered.filter((d) => d.nodeId === id).map((d) => d.msg);
    await until(() => to('rt').length > 0, 'the restarted routine reporting');
    const [first] = to('rt');
    assert.deepEqual([first.payload.event, first.payload.operation, first.payload.state], ['interrupted', '10', 'fault']);
    // YEL was held by op 10 at the shutdown: the interlock restores it faulted ("interrupted") and sends its lockout again.
    const lockouts = () => to('mqtt').filter((m) => m.retain);
    await until(() => lockouts().length === 3, 'the lockout of YEL');
    assert.deepEqual(lockouts().map((m) => [m.topic, m.payload]).sort(),
      [['ctrl-1/pump/1/command', 'OFF'], ['ctrl-1/valve/1/command', '0'], ['ctrl-1/valve/2/command', '0']]);
    assert.deepEqual(helper.getNode('il').runtime.faultedResources(), ['YEL']);
    const yel = helper.getNode('il').runtime.core.snapshot(0).resources.find((r) => r.name === 'YEL');
    assert.equal(yel.state.cause, 'interrupted');
    await quiet();
    assert.deepEqual(savedRoutine('truck'), { routine: 'truck', state: 'fault', pending: null, halted: false });
    assert.deepEqual(statusOf('r'), { fill: 'red', shape: 'dot', text: 'fault' });
  });

  it('a broken plant document is refused at deploy with every problem named, and its nodes refuse msgs', async function () {
    const doc = plantDocument();
    doc.operations[2].steps[0].command.valves.V999 = 100; // unknown actuator
    doc.operations[1].steps[0].command.valves.V501 = 100; // C2: op 12 holds YEL only
    doc.routines.push({ id: 'other', states: ['a'], initial: 'a', transitions: [{ from: 'a', to: 'a', operation: '10', trigger: { msg: 'go' } }] }); // C1
    doc.operations[0].steps[2].sensors = ['LT-9']; // unknown sensor
    doc.actuators[0].idle = undefined; // C3: V101 is commanded by op 10
    const seen = await start([operationNode('op10', '10')], doc);
    const [message] = helper.getNode('pl').error.getCalls().filter((c) => c.thisValue.id === 'pl').map((c) => String(c.args[0]));
    for (const expected of [
      "operations[2] (18).steps[0]: unknown actuator 'V999'",
      "operations[1] (12).steps[0]: C2: commands 'V501' on resource 'RED', outside the operation's resources (YEL)",
      "routines[1] (other).transitions[0]: C1: operation '10' already belongs to routine 'truck'",
      "operations[0] (10).steps[2]: unknown sensor 'LT-9'",
      "operations[0] (10).steps[0]: C3: commands 'V101', which has no idle state to return to",
    ]) assert.ok(message.includes(expected), `${expected}\nin: ${message}`);
    assert.equal(statusOf('op10').text, 'plant invalid');
    helper.getNode('op10').receive({ topic: 'go' });
    await until(() => seen.caught.length === 1, 'the refusal');
    assert.equal(seen.caught[0].error.code, 'INVALID_PLANT');
    assert.equal(seen.mqtt.length, 0);
  });
});
