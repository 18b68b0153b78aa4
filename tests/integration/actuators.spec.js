'use strict';
// The actuator nodes in Node-RED with the core mqtt in/out nodes, against a
// real Mosquitto and the plant simulator on the small fixture plant.
// Run: npx mocha --timeout 30000 --exit 'tests/integration/**/*.spec.js'
const assert = require('node:assert/strict');
const path = require('path');
const helper = require('node-red-node-test-helper');
const { startMosquitto } = require('./support/mosquitto');
const { connectProbe } = require('./support/mqtt-probe');
const { startTestSimulator, SMALL_PLANT } = require('./support/simulator');
const { loadPlant } = require('../../scripts/simulator/plant');
const {
  TAB, sinkNode, startRealTimeServer, settings, collect, sleep, until,
} = require('../flow/support');

helper.init(require.resolve('node-red'));
const { PALETTE_AND_MQTT, busNodes, actuatorEvents, stopAll } = require('./support/mqtt-nodes');
const { mqttBroker } = require('./support/node-red');


const PLANT = loadPlant(SMALL_PLANT);
const { noMotionMs, staleMs } = PLANT.actuatorTypes.valve; // 4 s, 5 s
const SINKS = ['ret', 'ev', 'out', 'caught'];

function flow(port) {
  return [
    TAB,
    { id: 'pl', type: 'sugarshack-plant', name: 'small plant', plant: PLANT },
    mqttBroker('br', port),
    {
      id: 'min', z: 'f1', type: 'mqtt in', name: '', topic: 'ctrl-1/#', qos: '1', datatype: 'auto-detect', broker: 'br',
      nl: false, rap: true, rh: 0, inputs: 0, wires: [['bus']],
    },
    // Topics of a device the plant does not have, to see them refused.
    {
      id: 'min9', z: 'f1', type: 'mqtt in', name: '', topic: 'ctrl-9/#', qos: '1', datatype: 'auto-detect', broker: 'br',
      nl: false, rap: true, rh: 0, inputs: 0, wires: [['bus']],
    },
    ...busNodes(),
    { id: 'c1', z: 'f1', type: 'catch', scope: null, uncaught: false, wires: [['caught']] },
    ...SINKS.map(sinkNode),
  ];
}

const warnings = (id) => helper.getNode(id).warn.getCalls().filter((c) => c.thisValue.id === id).map((c) => String(c.args[0]));
const command = (payload) => helper.getNode('gc').receive({ payload });
const lastStatus = (id) => helper.getNode(id).status.getCalls().filter((c) => c.thisValue.id === id).at(-1).args[0];

