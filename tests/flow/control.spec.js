'use strict';
// The pid, rcc and rcc-io nodes: PID terms in standard form for known inputs,
// limits, bumpless manual -> auto and tuning changes, a persisted integrator
// across a restart, fallback on a bad or stale measurement (never a NaN),
// refused configurations, RCC decisions and the I/O module's ages, and two
// redundant controllers handing over without a bump (the paper's G1-G2-G3).
// Watchdogs, polls and publish periods run on the manual clock.
const assert = require('node:assert/strict');
const fs = require('fs');
const path = require('path');
const helper = require('node-red-node-test-helper');
const {
  PALETTE, paletteNodes, TAB, sinkNode, collect, until, serverPerTest, completions,
  settings, settled, clock, runFor, runUntil, userDir, memoryStore, resealed,
} = require('./support');

helper.init(require.resolve('node-red'));

const coreNodesDir = path.dirname(require.resolve('@node-red/nodes/package.json'));
const contextModule = require(require.resolve('@node-red/runtime/lib/nodes/context', { paths: [path.dirname(require.resolve('node-red'))] }));

const close = (a, b, eps = 1e-9) => assert.ok(Math.abs(a - b) <= eps, `${a} is not ${b} (within ${eps})`);

function pidNode(id, extra = {}, wire = 'out') {
  return {
    id, z: 'f1', type: 'sugarshack-pid', name: '',
    kp: '2', ti: '10', td: '1', outMin: '0', outMax: '100', action: 'reverse', fallback: '',
    setpoint: '50', mode: 'auto', manual: '', ts: '1', staleS: '0',
    smith: 'off', modelGain: '1', modelTau: '10', deadSamples: '0', alpha: '0.1', horizon: '3', maxSamples: '400',
    persist: false, store: 'default',
    wires: [[wire]], ...extra,
  };
}

const rccNode = (id, controller, wire, extra = {}) => ({
  id, z: 'f1', type: 'sugarshack-rcc', controller: String(controller), thresholdsS: '0.1, 0.2', tsS: '0.05', smooth: true, pollTimeoutS: '0.15',
  wires: [[wire]], ...extra,
});
// The same rcc settings as a flow saved while they were in ms carries them.
const LEGACY_RCC = { thresholdsS: '', tsS: '', pollTimeoutS: '', thresholds: '100, 200', ts: '50', pollTimeout: '150' };

const CATCH = { id: 'c1', z: 'f1', type: 'catch', scope: null, uncaught: false, wires: [['caught']] };

/** Loads the nodes with a Catch node and helper sinks; `sinks` collect what reaches them. */
async function start(nodes, sinks = ['out'], modules = []) {
  await helper.load([...paletteNodes, ...modules], [TAB, CATCH, sinkNode('caught'), ...sinks.map(sinkNode), ...nodes]);
  const seen = { caught: collect(helper, 'caught') };
  for (const s of sinks) seen[s] = collect(helper, s);
  return seen;
}

/** Gives `msg` to node `id` and waits until the node completed it (and what it sent was delivered). */
async function deliver(id, msg) {
  const before = completions().filter((c) => c.nodeId === id).length;
  helper.getNode(id).receive(msg);
  await until(() => completions().filter((c) => c.nodeId === id).length > before, `node ${id} to complete the msg`);
  await settled(helper);
}

const statusOf = (id) => helper.getNode(id).status.getCalls().filter((c) => c.thisValue.id === id).map((c) => c.args[0]).at(-1);
function errorLogs(id) {
  const log = helper.log();
  return log.args.map((a) => a[0]).filter((e) => e && e.level === log.ERROR && (!id || e.id === id)).map((e) => e.msg);
}

