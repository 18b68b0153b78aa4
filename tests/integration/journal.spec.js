'use strict';
// The journal against a real line-protocol server (VictoriaMetrics, from
// Debian): a plant run journalled over HTTP and found in the server; the
// server killed for 20 s of plant time and started again (the journal's
// retries follow the manual clock, so the outage costs no wall-clock wait);
// the spool filled past its bound, with the exact drop count; and a real
// Node-RED journalling through a hostile proxy (connections cut after the
// body, 500s, answers too late, gone a while) and killed with SIGKILL while
// it is gone: every (writer, seq) arrives, seq goes on across the restart,
// the copies retries leave are counted and bounded, and the season report
// counts the same with them as without.
const assert = require('node:assert/strict');
const fs = require('fs');
const os = require('os');
const path = require('path');
const http = require('http');
const helper = require('node-red-node-test-helper');
const { startMosquitto } = require('./support/mosquitto');
const { connectProbe } = require('./support/mqtt-probe');
const { startTestSimulator, SMALL_PLANT } = require('./support/simulator');
const { startVictoriaMetrics } = require('./support/victoria-metrics');
const { NodeRedProcess, waitFor } = require('./support/node-red');
const { freePort } = require('./support/mosquitto');
const { main: seasonReport, analyse } = require('../../scripts/season-report');
const { loadPlant } = require('../../scripts/simulator/plant');
const {
  PALETTE, TAB, sinkNode, startRealTimeServer, settings, collect, until, sleep,
} = require('../flow/support');

const { useClock, ManualClock, settle } = require(path.join(PALETTE, 'lib', 'host', 'clock.js'));
const { Spool } = require(path.join(PALETTE, 'lib', 'journal', 'spool.js'));
const { JournalWriter, Encoder, httpTarget } = require(path.join(PALETTE, 'lib', 'journal', 'writer.js'));
const { JournalBus } = require(path.join(PALETTE, 'lib', 'journal', 'bus.js'));
const { writers } = require(path.join(PALETTE, 'nodes', 'journal.js'));

helper.init(require.resolve('node-red'));
const { PALETTE_AND_MQTT, stopAll } = require('./support/mqtt-nodes');
const { mqttBroker } = require('./support/node-red');
const PLANT = loadPlant(SMALL_PLANT);

/** Rows in the server: one per `<table>_seq` sample, as { table, tags, seq, at }. */
/** The rows in the server once `count` of those `kept` can be searched (VictoriaMetrics answers a write before). */
async function rowsOnceSearchable(vm, count, kept = () => true) {
  let rows = [];
  await waitFor(async () => {
    rows = (await rowsIn(vm)).filter(kept);
    return rows.length >= count;
  }, `${count} rows searchable in the server`, 20000).catch(() => {});
  return rows;
}

async function rowsIn(vm, table = 'sugarshack_.*') {
  const samples = await vm.export(`{__name__=~"${table}_seq"}`);
  return samples.map(({ metric, value, at }) => {
    const { __name__: name, ...tags } = metric;
    return { table: name.replace(/_seq$/, ''), tags, seq: value, at };
  }).sort((a, b) => a.seq - b.seq);
}

/** A flow that journals an operator note every 10 ms through the journal node, to a database at `port`. */
function noteEvery10ms(port) {
  return [
    { id: 'tab', type: 'tab', label: 'journal' },
    {
      id: 'tick', z: 'tab', type: 'inject', name: '', props: [{ p: 'payload' }, { p: 'topic', vt: 'str' }], repeat: '0.01', crontab: '',
      once: true, onceDelay: '0.1', topic: 'note', payload: '', payloadType: 'date', wires: [['j']],
    },
    {
      id: 'j', z: 'tab', type: 'sugarshack-journal', target: 'http', host: '127.0.0.1', port, plantId: 'shack', flushS: 0.1,
      timeoutS: 1, bufferMB: 64, wires: [[]],
    },
  ];
}

const LATE_MS = 2500; // past the journal's 1 s answer time

/**
 * Between the journal and the server: `mode` says what it does to each request.
 * pass: forwards it and answers as the server did; cut: forwards the body, then
 * drops the connection without an answer; error: forwards it, answers 500;
 * late: forwards it, answers 204 after LATE_MS; gone()/back(): nothing listens,
 * then it listens again on the same port. `unackedRows` counts the rows of the
 * requests the server took but whose 204 never reached the journal: the only
 * rows that can be in the server twice.
 */
