'use strict';
// An interlock bound to no plant runs on the core's engine
// (lib/interlock/engine-runtime.js). What the other suites do not reach
// there: a journal attached once the flows run hears the grants of normal
// work too (not only the abnormal events the alarms keep); a wasm instance that really traps in a msg is replaced, and the
// interlock comes back from its last saved state on the new one, the msg
// ending INTERNAL and no exception escaping. An operation aborted while the
// interlock ran bound to its plant stays aborted here until a person resets it.
const assert = require('node:assert/strict');
const path = require('path');
const helper = require('node-red-node-test-helper');
const {
  PALETTE, paletteNodes, TAB, interlockConfig, acquire, sinkNode, collect, until, trackCompletions, untrackCompletions,
  startServer, stopServer, settled,
} = require('./support');

helper.init(require.resolve('node-red'));

const wasm = require(path.join(PALETTE, 'lib', 'wasm', 'index.js'));
const { EngineRuntime } = require(path.join(PALETTE, 'lib', 'interlock', 'engine-runtime.js'));
const { journal } = require(path.join(PALETTE, 'lib', 'journal', 'bus.js'));
const operator = require(path.join(PALETTE, 'lib', 'interlock', 'operator.js'));
const fs = require('fs');

const runtimeOf = () => helper.getNode('il').runtime;
const quiet = () => settled(helper, 'il');
const liveLines = () => Object.fromEntries(runtimeOf().core.snapshot(0).resources
  .filter((r) => ['YEL', 'GRN', 'RED'].includes(r.name))
  .map((r) => [r.name, r.state.state === 'faulted' ? `faulted:${r.state.cause}` : r.state.state]));

function flow() {
  return [
    TAB, interlockConfig({ persist: true }),
    acquire('acq', '', 0, '', 'out'),
    { id: 'stop', z: 'f1', type: 'sugarshack-fault', interlock: 'il', mode: 'resources', operation: '', resources: '', wires: [[], []] },
    { id: 'clr', z: 'f1', type: 'sugarshack-clear', interlock: 'il', mode: 'lines', resources: '', wires: [[], []] },
    sinkNode('out'),
  ];
}

