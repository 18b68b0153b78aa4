'use strict';
// Real field firmware, no glue: the palette on a real Mosquitto against device
// impersonators that publish byte for byte what the firmware does and parse
// commands as the firmware does (tests/integration/support/impersonators/, each
// citing its firmware's source files):
//   - stock ESPHome (esphome/esphome: components/mqtt/mqtt_valve.cpp, mqtt_cover.cpp,
//     mqtt_switch.cpp, mqtt_number.cpp, mqtt_sensor.cpp, mqtt_component.cpp, mqtt/__init__.py):
//     valve + cover with 0-100 position topics, switch ON/OFF on change only, number "%f",
//     sensor "%.1f" and `nan`, no timestamps, retained Home Assistant discovery;
//   - Tasmota (arendst/Tasmota: xdrv_02_9_mqtt.ino, support_tasmota.ino, xdrv_27_esp32_shutter.ino):
//     LWT Online/Offline, POWER ON/OFF with RESULT JSON, shutters, SENSOR telemetry;
//   - Shelly Gen2 (API docs: Mqtt, Switch, Cover): <p>/online, status/switch:0 and
//     status/cover:0 JSON, command/switch:0 and command/cover:0, JSON-RPC.
// For each profile: a group command completes; a stuck valve faults its operation and
// the line's lockout reaches the devices as firmware commands; a device that loses
// power fails its command at once (the broker's will). The feedback mqtt in listens to
// `#`, with retained discovery and other foreign topics on the broker.
//
// Time: Node-RED runs on the palette's manual clock and each impersonator on its own;
// tick() moves both by the same slice and waits for the messages of the slice to be
// delivered (flush markers), so thresholds (noMotionMs, staleMs) are clock time, not waits.
//
// Run: npx mocha --timeout 30000 --exit tests/integration/devices.spec.js
const assert = require('node:assert/strict');
const path = require('path');
const helper = require('node-red-node-test-helper');
const { startMosquitto } = require('./support/mosquitto');
const { connectProbe } = require('./support/mqtt-probe');
const { startEspHome } = require('./support/impersonators/esphome');
const { startTasmota } = require('./support/impersonators/tasmota');
const { startShellyGen2 } = require('./support/impersonators/shelly-gen2');
const {
  TAB, startServer, stopServer, settings, settled, clock, collect, until,
} = require('../flow/support');

helper.init(require.resolve('node-red'));
const { PALETTE_AND_MQTT, busNodes, actuatorEvents } = require('./support/mqtt-nodes');
const { mqttBroker } = require('./support/node-red');
const { stepper, operationAndSinks } = require('./support/stepped');


const NO_MOTION_MS = 4000;
const STALE_MS = 5000;
const TYPES = {
  valve: {
    signal: 'analog', unit: '%', min: 0, max: 100, tolerance: 3, noMotionMs: NO_MOTION_MS, completionMs: 15000, staleMs: STALE_MS, retries: 1,
  },
  pump: {
    signal: 'binary', noMotionMs: NO_MOTION_MS, completionMs: 6000, staleMs: STALE_MS, retries: 1,
  },
};

const actuator = (id, type, device, extra) => ({
  id, type, device, idle: type === 'pump' ? false : 0, lockout: type === 'pump' ? false : 0, resource: 'YEL', ...extra,
});

// One line (YEL): two valves that open and a pump for the group command, a third
// valve that sticks, and an operation that runs them.
function plantDocument(name, devices, actuators, sensors) {
  return {
    name,
    actuatorTypes: TYPES,
    devices,
    resources: [{ id: 'YEL' }],
    actuators,
    sensors,
    operations: [{
      id: 'fill',
      description: 'open the line, then the stuck valve',
      priority: 10,
      resources: ['YEL'],
      steps: [
        { command: { valves: { V101: 100, V102: 100 }, pumps: { P1: true } }, timeoutMs: 20000 },
        { command: { valves: { V103: 100 } }, timeoutMs: 20000 },
      ],
    }],
  };
}

