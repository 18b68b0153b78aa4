'use strict';
// The plant simulator against a real Mosquitto (started by the test, on a
// free loopback port). Run: npx mocha --timeout 20000 --exit 'tests/integration/**/*.spec.js'
const assert = require('assert');
const path = require('path');
const { spawn } = require('child_process');
const { startMosquitto, freePort } = require('./support/mosquitto');
const { connectProbe } = require('./support/mqtt-probe');
const { startTestSimulator, SMALL_PLANT } = require('./support/simulator');
const { parseFaultArg } = require('../../scripts/simulator/faults');
const { buildModel, loadPlant } = require('../../scripts/simulator/plant');
const { parseArgs } = require('../../scripts/simulator/cli');
const { pymodbusClient } = require('./support/modbus/io-module');

/** Until `predicate` (which may be async) holds, polled; fails after `ms`. */
async function until(predicate, what, ms) {
  for (const start = Date.now(); !(await predicate());) {
    if (Date.now() - start > ms) throw new Error(`timed out waiting for ${what}`);
    await new Promise((r) => setTimeout(r, 20));
  }
}

const TOLERANCE = loadPlant(SMALL_PLANT).actuatorTypes.valve.tolerance; // 3 %
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

describe('plant simulator on Mosquitto', function () {
  let broker;
  let sim;
  let probe;

  before(async function () {
    broker = await startMosquitto();
  });
  after(async function () {
    if (broker) await broker.stop();
  });
  afterEach(async function () {
    if (probe) {
      // Retained commands left by a test would reach the next test's devices.
      for (const t of ['ctrl-1/pump/1/command', 'ctrl-1/valve/1/command']) await probe.publish(t, '', { retain: true });
      await probe.end();
    }
    if (sim) await sim.stop();
    probe = null;
    sim = null;
  });

  const lastBatch = () => probe.on('ctrl-1/state').slice(-1)[0];

  describe('connection and status', function () {
    it('publishes "online" retained on connect and its last will "offline" when it dies, then "online" when revived', async function () {
      sim = await startTestSimulator(broker.url);
      // A client that subscribes after the fact gets the retained birth message.
      probe = await connectProbe(broker.url, ['station-2/status']);
      const birth = await probe.waitFor('station-2/status', () => true, 2000, { fromHistory: true });
      assert.strictEqual(birth.text, 'online');
      assert.strictEqual(birth.retain, true);

      await sim.inject({ fault: 'dead', device: 'station-2' });
      const will = await probe.waitFor('station-2/status', (m) => m.text === 'offline', 3000);
      assert.ok(will);
      assert.strictEqual(sim.devices['station-2'].connected, false);

      // The will is retained: a newcomer sees the device as offline.
      const late = await connectProbe(broker.url, ['station-2/status']);
      try {
        const seen = await late.waitFor('station-2/status', () => true, 2000, { fromHistory: true });
        assert.strictEqual(seen.text, 'offline');
        assert.strictEqual(seen.retain, true);
      } finally {
        await late.end();
      }

      // It stays away: no datapoints while dead.
      probe.clear();
      await probe.client.subscribeAsync('station-2/sensor/+/state');
      await sleep(1300);
      assert.strictEqual(probe.on('station-2/sensor/+/state').length, 0);

      await sim.inject({ fault: 'revive', device: 'station-2' });
      await probe.waitFor('station-2/status', (m) => m.text === 'online', 3000, { fromHistory: true });
      await probe.waitFor('station-2/sensor/volume/state', () => true, 2500);
    });

    it('says "offline" (retained) itself on an orderly stop', async function () {
      sim = await startTestSimulator(broker.url);
      await sim.stop();
      sim = null;
      probe = await connectProbe(broker.url, ['ctrl-1/status', 'station-2/status']);
      for (const dev of ['ctrl-1', 'station-2']) {
        const m = await probe.waitFor(`${dev}/status`, () => true, 2000, { fromHistory: true });
        assert.strictEqual(m.text, 'offline');
        assert.strictEqual(m.retain, true);
      }
    });
  });

  describe('datapoints', function () {
    it('panel batches carry the device timestamp, all 16 valves and the pump, at 1 Hz', async function () {
      sim = await startTestSimulator(broker.url);
      probe = await connectProbe(broker.url, ['ctrl-1/state', 'station-2/sensor/+/state', 'ctrl-1/telemetry']);
      const t0 = Date.now();
      await probe.waitFor('ctrl-1/state', () => true, 2500);
      await probe.waitFor('ctrl-1/state', () => true, 2500);
      await probe.waitFor('ctrl-1/state', () => true, 2500);
      const batches = probe.on('ctrl-1/state');
      for (const b of batches) {
        assert.ok(Number.isInteger(b.json.ts), `ts in ${b.text}`);
        assert.ok(b.json.ts >= t0 - 50 && b.json.ts <= b.at + 5, `ts ${b.json.ts} not between ${t0} and ${b.at}`);
        assert.deepStrictEqual(Object.keys(b.json.valve).map(Number).sort((a, c) => a - c), [...Array(16)].map((_, i) => i + 1));
        assert.deepStrictEqual(b.json.pump, { 1: false });
        for (const v of Object.values(b.json.valve)) assert.ok(v >= 0 && v <= TOLERANCE, `closed valve reads ${v}`);
      }
      const gaps = batches.slice(1).map((b, i) => b.json.ts - batches[i].json.ts);
      for (const g of gaps) assert.ok(g > 900 && g < 1150, `sample interval ${g} ms`);

      const volume = probe.on('station-2/sensor/volume/state');
      const flow = probe.on('station-2/sensor/flow/state');
      assert.ok(volume.length >= 2 && flow.length >= 2);
      assert.ok(Number.isInteger(volume[0].json.ts));
      assert.ok(Math.abs(volume[0].json.value - 12000) <= 25, `volume ${volume[0].json.value}`);
      assert.strictEqual(flow[0].json.value, 0);
    });

    it('with --single, publishes one state topic per actuator, each with ts', async function () {
      sim = await startTestSimulator(broker.url, { single: true });
      probe = await connectProbe(broker.url, ['ctrl-1/#']);
      const m = await probe.waitFor('ctrl-1/valve/16/state', () => true, 2500);
      assert.ok(Number.isInteger(m.json.ts) && typeof m.json.value === 'number');
      const pump = await probe.waitFor('ctrl-1/pump/1/state', () => true, 2500, { fromHistory: true });
      assert.strictEqual(pump.json.value, false);
      assert.strictEqual(probe.on('ctrl-1/state').length, 0);
    });

    it('sends telemetry with counters at connect and then periodically', async function () {
      probe = await connectProbe(broker.url, ['+/telemetry']);
      sim = await startTestSimulator(broker.url, { telemetryPeriodMs: 600 });
      const first = await probe.waitFor('ctrl-1/telemetry', () => true, 2000, { fromHistory: true });
      for (const k of ['ts', 'uptimeS', 'rssi', 'freeHeap', 'published', 'dropped']) assert.ok(typeof first.json[k] === 'number', `${k} in ${first.text}`);
      const later = await probe.waitFor('ctrl-1/telemetry', (m) => m.json.published > first.json.published, 2500);
      assert.ok(later.json.uptimeS >= 0);
    });
  });

  describe('valves', function () {
    it('moves to the commanded position within the sweep time, feedback within tolerance', async function () {
      const sweepS = 1;
      sim = await startTestSimulator(broker.url, { sweepS });
      probe = await connectProbe(broker.url, ['ctrl-1/state']);
      await probe.waitFor('ctrl-1/state', () => true, 2500);
      const sent = Date.now();
      await probe.publish('ctrl-1/valve/2/command', '100', { qos: 0 });
      // Reached in sweep time; seen at most one sample (1 s) later.
      const done = await probe.waitFor('ctrl-1/state', (m) => Math.abs(m.json.valve['2'] - 100) <= TOLERANCE, sweepS * 1000 + 1500);
      assert.ok(done.at - sent <= sweepS * 1000 + 1200, `completed after ${done.at - sent} ms`);
      for (let i = 0; i < 3; i++) {
        const b = await probe.waitFor('ctrl-1/state', () => true, 1500);
        assert.ok(Math.abs(b.json.valve['2'] - 100) <= TOLERANCE, `feedback ${b.json.valve['2']}`);
        assert.ok(b.json.valve['1'] <= TOLERANCE, 'other valves stay put');
      }
      assert.strictEqual(sim.devices['ctrl-1'].valves[2].position, 100);
    });

    it('moves at the full-sweep rate (half way takes half the sweep)', async function () {
      sim = await startTestSimulator(broker.url, { sweepS: 4, speed: 4 });
      // speed 4: the 4 s sweep takes 1 s of wall time, sampled every 250 ms
      probe = await connectProbe(broker.url, ['ctrl-1/state']);
      await probe.publish('ctrl-1/valve/4/command', '50');
      await probe.waitFor('ctrl-1/state', (m) => Math.abs(m.json.valve['4'] - 50) <= TOLERANCE, 2000);
      const seen = probe.on('ctrl-1/state').map((m) => m.json.valve['4']);
      // A partial position was reported on the way (motion, not a jump).
      assert.ok(seen.some((v) => v > TOLERANCE && v < 50 - TOLERANCE), `positions ${seen}`);
    });

    it('a stuck valve never moves while its neighbour does', async function () {
      sim = await startTestSimulator(broker.url, { faults: ['stuck:ctrl-1:3'] });
      probe = await connectProbe(broker.url, ['ctrl-1/state']);
      await probe.publish('ctrl-1/valve/3/command', '100');
      await probe.publish('ctrl-1/valve/4/command', '100');
      await probe.waitFor('ctrl-1/state', (m) => m.json.valve['4'] >= 100 - TOLERANCE, 3000);
      await sleep(1200); // past the sweep time plus a sample
      const v3 = probe.on('ctrl-1/state').map((m) => m.json.valve['3']);
      assert.ok(v3.length >= 2);
      for (const v of v3) assert.ok(v <= TOLERANCE, `stuck valve reads ${v}`);
      assert.strictEqual(sim.devices['ctrl-1'].valves[3].position, 0);
      assert.strictEqual(sim.devices['ctrl-1'].valves[3].commanded, 100);
    });

    it('slow and drift faults: a slow valve lags, a drifting one moves uncommanded', async function () {
      sim = await startTestSimulator(broker.url);
      probe = await connectProbe(broker.url, ['ctrl-1/state', 'sim/control/result']);
      await probe.publish('sim/control', { fault: 'slow', device: 'ctrl-1', valve: 6, factor: 10 });
      const ack = await probe.waitFor('sim/control/result', () => true, 2000);
      assert.strictEqual(ack.json.ok, true);
      await probe.publish('ctrl-1/valve/6/command', '100');
      await sim.inject('drift:ctrl-1:5:40');
      await probe.waitFor('ctrl-1/state', (m) => Math.abs(m.json.valve['5'] - 40) <= TOLERANCE, 3000);
      const v6 = sim.devices['ctrl-1'].valves[6].position;
      assert.ok(v6 > 0 && v6 < 50, `slow valve at ${v6} % after ~1 s (10x slower than a 1 s sweep)`);
      assert.strictEqual(sim.devices['ctrl-1'].valves[5].commanded, 0, 'drift is not a command');
    });

    it('a noisy panel reports feedback beyond the tolerance', async function () {
      sim = await startTestSimulator(broker.url, { faults: ['noisy:ctrl-1:8'] });
      probe = await connectProbe(broker.url, ['ctrl-1/state']);
      await probe.waitFor('ctrl-1/state', () => true, 2500);
      await probe.waitFor('ctrl-1/state', () => true, 2500);
      const values = probe.on('ctrl-1/state').flatMap((m) => Object.values(m.json.valve));
      assert.ok(Math.max(...values) > TOLERANCE, `max ${Math.max(...values)}`);
      assert.ok(Math.max(...values) <= 8);
    });
  });

  describe('commands', function () {
    it('ignores malformed commands, counts them, and keeps obeying valid ones', async function () {
      sim = await startTestSimulator(broker.url, { telemetryPeriodMs: 500 });
      probe = await connectProbe(broker.url, ['ctrl-1/#']);
      const bad = [
        ['ctrl-1/valve/1/command', 'abc'],
        ['ctrl-1/valve/1/command', ''],
        ['ctrl-1/valve/1/command', '150'],
        ['ctrl-1/valve/1/command', '-1'],
        ['ctrl-1/valve/1/command', '{"value":50}'],
        ['ctrl-1/valve/17/command', '50'],
        ['ctrl-1/valve/x/command', '50'],
        ['ctrl-1/pump/1/command', 'MAYBE'],
        ['ctrl-1/pump/2/command', 'ON'],
        ['ctrl-1/valve/1/command', Buffer.from([0xff, 0xfe, 0x00])],
      ];
      for (const [t, p] of bad) await probe.client.publishAsync(t, p, { qos: 1 });
      await probe.publish('ctrl-1/valve/1/command', '50');
      await probe.waitFor('ctrl-1/state', (m) => Math.abs(m.json.valve['1'] - 50) <= TOLERANCE, 3000);
      const tele = await probe.waitFor('ctrl-1/telemetry', (m) => m.json.dropped >= bad.length, 2000, { fromHistory: true });
      assert.strictEqual(tele.json.dropped, bad.length);
      assert.strictEqual(probe.on('ctrl-1/status').filter((m) => m.text === 'offline').length, 0);
      assert.strictEqual(sim.devices['ctrl-1'].connected, true);
      assert.strictEqual(sim.logs.filter((l) => l.includes('ignored malformed command')).length, bad.length);
    });
  });

  describe('pumps', function () {
    it('spins up after a short delay', async function () {
      sim = await startTestSimulator(broker.url, { pumpDelayMs: 600 });
      probe = await connectProbe(broker.url, ['ctrl-1/state']);
      const sent = Date.now();
      await probe.publish('ctrl-1/pump/1/command', 'ON');
      await sleep(300);
      assert.strictEqual(sim.devices['ctrl-1'].pump.running, false, 'still spinning up');
      const on = await probe.waitFor('ctrl-1/state', (m) => m.json.pump['1'] === true, 2500);
      assert.ok(on.at - sent >= 600);
    });

    it('pauses while the broker is down and resumes when it is back (short outage)', async function () {
      sim = await startTestSimulator(broker.url);
      probe = await connectProbe(broker.url, ['ctrl-1/state']);
      await probe.publish('ctrl-1/pump/1/command', 'ON');
      await probe.waitFor('ctrl-1/state', (m) => m.json.pump['1'] === true, 2500);

      await broker.restart({ downMs: 800 });
      const panel = sim.devices['ctrl-1'];
      // The device may already be back; it paused while the broker was gone.
      assert.ok(sim.logs.some((l) => l === 'ctrl-1: pump 1 paused (no broker)'), 'pump paused');
      await probe.waitFor('ctrl-1/state', (m) => m.json.pump['1'] === true, 4000);
      assert.strictEqual(panel.pump.running, true);
      assert.ok(sim.logs.some((l) => l === 'ctrl-1: reconnected'));
    });

    it('stays off on reconnect when a retained OFF (lockout) is waiting', async function () {
      sim = await startTestSimulator(broker.url);
      probe = await connectProbe(broker.url, ['ctrl-1/state', 'ctrl-1/status']);
      await probe.publish('ctrl-1/pump/1/command', 'ON');
      await probe.waitFor('ctrl-1/state', (m) => m.json.pump['1'] === true, 2500);

      // The panel loses its network for 1 s; the broker fires its will.
      await sim.inject({ fault: 'disconnect', device: 'ctrl-1', forMs: 1000 });
      await probe.waitFor('ctrl-1/status', (m) => m.text === 'offline', 2000, { fromHistory: true });
      assert.strictEqual(sim.devices['ctrl-1'].pump.running, false, 'paused while away');
      // Meanwhile the server locks the line out: retained OFF.
      await probe.publish('ctrl-1/pump/1/command', 'OFF', { retain: true });

      await probe.waitFor('ctrl-1/status', (m) => m.text === 'online', 3000);
      probe.clear();
      await sleep(1500); // well past the spin-up a resumed pump would need
      const states = probe.on('ctrl-1/state').map((m) => m.json.pump['1']);
      assert.ok(states.length >= 1);
      assert.ok(states.every((v) => v === false), `pump states after reconnect: ${states}`);
      assert.strictEqual(sim.devices['ctrl-1'].pump.commanded, false);
    });
  });

  describe('network and hydraulics', function () {
    it('drop fault silences a device until cleared', async function () {
      sim = await startTestSimulator(broker.url);
      probe = await connectProbe(broker.url, ['ctrl-1/state']);
      await probe.waitFor('ctrl-1/state', () => true, 2500);
      await sim.inject({ fault: 'drop', device: 'ctrl-1', ratio: 1 });
      probe.clear();
      await sleep(1500);
      assert.strictEqual(probe.on('ctrl-1/state').length, 0);
      await sim.inject({ fault: 'clear' });
      await probe.waitFor('ctrl-1/state', () => true, 2500);
    });

    it('delays outgoing publishes by the configured mean (time of flight)', async function () {
      sim = await startTestSimulator(broker.url, { delayMs: 300, delayJitterMs: 50 });
      probe = await connectProbe(broker.url, ['ctrl-1/state', 'station-2/sensor/+/state']);
      await sleep(2200);
      const tof = probe.messages.map((m) => m.at - m.json.ts);
      assert.ok(tof.length >= 4);
      for (const t of tof) assert.ok(t >= 240 && t < 600, `time of flight ${t} ms`);
    });

    it('transfers between tanks when the line valves are open and the pump runs', async function () {
      sim = await startTestSimulator(broker.url, { speed: 5 });
      probe = await connectProbe(broker.url, ['station-2/sensor/+/state']);
      // Pump alone: valves closed, nothing flows.
      await probe.publish('ctrl-1/pump/1/command', 'ON');
      await sleep(400);
      assert.strictEqual(sim.hydraulics.snapshot().transfers['load-truck'], 0);
      await probe.publish('ctrl-1/valve/1/command', '100');
      await probe.publish('ctrl-1/valve/2/command', '100');
      const flowing = await probe.waitFor('station-2/sensor/flow/state', (m) => Math.abs(m.json.value - 400) <= 2, 3000);
      assert.ok(flowing);
      await sleep(600);
      const { tanks } = sim.hydraulics.snapshot();
      assert.ok(tanks['T-silo'] < 12000 - 10, `silo ${tanks['T-silo']}`);
      assert.ok(Math.abs(tanks['T-silo'] + tanks['T-truck'] - 12000) < 1e-6, 'volume is conserved');
      const vol = await probe.waitFor('station-2/sensor/volume/state', () => true, 1000);
      assert.ok(vol.json.value < 12000 - 10 + 25);
    });
  });

  describe('--profile modbus', function () {
    it('each device is a Modbus TCP server pymodbus\'s client reads and commands: a valve on 4-20 mA registers, the pump on a coil, sensors as floats', async function () {
      const modbusPort = await freePort();
      sim = await startTestSimulator(broker.url, { profile: 'modbus', modbusPort });
      const ctrl = modbusPort; // ctrl-1 is the first device, station-2 the next
      const [before, written, pump] = await pymodbusClient(ctrl, [
        ['read_input_registers', 0, 1, 1], ['write_register', 0, 20000, 1], ['write_coil', 0, true, 1],
      ]);
      assert.ok(Math.abs(before.registers[0] - 4000) <= 160 * TOLERANCE, `valve 1 closed (4 mA): ${before.registers[0]}`);
      assert.deepStrictEqual([written, pump], [{ ok: true }, { ok: true }]);
      const valve = sim.devices['ctrl-1'].valves[1];
      await until(() => valve.commanded === 100 && sim.devices['ctrl-1'].pump.running, 'the valve and pump commanded', 5000);
      await until(() => valve.position === 100, 'the valve open', 5000);
      let open = null;
      await until(async () => {
        [open] = await pymodbusClient(ctrl, [['read_input_registers', 0, 1, 1]]);
        return open.registers[0] >= 20000 - 160 * TOLERANCE;
      }, 'its feedback at 20 mA', 10000);
      const [running] = await pymodbusClient(ctrl, [['read_discrete_inputs', 0, 1, 1]]);
      assert.deepStrictEqual(running.bits, [true]);
      // The station's sensors: float32 in input registers 100, 102, ... (high word first).
      const [sensors] = await pymodbusClient(ctrl + 1, [['read_input_registers', 100, 4, 1]]);
      const volume = Buffer.from(sensors.registers.slice(0, 2).flatMap((w) => [w >> 8, w & 0xff])).readFloatBE(0);
      assert.ok(volume > 1000, `LT-2 reads as a volume: ${volume}`);
      // Dead: connections refused; revived: it answers again (registers at power-on until sampled).
      await sim.inject({ fault: 'dead', device: 'ctrl-1' });
      const [refused] = await pymodbusClient(ctrl, [['read_input_registers', 0, 1, 1]]);
      assert.match(refused.error, /Connection|connect|No response|Modbus/i);
      await sim.inject({ fault: 'revive', device: 'ctrl-1' });
      const [back] = await pymodbusClient(ctrl, [['read_coils', 0, 1, 1]]);
      assert.deepStrictEqual(back.bits, [false], 'a rebooted module starts with its coil off');
    });
  });

  describe('devices addressed by entity', function () {
    it('an ESPHome actuator without io gets an output of its own and obeys its entity\'s commands', async function () {
      const doc = loadPlant(SMALL_PLANT);
      doc.devices[0].profile = 'esphome';
      for (const a of doc.actuators) delete a.io;
      doc.actuatorTypes.damper = { ...doc.actuatorTypes.valve, min: 0, max: 90 };
      doc.actuators.push({ id: 'D1', type: 'damper', device: 'ctrl-1', idle: 0, lockout: 0 });
      sim = await startTestSimulator(broker.url, { plant: doc });
      const panel = sim.devices['ctrl-1'];
      assert.deepStrictEqual(['V101', 'V102', 'V103', 'V104', 'P1', 'D1'].map((id) => sim.model.actuators[id].slot), [17, 18, 19, 20, 2, 21]);
      probe = await connectProbe(broker.url, ['ctrl-1/#']);
      await probe.publish('ctrl-1/valve/v102/position/command', '100');
      await probe.publish('ctrl-1/valve/d1/position/command', '45');
      await probe.publish('ctrl-1/switch/p1/command', 'ON');
      await probe.waitFor('ctrl-1/valve/v102/position/state', (m) => m.text === '100', 3000);
      await probe.waitFor('ctrl-1/valve/d1/position/state', (m) => m.text === '45', 3000, { fromHistory: true });
      await probe.waitFor('ctrl-1/switch/p1/state', (m) => m.text === 'ON', 3000, { fromHistory: true });
      assert.strictEqual(panel.valves[18].position, 100);
      assert.strictEqual(panel.valves[21].position, 45, 'ESPHome carries a position in % of the damper\'s 0..90 travel');
      assert.strictEqual(panel.pumps[2].running, true);
      assert.strictEqual(panel.valves[2].position, 0, 'the unnamed output 2 is not V102');
    });
  });

  describe('types other than valve and pump', function () {
    it('a sugarshack panel drives an analog type on its io, in the type\'s range, and reports it under its type', async function () {
      const doc = loadPlant(SMALL_PLANT);
      doc.actuatorTypes.damper = { ...doc.actuatorTypes.valve, min: 0, max: 90 };
      doc.actuators.push({ id: 'D1', type: 'damper', device: 'ctrl-1', io: 7, idle: 0, lockout: 0 });
      sim = await startTestSimulator(broker.url, { plant: doc });
      probe = await connectProbe(broker.url, ['ctrl-1/state']);
      await probe.publish('ctrl-1/damper/7/command', '45');
      const batch = await probe.waitFor('ctrl-1/state', (m) => m.json.damper && Math.abs(m.json.damper['7'] - 45) <= 3, 3000);
      assert.ok(Math.abs(batch.json.valve['7'] - 50) <= 3, 'output 7 at half its travel');
      assert.strictEqual(sim.devices['ctrl-1'].valves[7].position, 50);
    });
  });

  describe('command line', function () {
    it('runs from the CLI with a start-up fault and stops cleanly on SIGTERM', async function () {
      probe = await connectProbe(broker.url, ['ctrl-1/state', 'ctrl-1/status']);
      const cli = spawn(process.execPath, [
        path.join(__dirname, '..', '..', 'scripts', 'simulator', 'cli.js'),
        '--broker', broker.url, '--plant', SMALL_PLANT, '--sweep-s', '1', '--fault', 'stuck:V103', '--seed', '7',
      ], { stdio: ['ignore', 'pipe', 'pipe'] });
      let out = '';
      cli.stdout.on('data', (d) => { out += d; });
      cli.stderr.on('data', (d) => { out += d; });
      try {
        await probe.waitFor('ctrl-1/status', (m) => m.text === 'online', 4000, { fromHistory: true });
        await probe.publish('ctrl-1/valve/3/command', '100');
        await probe.publish('ctrl-1/valve/1/command', '100');
        await probe.waitFor('ctrl-1/state', (m) => m.json.valve['1'] >= 100 - TOLERANCE, 3500);
        const last = probe.on('ctrl-1/state').slice(-1)[0];
        assert.ok(last.json.valve['3'] <= TOLERANCE, 'V103 stuck');
      } finally {
        const exited = new Promise((resolve) => cli.once('exit', (code) => resolve(code)));
        cli.kill('SIGTERM');
        assert.strictEqual(await exited, 0, out);
      }
      await probe.waitFor('ctrl-1/status', (m) => m.text === 'offline', 2000, { fromHistory: true });
      assert.match(out, /fault stuck ctrl-1 valve 3/);
    });
  });
});

