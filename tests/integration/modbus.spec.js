'use strict';
// Modbus with no glue: the palette's actuators node polls and writes a Modbus
// I/O module that no one here wrote, pymodbus's own server (PyPI `pymodbus`,
// installed by scripts/setup.sh), scripted in support/modbus/io_module.py as a
// module with a 4-20 mA valve (command holding 0, feedback input 0) and a pump
// (coil 0, feedback discrete 0) per unit. Over Modbus TCP, RTU frames through
// TCP (a gateway), and RTU on a serial line when socat and the serialport
// package are there (a pty pair stands for the RS-485 adapter):
//   - a group command completes;
//   - a valve whose feedback register does not follow faults after its
//     thresholds, and its line's lockout is written to the module;
//   - the server killed fails the command at once and marks the device
//     offline; its return gets the commanded states and lockouts written again;
//   - one unit that never answers delays another unit's command by no more
//     than its own timeout (same gateway), or not at all (its own connection).
//
// Time: Node-RED runs on the palette's manual clock and the module's valves on
// the test's `advance`; tick() moves both, then waits (bounded) until no request
// is in flight but those to a mute unit.
//
// Run: npx mocha --timeout 30000 --exit tests/integration/modbus.spec.js
const assert = require('node:assert/strict');
const { spawn, execFileSync } = require('child_process');
const fs = require('fs');
const os = require('os');
const path = require('path');
const helper = require('node-red-node-test-helper');
const {
  TAB, paletteNodes, startServer, stopServer, clock, collect, until, settled,
} = require('../flow/support');
const { startIoModule, pymodbusVersion } = require('./support/modbus/io-module');
const { actuatorEvents } = require('./support/mqtt-nodes');
const { stepper, operationAndSinks } = require('./support/stepped');

helper.init(require.resolve('node-red'));

const POLL_MS = 500;
const TIMEOUT_MS = 200;
const PCT = { raw: [4000, 20000], value: [0, 100] };

const TYPES = {
  valve: {
    signal: 'analog', unit: '%', min: 0, max: 100, tolerance: 3, noMotionMs: 2000, completionMs: 8000, staleMs: 3000, retries: 1,
  },
  pump: {
    signal: 'binary', noMotionMs: 2000, completionMs: 4000, staleMs: 3000, retries: 1,
  },
};

/** A Modbus device `id` at unit `unit` of the module on `port` (`framing` tcp or rtu; or a serial line). */
function device(id, { port, unit = 1, framing = 'tcp', serial = null, timeoutMs = TIMEOUT_MS }) {
  const endpoint = serial ? { serial: { path: serial, baudRate: 19200 } } : { host: '127.0.0.1', port, framing };
  return {
    id, kind: 'actuator-panel', profile: 'modbus', modbus: { ...endpoint, unit, pollMs: POLL_MS, timeoutMs, reconnectMs: 1000 },
  };
}

/** The unit's valve and pump, on line `line`. */
function actuators(n, deviceId, line) {
  return [
    {
      id: `V${n}`, type: 'valve', device: deviceId, idle: 0, lockout: 0, resource: line,
      modbus: { command: { kind: 'holding', address: 0, scale: PCT }, feedback: { kind: 'input', address: 0, scale: PCT } },
    },
    {
      id: `P${n}`, type: 'pump', device: deviceId, idle: false, lockout: false, resource: line,
      modbus: { command: { kind: 'coil', address: 0 }, feedback: { kind: 'discrete', address: 0 } },
    },
  ];
}

function plantDocument(devices, sensors = []) {
  return {
    name: 'modbus plant',
    actuatorTypes: TYPES,
    devices,
    actuators: devices.flatMap((d, i) => actuators(i + 1, d.id, i === 0 ? 'YEL' : 'GRN')),
    sensors,
    resources: devices.length > 1 ? [{ id: 'YEL' }, { id: 'GRN' }] : [{ id: 'YEL' }],
    operations: [{
      id: 'fill', priority: 10, resources: ['YEL'],
      steps: [{ command: { valves: { V1: 100 }, pumps: { P1: true } }, timeoutMs: 20000 }],
    }],
  };
}