// Per profile: the plant document (contract of issue 13: device profile/prefix,
// actuator entity/component, sensor entity/updateMs), the devices, and how to read
// an actuator's real state on its device.
const PROFILES = {
  esphome: {
    plant: () => plantDocument('esphome plant', [
      { id: 'ctrl-1', kind: 'actuator-panel', profile: 'esphome' },
      { id: 'station-2', kind: 'sensor-station', profile: 'esphome' },
    ], [
      actuator('V101', 'valve', 'ctrl-1', { entity: 'v101', component: 'valve' }),
      actuator('V102', 'valve', 'ctrl-1', { entity: 'v102', component: 'cover' }),
      actuator('V103', 'valve', 'ctrl-1', { entity: 'v103', component: 'valve' }),
      actuator('V104', 'valve', 'ctrl-1', { entity: 'v104', component: 'number' }),
      actuator('P1', 'pump', 'ctrl-1', { entity: 'p1', component: 'switch' }),
    ], [
      {
        id: 'LT-2', device: 'station-2', name: 'volume', entity: 'volume', unit: 'L', updateMs: 60000,
      },
      {
        id: 'TT-2', device: 'station-2', name: 'temperature', entity: 'temperature', unit: '°C', updateMs: 60000,
      },
    ]),
    async start(url) {
      const panel = await startEspHome(url, {
        name: 'ctrl-1',
        valves: [{ name: 'V101' }, { name: 'V102', component: 'cover' }, { name: 'V103' }],
        numbers: [{ name: 'V104' }],
        switches: [{ name: 'P1' }],
      });
      const station = await startEspHome(url, {
        name: 'station-2',
        sensors: [{ name: 'volume', value: 12000, accuracy: 0 }, { name: 'temperature', value: NaN, accuracy: 1, unit: '°C' }],
      });
      return { panel, station, all: [panel, station] };
    },
    // ESPHome's number entity as an analog actuator too.
    extraCommand: { valves: { V104: 37 } },
    stick: (d) => d.panel.stick('V103'),
    offline: (d) => d.panel,
    at(d, id) {
      if (id === 'P1') return d.panel.switch('P1').state;
      if (id === 'V104') return d.panel.number('V104').value;
      return Math.round(d.panel.valve(id).position * 100);
    },
  },

  tasmota: {
    plant: () => plantDocument('tasmota plant', [
      { id: 'ctrl-1', kind: 'actuator-panel', profile: 'tasmota' },
      { id: 'station-2', kind: 'sensor-station', profile: 'tasmota' },
    ], [
      actuator('V101', 'valve', 'ctrl-1', { entity: 'Shutter1' }),
      actuator('V102', 'valve', 'ctrl-1', { entity: 'Shutter2' }),
      actuator('V103', 'valve', 'ctrl-1', { entity: 'Shutter3' }),
      actuator('P1', 'pump', 'ctrl-1', { entity: 'POWER7' }),
    ], [
      {
        id: 'LT-2', device: 'station-2', name: 'volume', entity: 'ANALOG.A1', unit: 'L', updateMs: 300000,
      },
      {
        id: 'TT-2', device: 'station-2', name: 'temperature', entity: 'DS18B20.Temperature', unit: '°C', updateMs: 300000,
      },
    ]),
    async start(url) {
      // Shutters 1-3 drive relays 1-6 (ShutterMode 1); relay 7 is the pump.
      const panel = await startTasmota(url, { topic: 'ctrl-1', relays: 7, shutters: [{}, {}, {}] });
      const station = await startTasmota(url, { topic: 'station-2', sensors: { ANALOG: { A1: 12000 }, DS18B20: { Id: '01144A0CB2AA', Temperature: 21.5 } } });
      return { panel, station, all: [panel, station] };
    },
    stick: (d) => d.panel.stick(3),
    offline: (d) => d.panel,
    at(d, id) {
      if (id === 'P1') return d.panel.power[6];
      return Math.round(d.panel.shutter(Number(id.slice(-1))).position);
    },
  },

  'shelly-gen2': {
    plant: () => plantDocument('shelly plant', [
      { id: 'sh-v101', kind: 'actuator-panel', profile: 'shelly-gen2' },
      { id: 'sh-v102', kind: 'actuator-panel', profile: 'shelly-gen2' },
      { id: 'sh-v103', kind: 'actuator-panel', profile: 'shelly-gen2' },
      { id: 'sh-p1', kind: 'actuator-panel', profile: 'shelly-gen2' },
      { id: 'sh-ht', kind: 'sensor-station', profile: 'shelly-gen2' },
    ], [
      actuator('V101', 'valve', 'sh-v101', { entity: 'cover:0' }),
      actuator('V102', 'valve', 'sh-v102', { entity: 'cover:0' }),
      actuator('V103', 'valve', 'sh-v103', { entity: 'cover:0' }),
      actuator('P1', 'pump', 'sh-p1', { entity: 'switch:0' }),
    ], [
      {
        id: 'TT-2', device: 'sh-ht', name: 'temperature', entity: 'temperature:100.tC', unit: '°C', updateMs: 600000,
      },
    ]),
    async start(url) {
      const cover = (prefix) => startShellyGen2(url, { id: `shellyplus2pm-${prefix.slice(3)}a1b2c3`, prefix, covers: [{}] });
      const devices = {
        V101: await cover('sh-v101'),
        V102: await cover('sh-v102'),
        V103: await cover('sh-v103'),
        P1: await startShellyGen2(url, { id: 'shellyplus1pm-a1b2c3d4e5f6', prefix: 'sh-p1', switches: [{}] }),
        ht: await startShellyGen2(url, { id: 'shellyplusht-a1b2c3', prefix: 'sh-ht', temperatures: [{ id: 100, tC: 21.5 }] }),
      };
      return { ...devices, all: Object.values(devices) };
    },
    stick: (d) => d.V103.stick('cover:0'),
    offline: (d) => d.V101,
    at(d, id) {
      if (id === 'P1') return d.P1.switch(0).output;
      return Math.round(d[id].cover(0).position);
    },
  },
};

