'use strict';
// Actuator nodes with MQTT-shaped msgs fed straight in (no broker): plant
// config, actuators bus and group command, against the wasm tracker, on the
// manual clock (the tracker checks each threshold when it falls due on it).
const assert = require('node:assert/strict');
const path = require('path');
const helper = require('node-red-node-test-helper');
const {
  PALETTE, paletteNodes, linkNodes, TAB, sinkNode, collect, until, trackCompletions, untrackCompletions, startServer, stopServer, settled, clock, settings,
} = require('./support');

const { actuatorText, MAX_STATUS_LENGTH } = require(path.join(PALETTE, 'lib', 'host', 'status.js'));

helper.init(require.resolve('node-red'));

// Short thresholds so retries and escalation happen within a test.
const PLANT = {
  name: 'test plant',
  actuatorTypes: {
    valve: {
      signal: 'analog', unit: '%', min: 0, max: 100, tolerance: 3, noMotionMs: 300, completionMs: 3000, staleMs: 60000, retries: 1,
    },
    pump: { signal: 'binary', noMotionMs: 300, completionMs: 3000, staleMs: 60000, retries: 1 },
  },
  devices: [
    { id: 'ctrl-1', kind: 'actuator-panel' },
    { id: 'ctrl-2', kind: 'actuator-panel' },
    { id: 'station-2', kind: 'sensor-station' },
  ],
  actuators: [
    { id: 'V12', type: 'valve', device: 'ctrl-1', io: 12, idle: 0, lockout: 0 },
    { id: 'V13', type: 'valve', device: 'ctrl-1', io: 13, idle: 0, lockout: 0 },
    { id: 'P1', type: 'pump', device: 'ctrl-1', io: 1, idle: false, lockout: false },
    { id: 'V21', type: 'valve', device: 'ctrl-2', io: 1, idle: 0, lockout: 0 },
  ],
  sensors: [{ id: 'LT-2', device: 'station-2', name: 'volume', unit: 'L' }],
};

const SINKS = ['mqtt', 'ret', 'ev', 'out', 'caught'];

function plantConfig(plant = PLANT) {
  return { id: 'pl', type: 'sugarshack-plant', name: 'test plant', plant };
}

function bus(extra = {}) {
  return { id: 'bus', z: 'f1', type: 'sugarshack-actuators', plant: 'pl', devices: '', wires: [['mqtt'], ['ret'], ['ev']], ...extra };
}

function groupCommand(extra = {}) {
  return { id: 'gc', z: 'f1', type: 'sugarshack-group-command', plant: 'pl', timeout: 0, wires: [['out']], ...extra };
}

const catchAll = { id: 'c1', z: 'f1', type: 'catch', scope: null, uncaught: false, wires: [['caught']] };

async function start({ plant = PLANT, busProps = {}, gcProps = {}, extra = [] } = {}) {
  await helper.load([...paletteNodes, linkNodes], [
    TAB, plantConfig(plant), bus(busProps), groupCommand(gcProps), catchAll, ...SINKS.map(sinkNode), ...extra,
  ]);
  const seen = {};
  for (const id of SINKS) seen[id] = collect(helper, id);
  return seen;
}

/** A panel batch as ctrl-1 publishes it: {"ts", "valve": {"12": 0}, "pump": {"1": false}}. */
function panel(values, { device = 'ctrl-1', ts = clock().now(), target = 'bus' } = {}) {
  helper.getNode(target).receive({ topic: `${device}/state`, payload: JSON.stringify({ ts, ...values }), qos: 0, retain: false });
}

const atRest = () => panel({ valve: { 12: 0, 13: 0 }, pump: { 1: false } });

const command = (payload, extra = {}) => helper.getNode('gc').receive({ payload, ...extra });

const statusCalls = (id) => helper.getNode(id).status.getCalls().filter((c) => c.thisValue.id === id).map((c) => c.args[0]);
const lastStatus = (id) => statusCalls(id).at(-1);
const warnings = (id) => helper.getNode(id).warn.getCalls().filter((c) => c.thisValue.id === id).map((c) => String(c.args[0]));
const errors = (id) => helper.getNode(id).error.getCalls().filter((c) => c.thisValue.id === id).map((c) => String(c.args[0]));
const events = (seen, kind) => seen.ev.filter((m) => m.topic.startsWith(`actuator/${kind}/`)).map((m) => m.payload);
/** Lets what the msgs given so far set off run to its end, without time passing. */
const quiet = () => settled(helper, 'pl');

// Two actuators with three problems: an unknown device, io 0, a lockout out of range.
const BROKEN_ACTUATORS = [
  { id: 'V12', type: 'valve', device: 'ctrl-9', io: 12, idle: 0, lockout: 0 },
  { id: 'V13', type: 'valve', device: 'ctrl-1', io: 0, idle: 0, lockout: 200 },
];

