'use strict';
// One timer per engine: the interlock's engine timer and the plant's. What
// used to poll or keep a timer of its own now follows events and the core's
// deadlines: the plant's alarm conditions reach the interlock when the plant's
// timer wakes for staleness or a bus's connection changes, a deploy's drain
// ends when the last run or group command ends, and a routine's condition is
// checked at its deadline by the interlock's timer. No interval is left on the
// manual clock in any of these.
const assert = require('node:assert/strict');
const helper = require('node-red-node-test-helper');
const {
  paletteNodes, TAB, sinkNode, trackDeliveries, untrackCompletions, startServer, stopServer, settled, clock, runFor, runUntil,
} = require('./support');
const { fakePanel, sensor, stopPanels, fakePlant, fakeValve, boundPlant } = require('./fake-panel');

helper.init(require.resolve('node-red'));

const STALE_MS = 5000;

function plantDocument() {
  const doc = fakePlant([fakeValve('V201', 3, 'GRN'), fakeValve('V202', 4, 'GRN'), fakeValve('V501', 5, 'RED')]);
  doc.actuatorTypes.valve.staleMs = STALE_MS;
  return {
    ...doc,
    sensors: [{ id: 'LT-3', device: 'station-3', name: 'volume', staleMs: 60000 }],
    resources: [{ id: 'GRN' }, { id: 'RED' }],
    operations: [
      { id: '20', description: 'rinse', priority: 10, resources: ['GRN'], steps: [{ command: { valves: { V201: 100 } }, timeoutMs: 3000 }] },
      { id: '51', description: 'drain silo', priority: 1, resources: ['RED'], steps: [{ command: { valves: { V501: 100 } }, timeoutMs: 3000 }] },
    ],
    routines: [{
      id: 'silo', states: ['full', 'empty', 'fault'], initial: 'full', errorState: 'fault',
      transitions: [{ from: 'full', to: 'empty', operation: '51', trigger: { when: '`LT-3` >= 100', sensors: ['LT-3'], everyMs: 1000 } }],
    }],
  };
}

/** A broker config node the test connects and disconnects (an actuators node reads its `connected`). */
function fakeBroker(RED) {
  function FakeBroker(props) {
    RED.nodes.createNode(this, props);
    this.connected = true;
  }
  RED.nodes.registerType('fake-broker', FakeBroker);
}

function flowOf(doc = plantDocument(), { broker = false } = {}) {
  const plant = boundPlant(doc, { persist: true });
  if (broker) plant.find((n) => n.id === 'bus').broker = 'brk';
  return [
    TAB,
    ...plant,
    ...(broker ? [{ id: 'brk', type: 'fake-broker' }] : []),
    { id: 'r', z: 'f1', type: 'sugarshack-routine', interlock: 'il', routine: 'silo', wires: [['rt']] },
    { id: 'op20', z: 'f1', type: 'sugarshack-operation', interlock: 'il', operation: '20', wires: [['out']] },
    ...['mqtt', 'ev', 'out', 'caught', 'events', 'rt'].map(sinkNode),
  ];
}

const runtime = () => helper.getNode('il').runtime;
const plant = () => helper.getNode('pl').runtime;
const quiet = () => settled(helper, 'il');
const alarm = (id) => (runtime().describe().alarms || []).find((a) => a.id === id);
/** Every timer on the manual clock is a timeout: no interval polls anything. */
const noInterval = () => assert.deepEqual([...clock().timers.values()].filter((t) => t.every), [], 'no interval on the clock');

