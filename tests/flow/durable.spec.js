'use strict';
// The interlock's durable state: written to <userDir>/sugarshack/ before any
// effect of a change leaves a node, whatever context store the user chose;
// restored after a restart (held lines faulted "interrupted", faults kept,
// waiting requests dropped); a lost or inconsistent state starts with every
// line faulted instead of free; a shutdown never changes what was saved; a
// deploy that keeps the interlock's settings hands it over untouched.
const assert = require('node:assert/strict');
const fs = require('fs');
const path = require('path');
const helper = require('node-red-node-test-helper');
const {
  paletteNodes, TAB, interlockConfig, acquire, release, sinkNode, collect, until, trackCompletions, untrackCompletions,
  startServer, stopServer, settings, settled, userDir, clock, memoryStore, checksumOf, resealed, crashCopy,
} = require('./support');

helper.init(require.resolve('node-red'));

const LINES = ['YEL', 'GRN', 'BLU', 'PUR', 'RED'];
const runtimeOf = () => helper.getNode('il').runtime;
const counts = () => runtimeOf().core.counts();
const quiet = () => settled(helper, 'il');
const stateFile = () => path.join(userDir(), 'sugarshack', 'interlock-il.json');
const markerFile = () => path.join(userDir(), 'sugarshack', 'interlock-il.ran');
const saved = () => JSON.parse(fs.readFileSync(stateFile(), 'utf8'));
const writeSealed = (doc) => fs.writeFileSync(stateFile(), resealed(doc));
const savedLines = () => Object.fromEntries(saved().state.interlock.resources.map((r) => [r.name, r.state.state === 'faulted' ? `faulted:${r.state.cause}` : r.state.state]));
const liveLines = () => Object.fromEntries(runtimeOf().core.snapshot(0).resources.map((r) => [r.name, r.state.state === 'faulted' ? `faulted:${r.state.cause}` : r.state.state]));
const lastStatus = (id) => {
  const calls = helper.getNode(id).status.getCalls().filter((c) => c.thisValue.id === id);
  return calls.length ? calls[calls.length - 1].args[0] : undefined;
};
const errorsOf = (id) => helper.getNode(id).error.getCalls().filter((c) => c.thisValue.id === id).map((c) => String(c.args[0]));

const estop = (id, line, wire = 'lockout') => ({
  id, z: 'f1', type: 'sugarshack-fault', interlock: 'il', mode: 'resources', operation: '', resources: line, wires: [['back'], [wire]],
});
const clearAll = (id = 'clr') => ({ id, z: 'f1', type: 'sugarshack-clear', interlock: 'il', mode: 'all', resources: '', wires: [['cleared']] });
const eventsNode = { id: 'ev', z: 'f1', type: 'sugarshack-interlock-events', interlock: 'il', wires: [['events']] };

function flow(extra = [], config = {}) {
  return [
    TAB, interlockConfig({ persist: true, ...config }),
    acquire('a10', '10', 20, 'YEL', 'out'), acquire('a12', '12', 22, 'YEL', 'out'), acquire('a51', '51', 1, 'RED', 'out'),
    acquire('a18', '18', 92, 'YEL,RED', 'out'),
    release('rel', 'relout'), estop('stopGRN', 'GRN'), estop('stopPUR', 'PUR'), clearAll(), eventsNode,
    ...['out', 'relout', 'back', 'lockout', 'cleared', 'events'].map(sinkNode),
    ...extra,
  ];
}

