'use strict';
// Operations, condition waits and routines from a plant document, against a
// fake panel that obeys commands (no broker): success, timeout -> fault ->
// lockout -> blocked -> clear -> resumes, C1 and C2 refusals, stale sensors,
// a routine stepping through its states with one pending operation.
const assert = require('node:assert/strict');
const fs = require('fs');
const os = require('os');
const path = require('path');
const helper = require('node-red-node-test-helper');
const {
  paletteNodes, catchNode, linkNodes, TAB, sinkNode, collect, sleep, until, trackCompletions, trackDeliveries, untrackCompletions,
} = require('./support');

helper.init(require.resolve('node-red'));

const valve = (id, io, line) => ({ id, type: 'valve', device: 'ctrl-1', io, idle: 0, lockout: 0, resource: line });

function plantDocument() {
  return {
    actuatorTypes: {
      valve: { signal: 'analog', min: 0, max: 100, tolerance: 3, noMotionMs: 400, completionMs: 2000, staleMs: 60000 },
      pump: { signal: 'binary', noMotionMs: 400, completionMs: 2000, staleMs: 60000 },
    },
    devices: [{ id: 'ctrl-1', kind: 'actuator-panel' }, { id: 'station-3', kind: 'sensor-station' }],
    actuators: [
      valve('V101', 1, 'YEL'), valve('V102', 2, 'YEL'), valve('V501', 5, 'RED'),
      { id: 'P1', type: 'pump', device: 'ctrl-1', io: 1, idle: false, lockout: false, resource: 'YEL' },
    ],
    sensors: [{ id: 'LT-3', device: 'station-3', name: 'volume', staleMs: 400 }],
    resources: [{ id: 'YEL' }, { id: 'RED' }],
    operations: [
      {
        id: '10', description: 'load truck', priority: 20, resources: ['YEL'], steps: [
          { command: { valves: { V101: 100, V102: 100 } }, timeoutMs: 3000 },
          { command: { pumps: { P1: true } }, timeoutMs: 3000 },
          { wait: '`LT-3` >= 100', sensors: ['LT-3'], timeoutMs: 600 },
          { command: { pumps: { P1: false } }, timeoutMs: 3000 },
        ],
      },
      { id: '12', description: 'unload truck', priority: 22, resources: ['YEL'], steps: [{ command: { valves: { V101: 50 } }, timeoutMs: 3000 }] },
      { id: '18', description: 'flit downstock', priority: 92, resources: ['YEL', 'RED'], steps: [{ command: { valves: { V102: 100, V501: 100 } }, timeoutMs: 3000 }] },
    ],
    routines: [{
      id: 'truck', states: ['empty', 'full', 'fault'], initial: 'empty', errorState: 'fault',
      transitions: [
        { from: 'empty', to: 'full', operation: '10', trigger: { msg: 'load' } },
        { from: 'full', to: 'empty', operation: '12', trigger: { when: '`LT-3` >= 100', sensors: ['LT-3'], everyMs: 100 } },
      ],
    }],
  };
}

const SINKS = ['mqtt', 'ev', 'out', 'caught', 'events', 'rt', 'w'];

function flowOf(extra, doc) {
  return [
    TAB,
    { id: 'pl', type: 'sugarshack-plant', name: 'plant', plant: doc },
    { id: 'il', type: 'sugarshack-interlock', name: 'lines', plant: 'pl', resources: [], policy: 'greedy', persist: false },
    { id: 'bus', z: 'f1', type: 'sugarshack-actuators', plant: 'pl', devices: '', wires: [['mqtt'], [], ['ev']] },
    { id: 'ilev', z: 'f1', type: 'sugarshack-interlock-events', interlock: 'il', wires: [['events']] },
    { id: 'c1', z: 'f1', type: 'catch', scope: null, uncaught: false, wires: [['caught']] },
    ...SINKS.map(sinkNode),
    ...extra,
  ];
}

async function start(extra = [], doc = plantDocument()) {
  await helper.load([...paletteNodes, catchNode, linkNodes], flowOf(extra, doc));
  return collectAll();
}