const SINKS = ['mqtt', 'ret', 'ev', 'out', 'opdone', 'caught'];

function flow(plant) {
  return [
    TAB,
    { id: 'pl', type: 'sugarshack-plant', name: plant.name, plant },
    { id: 'il', type: 'sugarshack-interlock', name: 'lines', plant: 'pl', resources: [], policy: 'greedy', persist: false },
    { id: 'bus', z: 'f1', type: 'sugarshack-actuators', plant: 'pl', devices: '', wires: [['mqtt'], ['ret'], ['ev']] },
    { id: 'gc', z: 'f1', type: 'sugarshack-group-command', plant: 'pl', timeout: 0, wires: [['out']] },
    ...operationAndSinks(SINKS),
  ];
}

const HAVE_PYMODBUS = pymodbusVersion() !== null;
const haveCommand = (cmd) => {
  try {
    execFileSync('sh', ['-c', `command -v ${cmd}`]);
    return true;
  } catch {
    return false;
  }
};
const haveSerialport = () => {
  try {
    require.resolve('serialport');
    execFileSync(process.env.PYTHON || 'python3', ['-c', 'import serial']);
    return true;
  } catch {
    return false;
  }
};

describe('Modbus I/O modules (pymodbus server)', function () {
  this.timeout(60000);
  let modules;
  let seen;
  let muted;

  before(function () {
    if (!HAVE_PYMODBUS) throw new Error('pymodbus is missing: run scripts/setup.sh (pip install pymodbus)');
  });

  async function start(plant) {
    await new Promise((resolve) => startServer(resolve));
    await helper.load(paletteNodes, flow(plant));
    seen = {};
    for (const id of SINKS) seen[id] = collect(helper, id);
    muted = new Set();
    await until(() => transport().connected(), 'the connections to the modules', 5000);
    await tick(POLL_MS);
  }

  const transport = () => helper.getNode('pl').runtime.modbus;
  const command = (payload) => helper.getNode('gc').receive({ payload });

  /** Until no request is in flight but to a mute device: what the last clock step sent has been answered. */
  async function answered() {
    await until(() => transport().inFlight().every((f) => muted.has(f.device)), () => `answers (in flight: ${JSON.stringify(transport().inFlight())})`, 5000);
    await settled(helper, 'il', 'pl');
  }

  /** Moves the modules' valves and Node-RED's clock by `ms`, in slices, each slice's requests answered. */
  const { tick, tickUntil } = stepper({
    advance: async (ms) => {
      for (const m of modules) if (m.running) await m.advance(ms);
    },
    delivered: answered,
  });

  afterEach(async function () {
    await stopServer().catch(() => {});
    for (const m of modules || []) await m.stop();
    modules = null;
  });

  const raw = (percent) => 4000 + percent * 160;

  for (const framing of ['tcp', 'rtu']) {
    it(`a group command completes (${framing === 'tcp' ? 'Modbus TCP' : 'RTU frames through a TCP gateway'})`, async function () {
      const io = await startIoModule({ framing: framing === 'tcp' ? 'socket' : 'rtu' });
      modules = [io];
      await start(plantDocument([device('io-1', { port: io.port, framing })]));
      const msg = { payload: { valves: { V1: 100 }, pumps: { P1: true } } };
      helper.getNode('gc').receive(msg);
      await tickUntil(() => seen.out.length === 1 || seen.caught.length > 0, 'the return');
      assert.deepEqual(seen.caught.map((m) => m.error.message), []);
      assert.equal(seen.out[0], msg);
      const state = await io.get(1);
      assert.equal(state.holding[0], raw(100), 'the valve commanded 100 % (20 mA)');
      assert.ok(state.input[0] >= raw(97), `the valve's feedback followed: ${state.input[0]}`);
      assert.equal(state.coil[0], true);
      // Written once each, then verified by reading.
      assert.deepEqual(state.writes, [[6, 0, [raw(100)]], [5, 0, [1]]]);
      assert.deepEqual(seen.mqtt, [], 'no MQTT message for a Modbus device');
      assert.deepEqual(seen.ev.filter((m) => m.payload && ['malformed', 'rejected', 'fault'].includes(m.payload.kind)).map((m) => m.payload), []);
    });
  }

  it('a valve whose feedback register does not follow faults after its thresholds, and its line\'s lockout is written', async function () {
    const io = await startIoModule();
    modules = [io];
    await start(plantDocument([device('io-1', { port: io.port })]));
    await io.stick(1);
    helper.getNode('op').receive({ payload: 'go' });
    const tookMs = await tickUntil(() => seen.caught.length > 0, 'the operation\'s error');
    assert.match(seen.caught[0].error.message, /V1/);
    assert.deepEqual(actuatorEvents(seen, 'retry', 'V1').map((r) => r.fault), ['no-motion']);
    assert.deepEqual(actuatorEvents(seen, 'fault', 'V1').map((f) => f.fault), ['no-motion']);
    // noMotionMs, then again after its one retry.
    assert.ok(tookMs >= 2 * TYPES.valve.noMotionMs && tookMs <= 2 * TYPES.valve.noMotionMs + 2 * POLL_MS, `faulted after ${tookMs} ms`);
    assert.equal(seen.opdone.length, 0);
    // The lockout of YEL: the valve to 0 % (4 mA) and the pump off, written to the module.
    await tickUntil(() => actuatorEvents(seen, 'lockoutConfirmed', 'P1').length > 0, 'the lockout confirmed', 10000);
    const state = await io.get(1);
    assert.equal(state.holding[0], raw(0));
    assert.equal(state.coil[0], false);
    const writes = state.writes.map((w) => JSON.stringify(w));
    assert.deepEqual(writes.slice(-2).sort(), [[5, 0, [0]], [6, 0, [raw(0)]]].map((w) => JSON.stringify(w)).sort());
  });

  it('the server killed fails the command at once and marks the device offline; its return gets commanded states and lockouts written again', async function () {
    const io = await startIoModule();
    modules = [io];
    await start(plantDocument([device('io-1', { port: io.port })]));
    command({ valves: { V1: 100 }, pumps: { P1: true } });
    await tickUntil(() => actuatorEvents(seen, 'moving', 'V1').length > 0, 'motion');
    const at = clock().now();
    await io.kill();
    await until(() => seen.caught.length > 0, 'the failure', 5000);
    assert.equal(clock().now(), at, 'failed on the lost connection, before any threshold ran out');
    assert.equal(seen.caught[0].error.code, 'COMMAND_FAILED');
    assert.match(seen.caught[0].error.message, /its device .*io-1.* went offline/);
    assert.equal(actuatorEvents(seen, 'deviceStatus', 'io-1').at(-1).online, false);
    // A lockout while it is away: standing until the module confirms it.
    helper.getNode('bus').receive({ topic: 'lockout/YEL', payload: { pumps: { P1: false } } });
    await settled(helper, 'il', 'pl');
    // The module reboots (registers at power-on values); the palette connects again.
    await io.restart();
    await tickUntil(() => actuatorEvents(seen, 'deviceStatus', 'io-1').at(-1).online, 'the device back online', 5000);
    await tick(POLL_MS);
    const state = await io.get(1);
    assert.deepEqual(
      state.writes.map((w) => JSON.stringify(w)).sort(),
      [[5, 0, [0]], [6, 0, [raw(100)]]].map((w) => JSON.stringify(w)).sort(),
      'the valve\'s commanded state and the pump\'s lockout, written again',
    );
    await tickUntil(() => actuatorEvents(seen, 'lockoutConfirmed', 'P1').length > 0, 'the lockout confirmed');
  });

  it('a unit that never answers delays another unit\'s command behind the same gateway by no more than its own timeout', async function () {
    const MUTE_TIMEOUT_MS = 1000;
    const io = await startIoModule({ units: [1, 2], framing: 'rtu' });
    modules = [io];
    await start(plantDocument([
      device('io-1', { port: io.port, unit: 1, framing: 'rtu' }),
      device('io-2', { port: io.port, unit: 2, framing: 'rtu', timeoutMs: MUTE_TIMEOUT_MS }),
    ]));
    await io.mute(2);
    muted.add('io-2');
    // Until a poll of the mute unit is what the gateway is waiting on.
    await tickUntil(() => transport().inFlight().some((f) => f.device === 'io-2'), 'a request to the mute unit', 5000);
    const since = clock().now();
    command({ valves: { V1: 50 } });
    let writtenAt = null;
    for (let waited = 0; writtenAt === null && waited <= 2 * MUTE_TIMEOUT_MS; waited += 50) {
      await tick(50, 50);
      if ((await io.get(1)).writes.some((w) => w[0] === 6 && w[2][0] === raw(50))) writtenAt = clock().now();
    }
    assert.ok(writtenAt !== null, 'the command reached unit 1');
    const delay = writtenAt - since;
    assert.ok(delay <= MUTE_TIMEOUT_MS, `unit 1's command waited ${delay} ms, more than unit 2's timeout`);
    await tickUntil(() => seen.out.length === 1 || seen.caught.length > 0, 'the return');
    assert.deepEqual(seen.caught.map((m) => m.error.message), []);
    // Unit 2 is offline; unit 1 never was.
    await tickUntil(() => actuatorEvents(seen, 'deviceStatus', 'io-2').some((s) => !s.online), 'unit 2 offline', 10000);
    assert.deepEqual(actuatorEvents(seen, 'deviceStatus', 'io-1'), []);
  });

  it('a module that never answers on its own connection delays another module\'s command not at all', async function () {
    const io = await startIoModule();
    const frozen = await startIoModule();
    modules = [io, frozen];
    await start(plantDocument([
      device('io-1', { port: io.port }),
      device('io-2', { port: frozen.port, timeoutMs: 1000 }),
    ]));
    frozen.freeze();
    muted.add('io-2');
    await tickUntil(() => transport().inFlight().some((f) => f.device === 'io-2'), 'a request to the frozen module', 5000);
    const at = clock().now();
    command({ valves: { V1: 50 } });
    let writes = [];
    for (const started = Date.now(); writes.length === 0 && Date.now() - started < 3000;) {
      await settled(helper, 'pl');
      writes = (await io.get(1)).writes;
    }
    assert.deepEqual(writes, [[6, 0, [raw(50)]]]);
    assert.equal(clock().now(), at, 'written before the clock moved');
  });

  it('a group command completes over RTU on a serial line (socat pty pair, pymodbus serial server)', async function () {
    // scripts/setup.sh installs socat and pyserial; serialport is a devDependency.
    assert.ok(haveCommand('socat') && haveSerialport(), 'socat, pyserial or the serialport package is missing: run scripts/setup.sh and npm install');
    const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'sugarshack-pty-'));
    const [a, b] = [path.join(dir, 'palette'), path.join(dir, 'module')];
    const socat = spawn('socat', [`pty,raw,echo=0,link=${a}`, `pty,raw,echo=0,link=${b}`], { stdio: 'ignore' });
    try {
      await until(() => fs.existsSync(a) && fs.existsSync(b), 'the pty pair', 5000);
      const io = await startIoModule({ serial: b });
      modules = [io];
      await start(plantDocument([device('io-1', { serial: a })]));
      const msg = { payload: { valves: { V1: 100 }, pumps: { P1: true } } };
      helper.getNode('gc').receive(msg);
      await tickUntil(() => seen.out.length === 1 || seen.caught.length > 0, 'the return');
      assert.deepEqual(seen.caught.map((m) => m.error.message), []);
      assert.deepEqual((await io.get(1)).writes, [[6, 0, [raw(100)]], [5, 0, [1]]]);
    } finally {
      socat.kill();
      fs.rmSync(dir, { recursive: true, force: true });
    }
  });
});

