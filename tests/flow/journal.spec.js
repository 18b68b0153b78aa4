'use strict';
// The journal: its on-disk spool against a reference model, the writer's
// store and forward with a target that fails on command (time driven by the
// manual clock), the local files and their reader, and the journal node fed
// by a plant's events.
const assert = require('node:assert/strict');
const fs = require('fs');
const os = require('os');
const path = require('path');
const helper = require('node-red-node-test-helper');
const {
  PALETTE, paletteNodes, startServer, stopServer, clock, userDir, runFor, settled,
} = require('./support');
const { useClock, ManualClock, settle } = require(path.join(PALETTE, 'lib', 'host', 'clock.js'));
const { Spool } = require(path.join(PALETTE, 'lib', 'journal', 'spool.js'));
const { JournalWriter, Encoder } = require(path.join(PALETTE, 'lib', 'journal', 'writer.js'));
const { journal, JournalBus } = require(path.join(PALETTE, 'lib', 'journal', 'bus.js'));
const { filesTarget, readJournal, parseLine, writerId } = require(path.join(PALETTE, 'lib', 'journal', 'files.js'));
const { stats } = require(path.join(PALETTE, 'lib', 'host', 'stats.js'));

helper.init(require.resolve('node-red'));

const tmp = () => fs.mkdtempSync(path.join(os.tmpdir(), 'sugarshack-journal-'));
const row = (i, pad = 0) => Buffer.from(`t,k=v${'x'.repeat(pad)} n=${i} ${i}000000\n`);
const rowNumbers = (body) => body.toString().split('\n').filter(Boolean).map((l) => Number(/ n=(\d+)/.exec(l)[1]));

/** A line-protocol target that fails while `down` and records every body it accepted. */
function fakeTarget() {
  const t = {
    where: 'fake',
    down: false,
    bodies: [],
    send(body) {
      if (t.down) return Promise.reject(new Error('connect ECONNREFUSED'));
      t.bodies.push(Buffer.from(body));
      return Promise.resolve(true);
    },
    close() {},
    received: () => t.bodies.flatMap((b) => b.toString().split('\n').filter(Boolean).map((l) => Number(/seq=(\d+)i/.exec(l)[1]))),
  };
  return t;
}

// A tiny seeded generator, so a failing sequence can be replayed.
function rng(seed) {
  let s = seed >>> 0;
  return () => {
    s = (s * 1664525 + 1013904223) >>> 0;
    return s / 2 ** 32;
  };
}

describe('journal spool', function () {
  let dir;
  beforeEach(() => { dir = tmp(); });
  afterEach(() => fs.rmSync(dir, { recursive: true, force: true }));

  it('follows a reference queue over random appends, sends, acks and restarts: order kept, drops exact', function () {
    this.timeout(60000); // 4,500 steps, each ack a file write
    for (let seed = 1; seed <= 15; seed++) {
      fs.rmSync(dir, { recursive: true, force: true });
      const rand = rng(seed);
      const maxBytes = 200 + Math.floor(rand() * 800);
      let spool = new Spool({ dir, maxBytes, segmentBytes: 64 + Math.floor(rand() * 200) });
      const model = { queue: [], bytes: 0, dropped: 0 };
      const acked = [];
      let next = 1;
      for (let step = 0; step < 300; step++) {
        const r = rand();
        if (r < 0.5) {
          const rows = Array.from({ length: 1 + Math.floor(rand() * 5) }, () => row(next++, Math.floor(rand() * 30)));
          spool.append(rows);
          for (const b of rows) {
            if (model.bytes + b.length > maxBytes) model.dropped++;
            else { model.queue.push(b); model.bytes += b.length; }
          }
        } else if (r < 0.9) {
          const chunk = spool.peek(1 + Math.floor(rand() * 150));
          if (model.queue.length === 0) { assert.equal(chunk, null, `seed ${seed}`); continue; }
          const got = rowNumbers(chunk.body);
          assert.deepEqual(got, model.queue.slice(0, got.length).flatMap(rowNumbers), `seed ${seed}: chunk in order`);
          if (rand() < 0.8) {
            spool.ack(chunk);
            acked.push(...got);
            for (const b of model.queue.splice(0, got.length)) model.bytes -= b.length;
          }
        } else {
          spool = new Spool({ dir, maxBytes, segmentBytes: spool.segmentBytes }); // a restart
        }
        const b = spool.backlog();
        assert.deepEqual([b.rows, b.bytes, b.dropped], [model.queue.length, model.bytes, model.dropped], `seed ${seed} step ${step}`);
      }
      // Whatever was acknowledged is increasing: nothing sent twice, nothing out of order.
      assert.ok(acked.every((n, i) => i === 0 || n > acked[i - 1]), `seed ${seed}`);
    }
  });

  it('drops a row cut short by a crash while appending, keeps the whole ones', function () {
    const spool = new Spool({ dir, maxBytes: 10000 });
    spool.append([row(1), row(2)]);
    const seg = fs.readdirSync(dir).find((f) => f.endsWith('.lp'));
    fs.appendFileSync(path.join(dir, seg), 't,k=v n=3 30'); // no newline: the process died mid-write
    const again = new Spool({ dir, maxBytes: 10000 });
    assert.equal(again.backlog().rows, 2);
    assert.deepEqual(rowNumbers(again.peek().body), [1, 2]);
  });

  it('refuses a bound that is not a positive whole number of bytes', function () {
    assert.throws(() => new Spool({ dir, maxBytes: 0 }), /positive whole number/);
    assert.throws(() => new Spool({ dir, maxBytes: NaN }), /positive whole number/);
  });
});

