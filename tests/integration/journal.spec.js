'use strict';
// The journal against a real line-protocol server (VictoriaMetrics, from
// Debian): a plant run journalled over HTTP and found in the server; the
// server killed for 20 s of plant time and started again (the journal's
// retries follow the manual clock, so the outage costs no wall-clock wait);
// and the spool filled past its bound, with the exact drop count.
const assert = require('node:assert/strict');
const fs = require('fs');
const os = require('os');
const path = require('path');
const helper = require('node-red-node-test-helper');
const { startMosquitto } = require('./support/mosquitto');
const { connectProbe } = require('./support/mqtt-probe');
const { startTestSimulator, SMALL_PLANT } = require('./support/simulator');
const { startVictoriaMetrics } = require('./support/victoria-metrics');
const { loadPlant } = require('../../scripts/simulator/plant');
const {
  PALETTE, TAB, sinkNode, startRealTimeServer, settings, collect, until, sleep,
} = require('../flow/support');

const { useClock, ManualClock, settle } = require(path.join(PALETTE, 'lib', 'clock.js'));
const { Spool } = require(path.join(PALETTE, 'lib', 'journal', 'spool.js'));
const { JournalWriter, Encoder, httpTarget } = require(path.join(PALETTE, 'lib', 'journal', 'writer.js'));
const { JournalBus } = require(path.join(PALETTE, 'lib', 'journal', 'bus.js'));
const { writers } = require(path.join(PALETTE, 'nodes', 'journal.js'));

helper.init(require.resolve('node-red'));
const { PALETTE_AND_MQTT, stopAll } = require('./support/mqtt-nodes');
const { mqttBroker } = require('./support/node-red');
const PLANT = loadPlant(SMALL_PLANT);

/** Rows in the server: one per `<table>_seq` sample, as { table, tags, seq, at }. */
async function rowsIn(vm, table = 'sugarshack_.*') {
  const samples = await vm.export(`{__name__=~"${table}_seq"}`);
  return samples.map(({ metric, value, at }) => {
    const { __name__: name, ...tags } = metric;
    return { table: name.replace(/_seq$/, ''), tags, seq: value, at };
  }).sort((a, b) => a.seq - b.seq);
}

/** A plant's worth of rows each second of clock time: 5 datapoints, and every 5 s an event and a figure. */
function plantLike(bus, second) {
  for (let d = 1; d <= 5; d++) bus.datapoint('ctrl-1', `valve/${d}`, (second * 7 + d) % 100, null, null);
  if (second % 5 === 0) {
    bus.event('interlock', second % 10 === 0 ? 'granted' : 'released', `op-${second}`, { resources: ['YEL'] });
    bus.timing('tof/ctrl-1', 30 + (second % 20));
  }
}