describe('sugarshack control: pid', function () {
  serverPerTest();

  it('gives P = kp·e, I += kp/ti·e·dt, D = −kp·td·dpv/dt for known inputs, dt from msg.timestamp', async function () {
    const seen = await start([pidNode('pid')]);
    await deliver('pid', { topic: 'TT-1', payload: 40, timestamp: 1000 });
    await deliver('pid', { topic: 'TT-1', payload: 42, timestamp: 2000 });
    await deliver('pid', { topic: 'TT-1', payload: 45, timestamp: 2500 });
    assert.equal(seen.out.length, 3);
    const [a, b, c] = seen.out.map((m) => m.pid);
    // The first sample integrates over Ts (1 s) and has no derivative.
    assert.deepEqual({ ...a, i: 0, output: 0 }, {
      p: 20, i: 0, d: 0, output: 0, mode: 'auto', saturated: false, setpoint: 50, measurement: 40, seen: 40, deadTimeSamples: null, dtS: 1,
    });
    close(a.i, 2);
    close(a.output, 22);
    close(b.p, 16);
    close(b.i, 2 + 0.2 * 8 * 1);
    close(b.d, -2 * 1 * (42 - 40) / 1);
    close(b.output, 15.6);
    assert.equal(b.dtS, 1);
    assert.equal(c.dtS, 0.5);
    close(c.p, 10);
    close(c.i, 3.6 + 0.2 * 5 * 0.5);
    close(c.d, -2 * 1 * (45 - 42) / 0.5);
    close(c.output, 10 + 4.1 - 12);
    for (const m of seen.out) {
      assert.equal(m.payload, m.pid.output);
      assert.equal(m.topic, 'TT-1', 'the msg goes on with its topic');
    }
    assert.deepEqual(statusOf('pid'), { fill: 'green', shape: 'dot', text: 'auto 2.1' });
    assert.equal(seen.caught.length, 0);
  });

  it('direct action reverses the sign of every term', async function () {
    const seen = await start([pidNode('pid', { action: 'direct', setpoint: '50' })]);
    await deliver('pid', { payload: 60, timestamp: 1000 });
    await deliver('pid', { payload: 62, timestamp: 2000 });
    const [a, b] = seen.out.map((m) => m.pid);
    close(a.p, 20);
    close(a.output, 22);
    close(b.p, 24);
    close(b.d, 2 * 1 * 2);
  });

  it('keeps the output within its limits, flags saturation, and applies new limits', async function () {
    const seen = await start([pidNode('pid', { kp: '10', ti: '1', td: '0' })]);
    let limits = [0, 100];
    const step = async (payload, timestamp) => {
      await deliver('pid', { payload, timestamp });
      const m = seen.out.at(-1);
      assert.ok(m.payload >= limits[0] && m.payload <= limits[1], `${m.payload} within [${limits}]`);
      return m.pid;
    };
    let s = await step(0, 1000);
    assert.equal(s.output, 100);
    assert.equal(s.saturated, true);
    assert.deepEqual(statusOf('pid'), { fill: 'green', shape: 'ring', text: 'auto 100' });
    s = await step(0, 2000);
    assert.equal(s.output, 100, 'no windup past the limit');
    s = await step(100, 3000);
    assert.equal(s.output, 0, 'the integrator was not wound up: the output leaves the top at once');
    await deliver('pid', { limits: { min: 10, max: 60 } });
    limits = [10, 60];
    s = await step(50, 4000);
    assert.equal(s.output, 10, 'the last output, clamped into the new limits');
    for (let t = 5000; t < 9000; t += 1000) await step(t < 7000 ? 0 : 100, t);
    assert.equal(seen.out.length, 8);
    await deliver('pid', { limits: { min: 80, max: 20 } });
    assert.equal(seen.caught.at(-1).error.code, 'INVALID_CONFIG');
    assert.match(seen.caught.at(-1).error.message, /output limits must be numbers with min < max, got min 80 and max 20/);
    await step(50, 9000);
    assert.equal(seen.out.length, 9, 'the refused limits changed nothing');
  });

  it('takes a set point by topic or msg.setpoint without stepping; refuses one that is not a number', async function () {
    const seen = await start([pidNode('pid')]);
    await deliver('pid', { topic: 'setpoint', payload: 60 });
    await deliver('pid', { payload: 40, timestamp: 1000 });
    assert.equal(seen.out.length, 1, 'the set point msg sent nothing');
    assert.equal(seen.out[0].pid.setpoint, 60);
    close(seen.out[0].pid.p, 40);
    await deliver('pid', { setpoint: 55, payload: clock().now() }); // an inject's default timestamp payload is not a measurement
    await deliver('pid', { setpoint: 'fifty' });
    await deliver('pid', { topic: 'setpoint', payload: null });
    assert.equal(seen.out.length, 1);
    assert.deepEqual(seen.caught.map((m) => m.error.code), ['INVALID_INPUT', 'INVALID_INPUT']);
    assert.match(seen.caught[0].error.message, /msg.setpoint must be a number, got the string 'fifty'/);
    await deliver('pid', { payload: 40, timestamp: 2000 });
    assert.equal(seen.out[1].pid.setpoint, 55, 'the refused set points changed nothing');
  });

  it('applies new tunings bumplessly: the next output continues from the last one', async function () {
    const seen = await start([pidNode('pid')]);
    await deliver('pid', { payload: 40, timestamp: 1000 });
    await deliver('pid', { payload: 42, timestamp: 2000 });
    const before = seen.out.at(-1).payload;
    await deliver('pid', { tunings: { kp: 5, ti: 4 } });
    await deliver('pid', { payload: 43, timestamp: 3000 });
    const after = seen.out.at(-1).pid;
    close(after.output, before);
    close(after.p, 5 * 7, 1e-9);
    await deliver('pid', { payload: 43, timestamp: 4000 });
    const next = seen.out.at(-1).pid;
    close(next.output, before + (next.d - after.d) + (5 / 4) * 7 * 1, 1e-9);
    await deliver('pid', { tunings: { kp: -1 } });
    assert.match(seen.caught.at(-1).error.message, /kp must be a number >= 0, got -1/);
    await deliver('pid', { tunings: { ti: 'x' } });
    assert.match(seen.caught.at(-1).error.message, /msg.tunings.ti \(s\) must be a number/);
  });

  it('manual: sends the manual output and tracks it; back to auto is bumpless (only the P/D change and one integration)', async function () {
    const seen = await start([pidNode('pid')]);
    await deliver('pid', { payload: 40, timestamp: 1000 });
    await deliver('pid', { payload: 42, timestamp: 2000 });
    await deliver('pid', { mode: 'manual', manual: 30 });
    assert.deepEqual(statusOf('pid'), { fill: 'yellow', shape: 'dot', text: 'manual 30' });
    await deliver('pid', { payload: 43, timestamp: 3000 });
    await deliver('pid', { payload: 44, timestamp: 4000 });
    assert.deepEqual(seen.out.slice(2).map((m) => [m.payload, m.pid.mode]), [[30, 'manual'], [30, 'manual']]);
    const last = seen.out.at(-1).pid;
    await deliver('pid', { mode: 'auto' });
    await deliver('pid', { payload: 45, timestamp: 5000 });
    const first = seen.out.at(-1).pid;
    assert.equal(first.mode, 'auto');
    const expected = 30 + (first.p - last.p) + (first.d - last.d) + (2 / 10) * (50 - 45) * 1;
    close(first.output, expected, 1e-9);
    close(first.output, 29, 1e-9);
    // Into manual without a value holds the last output.
    await deliver('pid', { mode: 'manual' });
    await deliver('pid', { payload: 30, timestamp: 6000 });
    close(seen.out.at(-1).payload, first.output, 1e-9);
    await deliver('pid', { mode: 'hand' });
    assert.match(seen.caught.at(-1).error.message, /msg.mode must be 'auto' or 'manual'/);
  });

  it('tracks an action applied by someone else (msg.track), then continues from it', async function () {
    const seen = await start([pidNode('pid')]);
    await deliver('pid', { payload: 40, timestamp: 1000, track: 70 });
    assert.deepEqual([seen.out[0].payload, seen.out[0].pid.mode], [70, 'tracking']);
    assert.equal(statusOf('pid').text, 'tracking 70');
    await deliver('pid', { payload: 40, timestamp: 2000 });
    close(seen.out[1].payload, 70 + 0.2 * 10 * 1);
  });

  it('a bad measurement sends the fallback, its error reaches a Catch node, and no NaN is ever sent', async function () {
    const seen = await start([pidNode('pid', { fallback: '5' }), pidNode('hold', {}, 'held')], ['out', 'held']);
    for (const id of ['pid', 'hold']) {
      await deliver(id, { payload: 40, timestamp: 1000 });
      await deliver(id, { payload: NaN, timestamp: 2000 });
      await deliver(id, { payload: 'abc', timestamp: 3000 });
      await deliver(id, { topic: 'TT-1', timestamp: 4000 });
      await deliver(id, { payload: 45, timestamp: 5000 });
    }
    assert.deepEqual(seen.out.map((m) => m.payload).slice(1, 4), [5, 5, 5]);
    assert.deepEqual(seen.out.map((m) => m.pid.mode), ['auto', 'fallback', 'fallback', 'fallback', 'auto']);
    assert.deepEqual(seen.held.map((m) => m.payload).slice(1, 4), [22, 22, 22], 'a blank fallback holds the last output');
    assert.equal(seen.out[1].pid.measurement, null);
    // The next good sample does not differentiate across the gap.
    assert.equal(seen.out[4].pid.d, 0);
    assert.equal(seen.caught.length, 6);
    for (const m of seen.caught) assert.equal(m.error.code, 'BAD_MEASUREMENT');
    assert.match(seen.caught[0].error.message, /the measurement in msg.payload must be a number, got NaN; sent the fallback output 5/);
    assert.match(seen.caught[1].error.message, /got the string 'abc'/);
    assert.match(seen.caught[2].error.message, /got nothing/);
    for (const m of [...seen.out, ...seen.held]) assert.ok(Number.isFinite(m.payload), `sent ${m.payload}`);
    assert.deepEqual(statusOf('pid'), { fill: 'green', shape: 'dot', text: `auto ${Number(seen.out[4].payload.toPrecision(4))}` });
  });

  it('refuses two samples with the same timestamp (dt = 0) and sends nothing', async function () {
    const seen = await start([pidNode('pid')]);
    await deliver('pid', { payload: 40, timestamp: 1000 });
    await deliver('pid', { payload: 41, timestamp: 1000 });
    assert.equal(seen.out.length, 1);
    assert.equal(seen.caught[0].error.code, 'INVALID_INPUT');
    assert.match(seen.caught[0].error.message, /same timestamp/);
  });

  for (const [settings, stale] of [['staleS in s', { staleS: '0.08' }], ['staleMs of older flows', { staleS: '', staleMs: '80' }]]) it(`stale (${settings}): without a valid measurement for 'stale after' it sends the fallback every 'stale after'`, async function () {
    const seen = await start([pidNode('pid', { ...stale, fallback: '7' })]);
    await clock().advance(150);
    assert.equal(seen.out.length, 0, 'the watchdog starts with the first measurement');
    await deliver('pid', { payload: 40 });
    await clock().advance(79);
    assert.equal(seen.out.length, 1, 'fresh for 79 ms');
    await clock().advance(1);
    await until(() => seen.out.length === 2, 'the first watchdog send');
    await clock().advance(80);
    await until(() => seen.out.length === 3, 'the second, staleMs later');
    assert.deepEqual(seen.out.slice(1, 3).map((m) => [m.payload, m.pid.mode, m.pid.dtS]), [[7, 'fallback', 0.08], [7, 'fallback', 0.08]]);
    assert.deepEqual(statusOf('pid'), { fill: 'yellow', shape: 'ring', text: 'stale: fallback' });
    await deliver('pid', { payload: 41 });
    const m = seen.out.at(-1);
    assert.deepEqual([m.pid.mode, m.pid.dtS], ['auto', 1], 'the first sample after the gap integrates over Ts');
    assert.equal(statusOf('pid').fill, 'green');
    const count = seen.out.length;
    await helper.unload();
    await clock().advance(200);
    assert.equal(seen.out.length, count, 'the watchdog stops with the node');
  });

  describe('persist: the loop state in a file of the user directory', function () {
    const data = {}; // the 'kept' context store's contents: scope -> key -> value
    // A context store that takes 20 ms (manual clock) to read, as earlier versions' flows may have used.
    const slowStore = memoryStore(data, (scope, key, cb) => clock().setTimeout(() => cb(null, (data[scope] || {})[key]), 20));
    const stateFile = () => path.join(userDir(), 'sugarshack', 'pid-pid.json');
    const markerFile = () => path.join(userDir(), 'sugarshack', 'pid-pid.ran');
    const savedState = () => JSON.parse(fs.readFileSync(stateFile(), 'utf8'));
    const contextValue = () => (data['pid:f1'] || {}).pid;
    const warnings = () => helper.getNode('pid').warn.getCalls().filter((c) => c.thisValue.id === 'pid').map((c) => String(c.args[0]));
    const node = pidNode('pid', { persist: true, store: 'kept' });
    const load = () => start([node], ['out'], [() => contextModule.load()]);
    const restart = async () => {
      await helper.unload();
      await contextModule.close();
      return load();
    };

    beforeEach(function () {
      for (const scope of Object.keys(data)) delete data[scope];
      settings({ contextStorage: { kept: { module: slowStore } } });
    });
    afterEach(() => contextModule.close());

    it('a restart resumes where it left off, from the file (the context store holds nothing)', async function () {
      let seen = await load();
      await clock().advance(20); // a first start looks in the old context store once
      await until(() => statusOf('pid') && statusOf('pid').text === 'sp 50', 'started');
      await deliver('pid', { payload: 40, timestamp: 1000 });
      await deliver('pid', { payload: 42, timestamp: 2000 });
      await deliver('pid', { topic: 'setpoint', payload: 55 });
      const { i } = seen.out.at(-1).pid;
      seen = await restart(); // closing writes what was not yet on disk
      assert.deepEqual(savedState().state, { integral: i, setpoint: 55, mode: 'auto', manual: null });
      assert.equal(savedState().format, 'sugarshack-pid-state');
      assert.ok(fs.existsSync(markerFile()), 'marked as run here');
      assert.equal(contextValue(), undefined, 'nothing in the context store');

      // No context read this time (the file is there): restored at once, no clock needed.
      await until(() => statusOf('pid') && statusOf('pid').text === 'sp 55', 'the restored set point');
      await deliver('pid', { payload: 47, timestamp: 60000 });
      const first = seen.out[0].pid;
      assert.equal(first.setpoint, 55);
      close(first.i, i + 0.2 * 8 * 1, 1e-9);
      close(first.output, 2 * 8 + i + 0.2 * 8 * 1, 1e-9);
      // Manual mode and its output come back too.
      await deliver('pid', { mode: 'manual', manual: 33 });
      seen = await restart();
      await until(() => statusOf('pid') && statusOf('pid').text === 'manual 33', 'restored in manual');
      await deliver('pid', { payload: 47, timestamp: 70000 });
      assert.deepEqual([seen.out[0].payload, seen.out[0].pid.mode], [33, 'manual']);
      assert.deepEqual(warnings(), []);
    });

    it("msgs held while the saved state is read keep within nodeMessageBufferMaxLength: past it a msg is refused, as the delay node's buffer does", async function () {
      settings({ nodeMessageBufferMaxLength: 2, contextStorage: { kept: { module: slowStore } } });
      const seen = await load();
      for (const [i, payload] of [40, 41, 42].entries()) helper.getNode('pid').receive({ payload, timestamp: 1000 * (i + 1) });
      await until(() => seen.caught.length === 1, 'the third refused');
      assert.equal(seen.caught[0].error.code, 'QUEUE_FULL');
      assert.match(seen.caught[0].error.message, /2 msgs already wait for the saved PID state to be read/);
      assert.equal(seen.caught[0].payload, 42);
      await clock().advance(20);
      await until(() => seen.out.length === 2, 'the two held ones handled once started');
      assert.deepEqual(seen.out.map((m) => m.timestamp), [1000, 2000], 'in arrival order');
    });

    it('a state an earlier version saved in the context store is carried over once: restored, written to the file, deleted from the store', async function () {
      data['pid:f1'] = { pid: { integral: 7, setpoint: 60, mode: 'auto', manual: null } };
      let seen = await load();
      helper.getNode('pid').receive({ payload: 40, timestamp: 1000 }); // arrives while the old store is read
      await settled(helper);
      assert.equal(seen.out.length, 0, 'held until the saved state is read');
      assert.equal(fs.existsSync(stateFile()), false);
      await clock().advance(20);
      await until(() => seen.out.length === 1, 'the first output');
      const first = seen.out[0].pid;
      assert.equal(first.setpoint, 60);
      close(first.output, 2 * 20 + 7 + 0.2 * 20 * 1, 1e-9); // P + the carried-over integral + one step of it
      await until(() => contextValue() === undefined, 'the old context value deleted once the file holds it');
      assert.equal(savedState().state.setpoint, 60);
      assert.ok(fs.existsSync(markerFile()));

      // From now on the file is the state: a value left in the context store is not read again.
      data['pid:f1'] = { pid: { integral: 0, setpoint: 10, mode: 'manual', manual: 5 } };
      seen = await restart();
      await until(() => statusOf('pid') && statusOf('pid').text === 'sp 60', 'the state from the file');
      assert.deepEqual(contextValue(), { integral: 0, setpoint: 10, mode: 'manual', manual: 5 });
      assert.deepEqual(warnings(), []);
    });

    for (const [what, damage, why] of [
      ['not JSON', () => fs.writeFileSync(stateFile(), '{"format":"sugarshack-pid-st'), /not valid JSON/],
      ['empty', () => fs.writeFileSync(stateFile(), ''), /is empty/],
      ['missing though the node ran here', () => fs.rmSync(stateFile()), /is missing/],
      ['not a pid state', () => fs.writeFileSync(stateFile(), JSON.stringify({ format: 'sugarshack-interlock-state' })), /the state of an interlock/],
      ['holding no state object', () => fs.writeFileSync(stateFile(), JSON.stringify({ format: 'sugarshack-pid-state', state: 'x' })), /document version \(none\)/],
      ['of another pid node', () => fs.writeFileSync(stateFile(), resealed({ ...savedState(), owner: 'pid-2' })), /the state of node 'pid-2', not of this one/],
      ['with one byte changed', () => fs.writeFileSync(stateFile(), fs.readFileSync(stateFile(), 'utf8').replace('"setpoint":65', '"setpoint":66')), /does not match its checksum/],
      ['of an unknown version', () => fs.writeFileSync(stateFile(), resealed({ ...savedState(), version: 3 })), /document version 3; this version reads version 2 only/],
    ]) {
      it(`a state file ${what}: a warning that says so, "saved state lost", the configured set point and mode with a zero integrator`, async function () {
        await load();
        await clock().advance(20);
        await deliver('pid', { topic: 'setpoint', payload: 65 });
        await helper.unload();
        await contextModule.close();
        assert.equal(savedState().state.setpoint, 65);
        damage();
        // Not read: the node ran here, so the old context store is not asked again.
        data['pid:f1'] = { pid: { integral: 9, setpoint: 70, mode: 'manual', manual: 12 } };

        const seen = await load();
        await until(() => statusOf('pid') !== undefined, 'started');
        assert.deepEqual(statusOf('pid'), { fill: 'yellow', shape: 'ring', text: 'saved state lost' });
        const [warning, ...others] = warnings();
        assert.deepEqual(others, []);
        assert.match(warning, /saved PID state (is lost|cannot be used)/);
        assert.match(warning, /pid-pid\.json/);
        assert.match(warning, why);
        assert.match(warning, /starting from the config/);
        await deliver('pid', { payload: 40, timestamp: 1000 });
        const first = seen.out[0].pid;
        assert.deepEqual([first.setpoint, first.mode], [50, 'auto'], 'the configured set point and mode, not the context value');
        close(first.output, 2 * 10 + 0.2 * 10 * 1, 1e-9); // P + one step of a zero integrator
        assert.equal(statusOf('pid').fill, 'green', 'the next msg shows the loop again');
        await helper.unload();
        assert.equal(savedState().state.setpoint, 50, 'the file written afresh');
      });
    }
  });

  it('a Smith predictor reports what the PID saw and its dead time; the adaptive one follows msg.roundTripMs', async function () {
    const seen = await start([
      pidNode('smithFixed', { smith: 'fixed', modelGain: '1', modelTau: '3', deadSamples: '4', ts: '0.3', td: '0' }),
      pidNode('smithAdaptive', { smith: 'adaptive', modelGain: '1', modelTau: '3', alpha: '0.5', h: '0', ts: '0.3', td: '0' }, 'ad'),
    ], ['out', 'ad']);
    await deliver('smithFixed', { payload: 0, timestamp: 1000 });
    await deliver('smithFixed', { payload: 0, timestamp: 1300 });
    assert.equal(seen.out[0].pid.deadTimeSamples, 4);
    assert.ok(seen.out[1].pid.seen > 0, 'the model predicts the rise the dead time still hides');
    await deliver('smithAdaptive', { roundTripMs: 900 });
    assert.equal(seen.ad.length, 0, 'a round trip alone is no measurement');
    await deliver('smithAdaptive', { payload: 0, timestamp: 1000, roundTripMs: 900 });
    assert.equal(seen.ad[0].pid.deadTimeSamples, 3, 'floor(900 / 300)');
    await deliver('smithAdaptive', { roundTripMs: -1 });
    assert.equal(seen.caught.at(-1).error.code, 'INVALID_INPUT');
  });

  it("the adaptive Smith predictor's horizon h is read from 'horizon', or from 'h' in flows written before", async function () {
    const adaptive = { smith: 'adaptive', modelGain: '1', modelTau: '3', alpha: '0.5', ts: '0.3', td: '0' };
    const seen = await start([
      pidNode('flat', { ...adaptive, horizon: '0' }, 'flat'),
      pidNode('wide', { ...adaptive, horizon: '10' }, 'wide'),
      pidNode('legacy', { ...adaptive, horizon: undefined, h: '10' }, 'legacy'),
    ], ['flat', 'wide', 'legacy']);
    for (const id of ['flat', 'wide', 'legacy']) {
      await deliver(id, { payload: 0, timestamp: 1000, roundTripMs: 900 });
      await deliver(id, { payload: 0, timestamp: 1300, roundTripMs: 300 });
    }
    const dead = (id) => seen[id].at(-1).pid.deadTimeSamples;
    assert.ok(dead('wide') > dead('flat'), `h = 10 covers the spread of round trips: ${dead('wide')} vs ${dead('flat')}`);
    assert.equal(dead('legacy'), dead('wide'));
  });

  it("blank settings take the core's defaults (stale after 3 × Ts, alpha, h, max dead), and the editor and help state the same", async function () {
    const defaults = require(path.join(PALETTE, 'lib', 'wasm', 'index.js')).load().pidDefaults();
    const adaptive = { smith: 'adaptive', modelGain: '1', modelTau: '3', ts: '0.3', td: '0' };
    const seen = await start([
      pidNode('pid', { ts: '0.5', staleS: '', fallback: '7' }),
      pidNode('leftBlank', { ...adaptive, alpha: '', horizon: '', maxSamples: '' }, 'blank'),
      pidNode('setAsDefaults', { ...adaptive, alpha: String(defaults.alpha), horizon: String(defaults.h), maxSamples: String(defaults.maxSamples) }, 'set'),
    ], ['out', 'blank', 'set']);
    await deliver('pid', { payload: 40 });
    await clock().advance(defaults.staleSamples * 500 - 1);
    assert.equal(seen.out.length, 1, `fresh for ${defaults.staleSamples} × Ts less 1 ms`);
    await clock().advance(1);
    await until(() => seen.out.length === 2, 'the watchdog send');
    assert.deepEqual([seen.out[1].payload, seen.out[1].pid.mode], [7, 'fallback']);
    for (const id of ['leftBlank', 'setAsDefaults']) {
      await deliver(id, { payload: 0, timestamp: 1000, roundTripMs: 900 });
      await deliver(id, { payload: 0, timestamp: 1300, roundTripMs: 300 });
    }
    assert.deepEqual(seen.caught.map((m) => m.error.message), []);
    assert.deepEqual(seen.blank.map((m) => m.pid.deadTimeSamples), [3, 4], 'floor(900 / 300), then (840 + 3 × 180) / 300 with alpha 0.1, h 3');
    assert.deepEqual(seen.blank.map((m) => m.pid), seen.set.map((m) => m.pid));
    const editor = fs.readFileSync(path.join(PALETTE, 'nodes', 'pid.html'), 'utf8');
    const startsAt = (field) => Number(editor.match(new RegExp(`\\b${field}: \\{ value: ([\\d.]+)`))[1]);
    assert.deepEqual([startsAt('alpha'), startsAt('horizon'), startsAt('maxSamples')], [defaults.alpha, defaults.h, defaults.maxSamples]);
    const help = fs.readFileSync(path.join(PALETTE, 'nodes', 'locales', 'en-US', 'pid.html'), 'utf8');
    assert.match(help, new RegExp(`default ${defaults.staleSamples} × Ts`));
  });

  it('a change is applied whole or not at all: new tunings with limits the fallback falls outside change nothing', async function () {
    const seen = await start([pidNode('pid', { fallback: '5' })]);
    await deliver('pid', { payload: 40, timestamp: 1000 });
    await deliver('pid', { setpoint: 60, tunings: { kp: 5 }, limits: { min: 10, max: 60 } });
    assert.equal(seen.caught.at(-1).error.code, 'INVALID_CONFIG');
    assert.match(seen.caught.at(-1).error.message, /fallback output 5 must be a number within the output limits \[10, 60\]/);
    await deliver('pid', { payload: 40, timestamp: 2000 });
    const m = seen.out.at(-1).pid;
    assert.equal(m.setpoint, 50, 'the set point did not change');
    close(m.p, 2 * 10, 1e-9); // kp is still 2
    await deliver('pid', { tunings: { kp: null } });
    assert.match(seen.caught.at(-1).error.message, /msg.tunings.kp must be a number, got null/);
    await deliver('pid', { tunings: { kd: 1 } });
    assert.match(seen.caught.at(-1).error.message, /a tunings change names none of kp, ti, td/);
  });

  it('proportional on measurement: a set point change moves the output only through the integral', async function () {
    const seen = await start([pidNode('pid', { pOn: 'measurement', td: '0' })]);
    await deliver('pid', { payload: 40, timestamp: 1000 });
    await deliver('pid', { setpoint: 80 });
    await deliver('pid', { payload: 40, timestamp: 2000 });
    const [a, b] = seen.out.map((m) => m.pid);
    assert.equal(a.p, 0);
    close(a.output, 0.2 * 10 * 1);
    close(b.output, a.output + 0.2 * 40 * 1, 1e-9);
  });

  it('refuses configurations that cannot run at deploy, with the reason, and fails every msg', async function () {
    const seen = await start([
      pidNode('inverted', { outMin: '100', outMax: '0' }),
      pidNode('ts0', { ts: '0' }),
      pidNode('gain0', { smith: 'fixed', modelGain: '0' }),
      pidNode('fb', { fallback: '150' }),
      pidNode('blank', { kp: '' }),
    ]);
    const expected = {
      inverted: /output limits must be numbers with min < max, got min 100 and max 0/,
      ts0: /sample period Ts must be a number of seconds greater than 0, got 0/,
      gain0: /model gain must be a non-zero number, got 0/,
      fb: /fallback output 150 must be a number within the output limits \[0, 100\]/,
      blank: /kp \(proportional gain\) is required/,
    };
    for (const [id, text] of Object.entries(expected)) {
      assert.equal(errorLogs(id).length, 1, `${id} logged one error`);
      assert.match(String(errorLogs(id)[0]), text);
      assert.deepEqual(statusOf(id), { fill: 'red', shape: 'ring', text: 'config error' });
      await deliver(id, { payload: 40 });
      assert.match(seen.caught.at(-1).error.message, text);
      assert.equal(seen.caught.at(-1).error.code, 'INVALID_CONFIG');
    }
    assert.equal(seen.out.length, 0);
  });

  it("refuses at deploy a choice the editor does not offer (a flow written by hand), and takes a blank one as the core's default", async function () {
    const seen = await start([
      pidNode('hand', { action: 'forward' }),
      pidNode('pOn', { pOn: 'setpoint' }),
      pidNode('none', { action: '', pOn: '', mode: '' }),
    ]);
    assert.match(String(errorLogs('hand')[0]), /action must be one of 'reverse', 'direct'; got 'forward'/);
    assert.match(String(errorLogs('pOn')[0]), /proportionalOn must be one of 'error', 'measurement'; got 'setpoint'/);
    assert.deepEqual(errorLogs('none'), []);
    await deliver('none', { payload: 40, timestamp: 1000 });
    const { pid } = seen.out.at(-1);
    assert.deepEqual([pid.mode, pid.p], ['auto', 20], 'auto, reverse action, P on the error: kp 2 × (50 − 40)');
  });
});