describe('sugarshack actuator nodes', function () {
  beforeEach(startServer);

  afterEach(async function () {
    untrackCompletions();
    await stopServer();
  });

  it('runs a group command end to end: publish, motion, completion, then the same msg returns with its stats', async function () {
    const completions = trackCompletions();
    const seen = await start();
    atRest();
    const msg = { payload: { valves: { V12: 100 } }, _linkSource: [{ id: 'x', node: 'caller' }] };
    helper.getNode('gc').receive(msg);
    await until(() => seen.mqtt.length === 1, 'the command publish');
    assert.deepEqual(seen.mqtt[0], { topic: 'ctrl-1/valve/12/command', payload: '100', retain: false, qos: 1, _msgid: seen.mqtt[0]._msgid });
    assert.equal(lastStatus('bus').text, 'moving 1');

    await clock().advance(120);
    panel({ valve: { 12: 40, 13: 0 }, pump: { 1: false } });
    await until(() => events(seen, 'moving').length === 1, 'the moving event');
    assert.equal(seen.out.length, 0, 'the msg waits while V12 moves');
    assert.equal(completions.some((c) => c.msgid === msg._msgid), false, 'a held msg is not done yet');

    await clock().advance(1000);
    panel({ valve: { 12: 99, 13: 0 }, pump: { 1: false } });
    await until(() => seen.out.length === 1, 'the return');
    assert.equal(seen.out[0], msg, 'the very msg object that came in goes on');
    assert.deepEqual(seen.out[0]._linkSource, [{ id: 'x', node: 'caller' }]);
    const { command: stats } = seen.out[0];
    assert.equal(stats.completionMs, 1120);
    assert.deepEqual(stats.actuators, [{ actuator: 'V12', target: 100, issueToMotionMs: 120, completionMs: 1120, retries: 0 }]);
    await until(() => completions.some((c) => c.nodeId === 'gc' && c.msgid === msg._msgid), 'done of the command');
    assert.equal(completions.find((c) => c.nodeId === 'gc' && c.msgid === msg._msgid).error, undefined);
    assert.equal(seen.caught.length, 0);
    assert.equal(seen.mqtt.length, 1, 'no retry was needed');
    assert.equal(lastStatus('bus').text, 'stopped 1');
    assert.equal(lastStatus('bus').fill, 'green');
  });

  it('returns only once both actuators of the group have completed', async function () {
    const seen = await start();
    atRest();
    command({ valves: { V12: 100 }, pumps: { P1: true } });
    await until(() => seen.mqtt.length === 2, 'two publishes');
    assert.deepEqual(seen.mqtt.map((m) => [m.topic, m.payload, m.retain]), [
      ['ctrl-1/valve/12/command', '100', false],
      ['ctrl-1/pump/1/command', 'ON', false],
    ]);
    panel({ valve: { 12: 100, 13: 0 }, pump: { 1: false } });
    await until(() => events(seen, 'completed').length === 1, 'V12 completed');
    await quiet();
    assert.equal(seen.out.length, 0, 'P1 has not started yet');
    panel({ valve: { 12: 100, 13: 0 }, pump: { 1: true } });
    await until(() => seen.out.length === 1, 'the return');
    assert.deepEqual(seen.out[0].command.actuators.map((a) => [a.actuator, a.target]), [['V12', 100], ['P1', 1]]);
  });

  it('a command given to the actuators node returns on its second output', async function () {
    const seen = await start();
    atRest();
    const msg = { topic: 'open', payload: '{"valves":{"V13":50}}' };
    helper.getNode('bus').receive(msg);
    await until(() => seen.mqtt.length === 1, 'the publish');
    assert.equal(seen.mqtt[0].payload, '50');
    panel({ valve: { 12: 0, 13: 51 } });
    await until(() => seen.ret.length === 1, 'the return on output 2');
    assert.equal(seen.ret[0], msg);
    assert.equal(seen.out.length, 0);
  });

  it('refuses a second command to an actuator still moving, sending nothing', async function () {
    const seen = await start();
    atRest();
    command({ valves: { V12: 100 } });
    await until(() => seen.mqtt.length === 1, 'the first publish');
    command({ valves: { V12: 50, V13: 20 } });
    await until(() => seen.caught.length === 1, 'the refusal at the Catch node');
    assert.equal(seen.caught[0].error.code, 'STILL_MOVING');
    assert.match(seen.caught[0].error.message, /V12.*still carrying out a command/);
    await quiet();
    assert.equal(seen.mqtt.length, 1, 'nothing more was sent, not even for V13');
    assert.deepEqual(lastStatus('gc'), { fill: 'red', shape: 'ring', text: 'still moving' });
  });

  it('refuses unknown actuators and out-of-range targets; the errors reach a Catch node', async function () {
    const seen = await start();
    atRest();
    command({ valves: { V99: 10 } });
    command({ valves: { V12: 150 } });
    command({ pumps: { P1: 'yes' } });
    command({ pumps: { V12: true } });
    command({});
    command('not json');
    await until(() => seen.caught.length === 6, 'six refusals');
    assert.deepEqual(seen.caught.map((m) => m.error.code), [
      'UNKNOWN_ACTUATOR', 'INVALID_TARGET', 'INVALID_TARGET', 'INVALID_GROUP', 'EMPTY_COMMAND', 'INVALID_GROUP',
    ]);
    assert.match(seen.caught[0].error.message, /unknown actuator 'V99'/);
    assert.match(seen.caught[1].error.message, /V12.*0\.\.100, got 150/);
    await quiet();
    assert.equal(seen.mqtt.length, 0, 'nothing was sent');
    assert.equal(seen.out.length, 0);
    assert.equal(lastStatus('gc').shape, 'ring');
    assert.equal(lastStatus('gc').fill, 'red');
  });

  it('issues a lockout from a fault node retained, taking over an actuator still moving', async function () {
    const seen = await start();
    atRest();
    command({ valves: { V12: 100 } });
    await until(() => seen.mqtt.length === 1, 'the first publish');
    panel({ valve: { 12: 30, 13: 0 }, pump: { 1: false } });
    // The shape the interlock's fault node emits on its second output.
    const lockout = { topic: 'lockout/YEL', payload: { valves: { V12: 0, V13: 0 }, pumps: { P1: false } }, resource: 'YEL', operation: '12', note: null };
    const faultAtMs = clock().now() - 250;
    command(lockout.payload, { topic: lockout.topic, resource: 'YEL', faultAtMs });
    await until(() => seen.caught.length === 1, 'the taken-over command fails');
    assert.equal(seen.caught[0].error.code, 'LOCKED_OUT');
    assert.match(seen.caught[0].error.message, /valve V12 was taken over by a lockout command/);
    assert.equal(seen.caught[0].command.failed.actuator, 'V12');
    const retained = seen.mqtt.slice(1);
    assert.deepEqual(retained.map((m) => [m.topic, m.payload, m.retain]), [
      ['ctrl-1/valve/12/command', '0', true],
      ['ctrl-1/valve/13/command', '0', true],
      ['ctrl-1/pump/1/command', 'OFF', true],
    ]);
    // V13 and P1 are already there; V12 comes back to 0 and the lockout returns.
    await clock().advance(40);
    panel({ valve: { 12: 0, 13: 0 }, pump: { 1: false } });
    await until(() => seen.out.length === 1, 'the lockout returns');
    assert.equal(seen.out[0].topic, 'lockout/YEL');
    const { faultLockoutMs, completionMs } = seen.out[0].command;
    assert.equal(completionMs, 40);
    assert.equal(faultLockoutMs, 290, 'from the fault to the lockout completed');

    // A later normal command first clears the retained lockout on the broker.
    command({ valves: { V13: 10 } });
    await until(() => seen.mqtt.length === 6, 'clear and command');
    assert.deepEqual(seen.mqtt.slice(4).map((m) => [m.topic, m.payload, m.retain]), [
      ['ctrl-1/valve/13/command', '', true],
      ['ctrl-1/valve/13/command', '10', false],
    ]);
  });

  it('msg.lockout = true, or a lockout topic on the actuators node, also issues a retained lockout', async function () {
    const seen = await start();
    atRest();
    command({ valves: { V12: 0 } }, { lockout: true });
    await until(() => seen.mqtt.length === 1 && seen.out.length === 1, 'publish and return');
    assert.equal(seen.mqtt[0].retain, true);
    // On the actuators node too, whatever the resource is called.
    helper.getNode('bus').receive({ topic: 'lockout/state', payload: { pumps: { P1: false } } });
    await until(() => seen.ret.length === 1, 'the lockout returns on output 2');
    assert.deepEqual([seen.mqtt[1].topic, seen.mqtt[1].payload, seen.mqtt[1].retain], ['ctrl-1/pump/1/command', 'OFF', true]);
  });

  it('a command to a device that speaks another profile fails saying so, not that the valve did not move', async function () {
    const seen = await start();
    // ctrl-1 is ESPHome firmware while the document says sugarshack: its status reads, its states do not.
    const esphome = (topic, payload) => helper.getNode('bus').receive({ topic: `ctrl-1/${topic}`, payload, qos: 0, retain: false });
    esphome('status', 'online');
    esphome('valve/v12/position/state', '0');
    command({ valves: { V12: 100 } });
    await clock().advance(1000);
    await until(() => seen.caught.length === 1, 'the escalated error');
    assert.equal(seen.caught[0].error.code, 'COMMAND_FAILED');
    assert.ok(seen.caught[0].error.message.endsWith("valve V12 never reported a position within 0.3 s of its command (after 1 retry): its device ctrl-1 is online but nothing it sent reads as V12's position: does ctrl-1 speak profile 'sugarshack', as the plant document says?"), seen.caught[0].error.message);
    // ctrl-2 never said a word.
    command({ valves: { V21: 100 } });
    await clock().advance(1000);
    await until(() => seen.caught.length === 2, 'the second error');
    assert.match(seen.caught[1].error.message, /valve V21 never reported a position .*: nothing has come from its device ctrl-2 since the start: is ctrl-2 connected to this broker/);
  });

  it('retries a command without motion, then escalates: the error reaches a Catch node', async function () {
    const seen = await start();
    atRest();
    command({ valves: { V12: 100 } });
    await quiet();
    // No motion within 300 ms: seen when that window ends (the plant's timer is set for it), and the command sent again.
    await clock().advance(299);
    assert.equal(seen.mqtt.length, 1, 'no retry before the no-motion window ends');
    await clock().advance(1);
    await until(() => seen.mqtt.length === 2, 'the retry publish');
    assert.deepEqual(seen.mqtt.map((m) => [m.topic, m.payload]), [['ctrl-1/valve/12/command', '100'], ['ctrl-1/valve/12/command', '100']]);
    assert.deepEqual(events(seen, 'retry')[0], {
      kind: 'retry', actuator: 'V12', caller: events(seen, 'retry')[0].caller, attempt: 1, fault: 'no-motion', msgid: events(seen, 'retry')[0].msgid,
    });
    // The retry's window ends at 600 ms, when it escalates.
    await clock().advance(299);
    assert.equal(seen.caught.length, 0, 'the retry has its own window');
    await clock().advance(1);
    await until(() => seen.caught.length === 1, 'the escalated error');
    const { error } = seen.caught[0];
    assert.equal(error.code, 'COMMAND_FAILED');
    assert.match(error.message, /valve V12 did not move within 0\.3 s of its command \(after 1 retry\)/);
    assert.deepEqual(seen.caught[0].command.failed, { actuator: 'V12', device: 'ctrl-1', fault: 'no-motion', retries: 1 });
    assert.deepEqual(events(seen, 'fault').map((f) => [f.actuator, f.fault]), [['V12', 'no-motion']]);
    assert.equal(seen.out.length, 0, 'a failed command does not return');
    assert.equal(lastStatus('bus').fill, 'red');
    assert.equal(lastStatus('gc').text, 'command failed');
  });

  it('fails a command whose device goes offline, and shows the offline device as a ring', async function () {
    const seen = await start();
    atRest();
    command({ valves: { V12: 100 } });
    await until(() => seen.mqtt.length === 1, 'the publish');
    helper.getNode('bus').receive({ topic: 'ctrl-1/status', payload: 'offline', retain: true });
    await until(() => seen.caught.length === 1, 'the error');
    assert.equal(seen.caught[0].error.code, 'COMMAND_FAILED');
    assert.match(seen.caught[0].error.message, /valve V12 cannot complete its command: its device ctrl-1 went offline/);
    assert.deepEqual(events(seen, 'deviceStatus'), [{ kind: 'deviceStatus', device: 'ctrl-1', online: false }]);
    assert.equal(lastStatus('bus').shape, 'ring');
    assert.equal(lastStatus('bus').fill, 'red');

    command({ valves: { V13: 100 } });
    await until(() => seen.caught.length === 2, 'refused while offline');
    assert.equal(seen.caught[1].error.code, 'DEVICE_OFFLINE');

    // Back online: the core resends the last commanded state.
    helper.getNode('bus').receive({ topic: 'ctrl-1/status', payload: Buffer.from('online') });
    await until(() => events(seen, 'deviceStatus').length === 2, 'back online');
    assert.equal(events(seen, 'deviceStatus')[1].online, true);
    assert.equal(seen.mqtt.at(-1).topic, 'ctrl-1/valve/12/command');
    assert.equal(lastStatus('bus').shape, 'dot');
  });

  it('ignores malformed feedback with a warning per topic and reason, counts it, and leaves the rest unaffected', async function () {
    const completions = trackCompletions();
    const seen = await start();
    atRest();
    command({ valves: { V12: 100 } });
    await until(() => seen.mqtt.length === 1, 'the publish');
    const b = helper.getNode('bus');
    const bad = [
      { topic: 'ctrl-1/state', payload: '{"ts": 1, "valve": {"12": ' }, // cut off
      { topic: 'ctrl-1/state', payload: '{"ts": 1, "valve": {"12": ' }, // same again: counted, not warned again
      { topic: 'ctrl-1/state', payload: { ts: 1, valve: { 12: 50, 13: 'abc' } } }, // V13 bad, V12 fine (parsed by auto-detect)
      { topic: 'ctrl-1/valve/13/state', payload: '{"ts": 1, "value": "x"}' },
      { topic: 'ctrl-1/pump/1/state', payload: { ts: 1, value: 0.5 } }, // the core refuses: not a pump state
      { topic: 'ctrl-9/state', payload: '{"valve": {"1": 3}}' }, // not in the plant
      { topic: 'ctrl-1/status', payload: 'maybe' },
      { topic: 'ctrl-1/state', payload: [1, 2] },
    ];
    for (const m of bad) b.receive(m);
    await until(() => events(seen, 'malformed').length === 7, () => `malformed events ${JSON.stringify(events(seen, 'malformed'))}`);
    assert.deepEqual(events(seen, 'malformed').map((m) => [m.reason, m.count]), [
      ['bad JSON', 1], ['bad JSON', 2], ['non-numeric value', 3], ['non-numeric value', 4],
      ['unknown device', 6], ['bad status', 7], ['not an object', 8],
    ]);
    // A value the core refuses for this actuator is a rejected sample, counted the same way.
    assert.deepEqual(events(seen, 'rejected'), [{
      kind: 'rejected', actuator: 'P1', code: 'INVALID_FEEDBACK', message: "feedback 0.5 for 'P1' is not a valid state", topic: 'ctrl-1/pump/1/state', count: 5,
    }]);
    const warned = warnings('bus');
    assert.equal(warned.length, 7, warned.join('\n'));
    assert.match(warned[0], /ignored ctrl-1\/state: payload is not JSON/);
    assert.ok(warned.some((w) => /V13|valve 13/.test(w) && /abc/.test(w)), warned.join('\n'));
    assert.ok(warned.some((w) => /ctrl-9/.test(w)));
    // Telemetry, sensor datapoints and our own commands echoed back are not feedback problems.
    b.receive({ topic: 'ctrl-1/telemetry', payload: { ts: 1, uptimeS: 5 } });
    b.receive({ topic: 'station-2/sensor/volume/state', payload: { ts: 1, value: 123 } });
    b.receive({ topic: 'ctrl-1/valve/12/command', payload: 100 });
    b.receive({ topic: 'ctrl-1/valve/7/state', payload: { ts: 1, value: 12 } }); // a slot the plant does not name
    b.receive({ topic: 'ctrl-1/state', payload: { ts: 1, valve: { 7: 12, 12: 50 }, relay: 3 } });
    await quiet();
    assert.equal(events(seen, 'malformed').length + events(seen, 'rejected').length, 8);
    assert.equal(seen.caught.length, 0, 'feedback is telemetry: no errors');
    assert.equal(completions.filter((c) => c.nodeId === 'bus' && c.error).length, 0);
    for (const m of bad) assert.ok(completions.some((c) => c.nodeId === 'bus' && c.msgid === m._msgid), `${m.topic} completed`);
    assert.match(lastStatus('bus').text, /bad 8/);

    // V12 went on moving on the good sample; it completes normally.
    b.receive({ topic: 'ctrl-1/valve/12/state', payload: '{"ts": 2, "value": 100}' });
    await until(() => seen.out.length === 1, 'the return');
  });

  it('reports by exception with metrics: time of flight, issuance to motion, completion', async function () {
    const seen = await start();
    const ts = clock().now() - 40;
    panel({ valve: { 12: 0, 13: 0 }, pump: { 1: false } }, { ts });
    panel({ valve: { 12: 1, 13: 0 }, pump: { 1: false } }, { ts }); // within tolerance: no change reported
    await until(() => events(seen, 'changed').length === 3, 'three changes');
    await quiet();
    assert.equal(events(seen, 'changed').length, 3, 'a value within tolerance is not reported again');
    const changed = events(seen, 'changed');
    assert.deepEqual(changed.map((c) => [c.actuator, c.value]), [['V12', 0], ['V13', 0], ['P1', 0]]);
    assert.deepEqual(changed.map((c) => c.timeOfFlightMs), [40, 40, 40], 'reception minus the device ts');
    assert.equal(seen.ev.find((m) => m.payload.kind === 'changed').topic, 'actuator/changed/V12');

    command({ valves: { V12: 100 } });
    await quiet();
    await clock().advance(60);
    helper.getNode('bus').receive({ topic: 'ctrl-1/valve/12/state', payload: { value: 50 } });
    await clock().advance(30);
    helper.getNode('bus').receive({ topic: 'ctrl-1/valve/12/state', payload: { value: 100 } });
    await until(() => seen.out.length === 1, 'the return');
    const [moving] = events(seen, 'moving');
    const [completed] = events(seen, 'completed');
    assert.equal(moving.actuator, 'V12');
    assert.equal(moving.issueToMotionMs, 60);
    assert.equal(completed.completionMs, 90);
    assert.equal(completed.issueToMotionMs, 60);
    assert.equal(events(seen, 'changed').at(-1).timeOfFlightMs, null, 'no device ts, no time of flight');
    assert.equal(moving.msgid, seen.out[0]._msgid, 'events name the msg they belong to');
  });

  it('times out a command that does not complete, withdrawing it', async function () {
    const seen = await start({ plant: { ...PLANT, actuatorTypes: { ...PLANT.actuatorTypes, valve: { ...PLANT.actuatorTypes.valve, escalation: 'hang' } } }, gcProps: { timeout: 1.5 } });
    atRest();
    command({ valves: { V12: 100, V13: 10 } });
    panel({ valve: { 12: 0, 13: 10 } });
    await quiet();
    await clock().advance(1499);
    assert.equal(seen.caught.length, 0, 'still waiting 1 ms before the timeout');
    await clock().advance(1);
    await until(() => seen.caught.length === 1, 'the timeout');
    assert.equal(seen.caught[0].error.code, 'COMMAND_TIMEOUT');
    assert.match(seen.caught[0].error.message, /within 1\.5 s: V12 had not completed/);
    assert.deepEqual(seen.caught[0].command.waiting, ['V12']);
    assert.ok(events(seen, 'fault').some((f) => f.actuator === 'V12' && f.fault === 'no-motion'), 'hang: faulted, but left for the timeout');
    // Withdrawn: V12 takes a new command.
    command({ valves: { V12: 0 } });
    await until(() => seen.out.length === 1, 'the new command completes at once (V12 is at 0)');
  });

  it('an invalid plant fails every msg and shows "plant invalid"; the log lists every problem', async function () {
    const completions = trackCompletions();
    const broken = {
      ...PLANT,
      actuators: BROKEN_ACTUATORS,
    };
    const seen = await start({ plant: broken });
    const logged = errors('pl');
    assert.equal(logged.length, 1);
    assert.match(logged[0], /invalid plant document \(3 problems\)/);
    assert.match(logged[0], /actuators\[0\] \(V12\): unknown device 'ctrl-9'/);
    assert.match(logged[0], /actuators\[1\] \(V13\): io numbers start at 1/);
    assert.deepEqual(lastStatus('bus'), { fill: 'red', shape: 'ring', text: 'plant invalid' });
    assert.deepEqual(lastStatus('gc'), { fill: 'red', shape: 'ring', text: 'plant invalid' });
    command({ valves: { V12: 100 } });
    panel({ valve: { 12: 0 } });
    await until(() => seen.caught.length === 2, 'both msgs fail');
    assert.deepEqual(seen.caught.map((m) => m.error.code), ['INVALID_PLANT', 'INVALID_PLANT']);
    assert.equal(completions.filter((c) => c.error).length, 2);
    assert.equal(seen.mqtt.length, 0);
  });

  it('an invalid plant is logged once; each msg only fails with done(err), which a Catch node takes (then Node-RED does not log it)', async function () {
    const seen = await start({ plant: { ...PLANT, actuators: [{ id: 'V12', type: 'valve', device: 'ctrl-9', io: 12, idle: 0, lockout: 0 }] } });
    for (let i = 0; i < 3; i++) {
      command({ valves: { V12: 100 } });
      panel({ valve: { 12: 0 } });
    }
    await until(() => seen.caught.length === 6, 'every msg fails');
    const calls = (id, level) => helper.getNode(id)[level].getCalls().filter((c) => c.thisValue.id === id);
    // Node-RED logs each done(err) as node.error(err, msg); anything else would be the palette's own.
    const ofDone = (c) => c.args[1] && typeof c.args[1] === 'object' && c.args[1]._msgid && c.args[0].code === 'INVALID_PLANT';
    for (const id of ['gc', 'bus']) {
      assert.equal(calls(id, 'error').filter(ofDone).length, 3, `${id}: one done(err) per msg`);
      assert.deepEqual(calls(id, 'error').filter((c) => !ofDone(c)).map((c) => String(c.args[0])), [], `${id}: no log of its own`);
      assert.deepEqual(calls(id, 'warn').map((c) => String(c.args[0])), [], `${id}: no warnings`);
    }
    assert.equal(errors('pl').length, 1, 'the document\'s problems, once');
    assert.deepEqual(calls('pl', 'warn'), []);
    assert.ok(seen.caught.every((m) => m.error.code === 'INVALID_PLANT'));
    // With the Catch node in this flow, none of them reaches the log: only the plant's line does.
    const log = helper.log();
    const logged = log.args.map((a) => a[0]).filter((e) => e && e.level === log.ERROR);
    assert.deepEqual(logged.map((e) => e.id), ['pl']);
  });

  it('POST /sugarshack/plant/validate lists every problem with its path, and warnings, as a deploy would find them', async function () {
    await start();
    const validate = (plant) => helper.request().post('/sugarshack/plant/validate').send({ plant });
    let res = await validate(PLANT);
    assert.equal(res.status, 200, res.text);
    assert.deepEqual(res.body, { valid: true, errors: [], warnings: [] });
    res = await validate(JSON.stringify(PLANT, null, 2));
    assert.deepEqual(res.body, { valid: true, errors: [], warnings: [] }, 'as typed in the editor');

    res = await validate({
      ...PLANT,
      actuators: BROKEN_ACTUATORS,
    });
    assert.equal(res.status, 200);
    assert.equal(res.body.valid, false);
    assert.deepEqual(res.body.errors.map((e) => e.path), ['actuators[0] (V12)', 'actuators[1] (V13)', 'actuators[1] (V13)']);
    assert.match(res.body.errors[0].message, /^unknown device 'ctrl-9'/);
    assert.match(res.body.errors[1].message, /^io numbers start at 1/);
    assert.match(res.body.errors[2].message, /lockout must be within 0\.\.100, got 200/);

    res = await validate({ ...PLANT, actuatorTypes: { ...PLANT.actuatorTypes, pump: { signal: 'binary' } } });
    assert.deepEqual(res.body.errors, [{ path: 'actuatorTypes.pump', message: 'missing field `noMotionMs`' }]);
    res = await validate('{"devices": [');
    assert.equal(res.body.valid, false);
    assert.match(res.body.errors[0].message, /^it is not valid JSON/);
    res = await validate('');
    assert.match(res.body.errors[0].message, /^it is empty/);
    res = await validate(undefined);
    assert.match(res.body.errors[0].message, /^expected a JSON object/);

    const step = (V12) => ({ command: { valves: { V12 } }, timeoutMs: 1000 });
    res = await validate({
      ...PLANT,
      actuators: PLANT.actuators.map((a) => ({ ...a, resource: 'A' })),
      resources: [{ id: 'A' }],
      operations: [{ id: 'o1', priority: 1, resources: ['A'], steps: [step(100)] }, { id: 'o2', priority: 1, resources: ['A'], steps: [step(0)] }],
    });
    assert.equal(res.body.valid, true, res.text);
    assert.deepEqual(res.body.warnings.map((w) => w.path), ['operations[1] (o2)']);
    assert.match(res.body.warnings[0].message, /priority 1 is also operation 'o1''s/);

    assert.equal(helper.getNode('pl').runtime.state, 'ready', 'the deployed plant is untouched');
  });

  it('a plant that is not JSON is refused with the parse error', async function () {
    const seen = await start({ plant: '{"devices": [' });
    assert.match(errors('pl')[0], /invalid plant document: it is not valid JSON/);
    command({ valves: { V12: 100 } });
    await until(() => seen.caught.length === 1, 'the msg fails');
    assert.equal(seen.caught[0].error.code, 'INVALID_PLANT');
  });

  it('nodes without a plant say so', async function () {
    await helper.load(paletteNodes, [
      TAB, { ...groupCommand(), plant: '' }, catchAll, sinkNode('out'), sinkNode('caught'),
    ]);
    const caught = collect(helper, 'caught');
    command({ valves: { V12: 100 } });
    await until(() => caught.length === 1, 'the error');
    assert.equal(caught[0].error.code, 'NO_PLANT');
    assert.deepEqual(lastStatus('gc'), { fill: 'red', shape: 'ring', text: 'no plant' });
  });

  it('completes held msgs without sending them when the flows stop', async function () {
    const completions = trackCompletions();
    const seen = await start();
    atRest();
    const held = { payload: { valves: { V12: 100 } } };
    helper.getNode('gc').receive(held);
    const heldOnBus = { payload: { valves: { V13: 100 } } };
    helper.getNode('bus').receive(heldOnBus);
    await until(() => seen.mqtt.length === 2, 'both publishes');
    await helper.unload();
    const mine = completions.filter((c) => c.msgid === held._msgid || c.msgid === heldOnBus._msgid);
    assert.equal(mine.length, 2);
    assert.ok(mine.every((c) => c.error === undefined));
    assert.equal(seen.out.length + seen.ret.length, 0);
  });

  it('reports a device no actuators node serves, once, naming it', async function () {
    const seen = await start({ busProps: { devices: 'ctrl-1' } });
    atRest();
    command({ valves: { V21: 100 } });
    command({ valves: { V12: 100 } });
    await until(() => seen.mqtt.length === 1, 'the ctrl-1 publish');
    assert.equal(seen.mqtt[0].topic, 'ctrl-1/valve/12/command');
    const logged = errors('pl');
    assert.equal(logged.length, 1);
    assert.match(logged[0], /no actuators node serves device 'ctrl-2'/);
    // Feedback from a device this node does not serve is refused, not fed.
    panel({ valve: { 1: 20 } }, { device: 'ctrl-2' });
    await until(() => warnings('bus').length === 1, 'the warning');
    assert.match(warnings('bus')[0], /ctrl-2' is not in this node's device list/);
    assert.equal(lastStatus('bus').text, 'moving 1 · bad 1', 'counts only the served devices');
  });

  /** A deploy in progress: the plant's actuators node is not back yet. Returns what brings it back. */
  function deployInProgress() {
    const { runtime } = helper.getNode('pl');
    const busNode = helper.getNode('bus');
    runtime.palette.started = false;
    runtime.bus.remove(busNode);
    return async () => {
      runtime.palette.started = true;
      runtime.bus.add(busNode, null, null);
      await quiet();
    };
  }

  it('publishes waiting for a deploy\'s actuators node keep within nodeMessageBufferMaxLength: past it a warning, and every commanded state goes out again', async function () {
    settings({ nodeMessageBufferMaxLength: 2 });
    const seen = await start();
    atRest();
    await quiet();
    const { runtime } = helper.getNode('pl');
    const actuatorsBack = deployInProgress();
    command({ valves: { V12: 100, V13: 50 }, pumps: { P1: true } });
    await quiet();
    assert.equal(runtime.t.keptPublishes('unsent'), 2, 'two kept, the third past the bound');
    assert.deepEqual(warnings('pl').filter((w) => /publishes wait to go out/.test(w)).length, 1);
    assert.match(warnings('pl').at(-1), /more than 2 publishes wait to go out/);
    await actuatorsBack();
    const last = new Map(seen.mqtt.map((m) => [m.topic, m.payload]));
    assert.deepEqual([...last.keys()].sort(), ['ctrl-1/pump/1/command', 'ctrl-1/valve/12/command', 'ctrl-1/valve/13/command'],
      'the dropped command went out with the states sent again');
    assert.equal(seen.mqtt.length, 5, 'the two kept, then the three commanded states');
  });

  it('with nodeMessageBufferMaxLength past 2^32 - 1 a lockout waiting for a deploy\'s actuators node is kept and goes out', async function () {
    settings({ nodeMessageBufferMaxLength: 2 ** 32 });
    const seen = await start();
    atRest();
    await quiet();
    const { runtime } = helper.getNode('pl');
    const actuatorsBack = deployInProgress();
    runtime.issueLockouts([{ resource: 'L1', command: { pumps: { P1: false } } }]);
    await quiet();
    assert.deepEqual(errors('pl'), [], 'no publish failed to be kept');
    assert.equal(runtime.t.keptPublishes('unsent'), 1, 'the lockout waits');
    await actuatorsBack();
    assert.deepEqual(seen.mqtt.map((m) => [m.topic, m.payload, m.retain]), [['ctrl-1/pump/1/command', 'OFF', true]]);
  });

  it('a lockout waiting past nodeMessageBufferMaxLength is never the publish dropped: it takes an older command\'s place and goes out first', async function () {
    settings({ nodeMessageBufferMaxLength: 1 });
    const seen = await start();
    atRest();
    await quiet();
    const { runtime } = helper.getNode('pl');
    const actuatorsBack = deployInProgress();
    command({ valves: { V12: 100 } });
    await quiet();
    runtime.issueLockouts([{ resource: 'L1', command: { pumps: { P1: false } } }]);
    await quiet();
    assert.match(warnings('pl').at(-1), /more than 1 publishes wait to go out/);
    await actuatorsBack();
    assert.deepEqual(seen.mqtt.map((m) => [m.topic, m.payload, m.retain]), [
      ['ctrl-1/pump/1/command', 'OFF', true],
      // The dropped command: every commanded state and standing lockout goes out again.
      ['ctrl-1/valve/12/command', '100', false],
      ['ctrl-1/pump/1/command', 'OFF', true],
    ]);
  });

  it('a leader waiting for its lease keeps its publishes, a lockout never the one dropped past nodeMessageBufferMaxLength; a standby sends none', async function () {
    settings({ nodeMessageBufferMaxLength: 1 });
    const seen = await start();
    atRest();
    await quiet();
    const { runtime } = helper.getNode('pl');
    // The cluster as the plant reads it: a leader whose lease awaits etcd's answer.
    const cluster = { role: 'suspended', active: true, mayAct: () => cluster.role === 'active' };
    runtime.cluster = cluster;
    command({ valves: { V12: 100 } });
    await quiet();
    runtime.issueLockouts([{ resource: 'L1', command: { pumps: { P1: false } } }]);
    await quiet();
    assert.equal(seen.mqtt.length, 0, 'nothing goes out while the lease is in doubt');
    assert.equal(runtime.t.keptPublishes('held'), 1, 'the lockout in the command\'s place');
    assert.match(warnings('pl').at(-1), /more than 1 publishes wait to go out/);
    cluster.role = 'active';
    runtime.bus.sendWaiting('held'); // as the cluster's `resumed` does
    await quiet();
    assert.deepEqual(seen.mqtt.map((m) => [m.topic, m.payload, m.retain]), [
      ['ctrl-1/pump/1/command', 'OFF', true],
      ['ctrl-1/valve/12/command', '100', false],
      ['ctrl-1/pump/1/command', 'OFF', true],
    ]);
    const warned = warnings('pl').length;
    cluster.role = 'standby';
    cluster.active = false;
    runtime.issueLockouts([{ resource: 'L1', command: { pumps: { P1: false } } }]);
    await quiet();
    assert.equal(seen.mqtt.length, 3, 'a standby publishes nothing');
    assert.equal(runtime.t.keptPublishes('held') + runtime.t.keptPublishes('unsent'), 0, 'nor keeps it');
    assert.equal(warnings('pl').length, warned);
  });

  it('routes each device to the actuators node that serves it', async function () {
    const seen = await start({
      busProps: { devices: 'ctrl-1' },
      extra: [
        { id: 'bus2', z: 'f1', type: 'sugarshack-actuators', plant: 'pl', devices: 'ctrl-2, station-2', wires: [['mqtt2'], [], ['ev2']] },
        sinkNode('mqtt2'), sinkNode('ev2'),
      ],
    });
    const mqtt2 = collect(helper, 'mqtt2');
    const ev2 = collect(helper, 'ev2');
    atRest();
    panel({ valve: { 1: 0 } }, { device: 'ctrl-2', target: 'bus2' });
    command({ valves: { V12: 100, V21: 100 } });
    await until(() => seen.mqtt.length === 1 && mqtt2.length === 1, 'one publish each');
    assert.equal(mqtt2[0].topic, 'ctrl-2/valve/1/command');
    panel({ valve: { 1: 100 } }, { device: 'ctrl-2', target: 'bus2' });
    panel({ valve: { 12: 100 } });
    await until(() => seen.out.length === 1, 'the return');
    assert.ok(ev2.some((m) => m.topic === 'actuator/completed/V21'));
    assert.ok(!seen.ev.some((m) => m.topic === 'actuator/completed/V21'));
  });

  it('keeps every status under 20 characters', async function () {
    const values = [0, 1, 9, 14, 99, 100, 999, 1000, 12345, 999999, 1e6, 12345678, 1e9, 2 ** 32];
    for (const faulted of values) {
      for (const moving of values) {
        for (const stopped of values) {
          for (const bad of [0, 1, 123456, 2 ** 32]) {
            const text = actuatorText({ moving, stopped, faulted, bad });
            assert.ok(text.length <= MAX_STATUS_LENGTH, `${faulted}/${moving}/${stopped}/${bad}: "${text}"`);
          }
        }
      }
    }
    assert.equal(actuatorText({ moving: 2, stopped: 14, faulted: 1 }), 'flt 1·mov 2·stop 14');
    assert.equal(actuatorText({ stopped: 14 }), 'stopped 14');
    assert.equal(actuatorText({ moving: 2, stopped: 14 }), 'mov 2 · stop 14');
    assert.equal(actuatorText({}), 'idle');

    const seen = await start();
    atRest();
    command({ valves: { V12: 100 } });
    command({ valves: { V99: 100 } });
    helper.getNode('bus').receive({ topic: 'ctrl-1/state', payload: 'junk' });
    await until(() => seen.caught.length === 1, 'the refusal');
    for (const id of ['bus', 'gc']) {
      for (const s of statusCalls(id)) assert.ok(s.text.length < 20, `${id}: "${s.text}"`);
    }
  });
});
