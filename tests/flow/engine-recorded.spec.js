'use strict';
// The engine's determinism on a log no one wrote by hand: every call the
// interlock's nodes make into their core Engine while a flow runs (msgs,
// deadlines, state writes, reads) is recorded with what the engine answered,
// then replayed into a fresh Engine, which must answer the same, batch by batch.
const assert = require('node:assert/strict');
const path = require('path');
const helper = require('node-red-node-test-helper');
const {
  PALETTE, paletteNodes, TAB, interlockConfig, acquire, release, sinkNode, collect, startServer, stopServer, onInterlock, until,
  trackCompletions, untrackCompletions,
} = require('./support');

const wasm = require(path.join(PALETTE, 'lib', 'wasm', 'index.js'));
const { Wire } = require(path.join(PALETTE, 'lib', 'wasm', 'wire.js'));

helper.init(require.resolve('node-red'));

const VISITS = ['commit', 'after', 'send', 'emit', 'complete', 'counts', 'other'];
// Copies a value as it was at the call: the flow may change a msg later.
const copy = (v) => (v === undefined ? undefined : structuredClone(v));
const isWasmObject = (v) => v !== null && typeof v === 'object' && '__wbg_ptr' in v;
const outcome = (run) => {
  try {
    const value = run();
    return { value: isWasmObject(value) ? '(wasm object)' : copy(value) };
  } catch (err) {
    return { threw: `${err && err.code} ${err && err.message}` };
  }
};

/**
 * Records every Engine made from now on: its constructor's arguments, then
 * each call (with its answer) and each read of its outputs, in order.
 */
function recordEngines() {
  const facade = wasm.load();
  const Engine = facade.Engine;
  const logs = new Map(); // engine -> { args, entries }
  const byHeader = new Map(); // a Wire knows its engine by the header's address
  facade.Engine = new Proxy(Engine, {
    construct(target, args) {
      const engine = Reflect.construct(target, args);
      const log = { args: copy(args), entries: [] };
      logs.set(engine, log);
      byHeader.set(Engine.prototype.headerPtr.call(engine), log);
      return engine;
    },
  });
  const undo = [() => { facade.Engine = Engine; }];
  for (const name of Object.getOwnPropertyNames(Engine.prototype)) {
    const original = Object.getOwnPropertyDescriptor(Engine.prototype, name).value;
    // headerPtr answers an address, not an output: each replay's Wire asks its own.
    if (['constructor', 'free', 'headerPtr'].includes(name) || typeof original !== 'function') continue;
    Engine.prototype[name] = function (...args) {
      const log = logs.get(this);
      if (!log) return original.apply(this, args);
      assert.ok(!args.some(isWasmObject), `${name} took a wasm object: this log could not be replayed`);
      const entry = { call: name, args: copy(args) };
      log.entries.push(entry);
      let value;
      try {
        value = original.apply(this, args);
      } catch (err) {
        entry.answer = outcome(() => { throw err; });
        throw err;
      }
      entry.answer = outcome(() => value);
      return value;
    };
    undo.push(() => { Engine.prototype[name] = original; });
  }
  const read = Wire.prototype.read;
  Wire.prototype.read = function (visitor) {
    const log = byHeader.get(this.headerPtr);
    if (!log) return read.call(this, visitor);
    const batch = [];
    log.entries.push({ read: batch });
    const tee = {};
    for (const v of VISITS) tee[v] = (...args) => { batch.push([v, ...copy(args)]); return visitor[v](...args); };
    return read.call(this, tee);
  };
  undo.push(() => { Wire.prototype.read = read; });
  return { Engine, logs: () => [...logs.values()], restore: () => undo.reverse().forEach((fn) => fn()) };
}

/** `log` into a fresh engine: its answers and reads in the same form as recorded. */
function replay(Engine, log) {
  const engine = new Engine(...log.args);
  const wire = new Wire(engine);
  try {
    return log.entries.map((entry) => {
      if (entry.read) {
        const batch = [];
        const visitor = {};
        for (const v of VISITS) visitor[v] = (...args) => batch.push([v, ...copy(args)]);
        wire.read(visitor);
        return { read: batch };
      }
      return { call: entry.call, args: entry.args, answer: outcome(() => engine[entry.call](...entry.args)) };
    });
  } finally {
    engine.free();
  }
}