const SINKS = ['ret', 'ev', 'out', 'opdone', 'caught', 'flushed'];

function flow(port, plant) {
  return [
    TAB,
    { id: 'pl', type: 'sugarshack-plant', name: plant.name, plant },
    { id: 'il', type: 'sugarshack-interlock', name: 'lines', plant: 'pl', resources: [], policy: 'greedy', persist: false },
    mqttBroker('br', port),
    // Everything on the broker goes to the bus: device topics, discovery, its own commands, markers.
    {
      id: 'all', z: 'f1', type: 'mqtt in', name: '', topic: '#', qos: '1', datatype: 'auto-detect', broker: 'br',
      nl: false, rap: true, rh: 0, inputs: 0, wires: [['bus']],
    },
    {
      id: 'marks', z: 'f1', type: 'mqtt in', name: '', topic: 'test/flush/#', qos: '1', datatype: 'utf8', broker: 'br',
      nl: false, rap: true, rh: 0, inputs: 0, wires: [['flushed']],
    },
    ...busNodes({ broker: 'br' }),
    ...operationAndSinks(SINKS),
  ];
}


for (const [name, profile] of Object.entries(PROFILES)) {
  describe(`${name} devices on Mosquitto, the feedback mqtt in on '#'`, function () {
    this.timeout(30000);
    let broker;
    let probe;
    let devices;
    let seen;
    let sentByNodeRed;

    /** Devices first (their retained discovery and states wait on the broker), then Node-RED. */
    async function start() {
      broker = await startMosquitto();
      probe = await connectProbe(broker.url, ['#']);
      devices = await profile.start(broker.url);
      await new Promise((resolve) => startServer(resolve));
      settings({ mqttReconnectTime: 300 });
      await helper.load(PALETTE_AND_MQTT, flow(broker.port, profile.plant()));
      seen = {};
      for (const id of SINKS) seen[id] = collect(helper, id);
      sentByNodeRed = collect(helper, 'mout');
      await until(() => helper.getNode('br').connected, 'Node-RED connected to the broker', 5000);
      await delivered();
    }

    /**
     * Waits until Node-RED has taken in everything the devices published so far
     * (each device's flush marker arrives after its earlier messages), and until the
     * devices have every command Node-RED published (or, for a topic no device
     * listens to, the broker has passed it on).
     */
    async function delivered() {
      const marks = await Promise.all(devices.all.filter((d) => d.client).map(async (d) => [d.clientId, await d.flush()]));
      await until(() => marks.every(([id, n]) => seen.flushed.some((m) => m.topic === `test/flush/${id}` && m.payload === String(n))), 'the devices\' flush markers in Node-RED', 5000);
      await settled(helper, 'il', 'pl');
      const counts = new Map();
      for (const m of sentByNodeRed) counts.set(m.topic, (counts.get(m.topic) || 0) + 1);
      await until(() => [...counts].every(([topic, n]) => {
        const listener = devices.all.find((d) => d.client && d.listensTo(topic));
        const got = listener ? listener.commandsOn(topic).length : probe.on(topic).length;
        return got >= n;
      }), 'Node-RED\'s commands at the devices', 5000);
    }

    /** Moves devices and Node-RED by `ms`, in slices, the messages of each slice delivered. */
    const { tick, tickUntil } = stepper({
      advance: async (ms) => {
        for (const d of devices.all) if (d.client) await d.advance(ms);
      },
      delivered,
    });

    const command = (payload) => helper.getNode('gc').receive({ payload });
    const warnings = () => devices.all.flatMap((d) => d.warnings);

    afterEach(async function () {
      await stopServer().catch(() => {});
      for (const d of (devices && devices.all) || []) await d.stop().catch(() => {});
      if (probe) await probe.end().catch(() => {});
      if (broker) await broker.stop();
      broker = null;
      probe = null;
      devices = null;
    });

    it('a group command completes; the devices got commands they parse; foreign topics refuse nothing', async function () {
      await start();
      const extra = profile.extraCommand || { valves: {} };
      const msg = { payload: { valves: { V101: 100, V102: 100, ...extra.valves }, pumps: { P1: true } } };
      helper.getNode('gc').receive(msg);
      await tickUntil(() => seen.out.length === 1 || seen.caught.length > 0, 'the return');
      assert.deepEqual(seen.caught.map((m) => m.error.message), []);
      assert.equal(seen.out[0], msg);
      assert.deepEqual(seen.out[0].command.actuators.map((a) => a.actuator).sort(), ['P1', 'V101', 'V102', ...Object.keys(extra.valves)]);
      for (const [id, value] of Object.entries(extra.valves)) assert.equal(profile.at(devices, id), value);
      assert.ok(profile.at(devices, 'V101') >= 97 && profile.at(devices, 'V102') >= 97, 'the valves opened on the devices');
      assert.equal(profile.at(devices, 'P1'), true);
      assert.deepEqual(warnings(), [], 'every command was in a form the firmware parses');

      // Discovery, the bus's own commands coming back on '#', markers: none is a group command.
      const refused = seen.ev.filter((m) => m.payload && m.payload.kind === 'rejected');
      assert.deepEqual(refused.map((m) => m.payload), []);

      // On-change devices: idle well past staleMs is not stale, and a command to the
      // state the pump already reports completes although the device publishes nothing.
      await tick(3 * STALE_MS, 500);
      assert.deepEqual(seen.ev.filter((m) => m.payload && m.payload.kind === 'fault').map((m) => m.payload), []);
      const before = devices.all.reduce((n, d) => n + d.published.length, 0);
      command({ pumps: { P1: true } });
      await tickUntil(() => seen.out.length === 2 || seen.caught.length > 0, 'the return of a command to the current state', 2000);
      assert.deepEqual(seen.caught.map((m) => m.error.message), []);
      if (name === 'esphome') {
        // ESPHome's switch drops a repeated state: nothing new came from the device.
        assert.equal(devices.all.reduce((n, d) => n + d.published.length, 0), before);
      }

      // And back: close everything.
      command({ valves: { V101: 0, V102: 0 }, pumps: { P1: false } });
      await tickUntil(() => seen.out.length === 3 || seen.caught.length > 0, 'the close');
      assert.deepEqual(seen.caught.map((m) => m.error.message), []);
      assert.equal(profile.at(devices, 'V101'), 0);
      assert.equal(profile.at(devices, 'P1'), false);
    });

    it('a stuck valve faults its operation and the line\'s lockout reaches the devices as firmware commands', async function () {
      await start();
      profile.stick(devices);
      helper.getNode('op').receive({ payload: 'go' });
      await tickUntil(() => profile.at(devices, 'V101') === 100 && profile.at(devices, 'P1') === true, 'the first step on the devices');
      await tickUntil(() => seen.caught.length > 0, 'the operation\'s error');
      const { error } = seen.caught[0];
      assert.match(error.message, /V103/);
      assert.deepEqual(actuatorEvents(seen, 'fault', 'V103').map((f) => f.fault), ['no-motion']);
      assert.equal(seen.opdone.length, 0);
      // The lockout: every YEL actuator to its lockout state, in commands the firmware parses.
      await tickUntil(() => profile.at(devices, 'V101') === 0 && profile.at(devices, 'V102') === 0 && profile.at(devices, 'P1') === false,
        'the lockout carried out on the devices', 10000);
      assert.deepEqual(warnings(), []);
      const lockouts = sentByNodeRed.filter((m) => m.retain === true);
      assert.ok(lockouts.length >= 3, `lockout commands are retained: ${JSON.stringify(sentByNodeRed.map((m) => [m.topic, m.payload, m.retain]))}`);
    });

    it('a device that loses power fails its command at once (the broker publishes its will)', async function () {
      await start();
      command({ valves: { V101: 100 } });
      await tickUntil(() => actuatorEvents(seen, 'moving', 'V101').length > 0, 'motion');
      const at = clock().now();
      profile.offline(devices).crash();
      await until(() => seen.caught.length > 0, 'the failure', 5000);
      assert.equal(clock().now(), at, 'failed on the will, before any threshold ran out');
      const { error } = seen.caught[0];
      assert.equal(error.code, 'COMMAND_FAILED');
      assert.match(error.message, /valve V101 cannot complete its command: its device .* went offline/);
      const device = profile.plant().actuators.find((a) => a.id === 'V101').device;
      assert.equal(actuatorEvents(seen, 'deviceStatus', device).at(-1).online, false);
    });
  });
}