async function hostileProxy(serverPort) {
  const port = await freePort();
  const p = { port, mode: 'pass', counts: { pass: 0, cut: 0, error: 0, late: 0 }, ackedRows: 0, unackedRows: 0, server: null, sockets: new Set() };
  const forward = (body, url) => new Promise((resolve, reject) => {
    const req = http.request({ host: '127.0.0.1', port: serverPort, method: 'POST', path: url, headers: { 'Content-Length': body.length } }, (res) => {
      res.resume();
      res.on('end', () => resolve(res.statusCode));
    });
    req.on('error', reject);
    req.end(body);
  });
  const handle = (req, res) => {
    const chunks = [];
    req.on('data', (c) => chunks.push(c));
    req.on('end', async () => {
      const body = Buffer.concat(chunks);
      const rows = body.toString().split('\n').filter(Boolean).length;
      const mode = p.mode;
      let status;
      try {
        status = await forward(body, req.url);
      } catch {
        req.socket.destroy();
        return;
      }
      const answered = (code) => {
        if (res.destroyed || req.socket.destroyed) {
          p.unackedRows += rows; // the journal gave up or the proxy went away: the rows are in, unacknowledged
          return;
        }
        res.writeHead(code).end();
        if (code === 204) p.ackedRows += rows;
        else p.unackedRows += rows;
      };
      if (status !== 204) answered(status);
      else if (mode === 'cut') {
        p.counts.cut += 1;
        p.unackedRows += rows;
        req.socket.destroy();
      } else if (mode === 'error') {
        p.counts.error += 1;
        answered(500);
      } else if (mode === 'late') {
        p.counts.late += 1;
        setTimeout(() => answered(204), LATE_MS);
      } else {
        p.counts.pass += 1;
        answered(204);
      }
    });
  };
  p.listen = () => new Promise((resolve, reject) => {
    p.server = http.createServer(handle);
    p.server.on('connection', (socket) => {
      p.sockets.add(socket);
      socket.on('close', () => p.sockets.delete(socket));
    });
    p.server.once('error', reject);
    p.server.listen(port, '127.0.0.1', resolve);
  });
  p.gone = () => {
    p.server.close();
    for (const socket of p.sockets) socket.destroy();
  };
  p.back = () => p.listen();
  p.close = async () => {
    p.gone();
  };
  await p.listen();
  return p;
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
      const total = writer.metrics().rows;
      const rows = await rowsOnceSearchable(vm, total);
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
      const encoder = new Encoder('shack-1', writer.writerId);
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
      const rows = await rowsOnceSearchable(vm, kept.length, (r) => r.seq <= sizes.length);
      assert.deepEqual(rows.map((r) => r.seq), kept);
    });
  });

  describe('a real Node-RED behind a hostile proxy, killed while the server is gone', function () {
    this.timeout(5 * 60 * 1000);
    let proxy;
    let red;

    afterEach(async function () {
      if (red) await red.finish(this.currentTest);
      if (proxy) await proxy.close();
      [red, proxy] = [null, null];
    });

    it('every (writer, seq) arrives, seq goes on across the SIGKILL, copies are counted and bounded, the season report counts them once', async function () {
      proxy = await hostileProxy(vm.port);
      red = new NodeRedProcess({ tag: 'journal', flows: noteEvery10ms(proxy.port) });
      await red.start({ waitForBroker: false });
      const journalNow = async () => (await red.get('/sugarshack/journal')).j;
      /** The proxy in `mode` until it has done it `times` times, then passing until the spool is drained again. */
      const hostile = async (mode, times) => {
        const before = proxy.counts[mode];
        proxy.mode = mode;
        await waitFor(() => proxy.counts[mode] >= before + times, `${times} × ${mode}`, 30000);
        proxy.mode = 'pass';
        const acked = proxy.ackedRows;
        await waitFor(async () => proxy.ackedRows > acked + 200 && (await journalNow()).backlog < 10, 'the spool drained after it', 30000);
      };

      await waitFor(() => proxy.ackedRows >= 300, 'the first rows in the server', 30000);
      await hostile('cut', 3);
      await hostile('error', 3);
      await hostile('late', 3);

      // Gone: nothing listens. Rows wait in the spool; then a power cut.
      proxy.gone();
      const down = await journalNow();
      await waitFor(async () => (await journalNow()).backlog >= 60, 'rows waiting in the spool', 30000);
      const killedAt = Date.now();
      await red.kill();
      await red.start({ waitForBroker: false });
      const restartedAt = Date.now();
      await waitFor(async () => { const m = await journalNow(); return m.state === 'down' && m.rows > 20; }, 'new rows after the restart, the server still gone', 30000);
      const afterRestart = await journalNow();
      assert.equal(afterRestart.writer, down.writer, 'the same writer after the restart');
      proxy.back();
      let last;
      await waitFor(async () => {
        last = await journalNow();
        return last.backlog === 0 && last.pending === 0 && last.seq > afterRestart.seq + 50;
      }, 'the spool drained after the outage', 60000);
      await red.stop(); // no more rows: the server's content stays as it is for what follows

      // In the server: one writer, every seq up to the last acknowledged one, each at least once.
      // (VictoriaMetrics answers a write before the rows can be searched: they are looked for until they are.)
      let rows = [];
      await waitFor(async () => {
        rows = (await rowsIn(vm)).filter((r) => r.seq <= last.seq);
        return new Set(rows.map((r) => r.seq)).size >= last.seq;
      }, `every seq up to ${last.seq} searchable in the server`, 20000).catch(() => {});
      assert.deepEqual([...new Set(rows.map((r) => r.tags.writer))], [down.writer]);
      const distinct = new Set(rows.map((r) => r.seq));
      assert.deepEqual([...distinct].sort((a, b) => a - b), Array.from({ length: last.seq }, (_, i) => i + 1), 'every (writer, seq) present');
      const before = rows.filter((r) => r.at < killedAt);
      const after = rows.filter((r) => r.at >= restartedAt);
      assert.ok(Math.min(...after.map((r) => r.seq)) > Math.max(...before.map((r) => r.seq)), 'seq went on across the restart, never from 1');
      const duplicates = rows.length - distinct.size;
      const ratio = duplicates / distinct.size;
      console.log(`      ${distinct.size} rows, ${duplicates} copies (ratio ${ratio.toFixed(3)}); the proxy took ${proxy.unackedRows} rows in requests it did not acknowledge`
        + ` (${proxy.counts.cut} cut, ${proxy.counts.error} × 500, ${proxy.counts.late} late); ${after[0].seq - 1} rows before the restart`);
      const unanswered = proxy.counts.cut + proxy.counts.error + proxy.counts.late;
      assert.ok(duplicates > 0, 'the hostile answers left copies (a server without deduplication keeps them)');
      assert.ok(duplicates <= proxy.unackedRows, 'a copy only of a row in a request that was not acknowledged');
      assert.ok(proxy.unackedRows <= 16 * unanswered, `a few rows per unanswered request: ${proxy.unackedRows} in ${unanswered}`);
      assert.ok(ratio < 0.1, `copies bounded: ${ratio.toFixed(3)} per row`);

      // The season report over the server's rows, copies and all, counts as over each row once.
      const out = path.join(dir, 'season.html');
      const report = await seasonReport(['--url', vm.url, '--out', out, '--to', String(Date.now() + 60000)]);
      // Each row once, by the test's own count: the first sample of each (writer, seq).
      const firsts = new Map();
      for (const r of await rowsIn(vm)) if (!firsts.has(`${r.tags.writer} ${r.seq}`)) firsts.set(`${r.tags.writer} ${r.seq}`, r);
      const once = analyse([...firsts.values()].map((r) => ({ table: r.table, tags: r.tags, fields: { seq: r.seq }, at: r.at })));
      assert.equal(once.duplicates, 0);
      const counts = (r) => ({ rows: r.rows, actions: r.actions.length, events: r.events, datapoints: r.datapoints, figures: Object.values(r.figures).map((f) => f.n) });
      assert.deepEqual(counts(report), counts(once));
      assert.ok(report.duplicates >= duplicates, `${report.duplicates} copies set aside`);
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
