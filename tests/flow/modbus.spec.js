'use strict';
// The actuators node's Modbus side on the manual clock, against an in-process
// Modbus TCP server built from the core's device side (the simulator's; the
// integration tests use pymodbus's): outputs written as given and refused with
// their codes, sensor values handed on with their poll's round trip, and a
// plant document's Modbus mistakes refused at deploy with the entry named.
const assert = require('node:assert/strict');
const path = require('path');
const helper = require('node-red-node-test-helper');
const {
  TAB, PALETTE, sinkNode, paletteNodes, startServer, stopServer, clock, collect, until, settled,
} = require('./support');
const { ModbusServer } = require('../../scripts/simulator/modbus');
const { freePort } = require('../integration/support/mosquitto');

helper.init(require.resolve('node-red'));
const { DeviceSide } = require(path.join(PALETTE, 'wasm', 'sugarshack_wasm.js'));

const SCALE = { raw: [4000, 20000], value: [0, 100] };

function plantDocument(port, sensorModbus = { kind: 'input', address: 0, type: 'f32' }) {
  return {
    name: 'io module',
    actuatorTypes: {},
    devices: [{
      id: 'io', kind: 'sensor-station', profile: 'modbus',
      modbus: { host: '127.0.0.1', port, unit: 1, pollMs: 500, timeoutMs: 200, outputs: [{ id: 'FCV', kind: 'holding', address: 10, scale: SCALE }] },
    }],
    sensors: [{ id: 'TT', device: 'io', name: 'temperature', modbus: sensorModbus }],
  };
}

function flow(plant) {
  return [
    TAB,
    { id: 'pl', type: 'sugarshack-plant', name: 'io', plant },
    { id: 'bus', z: 'f1', type: 'sugarshack-actuators', plant: 'pl', devices: '', wires: [['mqtt'], ['ret'], ['ev']] },
    { id: 'c1', z: 'f1', type: 'catch', scope: null, uncaught: false, wires: [['caught']] },
    ...['mqtt', 'ret', 'ev', 'caught'].map(sinkNode),
  ];
}