describe('embedded broker (scripts/broker.js, aedes)', function () {
  let broker;
  let sim;
  let probe;
  afterEach(async function () {
    if (probe) await probe.end();
    if (sim) await sim.stop();
    if (broker && broker.exitCode === null) {
      const exited = new Promise((resolve) => broker.once('exit', resolve));
      broker.kill('SIGTERM');
      await exited;
    }
  });

  it('listens on MQTT_PORT, keeps retained messages and sends last wills', async function () {
    const port = await freePort();
    broker = spawn(process.execPath, [path.join(__dirname, '..', '..', 'scripts', 'broker.js')], {
      env: { ...process.env, MQTT_PORT: String(port) },
      stdio: ['ignore', 'pipe', 'pipe'],
    });
    let out = '';
    await new Promise((resolve, reject) => {
      const timer = setTimeout(() => reject(new Error(`broker did not start: ${out}`)), 5000);
      broker.stdout.on('data', (d) => {
        out += d;
        if (out.includes(`listening on mqtt://127.0.0.1:${port}`)) {
          clearTimeout(timer);
          resolve();
        }
      });
      broker.once('exit', (code) => reject(new Error(`broker exited ${code}: ${out}`)));
    });
    const url = `mqtt://127.0.0.1:${port}`;
    sim = await startTestSimulator(url);
    probe = await connectProbe(url, ['station-2/status']);
    const birth = await probe.waitFor('station-2/status', () => true, 2000, { fromHistory: true });
    assert.strictEqual(birth.text, 'online');
    assert.strictEqual(birth.retain, true);
    await sim.inject('dead:station-2');
    await probe.waitFor('station-2/status', (m) => m.text === 'offline', 3000);
    await sleep(100);
    assert.match(out, /client connected: ctrl-1/);
  });
});