describe('journal on VictoriaMetrics', function () {
  this.timeout(60000);
  let vm;
  let dir;

  beforeEach(async function () {
    vm = await startVictoriaMetrics();
    dir = fs.mkdtempSync(path.join(os.tmpdir(), 'sugarshack-journal-it-'));
  });
  afterEach(async function () {
    useClock();
    if (vm) await vm.stop();
    fs.rmSync(dir, { recursive: true, force: true });
  });

  describe('store and forward, clock driven', function () {
    let manual;
    let bus;
    let writer;

    function start(maxBytes) {
      manual = new ManualClock(Math.floor(Date.now() / 1000) * 1000 - 3600_000);
      useClock(manual);
      bus = new JournalBus();
      writer = new JournalWriter({
        plant: 'shack-1', flushMs: 1000, spool: new Spool({ dir, maxBytes }),
        target: httpTarget({ host: '127.0.0.1', port: vm.port, timeoutMs: 2000 }),
      });
      bus.attach(writer);
    }

    /** `seconds` of plant time, second by second; each second's sends finish before the next. */
    async function run(seconds, from) {
      for (let s = from; s < from + seconds; s++) {
        plantLike(bus, s);
        await manual.advance(1000);
        await until(() => writer.state !== 'sending', 'the journal to hear from the server', 5000);
        await settle();
      }
      return from + seconds;
    }

    afterEach(async () => { if (writer) await writer.close(); writer = null; });

    it('the server killed for 20 s: rows wait on disk, then every row reaches it once, in order', async function () {
      start(64 * 1024 * 1024);
      let s = await run(10, 0);
      assert.equal(writer.metrics().backlog, 0);
      const before = writer.metrics().rows;
      await vm.kill();
      s = await run(20, s);
      const down = writer.metrics();
      assert.equal(down.state, 'down');
      assert.equal(down.backlog, down.rows - before, 'every row of the outage waits in the spool');
      assert.ok(down.backlog >= 20 * 5, `${down.backlog} rows waiting`);
      await vm.start();
      let waited = 0;
      while (writer.metrics().backlog > 0 || writer.metrics().pending > 0) {
        s = await run(1, s);
        waited += 1;
        assert.ok(waited <= 10, 'the backlog drains within the longest retry delay');
      }
      const rows = await rowsIn(vm);
      const total = writer.metrics().rows;
      assert.deepEqual(rows.map((r) => r.seq), Array.from({ length: total }, (_, i) => i + 1), 'no row missing, none twice');
      assert.ok(rows.every((r, i) => i === 0 || r.at >= rows[i - 1].at), 'in the order they happened');
      assert.equal(rows.filter((r) => r.table === 'sugarshack_datapoint').length, s * 5);
      assert.equal(rows.filter((r) => r.table === 'sugarshack_event').length, Math.ceil(s / 5));
      assert.deepEqual([...new Set(rows.map((r) => r.tags.plant))], ['shack-1']);
      assert.equal(writer.metrics().dropped, 0);
    });

    it('past the bound: exactly the rows that did not fit are missing, and the count says how many', async function () {
      await vm.kill();
      const maxBytes = 16 * 1024;
      start(maxBytes);
      // What the spool must keep: rows in order while their bytes fit under the bound.
      const encoder = new Encoder('shack-1');
      const probeBus = new JournalBus();
      const sizes = [];
      probeBus.attach({ row: (r) => sizes.push(encoder.encode(r, sizes.length + 1).length) });
      for (let sec = 0; sec < 60; sec++) plantLike(probeBus, sec);
      let used = 0;
      const kept = [];
      sizes.forEach((size, i) => {
        if (used + size <= maxBytes) { used += size; kept.push(i + 1); }
      });
      await run(60, 0);
      const m = writer.metrics();
      assert.equal(m.rows, sizes.length);
      assert.equal(m.dropped, sizes.length - kept.length);
      assert.ok(m.dropped > 0, 'the run overflows the bound');
      assert.equal(m.backlog, kept.length);
      await vm.start();
      for (let i = 0; i < 10 && writer.metrics().backlog > 0; i++) await run(1, 1000 + i);
      // Rows made after the server came back were sent too: only those of the outage count here.
      const rows = (await rowsIn(vm)).filter((r) => r.seq <= sizes.length);
      assert.deepEqual(rows.map((r) => r.seq), kept);
    });
  });

  describe('a plant run with the simulator', function () {
    let broker;
    let sim;
    let probe;

    afterEach(async function () {
      await stopAll({ probe, sim, broker });
      [broker, sim, probe] = [null, null, null];
    });

    it('finds in the server every actuator event of the run and every datapoint the simulator published', async function () {
      broker = await startMosquitto();
      probe = await connectProbe(broker.url, ['ctrl-1/state', 'station-2/sensor/+/state']);
      await new Promise((resolve) => startRealTimeServer(resolve));
      settings({ mqttReconnectTime: 300 });
      await helper.load(PALETTE_AND_MQTT, [
        TAB,
        { id: 'pl', type: 'sugarshack-plant', name: 'small plant', plant: PLANT },
        mqttBroker('br', broker.port),
        {
          id: 'min', z: 'f1', type: 'mqtt in', name: '', topic: '+/#', qos: '1', datatype: 'auto-detect', broker: 'br',
          nl: false, rap: true, rh: 0, inputs: 0, wires: [['bus']],
        },
        { id: 'bus', z: 'f1', type: 'sugarshack-actuators', plant: 'pl', devices: '', wires: [['mout'], [], ['ev']] },
        { id: 'mout', z: 'f1', type: 'mqtt out', name: '', topic: '', qos: '', retain: '', broker: 'br', wires: [] },
        { id: 'gc', z: 'f1', type: 'sugarshack-group-command', plant: 'pl', timeout: 0, wires: [['out']] },
        { id: 'j', z: 'f1', type: 'sugarshack-journal', target: 'http', host: '127.0.0.1', port: vm.port, plantId: 'small', flushS: 0.2, wires: [[]] },
        sinkNode('ev'), sinkNode('out'),
      ]);
      const seen = { ev: collect(helper, 'ev'), out: collect(helper, 'out') };
      await until(() => helper.getNode('br').connected, 'Node-RED on the broker', 5000);
      await sleep(300); // the mqtt in node's subscription is acknowledged after the connection
      sim = await startTestSimulator(broker.url);
      await until(() => seen.ev.length > 0, 'the first actuator event', 5000);
      helper.getNode('gc').receive({ payload: { valves: { V101: 100, V102: 50 }, pumps: { P1: true } } });
      await until(() => seen.out.length === 1, 'the group command to complete', 15000);
      await sim.stop();
      sim = null;
      await sleep(300); // the last batches in flight reach both subscribers
      // What the simulator published, as the plant names it: every named slot of every batch, every sensor value.
      const named = new Set(PLANT.actuators.filter((a) => a.device === 'ctrl-1').map((a) => `${a.type}/${a.io}`));
      let published = 0;
      for (const m of probe.on('ctrl-1/state')) {
        const batch = JSON.parse(m.text);
        for (const [type, members] of Object.entries(batch)) {
          if (members && typeof members === 'object') published += Object.keys(members).filter((io) => named.has(`${type}/${io}`)).length;
        }
      }
      const sensorNames = new Set(PLANT.sensors.map((s) => s.name));
      published += probe.on('station-2/sensor/+/state').filter((m) => sensorNames.has(m.topic.split('/')[2])).length;
      const writer = writers.get('j');
      // Node-RED may still be reading the last msgs the probe has: flush and look again until the count settles.
      let rows = [];
      const datapoints = () => rows.filter((r) => r.table === 'sugarshack_datapoint').length;
      for (const deadline = Date.now() + 10000; Date.now() < deadline; await sleep(200)) {
        writer.flush();
        await until(() => writer.metrics().backlog === 0 && writer.state === 'idle', 'the journal to drain', 5000);
        rows = await rowsIn(vm);
        if (datapoints() >= published) break;
      }
      assert.equal(datapoints(), published);
      const events = rows.filter((r) => r.table === 'sugarshack_event' && r.tags.layer === 'actuator');
      const key = (kind, subject) => `${kind} ${subject}`;
      assert.deepEqual(
        events.map((r) => key(r.tags.kind, r.tags.subject)).sort(),
        seen.ev.filter((m) => m.payload.actuator && !['rejected', 'malformed'].includes(m.payload.kind)).map((m) => key(m.payload.kind, m.payload.actuator)).sort(),
      );
      assert.ok(rows.some((r) => r.table === 'sugarshack_timing' && r.tags.series === 'command/completion'));
    });
  });
});
