#!/usr/bin/env node
'use strict';
// Boundary crossings into wasm per msg, through the real Node-RED nodes
// (node-red-node-test-helper, manual clock): every method and getter of every
// facade class, and every free function, that calls into the wasm module is
// wrapped with a counter (tests/facade-spy.js). The palette's own JS wrappers
// around facade calls (lib/wasm/index.js numericCalls) are not counted themselves:
// the glue they call is. After a warm-up, N msgs of each kind go in, each
// counted from its receive() until the runtimes have settled; what a kind
// needs around its msg (the acquire before a release, the feedback that
// completes a group command) goes in uncounted. The case-study plant
// (flows/plant.json) and its five lines:
//   acquire / release           on an interlock bound to no plant (the core's
//                               Engine, lib/interlock/engine-runtime.js) and
//                               on one bound to the plant (the same engine)
//   release granting three      a holder of YEL, GRN and BLU releases; one
//                               waiter on each line is granted
//   feedback                    a <panel>/state msg into the actuators node,
//                               payload as text (as MQTT gives it) and as an object
//   group command               { valves: { V101: ... } } into the
//                               group-command node and into the actuators node
// Prints per kind the calls in per msg, the follow-ups among them (calls after
// the msg's input call: see Crossings), the top five methods, and a PASS/MISS
// line against the target: one call in per input, no follow-up.
//
// usage: node tests/bench/crossings.js [--msgs N]

const path = require('path');
const helper = require('node-red-node-test-helper');
const { verdict } = require('./verdict');
const { spyOnFacade } = require('../facade-spy');
const {
  PALETTE, paletteNodes, TAB, LINES, interlockConfig, acquire, release, sinkNode, collect, settled, clock, startServer, stopServer,
  trackCompletions, untrackCompletions,
} = require('../flow/support');

const ROOT = path.resolve(__dirname, '../..');
const wasm = require(path.join(PALETTE, 'lib', 'wasm', 'index.js'));
const PLANT = require(path.join(ROOT, 'scripts', 'simulator', 'plant.js')).withProfile(require(path.join(ROOT, 'flows', 'plant.json')), 'sugarshack');

const TARGET = 'at most 1 call in per input, no follow-up getters';

// ---- counting ---------------------------------------------------------------