describe('journal writer: store and forward', function () {
  let dir;
  let manual;
  beforeEach(() => { dir = tmp(); manual = new ManualClock(); useClock(manual); });
  afterEach(() => { useClock(); fs.rmSync(dir, { recursive: true, force: true }); });

  const rowOf = (i) => ({ table: 'sugarshack_timing', tags: { series: 'tof', subject: 'd' }, fields: { value_ms: i }, at: 1_700_000_000_000 + i });

  it('keeps rows on disk while the database is down and sends them all, in order, when it returns; retries follow the clock', async function () {
    const target = fakeTarget();
    const writer = new JournalWriter({ plant: 'p1', spool: new Spool({ dir, maxBytes: 1 << 20 }), target, flushMs: 100 });
    let n = 0;
    const produce = async (ms) => {
      for (let t = 0; t < ms; t += 100) {
        for (let k = 0; k < 5; k++) writer.row(rowOf(++n));
        await manual.advance(100);
        await settle();
      }
    };
    await produce(2000);
    assert.equal(target.received().length, n, 'sent as they come while up');
    target.down = true;
    await produce(20000); // 20 s of outage
    const m = writer.metrics();
    assert.equal(m.state, 'down');
    assert.equal(m.backlog, 1000);
    assert.equal(target.received().length, 100);
    target.down = false;
    await produce(6000); // the next retry is at most 5 s away
    assert.equal(writer.metrics().backlog, 0);
    assert.deepEqual(target.received(), Array.from({ length: n }, (_, i) => i + 1), 'every row once, in order');
    assert.equal(writer.metrics().dropped, 0);
    await writer.close();
  });

  it('a restart keeps the writer id and goes on with seq, from the spool\'s rows or, once all are sent, from its cursor', async function () {
    const target = fakeTarget();
    const spoolDir = path.join(dir, 'spool');
    const run = async (rows, up) => {
      target.down = !up;
      const writer = new JournalWriter({ plant: 'p1', spool: new Spool({ dir: spoolDir, maxBytes: 1 << 20 }), target, flushMs: 100 });
      for (let i = 0; i < rows; i++) writer.row(rowOf(i));
      await manual.advance(100);
      await settle();
      const { writer: id, seq } = writer.metrics();
      await writer.close();
      return [id, seq];
    };
    const [first, seq1] = await run(5, true);
    // All sent: its segments may go (as full ones do), and the cursor alone tells the seq.
    for (const f of fs.readdirSync(spoolDir).filter((name) => name.endsWith('.lp'))) fs.rmSync(path.join(spoolDir, f));
    const [second, seq2] = await run(3, false);
    // The rows wait in the spool; the cursor, written at acknowledgements only, still says 5: the rows tell 8.
    assert.equal(JSON.parse(fs.readFileSync(path.join(spoolDir, 'cursor.json'), 'utf8')).seq, 5);
    const [third, seq3] = await run(2, true);
    assert.deepEqual([seq1, seq2, seq3], [5, 8, 10]);
    assert.equal(new Set([first, second, third]).size, 1, 'one writer id across restarts');
    assert.deepEqual(target.received(), Array.from({ length: 10 }, (_, i) => i + 1), 'every seq once, on from the last run\'s');
    // The local files do the same.
    const filesDir = path.join(dir, 'files');
    const filesWriter = () => new JournalWriter({ plant: 'p1', target: filesTarget({ dir: filesDir }) });
    const a = filesWriter();
    [1, 2, 3].forEach((i) => a.row(rowOf(i)));
    await a.close();
    const b = filesWriter();
    b.row(rowOf(4));
    await b.close();
    assert.equal(b.writerId, a.writerId);
    assert.deepEqual(readJournal(filesDir).map((r) => [r.tags.writer, r.fields.seq]), [1, 2, 3, 4].map((n) => [a.writerId, n]));
  });

  it('a server that writes but does not acknowledge: only the unacknowledged rows come again, in chunks that start small after a failure', async function () {
    const target = fakeTarget();
    let failNext = 0;
    const send = target.send;
    target.send = (body) => {
      send(body); // written...
      if (failNext === 0) return Promise.resolve(true);
      failNext -= 1;
      return Promise.reject(new Error('socket hang up')); // ...but the answer is lost
    };
    const writer = new JournalWriter({ plant: 'p1', spool: new Spool({ dir, maxBytes: 1 << 24 }), target, flushMs: 100 });
    for (let i = 1; i <= 3000; i++) writer.row(rowOf(i));
    failNext = 3;
    for (let t = 0; t < 20 && (writer.metrics().backlog > 0 || writer.metrics().pending > 0); t++) {
      await manual.advance(1000);
      await settle();
    }
    const got = target.received();
    const sizes = target.bodies.map((b) => b.length);
    const m = writer.metrics();
    assert.equal(m.backlog, 0);
    assert.deepEqual([...new Set(got)].sort((x, y) => x - y), Array.from({ length: 3000 }, (_, i) => i + 1), 'every row arrived');
    const duplicates = got.length - 3000;
    assert.ok(duplicates > 0 && duplicates <= m.unacknowledged, `${duplicates} duplicates, ${m.unacknowledged} unacknowledged`);
    assert.ok(Math.max(...sizes) <= 64 * 1024, 'no request over 64 KB');
    assert.ok(sizes[1] <= 512 && sizes[2] <= 512 && sizes[3] <= 512, `after each failure a small chunk: ${sizes.slice(0, 6)}`);
    assert.ok(sizes[4] > sizes[3] && sizes[5] > sizes[4], 'then doubling');
    assert.ok(m.unacknowledged < sizes[0] / 100 + 3 * 30, `${m.unacknowledged} rows sent without an answer`);
    await writer.close();
  });

  it('past the bound drops exactly the rows that do not fit, counts them, and says so after a restart', async function () {
    const target = fakeTarget();
    target.down = true;
    const spoolDir = path.join(dir, 'spool');
    fs.mkdirSync(spoolDir);
    const encoder = new Encoder('p1', writerId(spoolDir)); // the id the spool's writer will have
    const sizeOf = (i) => encoder.encode(rowOf(i), i).length;
    const size = sizeOf(1);
    // Room for 250 rows of the first row's size; later rows are longer (their seq and values grow), so count bytes.
    const writer = new JournalWriter({ plant: 'p1', spool: new Spool({ dir: spoolDir, maxBytes: size * 250 }), target, flushMs: 100 });
    const sizes = [];
    for (let i = 1; i <= 400; i++) {
      sizes.push(sizeOf(i));
      writer.row(rowOf(i));
    }
    let used = 0;
    let expectDropped = 0;
    for (const s of sizes) {
      if (used + s > size * 250) expectDropped++;
      else used += s;
    }
    await manual.advance(100);
    await settle();
    const m = writer.metrics();
    assert.equal(m.dropped, expectDropped);
    assert.equal(m.backlog, 400 - expectDropped);
    assert.ok(expectDropped > 140 && expectDropped < 160, `sizes as expected (${expectDropped})`);
    await writer.close();
    const restarted = new Spool({ dir: spoolDir, maxBytes: size * 250 });
    assert.equal(restarted.backlog().dropped, expectDropped, 'the count survives a restart');
    assert.equal(restarted.backlog().rows, 400 - expectDropped);
  });
});

