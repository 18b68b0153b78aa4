'use strict';
// A lockout is a standing order. An operation holds line YEL with its valves
// open when the real Mosquitto is killed; while it is away (1 s, then 20 s)
// the operation faults, and its lockout is published into the void (core
// `mqtt out` drops publishes while disconnected). Within a bounded time after
// the broker is back, the simulator's own feedback shows every YEL actuator at
// its lockout state. Mosquitto runs without persistence, so nothing retained
// survives its restart: the palette must send the lockout again itself.
//
// Run: npx mocha --timeout 30000 --exit tests/integration/outage.spec.js
// (OUTAGE_LOG=1 prints how long after the broker's return the line was at its lockout state.)
const assert = require('node:assert/strict');
const helper = require('node-red-node-test-helper');
const { startMosquitto } = require('./support/mosquitto');
const { startTestSimulator } = require('./support/simulator');
const { mqttBroker } = require('./support/node-red');
const { PLANT_FILE, PLANT } = require('./support/routines-flow');
const {
  TAB, sinkNode, collect, until, startRealTimeServer, stopServer, settings,
} = require('../flow/support');

helper.init(require.resolve('node-red'));
const { PALETTE_AND_MQTT } = require('./support/mqtt-nodes');


const YEL = PLANT.actuators.filter((a) => a.resource === 'YEL');
// From the broker's return to every YEL actuator at its lockout state.
const BOUND_MS = 10000;

function flow(port) {
  return [
    TAB,
    { id: 'pl', type: 'sugarshack-plant', name: 'routines plant', plant: PLANT },
    { id: 'il', type: 'sugarshack-interlock', name: 'lines', plant: 'pl', resources: [], policy: 'greedy', persist: true },
    mqttBroker('br', port),
    ...PLANT.devices.map((d) => ({
      id: `in-${d.id}`, z: 'f1', type: 'mqtt in', topic: `${d.id}/#`, qos: '1', datatype: 'auto-detect', broker: 'br', nl: false, rap: true, rh: 0, inputs: 0, wires: [['bus']],
    })),
    { id: 'bus', z: 'f1', type: 'sugarshack-actuators', plant: 'pl', devices: '', broker: 'br', wires: [['mout'], [], ['ev']] },
    { id: 'mout', z: 'f1', type: 'mqtt out', topic: '', qos: '1', retain: '', broker: 'br', wires: [] },
    { id: 'op', z: 'f1', type: 'sugarshack-operation', interlock: 'il', operation: '10', wires: [['done']] },
    { id: 'estop', z: 'f1', type: 'sugarshack-fault', interlock: 'il', mode: 'resources', operation: '', resources: 'YEL', wires: [[], ['bus']] },
    { id: 'clr', z: 'f1', type: 'sugarshack-clear', interlock: 'il', mode: 'all', resources: '', wires: [[]] },
    { id: 'c1', z: 'f1', type: 'catch', scope: ['op'], uncaught: false, wires: [['caught']] },
    ...['ev', 'done', 'caught'].map(sinkNode),
  ];
}

describe('a lockout issued while the MQTT broker is away reaches the devices (Mosquitto killed)', function () {
  this.timeout(120000);
  let broker;
  let sim;

  beforeEach(async function () {
    broker = await startMosquitto();
    sim = await startTestSimulator(broker.url, { plant: PLANT_FILE, speed: 10, sweepS: 1, pumpDelayMs: 200, reconnectMs: 200 });
    await new Promise((resolve) => startRealTimeServer(resolve));
    settings({ mqttReconnectTime: 300 });
    await helper.load(PALETTE_AND_MQTT, flow(broker.port));
  });

  afterEach(async function () {
    await stopServer().catch(() => {});
    if (sim) await sim.stop().catch(() => {});
    if (broker) await broker.stop();
  });

  const panel = () => sim.devices['ctrl-1'];
  const atLockout = () => YEL.every((a) => (a.type === 'pump'
    ? panel().pump.running === Boolean(a.lockout)
    : Math.abs(panel().valves[a.io].position - a.lockout) <= 3));

  /** Runs op 10 until its valves are open, kills the broker for `downMs`, faults the line meanwhile if asked. */
  async function outage(downMs, { estopAfterMs = null } = {}) {
    const caught = collect(helper, 'caught');
    const events = collect(helper, 'ev');
    await until(() => events.some((e) => e.payload.kind === 'changed'), 'the panels reporting', 10000);
    helper.getNode('op').receive({ payload: 'load truck' });
    await until(() => panel().valves[1].position > 96 && panel().valves[2].position > 96, 'V101 and V102 open', 10000);
    assert.equal(atLockout(), false, 'the line is open before the outage');

    const restarting = broker.restart({ downMs });
    if (estopAfterMs !== null) {
      await new Promise((resolve) => setTimeout(resolve, estopAfterMs));
      helper.getNode('estop').receive({ payload: 'e-stop during the outage' });
    }
    await until(() => caught.length === 1, 'the operation faulting during the outage', downMs + 5000);
    const faultedAt = Date.now();
    await restarting;
    const backAt = Date.now();
    assert.ok(faultedAt < backAt, 'the fault (and its lockout) came while the broker was away');
    assert.deepEqual(helper.getNode('il').runtime.faultedResources(), ['YEL']);
    assert.equal(atLockout(), false, 'nothing reached the devices meanwhile');
    await until(atLockout, 'every YEL actuator at its lockout state', BOUND_MS);
    const restoredInMs = Date.now() - backAt;
    if (process.env.OUTAGE_LOG) console.log(`      broker away ${downMs} ms: every YEL actuator at its lockout state ${restoredInMs} ms after it was back`);
    return { caught, events, restoredInMs };
  }

  it('a 1 s outage with an e-stop in it: the lockout arrives once the broker is back', async function () {
    const { caught, restoredInMs } = await outage(1000, { estopAfterMs: 300 });
    assert.match(caught[0].error.message, /operation '10' faulted/);
    assert.ok(restoredInMs < BOUND_MS, `${restoredInMs} ms`);
  });

  it('a 20 s outage in which the operation faults on stale feedback: the lockout arrives once the broker is back', async function () {
    const { caught, events, restoredInMs } = await outage(20000);
    assert.match(caught[0].error.message, /operation '10' faulted .*(no feedback|offline|stale)/s);
    assert.ok(restoredInMs < BOUND_MS, `${restoredInMs} ms`);
    // The broker's return is seen, and the standing lockout is confirmed by feedback.
    await until(() => events.some((e) => e.payload.kind === 'mqtt' && e.payload.connected), 'the mqtt path back');
    await until(() => YEL.every((a) => events.some((e) => e.payload.kind === 'lockoutConfirmed' && e.payload.actuator === a.id)), 'every lockout confirmed');
    assert.equal(helper.getNode('pl').runtime.t.counts().lockoutsPending, 0);
  });
});
