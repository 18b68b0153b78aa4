'use strict';
// Shared fixtures for the flow tests: the plant's lines, flow builders, waits,
// a user directory per test (where interlocks keep their durable state) and a
// manual clock that the palette's runtimes read instead of the wall clock.
const fs = require('fs');
const os = require('os');
const path = require('path');

const PALETTE = path.join(__dirname, '..', '..', 'node-red-contrib-sugarshack');
const NODE_FILES = [
  'interlock', 'acquire', 'release', 'fault', 'clear', 'cancel', 'interlock-events', 'plant', 'actuators', 'group-command',
  'operation', 'wait', 'routine', 'pid', 'rcc', 'rcc-io', 'journal', 'state',
];
const paletteNodes = NODE_FILES.map((f) => require(path.join(PALETTE, 'nodes', `${f}.js`)));
// The palette's subflow modules, and the core nodes their subflows are built from besides link and catch.
const SUBFLOW_FILES = ['singular-operation', 'group-entry', 'condition-step', 'operator-panel'];
const subflowNodes = SUBFLOW_FILES.map((f) => require(path.join(PALETTE, 'nodes', `${f}.js`)));
const { useClock, ManualClock, settle } = require(path.join(PALETTE, 'lib', 'host', 'clock.js'));

const coreNodesDir = path.dirname(require.resolve('@node-red/nodes/package.json'));
const catchNode = require(path.join(coreNodesDir, 'core/common/25-catch.js'));
const linkNodes = require(path.join(coreNodesDir, 'core/common/60-link.js'));
const subflowCoreNodes = ['function/15-change.js', 'function/10-switch.js', 'common/25-status.js']
  .map((f) => require(path.join(coreNodesDir, 'core', f)));
const { hooks } = require('@node-red/util');

const LINES = ['YEL', 'GRN', 'BLU', 'PUR', 'RED'];
const lockoutOf = (line) => ({ valves: { [`${line}-V1`]: 0, [`${line}-V2`]: 0 }, pumps: { [`${line}-P`]: false } });

const TAB = { id: 'f1', type: 'tab', label: 'test' };

function interlockConfig(extra = {}) {
  return {
    id: 'il',
    type: 'sugarshack-interlock',
    name: 'plant',
    resources: LINES.map((name) => ({ name, lockout: lockoutOf(name) })),
    policy: 'greedy',
    queueBound: '',
    warnQueued: '',
    warnHeld: '',
    persist: false,
    store: 'default',
    ...extra,
  };
}

function acquire(id, operation, priority, resources, wire, extra = {}) {
  return {
    id, z: 'f1', type: 'sugarshack-acquire', interlock: 'il', operation, priority, resources, timeout: 0,
    wires: [wire ? [wire] : []], ...extra,
  };
}

function release(id, wire, extra = {}) {
  return { id, z: 'f1', type: 'sugarshack-release', interlock: 'il', operation: '', wires: [wire ? [wire] : []], ...extra };
}

function sinkNode(id) {
  return { id, z: 'f1', type: 'helper' };
}

/** Starts collecting what reaches a helper node. */
function collect(helper, id) {
  const got = [];
  helper.getNode(id).on('input', (msg) => got.push(msg));
  return got;
}

const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

async function until(predicate, what, ms = 3000) {
  const start = Date.now();
  while (!predicate()) {
    if (Date.now() - start > ms) throw new Error(`timed out waiting for ${typeof what === 'function' ? what() : what}`);
    await sleep(5);
  }
}

/** Records every done() (msg completion) in the runtime, with its error if any. */
function trackCompletions() {
  const completions = [];
  hooks.add('onComplete.sugarshack-test', (event) => {
    completions.push({ nodeId: event.node.id, msgid: event.msg && event.msg._msgid, error: event.error });
  });
  return completions;
}

/** Records every msg a node receives, across redeploys: [{ nodeId, msg }]. */
function trackDeliveries() {
  const deliveries = [];
  hooks.add('onReceive.sugarshack-test', (event) => {
    deliveries.push({ nodeId: event.destination.id, msg: event.msg });
  });
  return deliveries;
}

function untrackCompletions() {
  hooks.remove('*.sugarshack-test');
}

// The helper loads the core catch node once per catch node in a flow; a flow
// with several would register it twice, so while such a flow runs it is
// registered once per runtime.
const loadedCatch = new WeakSet();
function catchOnce(RED) {
  if (loadedCatch.has(RED)) return undefined;
  loadedCatch.add(RED);
  return catchNode(RED);
}
let helperCatch = null;

// The current test's user directory and clock (see startServer).
const current = { userDir: null, clock: null, completions: [] };

/** Runtime settings for the helper, always with the test's own user directory. */
function settings(extra = {}) {
  const helper = require('node-red-node-test-helper');
  return helper.settings({ userDir: current.userDir, ...extra });
}

/**
 * Starts the helper's server with a fresh user directory and a manual clock
 * (time moves only with `clock().advance(ms)`). Integration tests against real
 * devices, where time must pass, use `startRealTimeServer`.
 */
function startServer(done) {
  startWith(new ManualClock(), done);
}

function startRealTimeServer(done) {
  startWith(null, done);
}

function startWith(manual, done) {
  const helper = require('node-red-node-test-helper');
  /* eslint-disable no-underscore-dangle */
  helperCatch = helper._nodeModules.catch;
  helper._nodeModules.catch = catchOnce;
  /* eslint-enable no-underscore-dangle */
  current.userDir = fs.mkdtempSync(path.join(os.tmpdir(), 'sugarshack-flow-'));
  current.clock = useClock(manual);
  settings();
  helper.startServer(done);
}