/** wasm-bindgen's glue calls the module's exports (`wasm.engine_acquire(...)`); a JS wrapper around the glue does not. */
const crossesIn = (fn) => /\bwasm\.\w+\(/.test(String(fn));

/**
 * Counts the calls into wasm made while `during` runs (one msg), by facade
 * method. A msg's first call on a wasm object is its input; every call after
 * it in the same msg is a follow-up: reading back what the input did
 * (`lastTs()`, `granted(i)`, `takeEffects()`, a getter) or a second input.
 */
class Crossings {
  constructor(facade = wasm.load()) {
    this.counts = new Map();
    this.followUps = 0;
    this.counting = false;
    this.inputSeen = false;
    const onCall = (key, instance) => {
      if (!this.counting) return;
      this.counts.set(key, (this.counts.get(key) || 0) + 1);
      if (this.inputSeen) this.followUps += 1;
      else if (instance) this.inputSeen = true;
    };
    const spy = spyOnFacade(facade, onCall, { functions: true, skip: (className, name, fn) => !crossesIn(fn) });
    if (spy.methods.length < 100) throw new Error(`only ${spy.methods.length} facade calls found: is the facade loaded?`);
    this.restore = spy.restore;
  }

  /** Runs `fn` (awaited) with the counter on, as one msg. */
  async during(fn) {
    this.counting = true;
    this.inputSeen = false;
    try {
      return await fn();
    } finally {
      this.counting = false;
    }
  }

  /** What was counted, per msg over `msgs` msgs; the counts start over. */
  take(msgs) {
    const calls = [...this.counts].sort((a, b) => b[1] - a[1] || a[0].localeCompare(b[0]));
    const row = {
      perMsg: calls.reduce((s, [, n]) => s + n, 0) / msgs,
      followUpsPerMsg: this.followUps / msgs,
      top: calls.slice(0, 5).map(([key, n]) => ({ key, perMsg: n / msgs })),
    };
    this.counts = new Map();
    this.followUps = 0;
    return row;
  }
}

// ---- the flow -----------------------------------------------------------------

const WAITED = ['YEL', 'GRN', 'BLU'];
const OPERATIONS = 16; // names cycle, as the case study's 16 operations do: caches warm

/** An interlock's nodes: one acquire per line, a holder of the three WAITED lines, a release; grants and releases to sinks. */
function interlockNodes(il, extra) {
  const on = { interlock: il };
  return [
    interlockConfig({ id: il, ...extra }),
    ...LINES.map((line) => acquire(`${il}-${line}`, '', 5, line, `${il}-got`, on)),
    acquire(`${il}-hold`, '', 9, WAITED.join(','), `${il}-got`, on),
    release(`${il}-rel`, `${il}-out`, on),
    sinkNode(`${il}-got`), sinkNode(`${il}-out`),
  ];
}

const FLOW = [
  TAB,
  ...interlockNodes('il', {}),
  { id: 'pl', type: 'sugarshack-plant', name: 'plant', plant: PLANT },
  ...interlockNodes('ilp', { name: 'lines', plant: 'pl', resources: [] }),
  { id: 'bus', z: 'f1', type: 'sugarshack-actuators', plant: 'pl', devices: '', wires: [['mqtt'], ['ret'], []] },
  { id: 'gc', z: 'f1', type: 'sugarshack-group-command', plant: 'pl', timeout: 0, wires: [['gc-out']] },
  sinkNode('mqtt'), sinkNode('ret'), sinkNode('gc-out'),
];
const SINKS = ['il-got', 'il-out', 'ilp-got', 'ilp-out', 'mqtt', 'ret', 'gc-out'];

const PANELS = PLANT.devices.filter((d) => d.kind === 'actuator-panel').map((d) => d.id);
const COMMANDED = PLANT.actuators.find((a) => a.type === 'valve');

/** What each panel reports: every actuator on it at its idle value until commanded. */
function panelStates() {
  const states = Object.fromEntries(PANELS.map((d) => [d, {}]));
  for (const a of PLANT.actuators) {
    const group = (states[a.device][a.type] = states[a.device][a.type] || {});
    group[a.io] = a.idle;
  }
  return states;
}

// ---- the kinds ------------------------------------------------------------------

/**
 * Drives msgs of every kind; `step(kind, i)` gives msg i of a kind, counted,
 * with what it needs around it uncounted, and checks that it did its work.
 */
class Driver {
  constructor(crossings) {
    this.crossings = crossings;
    this.seen = Object.fromEntries(SINKS.map((id) => [id, collect(helper, id)]));
    this.states = panelStates();
    this.feedbackCompleted = 0;
    this.completions = trackCompletions();
  }

  /** Gives `msg` to node `id`; resolves once every runtime has settled. */
  async send(id, msg) {
    helper.getNode(id).receive(msg);
    await settled(helper, 'il', 'ilp', 'pl');
  }

  counted(id, msg) {
    return this.crossings.during(() => this.send(id, msg));
  }

  /** Runs `give()` and checks that sink `id` got `n` msgs from it. */
  async expect(id, n, what, give) {
    const before = this.seen[id].length;
    await give();
    const got = this.seen[id].length - before;
    if (got !== n) throw new Error(`${what}: ${got} msgs reached ${id}, not ${n}`);
  }

  /** A panel's state msg after 100 ms of plant time, values wobbling within tolerance. */
  async feedback(device, i, { counted = false, text = true } = {}) {
    await clock().advance(100);
    const wobble = ((i % 3) - 1) * 0.5;
    const state = this.states[device];
    const valve = Object.fromEntries(Object.entries(state.valve || {}).map(([io, v]) => [io, Math.min(100, Math.max(0, v + wobble))]));
    const body = { ts: clock().now(), ...state, valve };
    const msg = { topic: `${device}/state`, payload: text ? JSON.stringify(body) : body, qos: 0, retain: false };
    const done = () => this.completions.filter((c) => c.nodeId === 'bus' && c.msgid === msg._msgid);
    await (counted ? this.crossings.during(() => this.send('bus', msg)) : this.send('bus', msg));
    if (done().length !== 1 || done()[0].error) throw new Error(`the feedback msg ${msg.topic} did not complete cleanly: ${done().map((c) => c.error)}`);
  }

  /** A group command moving the commanded valve open or shut, counted; then its completion reported, uncounted. */
  async groupCommand(node, i) {
    const target = i % 2 ? COMMANDED.idle : 100;
    await this.expect('mqtt', 1, 'a group command', () => this.counted(node, { payload: { valves: { [COMMANDED.id]: target } } }));
    this.states[COMMANDED.device].valve[COMMANDED.io] = target;
    const back = node === 'gc' ? 'gc-out' : 'ret';
    await this.expect(back, 1, 'the group command\'s return', () => this.feedback(COMMANDED.device, i));
  }

  /** An acquire then its release, one of them counted. */
  async acquireRelease(il, i, countAcquire) {
    const operation = `op${i % OPERATIONS}`;
    const msg = { operation };
    await this.expect(`${il}-got`, 1, 'an acquire', () => (countAcquire ? this.counted(`${il}-YEL`, msg) : this.send(`${il}-YEL`, msg)));
    await this.expect(`${il}-out`, 1, 'a release', () => (countAcquire ? this.send(`${il}-rel`, msg) : this.counted(`${il}-rel`, msg)));
  }

  /** A holder of three lines and a waiter on each; the holder's release, counted, grants all three. */
  async releaseToThree(il, i) {
    const n = i % (OPERATIONS / 4);
    const waiters = WAITED.map((line) => ({ line, operation: `${line}-${n}` }));
    await this.expect(`${il}-got`, 1, 'the holder\'s grant, the waiters queued', async () => {
      await this.send(`${il}-hold`, { operation: `hold-${n}` });
      for (const w of waiters) await this.send(`${il}-${w.line}`, { operation: w.operation });
    });
    await this.expect(`${il}-got`, 3, 'a release granting three waiters', () => this.counted(`${il}-rel`, { operation: `hold-${n}` }));
    for (const w of waiters) await this.send(`${il}-rel`, { operation: w.operation });
  }
}

const KINDS = [
  { id: 'acquire', label: 'acquire, interlock alone (Engine)', step: (d, i) => d.acquireRelease('il', i, true) },
  { id: 'release', label: 'release, interlock alone (Engine)', step: (d, i) => d.acquireRelease('il', i, false) },
  { id: 'release3', label: 'release granting 3, alone (Engine)', step: (d, i) => d.releaseToThree('il', i) },
  { id: 'plant-acquire', label: 'acquire, plant-bound interlock', step: (d, i) => d.acquireRelease('ilp', i, true) },
  { id: 'plant-release', label: 'release, plant-bound interlock', step: (d, i) => d.acquireRelease('ilp', i, false) },
  { id: 'plant-release3', label: 'release granting 3, plant-bound', step: (d, i) => d.releaseToThree('ilp', i) },
  { id: 'feedback-text', label: 'feedback msg, payload as text', step: (d, i) => d.feedback(PANELS[i % PANELS.length], i, { counted: true }) },
  { id: 'feedback-object', label: 'feedback msg, payload as object', step: (d, i) => d.feedback(PANELS[i % PANELS.length], i, { counted: true, text: false }) },
  { id: 'gc-command', label: 'group command, group-command node', step: (d, i) => d.groupCommand('gc', i) },
  { id: 'bus-command', label: 'group command, actuators node', step: (d, i) => d.groupCommand('bus', i) },
];

/**
 * Loads the flow on a started server, then for each kind of `ids` gives
 * `warmup` msgs uncounted and `msgs` counted; resolves with one row per kind.
 */
async function measure(ids, { msgs, warmup }) {
  await helper.load(paletteNodes, FLOW);
  const crossings = new Crossings();
  const driver = new Driver(crossings);
  try {
    for (const device of PANELS) await driver.feedback(device, 0); // every panel heard from: the plant's state known
    const rows = [];
    for (const kind of KINDS.filter((k) => ids.includes(k.id))) {
      for (let i = 0; i < warmup; i++) await kind.step(driver, i);
      crossings.take(1); // drops the warm-up's counts
      for (let i = 0; i < msgs; i++) await kind.step(driver, warmup + i);
      rows.push({ ...kind, ...crossings.take(msgs) });
    }
    return rows;
  } finally {
    untrackCompletions();
    crossings.restore();
  }
}

/** Whether a row meets the target: at most one call in per msg, none after its input. */
const meets = (row) => row.perMsg <= 1 && row.followUpsPerMsg === 0;

async function main() {
  const at = process.argv.indexOf('--msgs');
  const msgs = at >= 0 ? Number(process.argv[at + 1]) : 200;
  helper.init(require.resolve('node-red'));
  await new Promise((resolve) => startServer(resolve));
  let rows;
  try {
    rows = await measure(KINDS.map((k) => k.id), { msgs, warmup: 2 * OPERATIONS });
  } finally {
    await stopServer();
  }
  console.log(`crossings: node ${process.version}, Node-RED ${require('node-red/package.json').version}; calls into wasm per msg, ${msgs} msgs per kind after ${2 * OPERATIONS} uncounted`);
  console.log(`  ${'kind'.padEnd(36)} ${'calls/msg'.padStart(9)} ${'follow-ups'.padStart(10)}  top methods (calls/msg)`);
  for (const row of rows) {
    const top = row.top.map((t) => `${t.key} ${+t.perMsg.toFixed(2)}`).join(', ');
    console.log(`  ${row.label.padEnd(36)} ${row.perMsg.toFixed(2).padStart(9)} ${row.followUpsPerMsg.toFixed(2).padStart(10)}  ${top}`);
  }
  for (const row of rows) {
    console.log(verdict(`crossings into wasm per ${row.label}`, `${+row.perMsg.toFixed(2)} calls, ${+row.followUpsPerMsg.toFixed(2)} follow-ups`, meets(row), TARGET));
  }
}

if (require.main === module) {
  main().then(() => process.exit(0), (err) => {
    console.error(`crossings: ${err.stack || err}`);
    process.exit(1);
  });
}

module.exports = { Crossings, measure, KINDS, meets };