describe('example modbus-pid-loop: the cloud paper\'s flow loop over Modbus/TCP against the simulator\'s I/O module', function () {
  this.timeout(90000);
  const { FlowLoop } = require('../../scripts/simulator/loop');
  const { freePort } = require('./support/mosquitto');
  const { startRealTimeServer } = require('../flow/support');
  const coreNodesDir = path.dirname(require.resolve('@node-red/nodes/package.json'));
  const coreNodes = ['common/20-inject.js', 'common/90-comment.js', 'function/10-switch.js', 'function/15-change.js']
    .map((f) => require(path.join(coreNodesDir, 'core', f)));
  let loop;

  afterEach(async function () {
    await stopServer().catch(() => {});
    if (loop) await loop.stop();
    loop = null;
  });

  it('from rest, the pid with the adaptive Smith predictor brings the flow to its set point without overshoot, its dead time learnt from the polls\' round trips', async function () {
    const example = JSON.parse(fs.readFileSync(path.join(__dirname, '..', '..', 'node-red-contrib-sugarshack', 'examples', 'modbus-pid-loop.json'), 'utf8'));
    const port = await freePort();
    const flow = example.map((n) => {
      if (n.type === 'sugarshack-plant') return { ...n, plant: { ...n.plant, devices: n.plant.devices.map((d) => ({ ...d, modbus: { ...d.modbus, port } })) } };
      if (n.type === 'debug') return { id: n.id, z: n.z, type: 'helper', name: n.name };
      return n;
    });
    const plant = flow.find((n) => n.type === 'sugarshack-plant').plant;
    loop = new FlowLoop(plant, { seed: 7 });
    await loop.start();
    await new Promise((resolve) => startRealTimeServer(resolve));
    await helper.load([...paletteNodes, ...coreNodes], flow);
    const named = (name) => flow.find((n) => n.type === 'helper' && n.name === name).id;
    const pidOut = collect(helper, named('flow and valve'));
    const errors = collect(helper, named('errors'));
    const events = collect(helper, named('I/O events'));
    const setpoint = flow.find((n) => n.type === 'sugarshack-pid').setpoint;
    // Each poll's flow, as the actuators node hands it to the pid.
    const flows = () => events.filter((m) => m.topic === 'sensor/FT-101');
    // Until the flow has stayed within 2 % of its set point for 3 s.
    await until(() => {
      const all = flows();
      const recent = all.filter((m) => m.timestamp >= Date.now() - 3000);
      return all.length > 0 && all[0].timestamp <= Date.now() - 3000 && recent.length >= 5
        && recent.every((m) => Math.abs(m.payload - setpoint) < 0.02 * setpoint);
    }, () => `the flow at ${setpoint} gal/min (now ${loop.y.toFixed(3)}, valve ${loop.u.toFixed(1)} %, ${flows().length} polls)`, 60000);
    assert.deepEqual(errors.map((m) => m.error && m.error.message), []);
    const peak = Math.max(...flows().map((m) => m.payload));
    assert.ok(peak <= setpoint * 1.05, `peak flow ${peak} overshoots ${setpoint} by more than 5 %`);
    const trips = flows().map((m) => m.roundTripMs);
    assert.ok(trips.every((ms) => ms >= 150 - 10 && ms <= 650 + 100), `each poll's round trip within the module's 400 ± 250 ms: ${Math.min(...trips)}..${Math.max(...trips)}`);
    const last = pidOut.at(-1);
    assert.ok(last.pid.deadTimeSamples >= 1, `the predictor's dead time: ${last.pid.deadTimeSamples} samples`);
  });
});