async function stopServer() {
  const helper = require('node-red-node-test-helper');
  await helper.unload();
  await new Promise((resolve) => helper.stopServer(resolve));
  helper._nodeModules.catch = helperCatch; // eslint-disable-line no-underscore-dangle
  helper.settings({});
  useClock();
  if (current.userDir) fs.rmSync(current.userDir, { recursive: true, force: true });
  current.userDir = null;
  current.clock = null;
}

const clock = () => current.clock;
const userDir = () => current.userDir;

/** A describe block's hooks: each test on its own server (startServer), its msg completions tracked. */
function serverPerTest() {
  beforeEach(function (done) {
    current.completions = trackCompletions();
    startServer(done);
  });
  afterEach(async function () {
    untrackCompletions();
    await stopServer();
  });
}

/** The msg completions of the current test of a serverPerTest block: [{ nodeId, msgid, error }]. */
const completions = () => current.completions;

/**
 * Lets the runtimes of these config nodes save what changed and run its effects,
 * twice over (an effect may change state again), then a few turns of the loop.
 */
async function settled(helper, ...ids) {
  for (let round = 0; round < 2; round++) {
    for (const id of ids) {
      const runtime = helper.getNode(id) && helper.getNode(id).runtime;
      if (runtime && runtime.settled) await runtime.settled();
    }
    await settle();
  }
}

/**
 * Lets `ms` of manual-clock time pass in steps of `step` ms; before and after
 * each step the runtimes of `ids` save and act on what it changed, so what a
 * timer sets off happens at that timer's time.
 */
async function runFor(helper, ms, { ids = ['il'], step = 5 } = {}) {
  await settled(helper, ...ids);
  for (let passed = 0; passed < ms; passed += step) {
    await current.clock.advance(Math.min(step, ms - passed));
    await settled(helper, ...ids);
  }
}

/**
 * Lets manual-clock time pass, `step` ms at a time, until `predicate` holds;
 * returns how much passed. Fails after `maxMs` of clock time.
 */
async function runUntil(helper, predicate, what, { ids = ['il'], step = 5, maxMs = 60000 } = {}) {
  await settled(helper, ...ids);
  let passed = 0;
  while (!predicate()) {
    if (passed >= maxMs) throw new Error(`${typeof what === 'function' ? what() : what} did not happen within ${maxMs} ms of clock time`);
    await current.clock.advance(step);
    passed += step;
    await settled(helper, ...ids);
  }
  return passed;
}

/** Shorthands of a flow test on interlock `id`: its runtime, settling, running the clock (until), a node's last status. */
function onInterlock(helper, id = 'il') {
  return {
    runtime: () => helper.getNode(id).runtime,
    quiet: () => settled(helper, id),
    run: (ms) => runFor(helper, ms, { ids: [id] }),
    runTill: (predicate, what) => runUntil(helper, predicate, what, { ids: [id] }),
    statusOf: (node) => helper.getNode(node).status.getCalls().filter((c) => c.thisValue.id === node).map((c) => c.args[0]).at(-1),
  };
}

/** The interlocks' state files a crash (kill -9, a power cut) would leave: copied now; the function returned puts them back after a shutdown. */
function crashCopy() {
  const dir = path.join(current.userDir, 'sugarshack');
  const copy = fs.mkdtempSync(path.join(current.userDir, 'crash-'));
  for (const f of fs.readdirSync(dir)) fs.copyFileSync(path.join(dir, f), path.join(copy, f));
  return () => {
    fs.rmSync(dir, { recursive: true, force: true });
    fs.mkdirSync(dir);
    for (const f of fs.readdirSync(copy)) fs.copyFileSync(path.join(copy, f), path.join(dir, f));
  };
}

/**
 * A context store module (for `settings({ contextStorage })`) over `data`
 * (scope -> key -> value), values kept as JSON as a store on disk keeps them.
 * `get` answers; pass one that answers late to stand for a store on a slow disk.
 */
/**
 * The checksum of a sealed state document, as the README gives it: SHA-256 of
 * its compact JSON without the checksum member (computed here, apart from the core).
 */
function checksumOf(doc) {
  const { checksum, ...rest } = doc; // eslint-disable-line no-unused-vars
  return `sha256:${require('crypto').createHash('sha256').update(JSON.stringify(rest)).digest('hex')}`;
}

/** `doc` as text with a checksum that matches it: damage a checksum alone would not catch. */
const resealed = (doc) => JSON.stringify({ ...doc, checksum: checksumOf(doc) });

function memoryStore(data, get = (scope, key, cb) => cb(null, (data[scope] || {})[key])) {
  return () => ({
    open: () => Promise.resolve(),
    close: () => Promise.resolve(),
    get,
    set: (scope, key, value, cb) => {
      const values = (data[scope] = data[scope] || {});
      if (value === undefined) delete values[key];
      else values[key] = JSON.parse(JSON.stringify(value));
      if (cb) cb();
    },
    keys: (scope, cb) => cb(null, Object.keys(data[scope] || {})),
    delete: (scope) => { delete data[scope]; return Promise.resolve(); },
    clean: () => Promise.resolve(),
  });
}

module.exports = {
  checksumOf, resealed, crashCopy, onInterlock, memoryStore, PALETTE, paletteNodes, subflowNodes, subflowCoreNodes, SUBFLOW_FILES, catchNode, catchOnce, startServer, startRealTimeServer, stopServer, serverPerTest, completions, settings, settled, clock, userDir, linkNodes, LINES, lockoutOf, TAB,
  interlockConfig, acquire, release, sinkNode, collect, sleep, until, runFor, runUntil, trackCompletions, trackDeliveries, untrackCompletions,
};