describe('plant simulator: plant document and fault specs', function () {
  const model = buildModel(loadPlant(SMALL_PLANT));

  it('reads devices, actuators and the datapoints of each station', function () {
    assert.deepStrictEqual(model.panels, ['ctrl-1']);
    assert.deepStrictEqual(model.stations.map((s) => s.id), ['station-2']);
    assert.deepStrictEqual(model.stations[0].datapoints.map((d) => d.name), ['volume', 'flow']);
    assert.deepStrictEqual(model.actuators.P1, { id: 'P1', type: 'pump', family: 'pump', device: 'ctrl-1', io: 1, slot: 1, range: [0, 1] });
    assert.strictEqual(model.simulation.transfers[0].valves.length, 2);
  });

  it('gives stations without sensors a few default datapoints', function () {
    const m = buildModel({ actuatorTypes: {}, devices: [{ id: 'station-4', kind: 'sensor-station' }] });
    assert.deepStrictEqual(m.stations[0].datapoints.map((d) => d.name), ['volume', 'flow', 'temperature', 'brix']);
  });

  it('rejects simulation sections that name unknown valves, pumps or tanks', function () {
    const doc = loadPlant(SMALL_PLANT);
    const bad = (simulation) => assert.throws(() => buildModel({ ...doc, simulation }), /plant: invalid plant document \(1 problem\):\n {2}simulation\.(tanks|transfers)\[0\]/);
    bad({ transfers: [{ from: 'T-nope', pump: 'P1', rateLpm: 1 }] });
    bad({ transfers: [{ pump: 'V101', rateLpm: 1 }] });
    bad({ transfers: [{ valves: ['P1'], rateLpm: 1 }] });
    bad({ tanks: [{ id: 'T', capacityL: 10, initialL: 11 }] });
  });

  it('accepts and refuses the same documents as the plant check, in the same words', function () {
    const { Tracker } = require('../../node-red-contrib-sugarshack/wasm/sugarshack_wasm.js');
    const checkSays = (doc) => {
      try {
        new Tracker(doc, 0).free();
        return null;
      } catch (err) {
        return err.message;
      }
    };
    const small = () => loadPlant(SMALL_PLANT);
    const cases = {
      'the small plant': small(),
      'an ESPHome panel whose actuators have no io': (() => {
        const d = small();
        d.devices[0].profile = 'esphome';
        for (const a of d.actuators) delete a.io;
        return d;
      })(),
      'a type that is neither valve nor pump, a 17th valve and a second pump': (() => {
        const d = small();
        d.actuatorTypes.heater = { signal: 'binary', noMotionMs: 1000, completionMs: 2000, staleMs: 5000 };
        d.actuators.push({ id: 'V117', type: 'valve', device: 'ctrl-1', io: 17, idle: 0, lockout: 0 });
        d.actuators.push({ id: 'H1', type: 'heater', device: 'ctrl-1', io: 1, idle: false, lockout: false });
        d.actuators.push({ id: 'P2', type: 'pump', device: 'ctrl-1', io: 2, idle: false, lockout: false });
        return d;
      })(),
      'a sensor datapoint with a dot': (() => {
        const d = small();
        d.sensors.push({ id: 'TT-2', device: 'station-2', name: 'temp.1' });
        return d;
      })(),
      'a sugarshack actuator without io': (() => {
        const d = small();
        delete d.actuators[0].io;
        return d;
      })(),
      'an actuator on a sensor station': (() => {
        const d = small();
        d.actuators[1].device = 'station-2';
        return d;
      })(),
      'no actuatorTypes': { devices: [{ id: 'ctrl-1', kind: 'actuator-panel' }] },
    };
    const refused = [];
    for (const [name, doc] of Object.entries(cases)) {
      const check = checkSays(doc);
      let simulator = null;
      try {
        buildModel(doc);
      } catch (err) {
        simulator = err.message;
      }
      assert.strictEqual(simulator, check === null ? null : `plant: ${check}`, name);
      if (check) refused.push(name);
    }
    assert.deepStrictEqual(refused, ['a sugarshack actuator without io', 'an actuator on a sensor station', 'no actuatorTypes']);
    const m = buildModel(cases['a type that is neither valve nor pump, a 17th valve and a second pump']);
    assert.deepStrictEqual([m.actuators.V117.slot, m.actuators.H1.slot, m.actuators.P2.slot], [17, 3, 2], 'a taken output goes to the next free one');
    assert.deepStrictEqual(m.panelSlots['ctrl-1'].pumps, [1, 2, 3]);
  });

  it('parses CLI fault specs into the JSON form', function () {
    assert.deepStrictEqual(parseFaultArg('stuck:ctrl-1:3', model), { fault: 'stuck', device: 'ctrl-1', valve: 3 });
    assert.deepStrictEqual(parseFaultArg('stuck:V103', model), { fault: 'stuck', device: 'ctrl-1', valve: 3 });
    assert.deepStrictEqual(parseFaultArg('stuck:P1', model), { fault: 'stuck', device: 'ctrl-1', pump: 1 });
    assert.deepStrictEqual(parseFaultArg('slow:ctrl-1:3:10', model), { fault: 'slow', device: 'ctrl-1', valve: 3, factor: 10 });
    assert.deepStrictEqual(parseFaultArg('dead:station-2', model), { fault: 'dead', device: 'station-2' });
    assert.deepStrictEqual(parseFaultArg('noisy:ctrl-1:8', model), { fault: 'noisy', device: 'ctrl-1', amplitude: 8 });
    assert.deepStrictEqual(parseFaultArg('drop:ctrl-1:0.3', model), { fault: 'drop', device: 'ctrl-1', ratio: 0.3 });
    assert.deepStrictEqual(parseFaultArg('drift:ctrl-1:5:40', model), { fault: 'drift', device: 'ctrl-1', valve: 5, to: 40 });
    assert.deepStrictEqual(parseFaultArg('disconnect:ctrl-1:2000', model), { fault: 'disconnect', device: 'ctrl-1', forMs: 2000 });
    assert.deepStrictEqual(parseFaultArg('clear', model), { fault: 'clear' });
    assert.throws(() => parseFaultArg('stuck:ctrl-9:3', model), /unknown device/);
    assert.throws(() => parseFaultArg('stuck:ctrl-1:17', model), /valve/);
    assert.throws(() => parseFaultArg('melt:ctrl-1', model), /unknown kind/);
  });

  it('parses the CLI flags', function () {
    const o = parseArgs(['--broker', 'mqtt://127.0.0.1:1', '--plant', 'p.json', '--sweep-s', '1', '--delay-ms=100', '--single', '--fault', 'dead:station-2', '--fault', 'clear']);
    assert.strictEqual(o.sweepS, 1);
    assert.strictEqual(o.delayMs, 100);
    assert.strictEqual(o.single, true);
    assert.deepStrictEqual(o.faults, ['dead:station-2', 'clear']);
    const modbus = parseArgs(['--profile', 'modbus', '--modbus-port', '6000', '--loop', 'loop.json']);
    assert.deepStrictEqual([modbus.profile, modbus.modbusPort, modbus.loop], ['modbus', 6000, 'loop.json']);
    assert.throws(() => parseArgs(['--speed', 'fast']), /not a number/);
    assert.throws(() => parseArgs(['--bogus']), /unknown option/);
  });
});