function collectAll() {
  const seen = {};
  for (const id of SINKS) seen[id] = collect(helper, id);
  return seen;
}

/** A panel that moves to every command within `delayMs` and reports at once (no broker). */
function fakePanel(seen, { delayMs = 20, stuck = new Set() } = {}) {
  const positions = { valve: { 1: 0, 2: 0, 5: 0 }, pump: { 1: false } };
  const report = () => helper.getNode('bus')?.receive({ topic: 'ctrl-1/state', payload: { ts: Date.now(), ...positions } });
  const mqtt = helper.getNode('mqtt');
  mqtt.on('input', (msg) => {
    const [, type, io] = msg.topic.split('/');
    if (stuck.has(`${type}/${io}`)) return;
    const value = type === 'pump' ? msg.payload === 'ON' : Number(msg.payload);
    setTimeout(() => {
      positions[type][io] = value;
      report();
    }, delayMs);
  });
  report();
  return { report, positions };
}

function sensor(value, name = 'volume') {
  helper.getNode('bus').receive({ topic: `station-3/sensor/${name}/state`, payload: { ts: Date.now(), value } });
}

const operationNode = (id, operation, wire = 'out') => ({ id, z: 'f1', type: 'sugarshack-operation', interlock: 'il', operation, wires: [[wire]] });
const statusOf = (id) => helper.getNode(id).status.getCalls().filter((c) => c.thisValue.id === id).map((c) => c.args[0]).at(-1);