describe('actuators node: Modbus outputs and sensors', function () {
  let server;
  let side;
  let seen;

  async function start(plant) {
    side = new DeviceSide(plant);
    server = new ModbusServer({
      side, device: 0, endpoint: side.modbusEndpoint(0), network: { delay: () => 0, drop: () => false }, onWrite: () => {}, log: () => {},
    });
    await server.listen();
    await new Promise((resolve) => startServer(resolve));
    await helper.load(paletteNodes, flow(plant));
    seen = {};
    for (const id of ['mqtt', 'ret', 'ev', 'caught']) seen[id] = collect(helper, id);
    await until(() => transport().connected() && transport().conns[0], 'the connection', 3000);
  }

  const transport = () => helper.getNode('pl').runtime.modbus;
  const idle = () => until(() => transport().inFlight().length === 0, 'no request in flight', 3000);

  afterEach(async function () {
    await stopServer();
    if (server) await server.close();
    server = null;
  });

  it('writes an output as given; a bad payload, an unknown output, a value outside its scale and a lost connection are refused with their codes', async function () {
    await start(plantDocument(await freePort()));
    const bus = helper.getNode('bus');
    bus.receive({ topic: 'output/FCV', payload: 25 });
    await until(() => server.memory.holding[10] === 8000, 'the write at the module', 3000);
    bus.receive({ topic: 'output/FCV', payload: true });
    await until(() => server.memory.holding[10] === 4160, 'true written as 1 %', 3000);
    bus.receive({ topic: 'output/FCV', payload: 'open' });
    bus.receive({ topic: 'output/nope', payload: 1 });
    bus.receive({ topic: 'output/FCV', payload: 150 });
    await settled(helper, 'pl');
    assert.deepEqual(seen.caught.map((m) => m.error.code), ['INVALID_INPUT', 'UNKNOWN_OUTPUT', 'INVALID_TARGET']);
    assert.match(seen.caught[0].error.message, /output\/FCV takes a number/);
    assert.match(seen.caught[2].error.message, /FCV takes 0\.\.100, got 150/);
    await server.close();
    await until(() => !transport().connected(), 'the connection lost', 3000);
    bus.receive({ topic: 'output/FCV', payload: 50 });
    await settled(helper, 'pl');
    assert.equal(seen.caught.at(-1).error.code, 'DEVICE_OFFLINE');
    assert.deepEqual(seen.mqtt, []);
    // Its devices went offline with the connection, and said so.
    assert.ok(seen.ev.some((m) => m.topic === 'actuator/deviceStatus/io' && m.payload.online === false));
    assert.ok(seen.ev.some((m) => m.topic === 'actuator/modbus' && m.payload.connected === false));
  });

  it('opens no Modbus connection while a hot standby, and opens it again on becoming active', async function () {
    await start(plantDocument(await freePort()));
    const plant = helper.getNode('pl').runtime;
    // The cluster as the plant sees it (tests/integration/standby.spec.js runs the real one on etcd).
    plant.cluster = { active: false, role: 'standby', mayAct: () => false };
    transport().sync();
    await until(() => server.sockets.size === 0, 'the module no longer connected', 3000);
    assert.ok(transport().conns.every((c) => c === null), 'no connection kept');
    helper.getNode('bus').receive({ topic: 'output/FCV', payload: 25 });
    await settled(helper, 'pl');
    assert.notEqual(server.memory.holding[10], 8000, 'a standby writes nothing');
    plant.cluster = { active: true, role: 'active', mayAct: () => true };
    transport().sync();
    await until(() => transport().connected() && server.sockets.size === 1, 'connected again', 3000);
    helper.getNode('bus').receive({ topic: 'output/FCV', payload: 25 });
    await until(() => server.memory.holding[10] === 8000, 'the leader\'s write at the module', 3000);
    plant.cluster = null;
  });

  it('hands each poll\'s sensor values on as sensor/<id> with the poll\'s round trip, NaN as null', async function () {
    const plant = plantDocument(await freePort());
    await start(plant);
    server.hold(side.modbusImage(0, new Uint32Array(0), new Float64Array(0), Uint32Array.of(0), Float64Array.of(21.5)));
    await clock().advance(500);
    await idle();
    await until(() => seen.ev.some((m) => m.topic === 'sensor/TT' && m.payload === 21.5), 'the temperature', 3000);
    const sample = seen.ev.find((m) => m.topic === 'sensor/TT' && m.payload === 21.5);
    assert.equal(sample.device, 'io');
    assert.equal(sample.timestamp, clock().now());
    assert.equal(sample.roundTripMs, 0, 'answered before the clock moved');
    server.hold(side.modbusImage(0, new Uint32Array(0), new Float64Array(0), Uint32Array.of(0), Float64Array.of(NaN)));
    await clock().advance(500);
    await idle();
    await until(() => seen.ev.some((m) => m.topic === 'sensor/TT' && m.payload === null), 'no reading', 3000);
    assert.equal(helper.getNode('pl').runtime.describe().sensors[0].value, null);
  });

  it('refuses a plant document with a Modbus mistake at deploy, naming the entry', async function () {
    const plant = plantDocument(5020, { kind: 'input', address: 65535, type: 'f32' });
    plant.devices[0].modbus.outputs.push({ id: 'FCV2', kind: 'input', address: 11 });
    await new Promise((resolve) => startServer(resolve));
    await helper.load(paletteNodes, flow(plant));
    const runtime = helper.getNode('pl').runtime;
    await until(() => runtime.state === 'failed', 'the plant refused', 3000);
    assert.match(runtime.failure.message, /devices\[0\] \(io\)\.modbus\.outputs\[1\] \(FCV2\): an output is a coil or a holding register/);
    assert.match(runtime.failure.message, /sensors\[0\] \(TT\)\.modbus: a 2-register value at 65535 runs past address 65535/);
    assert.deepEqual(transport().conns, [], 'no connection for a plant that does not run');
  });
});