describe('journal bus and local files', function () {
  let dir;
  beforeEach(() => { dir = tmp(); });
  afterEach(() => fs.rmSync(dir, { recursive: true, force: true }));

  it('encodes each kind of row with its tags and numbers, and the reader gives them back', function () {
    const bus = new JournalBus();
    const rows = [];
    bus.attach({ row: (r) => rows.push(r) });
    bus.datapoint('ctrl-1', 'valve/3', true, 1000, 1040);
    bus.event('interlock', 'granted', 'op 1', { resources: ['YEL', 'GRN'], waitedMs: 12, note: 'a, b=c' }, 2000);
    bus.action('clear', { who: 'Ann', why: 'checked the pump' }, ['YEL']);
    bus.timing('tof/ctrl-1', 40);
    bus.timing('overhead/interlock', 0.1);
    bus.datapoint('ctrl-1', 'valve/3', 'open', 1000, 1040); // not a number: not journalled
    assert.equal(rows.length, 4);
    const writer = new JournalWriter({ plant: 'sugar shack', target: filesTarget({ dir }) });
    rows.forEach((r) => writer.row(r));
    writer.flush();
    const back = readJournal(dir);
    const writer0 = writer.writerId;
    assert.match(writer0, /^[0-9a-f]{12}$/);
    assert.deepEqual(back.map((r) => r.table), ['sugarshack_datapoint', 'sugarshack_event', 'sugarshack_action', 'sugarshack_timing']);
    assert.deepEqual(back[0].tags, { plant: 'sugar shack', writer: writer0, device: 'ctrl-1', entity: 'valve/3' });
    assert.deepEqual(back[0].fields, { value: 1, device_ts: 1000, seq: 1 });
    assert.equal(back[0].at, 1040);
    assert.deepEqual(back[1].tags, { plant: 'sugar shack', writer: writer0, layer: 'interlock', kind: 'granted', subject: 'op 1', resources: 'YEL GRN', note: 'a, b=c' });
    assert.equal(back[1].fields.waited_ms, 12);
    assert.deepEqual(back[2].tags, { plant: 'sugar shack', writer: writer0, action: 'clear', who: 'Ann', why: 'checked the pump', target: 'YEL' });
    assert.deepEqual(back[3].tags, { plant: 'sugar shack', writer: writer0, series: 'tof', subject: 'ctrl-1' });
    assert.deepEqual(readJournal(dir, { fromMs: 1041, toMs: 2001 }).map((r) => r.table), ['sugarshack_event']);
    writer.close();
  });

  it('stamps rows of one series in one millisecond 1 ms apart, so a server keeping one value per ms keeps them all', function () {
    const bus = new JournalBus();
    const writer = new JournalWriter({ plant: 'p', target: filesTarget({ dir }) });
    bus.attach(writer);
    for (const value of [1, 2, 3]) bus.datapoint('ctrl-1', 'V101', value, null, 5000); // a backlog read in one ms
    bus.datapoint('ctrl-1', 'V102', 9, null, 5000); // another series keeps its time
    bus.datapoint('ctrl-1', 'V101', 4, null, 5001);
    bus.datapoint('ctrl-1', 'V101', 5, null, 1000); // a clock set back is followed
    writer.flush();
    const back = readJournal(dir).map((r) => [r.tags.entity, r.fields.value, r.at]);
    assert.deepEqual(back, [['V101', 1, 5000], ['V101', 2, 5001], ['V101', 3, 5002], ['V102', 9, 5000], ['V101', 4, 5003], ['V101', 5, 1000]]);
    writer.close();
  });

  it('rotates the local files and keeps at most maxFiles of them', function () {
    const target = filesTarget({ dir, fileBytes: 100, maxFiles: 3 });
    for (let i = 1; i <= 20; i++) target.append([row(i, 20)]);
    const files = fs.readdirSync(dir).filter((f) => f.endsWith('.lp'));
    assert.equal(files.length, 3);
    const kept = readJournal(dir).map((r) => r.fields.n);
    assert.deepEqual(kept, Array.from({ length: kept.length }, (_, i) => 21 - kept.length + i), 'the newest rows, in order');
  });

  it('parses escaped tags and string fields', function () {
    assert.deepEqual(parseLine('t,a=x\\ y,b=c\\,d f="q \\"z\\"",n=3i 5000000'), { table: 't', tags: { a: 'x y', b: 'c,d' }, fields: { f: 'q "z"', n: 3 }, at: 5 });
  });
});