describe('sugarshack operations and routines', function () {
  beforeEach(function (done) {
    helper.startServer(done);
  });

  afterEach(async function () {
    untrackCompletions();
    await helper.unload();
    await new Promise((resolve) => helper.stopServer(resolve));
  });

  it('runs an operation: acquire, steps, return to idle, release; the msg returns with its statistics', async function () {
    const seen = await start([operationNode('op10', '10')]);
    fakePanel(seen);
    const msg = { topic: 'go' };
    helper.getNode('op10').receive(msg);
    await until(() => seen.mqtt.some((m) => m.topic === 'ctrl-1/pump/1/command'), 'the pump start');
    await sleep(60);
    assert.equal(seen.out.length, 0, 'waits for LT-3');
    sensor(150);
    await until(() => seen.out.length === 1, 'the return');
    assert.equal(seen.out[0], msg);
    const { operation } = seen.out[0];
    assert.equal(operation.id, '10');
    assert.ok(operation.runMs >= operation.steps.reduce((a, s) => a + s.ms, 0) - 5);
    assert.ok(operation.queuedMs >= 0);
    assert.deepEqual(operation.steps.map((s) => s.kind), ['command', 'command', 'wait', 'command', 'returnToIdle']);
    // C3: the last commands put every commanded actuator back to idle.
    const last = seen.mqtt.slice(-3).map((m) => [m.topic, m.payload]);
    assert.deepEqual(last.sort(), [['ctrl-1/pump/1/command', 'OFF'], ['ctrl-1/valve/1/command', '0'], ['ctrl-1/valve/2/command', '0']]);
    // Interlock events are published once per turn of the event loop: the release may follow the msg.
    const kinds = () => seen.events.map((e) => e.payload.kind).filter((k) => ['granted', 'released'].includes(k));
    await until(() => kinds().length === 2, 'the granted and released events');
    assert.deepEqual(kinds(), ['granted', 'released']);
    assert.equal(seen.caught.length, 0);
    assert.equal(statusOf('op10').fill, 'green');
  });

  it('a wait that times out faults the operation: lockout goes out, the line is blocked until cleared, then resumes', async function () {
    const completions = trackCompletions();
    const seen = await start([
      operationNode('op10', '10'), operationNode('op12', '12'),
      { id: 'clr', z: 'f1', type: 'sugarshack-clear', interlock: 'il', resources: 'YEL', wires: [[]] },
    ]);
    fakePanel(seen);
    const msg = { topic: 'go' };
    helper.getNode('op10').receive(msg);
    await until(() => seen.caught.length === 1, 'the fault reaching the Catch node', 4000);
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
    await sleep(100);
    assert.equal(seen.out.length, 0, 'the faulted line is not granted');
    assert.equal(statusOf('op12').text, 'queued');
    helper.getNode('clr').receive({});
    await until(() => seen.out.length === 1, 'op 12 after the clear');
    assert.equal(seen.out[0].operation.id, '12');
    assert.ok(seen.out[0].operation.queuedMs >= 100);
  });

  it('C1: a second start of a running operation is refused and the first goes on', async function () {
    const seen = await start([operationNode('op10', '10'), operationNode('op10b', '10')]);
    fakePanel(seen);
    helper.getNode('op10').receive({ topic: 'first' });
    await until(() => seen.mqtt.length > 0, 'the first command');
    helper.getNode('op10b').receive({ topic: 'second' });
    await until(() => seen.caught.length === 1, 'the refusal');
    assert.equal(seen.caught[0].error.code, 'OPERATION_RUNNING');
    assert.match(seen.caught[0].error.message, /C1/);
    sensor(200);
    await until(() => seen.out.length === 1, 'the first completes');
    assert.equal(seen.out[0].topic, 'first');
  });

  it('C2: a group command outside the resources its msg acquired is refused and sends nothing', async function () {
    const seen = await start([
      { id: 'acq', z: 'f1', type: 'sugarshack-acquire', interlock: 'il', operation: '77', priority: 5, resources: 'YEL', timeout: 0, wires: [['gc']] },
      { id: 'gc', z: 'f1', type: 'sugarshack-group-command', plant: 'pl', timeout: 0, wires: [['out']] },
    ]);
    fakePanel(seen);
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
    await sleep(450); // past LT-3's staleMs of 400
    helper.getNode('wt').receive({ topic: 'a' });
    await until(() => seen.caught.length === 1, 'the timeout', 3000);
    assert.equal(seen.w.length, 0);
    assert.equal(seen.caught[0].error.code, 'CONDITION_TIMEOUT');
    assert.match(seen.caught[0].error.message, /sensor 'LT-3' is stale/);
    helper.getNode('wt').receive({ topic: 'b' });
    sensor(500);
    await until(() => seen.w.length === 1, 'a fresh value passing');
    assert.deepEqual(seen.w[0].condition.values, { 'LT-3': 500 });
  });

  it('a routine steps through its states, one pending operation at a time, and persists its state', async function () {
    const seen = await start([
      { id: 'r', z: 'f1', type: 'sugarshack-routine', interlock: 'il', routine: 'truck', store: 'default', wires: [['rt']] },
    ]);
    fakePanel(seen);
    const kick = setInterval(() => sensor(50), 100);
    try {
      await sleep(50);
      helper.getNode('r').receive({ topic: 'load' });
      await until(() => seen.rt.some((m) => m.payload.event === 'dispatched'), 'the dispatch');
      helper.getNode('r').receive({ topic: 'load' });
      await until(() => seen.caught.length === 1, 'the busy refusal');
      assert.equal(seen.caught[0].error.code, 'ROUTINE_BUSY');
      clearInterval(kick);
      const kick2 = setInterval(() => sensor(150), 100);
      try {
        await until(() => seen.rt.filter((m) => m.payload.event === 'completed').length === 2, 'op 10 then op 12', 6000);
      } finally {
        clearInterval(kick2);
      }
    } finally {
      clearInterval(kick);
    }
    const trail = seen.rt.map((m) => [m.payload.event, m.payload.operation, m.payload.state]);
    assert.deepEqual(trail.slice(0, 4), [
      ['dispatched', '10', 'empty'], ['completed', '10', 'full'], ['dispatched', '12', 'full'], ['completed', '12', 'empty'],
    ]);
    const saved = await new Promise((resolve) => helper.getNode('r').context().get('routine', (err, v) => resolve(v)));
    assert.equal(saved.state, trail.at(-1)[2]);
  });

  it('a routine trigger whose operation is already running is refused and the routine stays where it was', async function () {
    const seen = await start([
      operationNode('op10', '10'),
      { id: 'r', z: 'f1', type: 'sugarshack-routine', interlock: 'il', routine: 'truck', store: 'default', wires: [['rt']] },
    ]);
    fakePanel(seen);
    await until(() => statusOf('r') && statusOf('r').text === 'empty', 'the routine ready');
    helper.getNode('op10').receive({ topic: 'manual' });
    await until(() => seen.mqtt.length > 0, 'op 10 started by hand');
    helper.getNode('r').receive({ topic: 'load' });
    await until(() => seen.rt.some((m) => m.payload.event === 'refused'), 'the refusal');
    const refused = seen.rt.find((m) => m.payload.event === 'refused').payload;
    assert.deepEqual([refused.operation, refused.state, refused.pending, refused.error.code], ['10', 'empty', null, 'OPERATION_RUNNING']);
    assert.equal(seen.caught.filter((m) => m.error.code === 'OPERATION_RUNNING').length, 1);
    sensor(150);
    await until(() => seen.out.length === 1, 'the manual run completes');
    helper.getNode('r').receive({ topic: 'load' });
    await until(() => seen.rt.some((m) => m.payload.event === 'completed'), 'the routine runs it now');
    assert.equal(seen.events.filter((e) => e.payload.kind === 'faulted').length, 0, 'nothing was faulted');
  });

  it('a restart while a routine waits for its operation: the routine comes back in its error state and the lines lock out', async function () {
    const contextModule = require(require.resolve('@node-red/runtime/lib/nodes/context', { paths: [path.dirname(require.resolve('node-red'))] }));
    const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'sugarshack-routine-'));
    helper.settings({ contextStorage: { default: { module: 'localfilesystem', config: { dir, flushInterval: 0 } } } });
    const loadStores = () => contextModule.load();
    const routine = { id: 'r', z: 'f1', type: 'sugarshack-routine', interlock: 'il', routine: 'truck', store: 'default', wires: [['rt']] };
    try {
      await helper.load([...paletteNodes, catchNode, linkNodes, loadStores], flowOf([routine], plantDocument()));
      let seen = collectAll();
      fakePanel(seen);
      await until(() => statusOf('r') && statusOf('r').text === 'empty', 'the routine ready');
      helper.getNode('r').receive({ topic: 'load' });
      await until(() => seen.mqtt.some((m) => m.topic === 'ctrl-1/pump/1/command'), 'op 10 running (pump on)');
      await helper.unload();
      await contextModule.close();

      const delivered = trackDeliveries();
      await helper.load([...paletteNodes, catchNode, linkNodes, loadStores], flowOf([routine], plantDocument()));
      seen = collectAll();
      const to = (id) => delivered.filter((d) => d.nodeId === id).map((d) => d.msg);
      await until(() => to('rt').length > 0, 'the restarted routine reporting');
      const [first] = to('rt');
      assert.deepEqual([first.payload.event, first.payload.operation, first.payload.state], ['interrupted', '10', 'fault']);
      // The interlock is not persisted here: the routine faults the lines of its interrupted operation, and their lockouts go out.
      const lockouts = () => to('mqtt').filter((m) => m.retain);
      await until(() => lockouts().length === 3, 'the lockout of YEL');
      assert.deepEqual(lockouts().map((m) => [m.topic, m.payload]).sort(),
        [['ctrl-1/pump/1/command', 'OFF'], ['ctrl-1/valve/1/command', '0'], ['ctrl-1/valve/2/command', '0']]);
      assert.deepEqual(helper.getNode('il').runtime.faultedResources(), ['YEL']);
      const saved = await new Promise((resolve) => helper.getNode('r').context().get('routine', (err, v) => resolve(v)));
      assert.deepEqual(saved, { routine: 'truck', state: 'fault', pending: null, halted: false });
    } finally {
      await helper.unload();
      await contextModule.close();
      helper.settings({});
      fs.rmSync(dir, { recursive: true, force: true });
    }
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