describe('sugarshack control: rcc and rcc-io', function () {
  serverPerTest();

  for (const [settings, extra] of [['in s', {}], ['in ms, older flows', LEGACY_RCC]]) it(`rcc (${settings}): the primary is engaged; the secondary stands by while the primary is fresh and engages once its age reaches D2`, async function () {
    const seen = await start([rccNode('r1', 1, 'o1', extra), rccNode('r2', 2, 'o2', extra)], ['o1', 'o2']);
    const both = async (payload, timestamp) => {
      await deliver('r1', { payload, timestamp });
      await deliver('r2', { payload, timestamp });
      return [seen.o1.at(-1), seen.o2.at(-1)];
    };
    let [a, b] = await both({ procVar: 40, lastAction: 10, agesMs: [null, null] }, 111);
    // No controller has acted yet (ages ∞): both engage, tracking the initial action on their first cycle.
    assert.deepEqual([a.payload, a.timestamp, a.rcc], [40, 111, { id: 1, engaged: true, firstCycle: true, track: 10 }]);
    assert.deepEqual(b.rcc, { id: 2, engaged: true, firstCycle: true, track: 10 });
    [a, b] = await both({ procVar: 41, lastAction: 12, agesMs: [20, null] }, 222);
    assert.deepEqual(a.rcc, { id: 1, engaged: true, firstCycle: false, track: null });
    assert.deepEqual(b.rcc, { id: 2, engaged: false, firstCycle: false, track: 12 }, 'standby tracks the last action');
    assert.deepEqual(statusOf('r2'), { fill: 'grey', shape: 'dot', text: 'standby' });
    [, b] = await both({ procVar: 41, lastAction: 12, agesMs: [199, null] }, 333);
    assert.equal(b.rcc.engaged, false);
    [, b] = await both({ procVar: 41, lastAction: 12, agesMs: [200, null] }, 444);
    assert.deepEqual(b.rcc, { id: 2, engaged: true, firstCycle: false, track: null }, 'primary silent for D2: the secondary acts');
    assert.deepEqual(statusOf('r2'), { fill: 'green', shape: 'dot', text: 'engaged' });
    assert.deepEqual(statusOf('r1'), { fill: 'green', shape: 'dot', text: 'engaged' });
  });

  for (const [settings, extra] of [['in s', {}], ['in ms, older flows', LEGACY_RCC]]) it(`rcc (${settings}): a poll timeout shows "no I/O" and makes the next decision a first cycle that tracks; bad states are refused`, async function () {
    const seen = await start([rccNode('r1', 1, 'o1', extra)], ['o1']);
    await deliver('r1', { payload: { procVar: 40, lastAction: 10, agesMs: [null, null] } });
    await deliver('r1', { payload: { procVar: 40, lastAction: 15, agesMs: [30, null] } });
    assert.equal(seen.o1.at(-1).rcc.firstCycle, false);
    await clock().advance(149);
    assert.deepEqual(statusOf('r1'), { fill: 'green', shape: 'dot', text: 'engaged' });
    await clock().advance(1);
    await until(() => statusOf('r1').text === 'no I/O', 'the poll timeout, 150 ms after the last state');
    assert.deepEqual(statusOf('r1'), { fill: 'yellow', shape: 'ring', text: 'no I/O' });
    await deliver('r1', { payload: { procVar: 40, lastAction: 18, agesMs: [400, 20] } });
    assert.deepEqual(seen.o1.at(-1).rcc, { id: 1, engaged: true, firstCycle: true, track: 18 });
    await deliver('r1', { payload: 'state' });
    await deliver('r1', { payload: { procVar: 40, lastAction: 18, agesMs: [1] } });
    await deliver('r1', { payload: { procVar: 40, agesMs: [1, 2] } });
    assert.deepEqual(seen.caught.map((m) => m.error.code), ['INVALID_INPUT', 'INVALID_INPUT', 'INVALID_INPUT']);
    assert.match(seen.caught[0].error.message, /must be the I\/O module's state \{ procVar, lastAction, agesMs \}/);
    assert.match(seen.caught[1].error.message, /the I\/O state lists 1 controller ages, this group has 2/);
    assert.deepEqual(statusOf('r1'), { fill: 'red', shape: 'ring', text: 'invalid input' });
    assert.equal(seen.o1.length, 3);
  });

  it('rcc: refuses thresholds out of order or below Ts, Ts <= 0 and an id outside the group at deploy', async function () {
    const seen = await start([
      rccNode('order', 2, 'o1', { thresholdsS: '2, 1', tsS: '0.5' }),
      rccNode('below', 1, 'o1', { thresholdsS: '0.4, 1', tsS: '0.5' }),
      rccNode('ts0', 1, 'o1', { tsS: '0' }),
      rccNode('id3', 3, 'o1'),
      rccNode('text', 1, 'o1', { thresholdsS: '1, soon' }),
      rccNode('none', 1, 'o1', { thresholdsS: '' }),
      { id: 'io0', z: 'f1', type: 'sugarshack-rcc-io', controllers: '0', initialAction: '0', periodS: '0.1', wires: [[], []] },
      { id: 'io-1', z: 'f1', type: 'sugarshack-rcc-io', controllers: '2', initialAction: '0', periodS: '-1', wires: [[], []] },
    ], ['o1']);
    const expected = {
      // Worded in seconds, as typed in the form.
      order: /engagement threshold D_2 = 1 s must be greater than D_1 = 2 s/,
      below: /engagement threshold D_1 = 0.4 s must be at least the sampling period Ts = 0.5 s/,
      ts0: /sampling period Ts must be greater than 0 s, got 0 s/,
      id3: /controller id 3 is outside 1..2/,
      text: /engagement thresholds D_1..D_n \(thresholdsS, s\) \(item 2\) must be a number, got 'soon'/,
      none: /engagement thresholds D_1..D_n \(thresholdsS, s\): give one number per controller, comma-separated \(e.g. 1, 2\)/,
      'io-1': /publish period \(periodS\) must be a number of seconds greater than 0, got -1/,
      io0: /controllers must be a whole number >= 1, got 0/,
    };
    for (const [id, text] of Object.entries(expected)) {
      assert.match(String(errorLogs(id)[0]), text, id);
      assert.deepEqual(statusOf(id), { fill: 'red', shape: 'ring', text: 'config error' });
      await deliver(id, { payload: { procVar: 1, lastAction: 1, agesMs: [null, null] } });
      assert.match(seen.caught.at(-1).error.message, text);
    }
  });

  for (const [settings, period] of [['periodS in s', { periodS: '0.04' }], ['period in ms, older flows', { periodS: '', period: '40' }]]) it(`rcc-io (${settings}): publishes the state every period; ages grow from each write and reset on the next; writes go to output 2`, async function () {
    const seen = await start([
      { id: 'io', z: 'f1', type: 'sugarshack-rcc-io', controllers: '2', initialAction: '10', ...period, wires: [['state'], ['act']] },
    ], ['state', 'act']);
    await clock().advance(39);
    assert.equal(seen.state.length, 0, 'the first state after one period');
    await clock().advance(1);
    await until(() => seen.state.length === 1, 'the first state');
    assert.deepEqual(seen.state[0].payload, { procVar: null, lastAction: 10, agesMs: [null, null] });
    assert.equal(seen.state[0].timestamp, clock().now(), 'stamped with the I/O side\'s clock');
    await deliver('io', { topic: 'measurement', payload: 42.5 });
    await deliver('io', { payload: 20, controller: 1 });
    assert.deepEqual(seen.act.map((m) => m.payload), [20]);
    let n = seen.state.length;
    await clock().advance(120);
    await until(() => seen.state.length === n + 3, 'three more states');
    const ages = seen.state.slice(n).map((m) => m.payload.agesMs[0]);
    assert.deepEqual(seen.state.at(-1).payload.procVar, 42.5);
    assert.equal(seen.state.at(-1).payload.lastAction, 20);
    assert.deepEqual(ages, [40, 80, 120], 'ages grow by the period from the write');
    assert.equal(seen.state.at(-1).payload.agesMs[1], null, 'controller 2 never acted');
    await deliver('io', { payload: 25, rcc: { id: 2, engaged: true, firstCycle: false, track: null, write: 25 } });
    await clock().advance(10);
    await deliver('io', { payload: 21, controller: 1 });
    n = seen.state.length;
    await clock().advance(30);
    await until(() => seen.state.length > n, 'the next state');
    const { payload } = seen.state.at(-1);
    assert.equal(payload.lastAction, 21);
    assert.deepEqual(payload.agesMs, [30, 40], 'age 1 reset by its write 30 ms ago; controller 2 wrote 10 ms before');
    assert.deepEqual(seen.act.map((m) => m.payload), [20, 25, 21]);
    assert.equal(seen.act[1].rcc.id, 2, 'the write goes on with its msg');
    assert.deepEqual(statusOf('io'), { fill: 'green', shape: 'dot', text: 'C1 21' });

    await deliver('io', { payload: 5, controller: 3 });
    await deliver('io', { payload: 'open', controller: 1 });
    await deliver('io', { payload: 5 });
    await deliver('io', { topic: 'measurement', payload: 'n/a' });
    assert.deepEqual(seen.caught.map((m) => m.error.code), ['UNKNOWN_CONTROLLER', 'INVALID_INPUT', 'INVALID_INPUT', 'BAD_MEASUREMENT']);
    assert.match(seen.caught[0].error.message, /controller id 3 is not one of the 2 configured/);
    assert.match(seen.caught[2].error.message, /a write needs the controller id in msg.controller or msg.rcc.id/);
    assert.equal(seen.act.length, 3, 'refused writes reach no actuator');
    n = seen.state.length;
    await clock().advance(40);
    await until(() => seen.state.length > n, 'the next state');
    assert.equal(seen.state.at(-1).payload.procVar, null, 'a bad measurement is not passed on as a good one');
    assert.equal(seen.state.at(-1).payload.lastAction, 21);
    assert.deepEqual(seen.state.at(-1).payload.agesMs, [70, 80]);
  });

  it('two redundant controllers: the secondary takes over without a bump (G1, G3) and the primary takes back (G2)', async function () {
    const pidOf = (id, wire) => pidNode(id, { kp: '1', ti: '0.3', td: '0', ts: '0.05', staleS: '', setpoint: '50' }, wire);
    const seen = await start([
      { id: 'io', z: 'f1', type: 'sugarshack-rcc-io', controllers: '2', initialAction: '0', periodS: '0.05', wires: [['link1', 'link2'], ['act']] },
      rccNode('rcc1', 1, 'pid1'), rccNode('rcc2', 2, 'pid2'),
      pidOf('pid1', 'w1'), pidOf('pid2', 'w2'),
    ], ['link1', 'link2', 'w1', 'w2', 'act']);
    const io = helper.getNode('io');
    // Each controller's link to the I/O module, both ways: the state to its rcc node, its pid's writes to the I/O.
    const up = { 1: false, 2: false };
    helper.getNode('link1').on('input', (m) => { if (up[1]) helper.getNode('rcc1').receive(m); });
    helper.getNode('link2').on('input', (m) => { if (up[2]) helper.getNode('rcc2').receive(m); });
    helper.getNode('w1').on('input', (m) => { if (up[1] && m.rcc) io.receive(m); });
    helper.getNode('w2').on('input', (m) => { if (up[2] && m.rcc) io.receive(m); });

    // The process: first order (K = 1, τ = 0.3 s), driven by the actions the I/O applies, on the clock.
    const writes = []; // [ms, controller, action, msg.rcc]
    let u = 0;
    let y = 0;
    let t = clock().now();
    helper.getNode('act').on('input', (m) => {
      u = m.payload;
      writes.push([clock().now(), m.rcc.id, m.payload, m.rcc]);
    });
    const ys = [];
    clock().setInterval(() => {
      const now = clock().now();
      y += (u - y) * (1 - Math.exp(-(now - t) / 300));
      t = now;
      ys.push(y);
      io.receive({ topic: 'measurement', payload: y });
    }, 20);
    // Every timer (20 ms process steps, 50 ms periods) is due on a multiple of 10 ms: each round trip completes within its step.
    const run = (ms) => runFor(helper, ms, { ids: [], step: 10 });
    const runTill = (predicate, what) => runUntil(helper, predicate, what, { ids: [], step: 10, maxMs: 20000 });
    // The secondary was run on its own before joining: its integrator is wound up to the top.
    for (let k = 0; k < 5; k++) await deliver('pid2', { payload: 0, timestamp: clock().now() - 5000 + k * 1000 });
    assert.equal(seen.w2.at(-1).payload, 100);
    up[1] = true;
    up[2] = true;
    await runTill(() => Math.abs(y - 50) < 0.5 && writes.length > 20, 'the primary settling the process');
    await run(300);
    const settledWrites = writes.length;
    assert.ok(writes.slice(3).every((w) => w[1] === 1), `only the primary acts: ${writes.slice(3).map((w) => w[1])}`);
    const pid2Sent = seen.w2.length;
    await run(200);
    assert.equal(seen.w2.length, pid2Sent, 'the secondary in standby sends nothing');
    assert.deepEqual(statusOf('pid2'), { fill: 'grey', shape: 'ring', text: 'standby' });

    // G1: the primary's link fails; the secondary engages once the primary's age reaches D2.
    up[1] = false;
    const cut = clock().now();
    await runTill(() => writes.some((w) => w[1] === 2 && w[0] > cut), 'the secondary taking over');
    const firstSecondary = writes.find((w) => w[1] === 2 && w[0] > cut);
    const lastPrimary = writes.filter((w) => w[1] === 1 && w[0] < firstSecondary[0]).at(-1);
    assert.equal(firstSecondary[0] - lastPrimary[0], 200, 'at the first poll that finds the primary silent for D2 = 200 ms');
    // G3: its first action continues the primary's (its wound-up integrator was replaced by tracking).
    assert.ok(Math.abs(firstSecondary[2] - lastPrimary[2]) < 0.5, `bumpless: ${lastPrimary[2]} -> ${firstSecondary[2]}`);
    await runTill(() => statusOf('rcc1').text === 'no I/O', 'the primary missing its polls');
    const w1Sent = seen.w1.length;
    await run(300);
    assert.equal(seen.w1.length, w1Sent, 'the cut-off primary writes nothing blind');
    assert.deepEqual(statusOf('pid1'), { fill: 'yellow', shape: 'ring', text: 'stale: no I/O' });

    // G2: the link recovers; the primary's first cycle tracks the last action and takes back control.
    const lastSecondary = writes.at(-1);
    up[1] = true;
    const back = clock().now();
    await runTill(() => writes.some((w) => w[1] === 1 && w[0] > back), 'the primary taking back');
    const retaken = writes.find((w) => w[1] === 1 && w[0] > back);
    assert.equal(retaken[3].firstCycle, true);
    close(retaken[2], retaken[3].track, 1e-9); // its first action is the last action it polled
    assert.ok(Math.abs(retaken[2] - lastSecondary[2]) < 0.5, `bumpless: ${lastSecondary[2]} -> ${retaken[2]}`);
    await run(300);
    const after = writes.filter((w) => w[0] > retaken[0] + 120);
    assert.ok(after.length > 0 && after.every((w) => w[1] === 1), `the secondary stood down: ${after.map((w) => w[1])}`);
    assert.deepEqual(statusOf('pid2'), { fill: 'grey', shape: 'ring', text: 'standby' });
    // The process never felt the handovers.
    const sinceSettled = ys.slice(-Math.floor((clock().now() - cut) / 20) + 5);
    assert.ok(sinceSettled.every((v) => Math.abs(v - 50) < 1), `y stays at 50: ${Math.min(...sinceSettled)}..${Math.max(...sinceSettled)}`);
    assert.ok(writes.length > settledWrites);
    for (const w of writes) assert.ok(Number.isFinite(w[2]));
    assert.equal(seen.caught.length, 0, seen.caught.map((m) => m.error.message).join('; '));
  });
});

describe('example: pid-loop', function () {
  const coreNodes = ['common/20-inject.js', 'common/90-comment.js', 'function/10-function.js']
    .map((f) => require(path.join(coreNodesDir, 'core', f)));

  serverPerTest();

  it('settles the simulated process on the set point without overshoot, follows a new set point, and goes back to auto bumplessly', async function () {
    const flow = JSON.parse(fs.readFileSync(path.join(PALETTE, 'examples', 'pid-loop.json'), 'utf8'))
      .map((n) => {
        if (n.type === 'debug') return { id: n.id, z: n.z, type: 'helper', name: n.name };
        if (n.type === 'inject' && n.repeat) return { ...n, repeat: '', once: false }; // the test ticks it: one Ts of process time each
        return n;
      });
    const byName = (type, name) => flow.find((n) => n.type === type && n.name === name).id;
    await helper.load([...paletteNodes, ...coreNodes], flow);
    const out = [];
    let next = null;
    helper.getNode(byName('helper', 'pid terms')).on('input', (m) => {
      out.push(m.pid);
      if (next) next();
    });
    const tick = helper.getNode(byName('inject', 'tick every Ts (1 s)'));
    /** `k` ticks of the process, each once the pid has answered the one before. */
    async function ticks(k) {
      for (let i = 0; i < k; i++) {
        const answered = new Promise((resolve) => { next = resolve; });
        tick.receive({});
        await answered;
        await settled(helper);
      }
    }
    await ticks(200);
    const ys = out.map((m) => m.measurement);
    assert.ok(Math.abs(ys.at(-1) - 60) < 0.5, `settled at ${ys.at(-1)}`);
    assert.ok(Math.max(...ys) < 60 * 1.02, `no overshoot: peak ${Math.max(...ys)}`);
    assert.equal(out.at(-1).deadTimeSamples, 5);
    assert.ok(out.every((p) => Number.isFinite(p.output) && p.dtS === 1));
    helper.getNode(byName('inject', 'set point 90')).receive({});
    await settled(helper);
    let n = out.length;
    await ticks(200);
    assert.ok(Math.abs(out.at(-1).measurement - 90) < 0.5, `follows to ${out.at(-1).measurement}`);
    helper.getNode(byName('inject', 'manual 40')).receive({});
    await settled(helper);
    await ticks(60);
    assert.equal(out.at(-1).mode, 'manual');
    assert.equal(out.at(-1).output, 40);
    helper.getNode(byName('inject', 'auto')).receive({});
    await settled(helper);
    n = out.length;
    await ticks(5);
    assert.equal(out.at(-1).mode, 'auto');
    const k = out.findIndex((p, j) => j >= n - 1 && p.mode === 'auto');
    assert.equal(k, n, 'the first tick after the auto inject');
    const [last, first] = [out[k - 1], out[k]];
    assert.equal(last.output, 40);
    close(first.output, 40 + (first.p - last.p) + (first.d - last.d) + (1 / 20) * (first.setpoint - first.seen) * 1, 1e-9);
  });
});