describe('journal node', function () {
  beforeEach(startServer);
  afterEach(stopServer);

  for (const [settings, flush] of [['flushS in s', { flushS: '0.1' }], ['flushMs of older flows', { flushS: '', flushMs: 100 }]]) it(`journals a plant run into local files (${settings}): the operator action, the interlock events, and the timing series`, async function () {
    const flow = [
      { id: 'f1', type: 'tab', label: 'test' },
      { id: 'j', z: 'f1', type: 'sugarshack-journal', name: '', target: 'files', plantId: 'p1', ...flush, wires: [['out']] },
      { id: 'out', z: 'f1', type: 'helper' },
    ];
    await helper.load(paletteNodes, flow);
    const node = helper.getNode('j');
    const out = helper.getNode('out');
    const got = [];
    out.on('input', (msg) => got.push(msg));
    node.receive({ topic: 'YEL', who: 'Ann', why: 'sap is running', flush: true });
    stats.add('tof/ctrl-1', 35);
    journal.interlockEvents([{ kind: 'granted', operation: 'fill', resources: ['YEL'], atMs: clock().now(), waitedMs: 0 }]);
    await runFor(helper, 300, { ids: [], step: 100 });
    await settled(helper);
    const rows = readJournal(path.join(userDir(), 'sugarshack-journal', 'files'));
    assert.deepEqual(rows.map((r) => `${r.table}:${r.tags.action || r.tags.kind || r.tags.series}`),
      ['sugarshack_action:note', 'sugarshack_timing:tof', 'sugarshack_event:granted']);
    assert.equal(rows[0].tags.who, 'Ann');
    assert.equal(got.length, 1);
    assert.equal(got[0].journal.state, 'idle');
    assert.match(node.status.lastCall ? node.status.lastCall.args[0].text : 'rows 3', /^rows \d+$/);
  });

  it('takes its database from ${NAME} properties filled from the environment (the container flows), HTTPS as the text true', async function () {
    const names = { SS_TEST_DB_HOST: '127.0.0.1', SS_TEST_DB_PORT: '1', SS_TEST_DB_TLS: 'true', SS_TEST_PLANT: 'shack-7' };
    Object.assign(process.env, names);
    try {
      const flow = [{ id: 'j', type: 'sugarshack-journal', target: 'http', host: '${SS_TEST_DB_HOST}', port: '${SS_TEST_DB_PORT}', tls: '${SS_TEST_DB_TLS}', plantId: '${SS_TEST_PLANT}' }];
      await helper.load(paletteNodes, flow);
      const { writers } = require(path.join(PALETTE, 'nodes', 'journal.js'));
      const writer = writers.get('j');
      assert.equal(writer.target.where, 'https://127.0.0.1:1');
      assert.equal(writer.encoder.plant, 'shack-7');
    } finally {
      for (const k of Object.keys(names)) delete process.env[k];
    }
  });

  it('refuses a database target without a host: an error and a red status, nothing journalled', async function () {
    const flow = [{ id: 'j', type: 'sugarshack-journal', target: 'http', host: '', port: 9000 }];
    await helper.load(paletteNodes, flow);
    const node = helper.getNode('j');
    assert.match(String(node.error.firstCall.args[0]), /needs the database host/);
    assert.equal(journal.active, false);
  });
});