describe('an interlock run by the engine', function () {
  let uncaught;
  const onUncaught = (err) => uncaught.push(err);

  beforeEach(function (done) {
    uncaught = [];
    process.on('uncaughtException', onUncaught);
    startServer(done);
  });

  afterEach(async function () {
    process.removeListener('uncaughtException', onUncaught);
    untrackCompletions();
    await stopServer();
  });

  it('a trap in a msg: the msg ends INTERNAL, the engine is rebuilt on the new instance from the last saved state', async function () {
    const completions = trackCompletions();
    await helper.load(paletteNodes, flow());
    assert.ok(runtimeOf() instanceof EngineRuntime, 'bound to no plant: the engine runs it');
    const out = collect(helper, 'out');
    helper.getNode('acq').receive({ operation: 'h', resources: 'YEL' });
    helper.getNode('stop').receive({ resources: 'GRN', reason: 'leak' });
    await until(() => out.length === 1, 'the grant on YEL');
    await quiet();
    assert.deepEqual(liveLines(), { YEL: 'held', GRN: 'faulted:manual', RED: 'free' });

    const generation = wasm.currentGeneration();
    const core = runtimeOf().core;
    core.__wbg_ptr = 0x7ffffff0; // eslint-disable-line no-underscore-dangle
    const msg = { operation: 'x', resources: 'RED' };
    helper.getNode('acq').receive(msg);
    await until(() => completions.some((c) => c.msgid === msg._msgid), 'the msg to complete');
    const err = completions.find((c) => c.msgid === msg._msgid).error;
    assert.equal(err.code, 'INTERNAL');
    assert.match(err.message, /rebuilt/);

    await until(() => wasm.currentGeneration() === generation + 1, 'the new instance');
    await quiet();
    assert.equal(runtimeOf().state, 'ready');
    assert.notEqual(runtimeOf().core, core, 'the engine rebuilt');
    const fresh = require(path.join(PALETTE, 'wasm', 'sugarshack_wasm.js'));
    assert.ok(runtimeOf().core instanceof fresh.Engine, 'on the new instance');
    assert.deepEqual(liveLines(), { YEL: 'faulted:interrupted', GRN: 'faulted:manual', RED: 'free' }, 'from the last saved state');

    // A free line is granted; one faulted by the rebuild queues until it is cleared.
    helper.getNode('acq').receive({ operation: 'red', resources: 'RED' });
    await until(() => out.length === 2, 'the grant on RED');
    helper.getNode('acq').receive({ operation: 'yel', resources: 'YEL' });
    await quiet();
    assert.deepEqual(runtimeOf().core.snapshot(0).queue.map((q) => q.operation), ['yel']);
    helper.getNode('clr').receive({ resources: 'YEL', by: 'ana' });
    await until(() => out.length === 3, 'the waiter granted once YEL is cleared');
    assert.equal(out[2].interlock.operation, 'yel');
    assert.deepEqual(uncaught, [], 'no uncaught exception');
  });

  it('a journal attached while it runs hears every event, and one detached stops the normal ones', async function () {
    await helper.load(paletteNodes, flow());
    const out = collect(helper, 'out');
    await until(() => runtimeOf().state === 'ready', 'the interlock');
    await quiet();
    const rows = [];
    const detach = journal.attach({ row: (row) => rows.push(row) });
    try {
      helper.getNode('acq').receive({ operation: 'a', resources: 'YEL' });
      await until(() => out.length === 1, 'the grant');
      await quiet();
      assert.deepEqual(rows.filter((r) => r.tags.layer === 'interlock').map((r) => r.tags.kind), ['granted']);
    } finally {
      detach();
    }
    helper.getNode('acq').receive({ operation: 'b', resources: 'RED' });
    await until(() => out.length === 2, 'the second grant');
    await quiet();
    assert.equal(rows.filter((r) => r.tags.layer === 'interlock').length, 1, 'nothing more once detached');
  });

  it('an abort saved with the state stands until a person resets it; nothing else is commanded here', async function () {
    await helper.load(paletteNodes, flow());
    await until(() => runtimeOf().state === 'ready', 'the interlock');
    await quiet();
    const { where } = runtimeOf().store;
    const config = runtimeOf().config;
    await helper.unload();
    // The document as an interlock bound to its plant writes it after an abort of operation 10.
    const { Interlock } = wasm.load();
    const opened = Interlock.open(config, 'il', undefined, where, fs.readFileSync(where, 'utf8'), 10);
    const aborted = { 10: { sinceMs: 5, by: { by: 'ana', reason: 'gasket' } } };
    fs.writeFileSync(where, opened.interlock.seal('il', undefined, { routines: {}, aborted }, 11));
    opened.interlock.free();

    await helper.load(paletteNodes, flow());
    await until(() => runtimeOf().state === 'ready', 'the interlock again');
    assert.deepEqual(runtimeOf().describe().aborted, [{ operation: '10', sinceMs: 5, by: 'ana', reason: 'gasket', commands: ['reset'] }]);
    const refused = (target, name) => operator.command(runtimeOf(), target, name, { by: 'bo' }).then(() => null, (err) => err.code);
    assert.equal(await refused({ operation: '10' }, 'restart'), 'COMMAND_REFUSED');
    assert.equal(await refused({ operation: '12' }, 'reset'), 'UNKNOWN_RUN');
    assert.equal(await refused({ routine: 'r' }, 'hold'), 'UNKNOWN_RUN');
    assert.equal(await refused({ operation: '10' }, 'start'), 'INVALID_INPUT');
    assert.equal(await refused({}, 'reset'), 'INVALID_INPUT');

    const rows = [];
    const detach = journal.attach({ row: (row) => rows.push(row) });
    try {
      const reset = await operator.command(runtimeOf(), { operation: '10' }, 'reset', { by: 'bo', reason: 'gasket changed' });
      assert.deepEqual(reset, { operation: '10', command: 'reset', state: 'idle', by: 'bo' });
    } finally {
      detach();
    }
    assert.deepEqual(rows.filter((r) => r.tags.action === 'reset').map((r) => [r.tags.who, r.tags.target]), [['bo', '10']]);
    assert.deepEqual(runtimeOf().describe().aborted, []);
    // Answered once saved: the file no longer has it.
    const reread = Interlock.open(config, 'il', undefined, where, fs.readFileSync(where, 'utf8'), 20);
    assert.deepEqual(reread.aborted, {});
    reread.interlock.free();
  });

  it('one whose settings were refused, given good ones by the next deploy, starts from its saved state: a faulted line stays faulted', async function () {
    await helper.load(paletteNodes, flow());
    helper.getNode('stop').receive({ resources: 'GRN', payload: 'e-stop GRN' });
    await until(() => liveLines().GRN === 'faulted:manual', 'GRN faulted');
    await quiet();
    // The same line twice: the core refuses these settings at deploy.
    const refused = flow().map((n) => (n.id === 'il' ? { ...n, resources: [...n.resources, n.resources[0]] } : n));
    await helper.setFlows(refused, 'full');
    await until(() => runtimeOf().state === 'failed', 'the refused settings');
    await helper.setFlows(flow(), 'full');
    await until(() => runtimeOf().state === 'ready', 'the start with good settings');
    await quiet();
    assert.deepEqual(liveLines(), { YEL: 'free', GRN: 'faulted:manual', RED: 'free' }, 'from the saved state, not a first start');
    helper.getNode('acq').receive({ operation: 'rinse', resources: 'GRN' });
    await quiet();
    assert.deepEqual(runtimeOf().core.counts(), { holding: 0, queued: 1, faulted: 1 }, 'the faulted line is not granted');
  });
});