describe('one timer per engine: alarms, drains and routine deadlines with no poll', function () {
  let delivered;
  const to = (id) => delivered.filter((d) => d.nodeId === id).map((d) => d.msg);

  beforeEach(async function () {
    await new Promise((resolve) => startServer(resolve));
    delivered = trackDeliveries();
  });

  afterEach(async function () {
    stopPanels();
    untrackCompletions();
    await stopServer();
  });

  it('raises a stale-feedback alarm when the plant\'s timer wakes at the staleness deadline, with no poll', async function () {
    await helper.load(paletteNodes, flowOf());
    fakePanel(helper, plantDocument());
    await quiet();
    noInterval();
    const due = plant().deadline.at;
    assert.equal(due, clock().now() + STALE_MS, 'the plant\'s one timer is at the staleness deadline');
    await clock().advance(due - clock().now() - 1);
    await quiet();
    assert.equal(alarm('device-stale:ctrl-1'), undefined, 'not before its deadline');
    await clock().advance(1);
    await quiet();
    const raised = alarm('device-stale:ctrl-1');
    assert.ok(raised, 'raised at the deadline, by the plant telling its interlock');
    assert.equal(raised.state, 'active-unacknowledged');
    assert.match(raised.text, /stale feedback from V201, V202, V501/);
    noInterval();
    // Fresh feedback clears the condition: the feedback msg's answer says so, no poll needed.
    helper.getNode('bus').receive({ topic: 'ctrl-1/state', payload: { ts: clock().now(), valve: { 3: 0, 4: 0, 5: 0 } } });
    await quiet();
    assert.equal(runtime().core.alarmIds().includes('device-stale:ctrl-1'), true, 'kept until acknowledged');
    assert.notEqual(alarm('device-stale:ctrl-1').state, 'active-unacknowledged', 'its condition is over');
  });

  it('raises the bus-disconnected alarm when an actuators node\'s broker goes down, and clears it when it comes back', async function () {
    await helper.load([...paletteNodes, fakeBroker], flowOf(plantDocument(), { broker: true }));
    fakePanel(helper, plantDocument());
    const broker = helper.getNode('brk');
    await runFor(helper, 300);
    assert.equal(plant().buses[0].connected, true);
    broker.connected = false;
    // The plant looks at its brokers on its own timer; the alarm's on-delay is the engine's.
    await runUntil(helper, () => alarm('bus-disconnected:bus'), 'the bus-disconnected alarm', { step: 100, maxMs: 11000 });
    assert.equal(alarm('bus-disconnected:bus').state, 'active-unacknowledged');
    noInterval();
    broker.connected = true;
    await runUntil(helper, () => alarm('bus-disconnected:bus').state !== 'active-unacknowledged', 'the condition to end', { step: 50, maxMs: 1000 });
    noInterval();
  });

  /**
   * Deploys a changed plant document: it drains until `ended` holds (the last
   * run or command ended), and the drain is over then, with no clock time more.
   */
  async function drainUntil(ended, what) {
    const changed = plantDocument();
    changed.operations[0].description = 'rinse again';
    await helper.setFlows(flowOf(changed), 'full');
    await quiet();
    assert.equal(runtime().gateOpen, false, 'draining');
    noInterval();
    await runUntil(helper, ended, what, { step: 5 });
    const endedAt = clock().now();
    await quiet();
    assert.equal(clock().now(), endedAt, 'no clock time passed');
    assert.equal(runtime().gateOpen, true, 'the drain ended with it, not on a later look');
    assert.equal(plant().plant.operations[0].description, 'rinse again', 'the new document is in force');
  }

  it('ends a deploy\'s drain when the last run releases, without waiting for any timer', async function () {
    await helper.load(paletteNodes, flowOf());
    fakePanel(helper, plantDocument());
    await quiet();
    helper.getNode('op20').receive({ topic: 'rinse', payload: 20 });
    await quiet();
    assert.equal(runtime().describe().runs.length, 1);
    await drainUntil(() => runtime().runs.size === 0, 'op 20 to end');
    assert.equal(to('out').length, 1);
  });

  it('ends a deploy\'s drain when the last group command in flight completes', async function () {
    await helper.load(paletteNodes, flowOf());
    fakePanel(helper, plantDocument());
    await quiet();
    helper.getNode('bus').receive({ topic: 'by hand', payload: { valves: { V202: 40 } } });
    await quiet();
    assert.equal(plant().quiescent(), false, 'a group command in flight');
    await drainUntil(() => plant().quiescent(), 'the command to complete');
  });

  it('checks a routine\'s condition at the core\'s deadline through the interlock\'s one engine timer', async function () {
    await helper.load(paletteNodes, flowOf());
    fakePanel(helper, plantDocument());
    sensor(helper, 50);
    await quiet();
    const host = runtime().routines.get('silo');
    // Checked at start (no value yet); sampled since: due everyMs after that check.
    await runFor(helper, 100);
    sensor(helper, 150);
    await quiet();
    const due = host.dueAt;
    assert.equal(typeof due, 'number');
    assert.ok(due > clock().now(), 'due later, not at once');
    assert.equal(runtime().carrier.timerAt, due, 'the interlock\'s one timer is at the routine\'s deadline');
    assert.equal(clock().timers.size, [plant().deadline, runtime().carrier.timer].filter(Boolean).length + (runtime().statusPacer.timer ? 1 : 0),
      'no timer of the routine\'s own');
    await clock().advance(due - clock().now() - 1);
    await quiet();
    assert.deepEqual(to('rt').map((m) => m.payload.event), [], 'not before its deadline');
    await clock().advance(1);
    await quiet();
    assert.deepEqual(to('rt').map((m) => [m.payload.event, m.payload.operation]), [['dispatched', '51']], 'fired at its deadline');
    noInterval();
  });

  it('keeps no routine deadline while its interlock drains: a sample then arms no timer, and the condition is checked once the drain ended', async function () {
    await helper.load(paletteNodes, flowOf());
    fakePanel(helper, plantDocument());
    sensor(helper, 50);
    await quiet();
    await runFor(helper, 100);
    // A run keeps a deploy's drain open until it ends.
    helper.getNode('op20').receive({ topic: 'rinse', payload: 20 });
    await quiet();
    const changed = plantDocument();
    changed.operations[0].description = 'rinse again';
    await helper.setFlows(flowOf(changed), 'full');
    await quiet();
    assert.equal(runtime().gateOpen, false, 'draining');
    const host = runtime().routines.get('silo');
    sensor(helper, 150); // the silo's condition holds now
    await quiet();
    assert.equal(host.dueAt, undefined, 'no deadline while draining');
    assert.deepEqual(to('rt').map((m) => m.payload.event), [], 'nothing fired');
    await runUntil(helper, () => runtime().gateOpen, 'the drain to end', { step: 5 });
    // The new document's sensors start empty: the next sample makes the condition hold again.
    sensor(helper, 150);
    await runUntil(helper, () => to('rt').length > 0, 'the condition checked', { step: 50, maxMs: 2000 });
    assert.deepEqual(to('rt').map((m) => [m.payload.event, m.payload.operation]), [['dispatched', '51']], 'fired once the drain ended');
  });
});