describe('the engine replayed from a recorded flow', function () {
  let recorder;

  beforeEach(function (done) {
    recorder = recordEngines();
    startServer(done);
  });

  afterEach(async function () {
    untrackCompletions();
    await stopServer();
    recorder.restore();
  });

  it('answers every recorded call and read of a running interlock alike', async function () {
    const completions = trackCompletions();
    await helper.load(paletteNodes, [
      TAB, interlockConfig({ persist: true }),
      acquire('aBoil', 'boil', 20, 'YEL', 'out'),
      acquire('aRinse', 'rinse', 5, 'YEL,GRN', 'out', { timeout: 0.5 }),
      acquire('aWash', 'wash', 90, 'YEL', 'out'),
      release('rel', 'released'),
      { id: 'flt', z: 'f1', type: 'sugarshack-fault', interlock: 'il', mode: 'operation', operation: '', resources: '', wires: [['back'], ['lockout']] },
      { id: 'clr', z: 'f1', type: 'sugarshack-clear', interlock: 'il', mode: 'all', resources: '', wires: [['cleared']] },
      { id: 'can', z: 'f1', type: 'sugarshack-cancel', interlock: 'il', operation: '', wires: [['canceled']] },
      ...['out', 'released', 'back', 'lockout', 'cleared', 'canceled'].map(sinkNode),
    ]);
    const { quiet, run } = onInterlock(helper);
    const [out, lockout, cleared] = ['out', 'lockout', 'cleared'].map((id) => collect(helper, id));

    // A season's morning: a grant, a wait that times out, a higher priority
    // served on release, a fault and its clear, a waiter withdrawn.
    helper.getNode('aBoil').receive({ payload: 1 });
    await until(() => out.length === 1, 'boil granted');
    helper.getNode('aRinse').receive({ payload: 2 });
    await run(600);
    helper.getNode('aWash').receive({ payload: 3 });
    helper.getNode('aRinse').receive({ payload: 4 });
    await quiet();
    helper.getNode('rel').receive({ interlock: out[0].interlock });
    await until(() => out.length === 2, 'wash granted on release');
    helper.getNode('flt').receive({ ...out[1], error: { message: 'pump P1 ran dry' } });
    await until(() => lockout.length === 1, 'lockout sent');
    helper.getNode('clr').receive({ payload: 'operator cleared YEL' });
    await until(() => cleared.length === 1 && out.length === 3, 'rinse granted after the clear');
    helper.getNode('aBoil').receive({ payload: 5 });
    await quiet();
    helper.getNode('can').receive({ operation: 'boil' });
    await quiet();
    assert.ok(completions.some((c) => c.error), 'the rinse that waited too long ended with an error');

    const logs = recorder.logs();
    assert.equal(logs.length, 1, 'one engine for the interlock');
    const [log] = logs;
    const replayed = replay(recorder.Engine, log);
    assert.deepEqual(replayed, log.entries.map((e) => (e.read ? { read: e.read } : { call: e.call, args: e.args, answer: e.answer })));
    // Again from the same log: nothing in it depends on the run it came from.
    assert.deepEqual(replay(recorder.Engine, log), replayed);

    // The log held what a replay could get wrong: grants, a timeout's refusal, a state write, a lockout.
    const outputs = log.entries.filter((e) => e.read).flatMap((e) => e.read);
    const calls = new Set(log.entries.filter((e) => e.call).map((e) => e.call));
    for (const call of ['acquire', 'tick', 'fault', 'clear', 'cancel']) assert.ok(calls.has(call), `the flow called ${call}`);
    assert.ok(outputs.filter(([kind, , , set]) => kind === 'send' && set && set.kind === 'interlock').length >= 3, 'grants');
    assert.ok(outputs.some(([kind, , refusal]) => kind === 'complete' && refusal), 'a refusal');
    assert.ok(outputs.some(([kind]) => kind === 'commit'), 'a state write');
  });
});