describe('actuator nodes on Mosquitto with the plant simulator', function () {
  this.timeout(30000);
  let broker;
  let sim;
  let probe;
  let seen;

  /** Broker, simulator, then Node-RED; resolves once the tracker has the panel's first batch. */
  async function start(simOptions = {}) {
    broker = await startMosquitto();
    sim = await startTestSimulator(broker.url, simOptions);
    probe = await connectProbe(broker.url, ['ctrl-1/+/+/command']);
    await new Promise((resolve) => startRealTimeServer(resolve));
    settings({ mqttReconnectTime: 300 });
    await helper.load(PALETTE_AND_MQTT, flow(broker.port));
    seen = {};
    for (const id of SINKS) seen[id] = collect(helper, id);
    await until(() => actuatorEvents(seen, 'changed', 'V101').length > 0 && actuatorEvents(seen, 'changed', 'P1').length > 0, 'the first panel batch', 5000);
  }

  afterEach(async function () {
    await stopAll({ probe, sim, broker });
    [broker, sim, probe] = [null, null, null];
  });

  it('runs a group command end to end: command, motion, completion, return', async function () {
    await start();
    const msg = { payload: { valves: { V101: 100, V102: 100 }, pumps: { P1: true } } };
    helper.getNode('gc').receive(msg);
    await until(() => seen.out.length === 1, 'the return', 8000);
    assert.equal(seen.out[0], msg);
    assert.deepEqual(seen.out[0].command.actuators.map((a) => a.actuator).sort(), ['P1', 'V101', 'V102']);
    assert.ok(seen.out[0].command.completionMs > 0);
    assert.equal(seen.caught.length, 0);

    // The simulated panel got the commands over the broker and carried them out.
    assert.deepEqual(probe.on('ctrl-1/+/+/command').map((m) => [m.topic, m.text]).sort(), [
      ['ctrl-1/pump/1/command', 'ON'], ['ctrl-1/valve/1/command', '100'], ['ctrl-1/valve/2/command', '100'],
    ]);
    const panel = sim.devices['ctrl-1'];
    assert.ok(panel.valves[1].position > 96 && panel.valves[2].position > 96);
    assert.equal(panel.pump.running, true);

    // Metrics: issuance to motion, completion, and time of flight from the device timestamps.
    const [moving] = actuatorEvents(seen, 'moving', 'V101');
    const [completed] = actuatorEvents(seen, 'completed', 'V101');
    assert.ok(moving.issueToMotionMs >= 0 && moving.issueToMotionMs <= noMotionMs);
    assert.ok(completed.completionMs >= moving.issueToMotionMs);
    const flights = actuatorEvents(seen, 'changed', 'V101').map((c) => c.timeOfFlightMs);
    assert.ok(flights.every((f) => typeof f === 'number' && f > -50 && f < 1000), `time of flight ${flights}`);

    command({ valves: { V101: 0, V102: 0 }, pumps: { P1: false } });
    await until(() => seen.out.length === 2, 'the close returns', 8000);
    assert.equal(sim.devices['ctrl-1'].pump.running, false);
  });

  it('a broker restart during a command: the command fails on the wills or completes, and the plant works on', async function () {
    await start({ sweepS: 4 });
    command({ valves: { V101: 100 } });
    await until(() => actuatorEvents(seen, 'moving', 'V101').length === 1, 'motion', 5000);
    await broker.restart({ downMs: 1000 });
    await until(() => seen.out.length + seen.caught.length === 1, 'the command to end', 15000);
    const wentOffline = actuatorEvents(seen, 'deviceStatus', 'ctrl-1').some((d) => d.online === false);
    if (wentOffline) {
      // Mosquitto sends its clients' wills as it shuts down: Node-RED hears ctrl-1 go
      // offline, and the core fails the command at once (fail-fast), naming the cause.
      assert.equal(seen.out.length, 0);
      assert.equal(seen.caught[0].error.code, 'COMMAND_FAILED');
      assert.match(seen.caught[0].error.message, /valve V101 cannot complete its command: its device ctrl-1 went offline/);
      await until(() => actuatorEvents(seen, 'deviceStatus', 'ctrl-1').at(-1).online === true, 'ctrl-1 back online', 8000);
      assert.ok(actuatorEvents(seen, 'recovered', 'V101').some((r) => r.fault === 'device-offline'));
    } else {
      // Node-RED's own connection closed before the will reached it: feedback resumes
      // well within staleMs, so nothing failed and the command completes.
      assert.deepEqual(seen.caught.map((m) => m.error.message), []);
      assert.equal(seen.out[0].command.actuators[0].actuator, 'V101');
    }
    // Either way the panel carries out its last command, and the next command completes.
    await until(() => sim.devices['ctrl-1'].valves[1].position === 100, 'V101 open', 8000);
    const tracker = helper.getNode('pl').runtime.t;
    await until(() => tracker.phase(tracker.actuator('V101')) === 'stopped', 'V101 at rest', 5000);
    command({ valves: { V101: 0 } });
    await until(() => seen.out.length === (wentOffline ? 1 : 2), 'the next command', 8000);
  });

  it('fails a command with a stale-feedback error when the panel\'s feedback stops', async function () {
    await start({ sweepS: 8 });
    command({ valves: { V101: 100 } });
    await until(() => actuatorEvents(seen, 'moving', 'V101').length === 1, 'motion', 5000);
    await sim.inject({ fault: 'drop', device: 'ctrl-1', ratio: 1 }); // every datapoint lost, the device still online
    const lost = Date.now();
    await until(() => seen.caught.length === 1, 'the error', staleMs + 3000);
    assert.ok(Date.now() - lost >= staleMs - 1100, 'stale once no sample came for staleMs');
    const { error } = seen.caught[0];
    assert.equal(error.code, 'COMMAND_FAILED');
    assert.match(error.message, /valve V101 sent no feedback for 5 s \(device ctrl-1\)/);
    assert.equal(seen.caught[0].command.failed.fault, 'stale');
    assert.equal(seen.out.length, 0);
    await sim.inject({ fault: 'clear', device: 'ctrl-1' });
    await until(() => actuatorEvents(seen, 'recovered', 'V101').some((r) => r.fault === 'stale'), 'recovery', 5000);
  });

  it('fails a command when its device dies (last will "offline"); the error reaches a Catch node', async function () {
    await start({ sweepS: 4 });
    command({ valves: { V101: 100, V102: 100 } });
    await until(() => actuatorEvents(seen, 'moving', 'V101').length === 1, 'motion', 5000);
    await sim.inject({ fault: 'dead', device: 'ctrl-1' });
    await until(() => seen.caught.length === 1, 'the error', 5000);
    const { error } = seen.caught[0];
    assert.equal(error.code, 'COMMAND_FAILED');
    assert.match(error.message, /valve V10[12] cannot complete its command: its device ctrl-1 went offline/);
    assert.deepEqual(actuatorEvents(seen, 'deviceStatus', 'ctrl-1').at(-1), { kind: 'deviceStatus', device: 'ctrl-1', online: false });
    await until(() => lastStatus('bus').shape === 'ring', 'the offline ring', 2000);

    // A command while it is offline is refused outright.
    command({ valves: { V103: 50 } });
    await until(() => seen.caught.length === 2, 'the refusal');
    assert.equal(seen.caught[1].error.code, 'DEVICE_OFFLINE');

    await sim.inject({ fault: 'revive', device: 'ctrl-1' });
    await until(() => actuatorEvents(seen, 'deviceStatus', 'ctrl-1').at(-1).online === true, 'back online', 5000);
    command({ valves: { V103: 50 } });
    await until(() => seen.out.length === 1, 'a command after the revival completes', 8000);
  });

  it('ignores malformed payloads on feedback topics with a warning, counts them, and other actuators still complete', async function () {
    await start({ sweepS: 2 });
    command({ valves: { V101: 100, V102: 60 } });
    const bad = [
      ['ctrl-1/state', 'not json{'],
      ['ctrl-1/state', '{"ts": 1, "valve": {"3": "abc"}}'],
      ['ctrl-1/valve/4/state', '{"ts": 1, "value": "x"}'],
      ['ctrl-1/pump/1/state', '{"ts": 1, "value": 7}'],
      ['ctrl-1/status', 'rebooting'],
      ['ctrl-9/state', '{"ts": 1, "valve": {"1": 3}}'],
    ];
    for (const [topic, payload] of bad) await probe.publish(topic, payload);
    await until(() => seen.out.length === 1, 'the command completes regardless', 8000);
    await until(() => seen.ev.filter((m) => /^actuator\/(malformed|rejected)\//.test(m.topic)).length >= bad.length, 'bad input events', 3000);
    const reasons = seen.ev.filter((m) => /^(malformed|rejected)$/.test(m.payload.kind)).map((m) => m.payload.reason || m.payload.code);
    for (const reason of ['bad JSON', 'non-numeric value', 'INVALID_FEEDBACK', 'bad status', 'unknown device']) {
      assert.ok(reasons.includes(reason), `${reason} in ${reasons}`);
    }
    const warned = warnings('bus');
    assert.equal(warned.length, bad.length, warned.join('\n'));
    assert.match(lastStatus('bus').text, new RegExp(`bad ${bad.length}`));
    assert.equal(seen.caught.length, 0, 'bad feedback is not an error of any command');

    // The same bad input again is counted but not warned about twice.
    await probe.publish('ctrl-1/state', 'not json{');
    await until(() => seen.ev.filter((m) => /^(malformed|rejected)$/.test(m.payload.kind)).at(-1).payload.count === bad.length + 1, 'the count');
    assert.equal(warnings('bus').length, bad.length);
  });

  it('retries a command to a stuck valve, then escalates: the error reaches a Catch node', async function () {
    await start({ faults: ['stuck:ctrl-1:3'] });
    const started = Date.now();
    command({ valves: { V103: 100, V104: 100 } });
    await until(() => probe.on('ctrl-1/valve/3/command').length === 2, 'the retry publish', noMotionMs + 3000);
    assert.deepEqual(probe.on('ctrl-1/valve/3/command').map((m) => m.text), ['100', '100']);
    assert.equal(probe.on('ctrl-1/valve/4/command').length, 1, 'V104 moved: no retry');
    assert.deepEqual(actuatorEvents(seen, 'retry', 'V103').map((r) => [r.attempt, r.fault]), [[1, 'no-motion']]);
    await until(() => seen.caught.length === 1, 'the escalated error', noMotionMs + 3000);
    assert.ok(Date.now() - started >= 2 * noMotionMs);
    const { error } = seen.caught[0];
    assert.equal(error.code, 'COMMAND_FAILED');
    assert.match(error.message, /valve V103 did not move within 4 s of its command \(after 1 retry\)/);
    assert.deepEqual(actuatorEvents(seen, 'fault', 'V103').map((f) => f.fault), ['no-motion']);
    assert.equal(seen.out.length, 0);
    await sleep(100);
    assert.equal(lastStatus('bus').fill, 'red');
  });
});