describe('sugarshack durable interlock state', function () {
  beforeEach(startServer);

  afterEach(async function () {
    untrackCompletions();
    await stopServer();
  });

  it('first start of a new interlock: every line free, its marker and state written to the user directory', async function () {
    assert.equal(fs.existsSync(markerFile()), false);
    await helper.load(paletteNodes, flow());
    await quiet();
    assert.deepEqual(liveLines(), Object.fromEntries(LINES.map((l) => [l, 'free'])));
    assert.ok(fs.existsSync(markerFile()), 'the "has run before" marker');
    assert.deepEqual(savedLines(), liveLines());
    const doc = saved();
    assert.deepEqual([doc.format, doc.version, doc.owner], ['sugarshack-interlock-state', 2, 'il']);
    assert.match(doc.savedFor, /^sha256:[0-9a-f]{64}$/);
    assert.equal(doc.checksum, checksumOf(doc), 'the checksum, computed as documented by another implementation');
    assert.equal(doc.state.interlock.version, 2);
    assert.deepEqual(doc.state.interlock.configured, LINES);
  });

  it('a grant, a lockout and a clear leave only once the state holding them is on disk', async function () {
    await helper.load(paletteNodes, flow());
    // Each effect reads the file at the moment it arrives, as a crash right then would leave it.
    const seenAtGrant = [];
    const seenAtLockout = [];
    const seenAtClear = [];
    helper.getNode('out').on('input', () => seenAtGrant.push(savedLines()));
    helper.getNode('lockout').on('input', () => seenAtLockout.push(savedLines()));
    helper.getNode('cleared').on('input', () => seenAtClear.push(savedLines()));
    helper.getNode('a10').receive({});
    helper.getNode('stopGRN').receive({ payload: 'e-stop pressed' });
    await until(() => seenAtGrant.length === 1 && seenAtLockout.length === 1, 'grant and lockout');
    assert.equal(seenAtGrant[0].YEL, 'held');
    assert.equal(seenAtLockout[0].GRN, 'faulted:manual');
    helper.getNode('clr').receive({});
    await until(() => seenAtClear.length === 1, 'clear');
    assert.equal(seenAtClear[0].GRN, 'free');
    assert.equal(seenAtClear[0].YEL, 'held');
  });

  it('a new operation name per msg: idle names are forgotten, state and memory stay bounded, a known name still works', async function () {
    this.timeout(60000);
    await helper.load(paletteNodes, [...flow([{ id: 'c1', z: 'f1', type: 'catch', scope: null, uncaught: false, wires: [['caught']] }, sinkNode('caught')])]);
    const [out, relout, caught] = ['out', 'relout', 'caught'].map((id) => collect(helper, id));
    const epoch = runtimeOf().core.handleEpoch();
    helper.getNode('a10').receive({ operation: 'steady' });
    helper.getNode('rel').receive({ operation: 'steady' });
    const batches = 6000; // past the 4096 names an interlock keeps
    for (let i = 0; i < batches; i++) {
      helper.getNode('a10').receive({ operation: `batch-${i}` });
      helper.getNode('rel').receive({ operation: `batch-${i}` });
      // Msgs from a flow arrive over many turns, and events are drained between them.
      if (i % 100 === 99) await new Promise(setImmediate);
    }
    await until(() => relout.length === batches + 1, 'every batch released', 30000);
    assert.notEqual(runtimeOf().core.handleEpoch(), epoch, 'idle names were forgotten');
    const slot = runtimeOf().core.findOperation(`batch-${batches - 1}`) % 2 ** 32;
    // Reused, not new: 6,001 names went through. How far under 6,000 it lands depends on how many
    // names undrained events still pinned at the forgetting (the core forgets again at twice those).
    assert.ok(slot < batches, `slots are reused: the last batch is in slot ${slot}`);
    // 'steady' was forgotten while its handle was kept by name: it is asked for again, not refused.
    helper.getNode('a10').receive({ operation: 'steady' });
    await until(() => out.length === batches + 2, 'steady granted again');
    await quiet();
    assert.deepEqual(caught.map((m) => m.error.message), []);
    assert.deepEqual(counts(), { holding: 1, queued: 0, faulted: 0 });
    assert.equal(saved().state.interlock.holds.length, 1);
    assert.ok(fs.statSync(stateFile()).size < 4000, `saved state ${fs.statSync(stateFile()).size} bytes`);
  });

  it('one turn of the event loop is one write, however many changes it made', async function () {
    await helper.load(paletteNodes, flow());
    await quiet();
    const before = runtimeOf().committer.writes;
    const ops = Array.from({ length: 50 }, (_, i) => `op${i}`);
    for (const op of ops) helper.getNode('a10').receive({ operation: op, resources: 'BLU' });
    await quiet();
    assert.deepEqual(counts(), { holding: 1, queued: 49, faulted: 0 });
    assert.equal(runtimeOf().committer.writes - before, 1, '50 requests, one write');
  });

  it('restart after a crash: held lines come back faulted "interrupted", faults stay, waiting requests are dropped, nothing is granted', async function () {
    await helper.load(paletteNodes, flow());
    const out = collect(helper, 'out');
    helper.getNode('a10').receive({});
    helper.getNode('stopPUR').receive({ payload: 'washball leak' });
    await until(() => out.length === 1, 'op 10 holds YEL');
    helper.getNode('a12').receive({ payload: 'waits for YEL' });
    await quiet();
    assert.deepEqual(counts(), { holding: 1, queued: 1, faulted: 1 });
    const putBack = crashCopy();
    await helper.unload();
    putBack();

    await helper.load(paletteNodes, flow());
    const after = collect(helper, 'out');
    const events = collect(helper, 'events');
    await quiet();
    assert.deepEqual(liveLines(), { YEL: 'faulted:interrupted', GRN: 'free', BLU: 'free', PUR: 'faulted:manual', RED: 'free' });
    assert.equal(runtimeOf().core.snapshot(0).resources.find((r) => r.name === 'PUR').state.note, 'washball leak');
    assert.deepEqual(counts(), { holding: 0, queued: 0, faulted: 2 });
    assert.equal(after.length, 0, 'the restart granted nothing');
    await until(() => events.length > 0, 'restore events');
    assert.ok(events.some((e) => e.payload.kind === 'interrupted' && e.payload.operation === '10'), JSON.stringify(events.map((e) => e.payload)));
    assert.ok(events.some((e) => e.payload.kind === 'dropped' && e.payload.operation === '12'));
    assert.deepEqual(lastStatus('a10'), { fill: 'red', shape: 'dot', text: 'faulted 2' });
    helper.getNode('a51').receive({});
    await until(() => after.length === 1, 'RED was never affected');
  });

  it('with the localfilesystem context store and its default cache, a crash loses nothing', async function () {
    // Node-RED's default: the store keeps writes in memory and flushes every 30 s.
    settings({ contextStorage: { default: { module: 'localfilesystem' } } });
    const contextModule = require(require.resolve('@node-red/runtime/lib/nodes/context', { paths: [path.dirname(require.resolve('node-red'))] }));
    const loadStores = () => contextModule.load();
    try {
      await helper.load([...paletteNodes, loadStores], flow());
      const out = collect(helper, 'out');
      helper.getNode('a10').receive({});
      helper.getNode('stopGRN').receive({});
      await until(() => out.length === 1, 'held');
      await quiet();
      const putBack = crashCopy();
      assert.equal(fs.existsSync(path.join(userDir(), 'context', 'global', 'global.json')), false, 'the context store has not flushed');
      await helper.unload();
      await contextModule.close();
      putBack();
      await helper.load([...paletteNodes, loadStores], flow());
      await quiet();
      assert.equal(liveLines().YEL, 'faulted:interrupted');
      assert.equal(liveLines().GRN, 'faulted:manual');
    } finally {
      await contextModule.close();
    }
  });

  it('a shutdown does not change the saved state, even when withdrawing a waiter would grant another', async function () {
    // No overtaking: 51 (RED) waits behind 18 (YEL+RED); withdrawing 18 at close would grant 51.
    await helper.load(paletteNodes, flow([], { policy: 'no-overtaking' }));
    const out = collect(helper, 'out');
    helper.getNode('a10').receive({});
    await until(() => out.length === 1, 'op 10 holds YEL');
    helper.getNode('a18').receive({});
    helper.getNode('a51').receive({});
    await quiet();
    assert.deepEqual(counts(), { holding: 1, queued: 2, faulted: 0 });
    const before = fs.readFileSync(stateFile(), 'utf8');
    const completions = trackCompletions();
    await helper.unload();
    assert.equal(fs.readFileSync(stateFile(), 'utf8'), before, 'byte for byte what was saved before the shutdown');
    assert.equal(out.length, 1, 'nothing granted while stopping');
    assert.equal(completions.filter((c) => c.nodeId === 'a18' || c.nodeId === 'a51').length, 2, 'both waiting msgs completed unsent');

    await helper.load(paletteNodes, flow([], { policy: 'no-overtaking' }));
    await quiet();
    assert.deepEqual(liveLines(), { YEL: 'faulted:interrupted', GRN: 'free', BLU: 'free', PUR: 'free', RED: 'free' });
  });

  describe('a lost or inconsistent saved state starts with every line faulted', function () {
    /** Runs the interlock once (op 10 holds YEL), breaks its saved state, and starts it again. */
    async function restartWith(breakIt) {
      await helper.load(paletteNodes, flow());
      const out = collect(helper, 'out');
      helper.getNode('a10').receive({});
      await until(() => out.length === 1, 'held');
      await quiet();
      await helper.unload();
      breakIt();
      await helper.load(paletteNodes, flow());
      await quiet();
    }

    const breakages = [
      ['the state file is empty (0 bytes)', () => fs.writeFileSync(stateFile(), ''), /is empty/],
      ['the state file is deleted', () => fs.rmSync(stateFile()), /is missing/],
      ['the state file is not JSON', () => fs.writeFileSync(stateFile(), '{"format": "sugarshack-interlock-state", "interl'), /not valid JSON/],
      ['the snapshot no longer lists a line', () => {
        const doc = saved();
        doc.state.interlock.resources = doc.state.interlock.resources.filter((r) => r.name !== 'RED');
        writeSealed(doc);
      }, /line 'RED' was configured but 'resources' does not say its state/],
      ['a hold contradicts the lines', () => {
        const doc = saved();
        doc.state.interlock.holds[0].resources = ['GRN'];
        writeSealed(doc);
      }, /GRN|YEL/],
      ['a line is listed twice', () => {
        const doc = saved();
        doc.state.interlock.resources.push({ ...doc.state.interlock.resources[1] });
        writeSealed(doc);
      }, /GRN.*twice|twice.*GRN/],
      ['an unknown line is listed', () => {
        const doc = saved();
        doc.state.interlock.resources.push({ name: 'BLK', state: { state: 'free' } });
        writeSealed(doc);
      }, /BLK/],
      ['a note is nested 10,000 levels deep', () => {
        const doc = saved();
        doc.state.interlock.resources[0].state = { state: 'faulted', cause: 'manual', note: 'DEEP', sinceMs: 0 };
        // Written as text: JSON.stringify itself cannot go that deep.
        fs.writeFileSync(stateFile(), JSON.stringify(doc).replace('"DEEP"', `${'['.repeat(10000)}"x"${']'.repeat(10000)}`));
      }, /nested/],
      ['its checksum no longer matches (the file edited by hand)', () => {
        const doc = saved();
        doc.state.interlock.holds = [];
        doc.state.interlock.resources[0].state = { state: 'free' };
        fs.writeFileSync(stateFile(), JSON.stringify(doc));
      }, /does not match its checksum/],
    ];

    for (const [what, breakIt, why] of breakages) {
      it(`${what}: every line faulted "unknown", said in the log and a red status, until a person clears it`, async function () {
        await restartWith(breakIt);
        assert.deepEqual(liveLines(), Object.fromEntries(LINES.map((l) => [l, 'faulted:unknown'])));
        const logged = errorsOf('il');
        assert.ok(logged.some((m) => /state unknown after restart/.test(m) && why.test(m)), logged.join('\n'));
        assert.equal(lastStatus('a10').fill, 'red');
        assert.match(lastStatus('a10').text, /^lost/);
        assert.ok(lastStatus('a10').text.length < 20);
        const out = collect(helper, 'out');
        helper.getNode('a51').receive({});
        await quiet();
        assert.equal(out.length, 0, 'nothing is granted before a person clears');
        helper.getNode('clr').receive({});
        await until(() => out.length === 1, 'granted once cleared');
        assert.deepEqual(lastStatus('a10'), { fill: 'green', shape: 'dot', text: 'held 1' });
        assert.equal(runtimeOf().lostState, null);
      });
    }
  });

  describe('a state file that is not this interlock\'s, or that cannot show a line is new, is lost state', function () {
    const stateApi = async () => (await helper.request().get('/sugarshack/state').expect(200)).body.interlocks.find((i) => i.id === 'il');
    const warningsOf = (id) => helper.getNode(id).warn.getCalls().filter((c) => c.thisValue.id === id).map((c) => String(c.args[0]));

    /** Runs the interlock once (op 10 holds YEL, PUR e-stopped with a note), changes its file, starts it again. */
    async function restartAfter(change, config = {}) {
      await helper.load(paletteNodes, flow());
      const out = collect(helper, 'out');
      helper.getNode('a10').receive({});
      helper.getNode('stopPUR').receive({ payload: 'washball leak' });
      await until(() => out.length === 1, 'held');
      await quiet();
      await helper.unload();
      await change();
      await helper.load(paletteNodes, flow([], config));
      const events = collect(helper, 'events');
      await quiet();
      return events;
    }

    /** Every line faulted "unknown", the reason logged, on the nodes and in the state API; nothing granted until cleared. */
    async function assertLost(why) {
      assert.deepEqual(liveLines(), Object.fromEntries(LINES.map((l) => [l, 'faulted:unknown'])));
      const logged = errorsOf('il');
      assert.ok(logged.some((m) => /state unknown after restart/.test(m) && why.test(m)), logged.join('\n'));
      assert.equal(lastStatus('a10').fill, 'red');
      assert.equal(lastStatus('a10').text, 'lost · faulted 5');
      const api = await stateApi();
      assert.match(api.lostState, why);
      assert.deepEqual({ ...api.started, reason: undefined }, { outcome: 'lost', reason: undefined, added: [], dropped: [] });
      assert.ok(api.lines.every((l) => l.fault.cause === 'unknown' && why.test(l.fault.note)), JSON.stringify(api.lines[0]));
      const out = collect(helper, 'out');
      helper.getNode('a51').receive({});
      await quiet();
      assert.equal(out.length, 0, 'nothing is granted before a person clears');
    }

    it('another interlock\'s state file, with the same lines, copied over this one\'s', async function () {
      await restartAfter(async () => {
        // Interlock "il-2" runs here with every line free; its file then replaces this one's.
        await helper.load(paletteNodes, [TAB, interlockConfig({ id: 'il-2', persist: true })]);
        await settled(helper, 'il-2');
        await helper.unload();
        fs.copyFileSync(path.join(userDir(), 'sugarshack', 'interlock-il-2.json'), stateFile());
      });
      await assertLost(/state of node 'il-2', not of this one/);
    });

    it('a checksum mismatch: one byte changed inside a note', async function () {
      await restartAfter(() => {
        const text = fs.readFileSync(stateFile(), 'utf8');
        assert.ok(text.includes('washball leak'));
        fs.writeFileSync(stateFile(), text.replace('washball leak', 'washball leek'));
      });
      await assertLost(/does not match its checksum/);
    });

    it('an outer document version it does not know', async function () {
      await restartAfter(() => writeSealed({ ...saved(), version: 99 }));
      await assertLost(/document version 99; this version reads version 2 only/);
    });

    it('a version 1 snapshot listing no lines', async function () {
      await restartAfter(() => {
        const doc = saved();
        doc.state.interlock = { version: 1, takenAtMs: 0, resources: [], queue: [], holds: [] };
        writeSealed(doc);
      });
      await assertLost(/snapshot is version 1; a state file holds version 2 only/);
    });

    it('a line removed from both lists of the snapshot, resealed', async function () {
      await restartAfter(() => {
        const doc = saved();
        doc.state.interlock.configured = doc.state.interlock.configured.filter((l) => l !== 'RED');
        doc.state.interlock.resources = doc.state.interlock.resources.filter((r) => r.name !== 'RED');
        writeSealed(doc);
      });
      await assertLost(/saved for this very configuration, yet it lists the lines YEL, GRN, BLU, PUR where the configuration has YEL, GRN, BLU, PUR, RED/);
    });

    it('a line really added to the configuration after the save starts free, logged and evented', async function () {
      const withBlk = [...interlockConfig().resources, { name: 'BLK', lockout: null }];
      const restartEvents = await restartAfter(() => {}, { resources: withBlk });
      assert.deepEqual(liveLines(), { YEL: 'faulted:interrupted', GRN: 'free', BLU: 'free', PUR: 'faulted:manual', RED: 'free', BLK: 'free' });
      assert.deepEqual(warningsOf('il').filter((m) => /BLK/.test(m)), ['line BLK was added to the configuration after the state was saved: it starts free']);
      assert.deepEqual(errorsOf('il'), []);
      const api = await stateApi();
      assert.equal(api.lostState, null);
      assert.deepEqual(api.started, { outcome: 'restored', reason: null, added: ['BLK'], dropped: [] });
      assert.equal(lastStatus('a10').text, 'faulted 2');
      await until(() => restartEvents.length >= 2, 'the restart\'s events');
      assert.deepEqual(restartEvents.map((e) => [e.payload.kind, e.payload.resources.join(), e.summary]), [
        ['resource-added', 'BLK', 'line BLK added, starts free'],
        ['interrupted', 'YEL', 'interrupted 10: YEL held at the restart, now faulted'],
      ]);
      helper.getNode('a10').receive({ operation: 'blk', resources: 'BLK' });
      const out = collect(helper, 'out');
      await until(() => out.length === 1, 'BLK granted');
    });
  });

  it('a state saved by an earlier version in a context store is carried over, msgs waiting meanwhile', async function () {
    const contextModule = require(require.resolve('@node-red/runtime/lib/nodes/context', { paths: [path.dirname(require.resolve('node-red'))] }));
    let release150 = null;
    const data = { global: { 'sugarshack-interlock:il': {
      version: 1,
      takenAtMs: 0,
      resources: LINES.map((name) => ({ name, state: name === 'PUR' ? { state: 'faulted', cause: 'manual', note: 'old fault', sinceMs: 5 } : { state: 'free' } })),
      queue: [],
      holds: [],
    } } };
    const slowStore = memoryStore(data, (scope, key, cb) => { release150 = () => cb(null, (data[scope] || {})[key]); });
    settings({ contextStorage: { slow: { module: slowStore } } });
    await helper.load([...paletteNodes, () => contextModule.load()], flow([], { store: 'slow' }));
    const out = collect(helper, 'out');
    assert.equal(runtimeOf().state, 'starting');
    assert.deepEqual(lastStatus('a10'), { fill: 'grey', shape: 'ring', text: 'starting' });
    helper.getNode('a10').receive({});
    helper.getNode('a12').receive({});
    await until(() => release150 !== null, 'the legacy read');
    await quiet();
    assert.equal(out.length, 0, 'nothing is granted before the state is read');
    release150();
    await until(() => out.length === 1, 'the first grant after loading');
    assert.equal(out[0].interlock.operation, '10', 'the msg that came first is served first');
    assert.equal(liveLines().PUR, 'faulted:manual');
    await quiet();
    assert.equal(savedLines().PUR, 'faulted:manual', 'now in the state file');
    await contextModule.close();
  });

  describe('deploys', function () {
    /** Loads `f`: op 10 holds YEL, GRN is e-stopped, and op 12 (msg `waiter`) waits for YEL. */
    async function holdFaultAndWait(f, waiter = {}) {
      await helper.load(paletteNodes, f);
      const out = collect(helper, 'out');
      helper.getNode('a10').receive({});
      helper.getNode('stopGRN').receive({});
      await until(() => out.length === 1, 'op 10 holds YEL');
      helper.getNode('a12').receive(waiter);
      await quiet();
    }
    /** What holdFaultAndWait set up, still there. */
    function assertHeldFaultedWaiting() {
      assert.deepEqual(liveLines(), { YEL: 'held', GRN: 'faulted:manual', BLU: 'free', PUR: 'free', RED: 'free' });
      assert.deepEqual(counts(), { holding: 1, queued: 1, faulted: 1 });
    }
    /** Loads `f` (no overtaking): op 10 holds YEL; op 18 (msg `wide`, YEL and RED), then op 51 (RED) wait. */
    async function holdAndTwoWaiting(f, wide) {
      await helper.load(paletteNodes, f);
      const out = collect(helper, 'out');
      helper.getNode('a10').receive({});
      await until(() => out.length === 1, 'op 10 granted');
      helper.getNode('a18').receive(wide);
      helper.getNode('a51').receive({ payload: 'drain silo' });
      await quiet();
    }

    it('a full deploy of unchanged flows hands everything over: holds, faults and waiting msgs go on, nothing faults', async function () {
      const f = flow();
      const waiter = { payload: 'unload' };
      await holdFaultAndWait(f, waiter);
      const core = runtimeOf().core;

      await helper.setFlows(f, 'full');
      await quiet();
      assert.equal(runtimeOf().core, core, 'the same interlock, not a restored one');
      assertHeldFaultedWaiting();
      const after = collect(helper, 'out');
      const events = collect(helper, 'events');
      helper.getNode('rel').receive({ operation: '10' });
      await until(() => after.length === 1, 'the waiting msg, granted after the deploy');
      assert.equal(after[0], waiter, 'the same msg object');
      assert.equal(after[0].interlock.operation, '12');
      await quiet();
      assert.deepEqual(events.map((e) => e.payload.kind), ['released', 'granted']);
    });

    it('a modified-nodes deploy of a waiting acquire node sends its msg from its new instance', async function () {
      const f = flow([], { policy: 'no-overtaking' });
      const wide = { payload: 'flit downstock' };
      await holdAndTwoWaiting(f, wide);
      assert.deepEqual(counts(), { holding: 1, queued: 2, faulted: 0 });

      await helper.setFlows(f.map((n) => (n.id === 'a18' ? { ...n, name: 'renamed' } : n)), 'nodes');
      await quiet();
      assert.deepEqual(counts(), { holding: 1, queued: 2, faulted: 0 }, 'nothing withdrawn, nothing overtook');
      const after = collect(helper, 'out');
      helper.getNode('rel').receive({ operation: '10' });
      await until(() => after.length === 1, 'op 18 granted');
      assert.equal(after[0], wide);
    });

    it('a deploy that removes a waiting acquire node withdraws its request; the next waiter goes', async function () {
      const f = flow([], { policy: 'no-overtaking' });
      const completions = trackCompletions();
      const wide = { payload: 'flit downstock' };
      await holdAndTwoWaiting(f, wide);
      await helper.setFlows(f.filter((n) => n.id !== 'a18'), 'nodes');
      const after = collect(helper, 'out');
      await until(() => after.length === 1, 'op 51 granted once 18 left');
      assert.equal(after[0].interlock.operation, '51');
      assert.equal(completions.filter((c) => c.msgid === wide._msgid).length, 1, 'the removed node\'s msg completed');
    });

    it('a deploy that restarts a waiting acquire node bound elsewhere withdraws its request at the deploy\'s end; the next waiter goes', async function () {
      const f = flow([], { policy: 'no-overtaking' });
      const completions = trackCompletions();
      const wide = { payload: 'flit downstock' };
      await holdAndTwoWaiting(f, wide);
      // Modified, not removed: its new instance names no interlock here, so it never comes back to this one.
      await helper.setFlows(f.map((n) => (n.id === 'a18' ? { ...n, interlock: 'gone' } : n)), 'nodes');
      const after = collect(helper, 'out');
      await until(() => after.length === 1, 'op 51 granted once 18 was withdrawn');
      assert.equal(after[0].interlock.operation, '51');
      assert.deepEqual(counts(), { holding: 2, queued: 0, faulted: 0 }, 'op 10 holds YEL, op 51 RED, nothing waits');
      assert.equal(completions.filter((c) => c.msgid === wide._msgid).length, 1, 'the restarted node\'s msg completed');
    });

    it('a deploy that changes the interlock\'s settings keeps holds, faults and waiting requests', async function () {
      const f = flow();
      await holdFaultAndWait(f);
      const core = runtimeOf().core;
      await helper.setFlows(f.map((n) => (n.id === 'il' ? { ...n, policy: 'no-overtaking' } : n)), 'full');
      await until(() => runtimeOf().core !== core && runtimeOf().gateOpen, 'the new settings applied');
      await quiet();
      assert.equal(runtimeOf().config.policy, 'no-overtaking');
      assertHeldFaultedWaiting();
      const after = collect(helper, 'out');
      helper.getNode('rel').receive({ operation: '10' });
      await until(() => after.length === 1, 'the waiting request granted');
      assert.equal(after[0].interlock.operation, '12');
    });
  });

  it('a state that cannot be written holds grants back (status "state not saved") but lets lockouts out', async function () {
    await helper.load(paletteNodes, flow());
    await quiet();
    // The state directory replaced by a file: every write now fails.
    const dir = path.join(userDir(), 'sugarshack');
    fs.rmSync(dir, { recursive: true, force: true });
    fs.writeFileSync(dir, 'not a directory');
    const out = collect(helper, 'out');
    const lockout = collect(helper, 'lockout');
    helper.getNode('a10').receive({});
    helper.getNode('stopGRN').receive({});
    await until(() => lockout.length === 1, 'the lockout goes out anyway');
    await until(() => lastStatus('a10').text === 'state not saved', 'the status');
    assert.equal(out.length, 0, 'the grant waits for its state');
    assert.ok(errorsOf('il').some((m) => /cannot save the interlock state/.test(m)));
    fs.rmSync(dir);
    fs.mkdirSync(dir);
    await clock().advance(1000);
    await until(() => out.length === 1, 'granted once saved');
    assert.equal(savedLines().YEL, 'held');
  });
});
