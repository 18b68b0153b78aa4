#!/usr/bin/env node
'use strict';
// Node-RED cost per feedback msg through the actuators node: prints figures,
// asserts nothing about speed.
//
// The case-study plant (flows/plant.json) runs in Node-RED under
// node-red-node-test-helper. The same `<panel>/state` msgs, JSON text exactly
// as the simulator publishes it (16 valves + 1 pump = 17 datapoints), go by
// node.receive() into three nodes of one flow:
//   change     a core change node setting one property: what any node costs
//              in Node-RED (the floor)
//   function   a core function node doing what a hand-written tracker at the
//              very least does: JSON.parse, then a loop over the values
//              comparing each with the last one (tolerance 3 %). Its code runs
//              in a vm context, where globals (JSON, Math) are slow to reach:
//              the same code runs about 3x faster outside one.
//   actuators  sugarshack-actuators on the plant (10 or 11 of the 17
//              datapoints are named actuators, the rest are skipped)
// The panels report noise within tolerance around their position; on each
// panel two named valves open and close every 40 plant seconds (25 %/s) and
// the pump follows, as commanded by group commands given to the actuators
// node between samples (untimed), so its msgs also carry motion, completion
// and returned group commands. Outputs are unwired: the nodes' own cost.
//
// Each round pushes every msg into one node, plant second by plant second,
// and times the receive calls until every msg has completed (done()); rounds
// rotate over the nodes. The figure is the median round.
// The helper's sinon spies (log, send, status...) are removed after loading:
// they record every call, which is the helper's cost, not Node-RED's.
//
// usage: node tests/bench/actuator-node-bench.js [--msgs N] [--rounds R] [--quick]

const os = require('os');
const path = require('path');
const { mulberry32: rng } = require('../../scripts/simulator/random');

const ROOT = path.resolve(__dirname, '../..');
process.chdir(ROOT); // the helper finds Node-RED from the working directory
const helper = require('node-red-node-test-helper');
const PALETTE = path.join(ROOT, 'node-red-contrib-sugarshack');
const coreNodesDir = path.dirname(require.resolve('@node-red/nodes/package.json'));

helper.init(require.resolve('node-red'));

const args = process.argv.slice(2);
const flag = (name) => args.includes(name);
const option = (name, fallback) => {
  const i = args.indexOf(name);
  return i >= 0 && args[i + 1] !== undefined ? Number(args[i + 1]) : fallback;
};
const QUICK = flag('--quick');
const PANEL_VALVES = 16;
const DATAPOINTS = PANEL_VALVES + 1;
const CYCLE_S = 40; // open at 10, closed again from 34
// Whole cycles for every panel, so round after round continues the same motion.
const MSGS = Math.max(1, Math.round(option('--msgs', QUICK ? 5000 : 20000) / 200)) * 200;
const ROUNDS = Math.max(1, option('--rounds', QUICK ? 3 : 7));

// Measured on this palette's own batch format (one msg per panel second).
const PLANT = require(path.join(ROOT, 'scripts', 'simulator', 'plant.js')).withProfile(require(path.join(ROOT, 'flows', 'plant.json')), 'sugarshack');
const PANELS = PLANT.devices.filter((d) => d.kind === 'actuator-panel').map((d) => d.id);
const SECONDS = MSGS / PANELS.length;

// ---- msgs ------------------------------------------------------------------

const random = rng(42);
const round1 = (v) => Math.round(v * 10) / 10;
const noisy = (position) => round1(Math.min(100, Math.max(0, position + (random() * 2 - 1)))); // ± 1 %, as the simulator

/** Where a moving valve is `c` seconds into its cycle: commanded open at 10, closed at 30, 4 s sweep. */
function travel(c) {
  if (c < 10) return 0;
  if (c < 14) return 12.5 + 25 * (c - 10);
  if (c < 30) return 100;
  if (c < 34) return 87.5 - 25 * (c - 30);
  return 0;
}
// Panels out of step; at the end of a round (second 39 of a cycle + offset) none has a command running.
const OFFSETS = [0, 3, 5, 20, 23];
const phase = (second, panel) => (second + OFFSETS[panel % OFFSETS.length]) % CYCLE_S;

const MOVING_IO = [1, 2];
const named = (device, type, io) => PLANT.actuators.find((a) => a.device === device && a.type === type && a.io === io);

/** Every plant second, one batch per panel, as `<panel>/state` text. */
function batches() {
  const out = [];
  const ts0 = Date.now();
  for (let s = 0; s < SECONDS; s++) {
    PANELS.forEach((device, p) => {
      const c = phase(s, p);
      const valve = {};
      for (let io = 1; io <= PANEL_VALVES; io++) {
        let position = io % 4 === 0 ? 100 : 0;
        if (MOVING_IO.includes(io)) position = travel(c);
        if (io === 12) position = travel(phase(s + 20, p)); // an unnamed valve moving too
        valve[io] = noisy(position);
      }
      const running = c >= 11 && c < 31; // 1 s spin-up
      // Device time moves 1 ms per plant second: the replay runs far faster than the plant, and a
      // stamp more than clockSkewMs ahead of its reception would be refused as a clock gone wrong.
      out.push({ second: s, topic: `${device}/state`, payload: JSON.stringify({ ts: ts0 + s, valve, pump: { 1: running } }) });
    });
  }
  return out;
}

/** Group commands given to the actuators node before the samples of second `s`. */
function commandsAt(s) {
  const out = [];
  PANELS.forEach((device, p) => {
    const c = phase(s, p);
    if (c !== 10 && c !== 30) return;
    const open = c === 10;
    const valves = {};
    for (const io of MOVING_IO) valves[named(device, 'valve', io).id] = open ? 100 : 0;
    const payload = { valves };
    const pump = named(device, 'pump', 1);
    if (pump) payload.pumps = { [pump.id]: open };
    out.push({ payload });
  });
  return out;
}

// ---- flow ------------------------------------------------------------------

const FUNCTION_CODE = `
const batch = JSON.parse(msg.payload);
const topic = msg.topic;
const device = topic.slice(0, topic.indexOf('/'));
const last = context.get('last');
const seen = last[device] || (last[device] = {});
let changed = 0;
for (const type in batch) {
  if (type === 'ts') continue;
  const group = batch[type];
  for (const io in group) {
    const v = +group[io];
    const key = type + io;
    const prev = seen[key];
    if (prev === undefined || Math.abs(v - prev) > 3) { seen[key] = v; changed++; }
  }
}
return null;`;

const FLOW = [
  { id: 'f1', type: 'tab', label: 'bench' },
  { id: 'pl', type: 'sugarshack-plant', name: 'plant', plant: PLANT },
  { id: 'bus', z: 'f1', type: 'sugarshack-actuators', name: '', plant: 'pl', devices: '', wires: [[], [], []] },
  {
    id: 'fn', z: 'f1', type: 'function', name: 'tracker minimum', func: FUNCTION_CODE, outputs: 1, timeout: 0, noerr: 0,
    initialize: "context.set('last', {});", finalize: '', libs: [], wires: [[]],
  },
  {
    id: 'chg', z: 'f1', type: 'change', name: 'floor', rules: [{ t: 'set', p: 'seen', pt: 'msg', to: 'true', tot: 'bool' }],
    action: '', property: '', from: '', to: '', reg: false, wires: [[]],
  },
];

const NODES = [
  { id: 'chg', label: 'change (set msg.seen: the floor)' },
  { id: 'fn', label: 'function (JSON.parse + loop)' },
  { id: 'bus', label: 'sugarshack-actuators', commands: true },
];

// ---- timing ----------------------------------------------------------------

const immediate = () => new Promise((resolve) => setImmediate(resolve));
const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

/** Counts done() per node: feedback msgs completed (they have a topic; group commands do not), errors of any. */
function countCompletions(node) {
  const counter = { done: 0, errors: 0, lastError: null };
  const complete = node._complete;
  node._complete = function (msg, err) {
    if (msg && msg.topic !== undefined) counter.done++;
    if (err) {
      counter.errors++;
      counter.lastError = err;
    }
    return complete.call(this, msg, err);
  };
  return counter;
}

/** Counts msgs per output (the actuators node's MQTT commands, returns, events). */
function countOutputs(node) {
  const counts = [0, 0, 0];
  const send = node.send;
  node.send = function (msgs) {
    if (Array.isArray(msgs)) msgs.forEach((m, i) => { if (m) counts[i]++; });
    else if (msgs) counts[0]++;
    return send.apply(this, arguments);
  };
  return counts;
}

async function runRound(entry, msgs) {
  const node = helper.getNode(entry.id);
  const counter = entry.counter;
  const before = counter.done;
  const expected = msgs.length;
  let elapsed = 0n;
  let i = 0;
  for (let s = 0; s < SECONDS; s++) {
    if (entry.commands) for (const cmd of commandsAt(s)) node.receive(cmd);
    const t0 = process.hrtime.bigint();
    for (; i < msgs.length && msgs[i].second === s; i++) {
      node.receive({ topic: msgs[i].topic, payload: msgs[i].payload, qos: 0, retain: false });
    }
    elapsed += process.hrtime.bigint() - t0;
  }
  // Nodes that complete asynchronously: wait for the rest, timed too.
  const t0 = process.hrtime.bigint();
  const deadline = Date.now() + 30000;
  while (counter.done - before < expected) {
    if (Date.now() > deadline) throw new Error(`${entry.label}: ${counter.done - before} of ${expected} msgs completed`);
    await immediate();
  }
  elapsed += process.hrtime.bigint() - t0;
  return Number(elapsed) / 1e3 / msgs.length; // µs per feedback msg
}

const median = (xs) => {
  const s = [...xs].sort((a, b) => a - b);
  const m = s.length >> 1;
  return s.length % 2 ? s[m] : (s[m - 1] + s[m]) / 2;
};
const fmt = (x, d = 2) => x.toFixed(d);
const int = (x) => Math.round(x).toLocaleString('en');

async function main() {
  const paletteNodes = ['plant', 'actuators'].map((f) => require(path.join(PALETTE, 'nodes', `${f}.js`)));
  const coreNodes = ['function/10-function.js', 'function/15-change.js'].map((f) => require(path.join(coreNodesDir, 'core', f)));
  await new Promise((resolve) => helper.startServer(resolve));
  try {
    await helper.load([...paletteNodes, ...coreNodes], FLOW);
    helper._sandbox.restore(); // the helper's spies: see the header
    await sleep(200); // the function node's initialize runs asynchronously

    const bus = helper.getNode('bus');
    if (!bus) throw new Error('the actuators node did not load');
    for (const entry of NODES) entry.counter = countCompletions(helper.getNode(entry.id));
    const busOutputs = countOutputs(bus);

    const msgs = batches();
    const cpus = os.cpus();
    console.log(`actuator node cost: ${MSGS.toLocaleString('en')} <panel>/state msgs (${PANELS.length} panels x ${SECONDS} plant seconds, ${DATAPOINTS} datapoints each) per round, ${ROUNDS} rounds + 1 warm-up per node`);
    console.log(`node ${process.version}, Node-RED ${require('node-red/package.json').version}, ${cpus.length} cores (${cpus[0] && cpus[0].model.trim()})`);

    const times = new Map(NODES.map((n) => [n.id, []]));
    for (let r = 0; r <= ROUNDS; r++) {
      // Rotate the order so that drift and GC fall on every node alike.
      for (let k = 0; k < NODES.length; k++) {
        const entry = NODES[(k + r) % NODES.length];
        const us = await runRound(entry, msgs);
        if (r > 0) times.get(entry.id).push(us);
        await sleep(20);
      }
      if (r === 0) busOutputs.fill(0); // count outputs over the timed rounds only
    }

    for (const entry of NODES) {
      if (entry.counter.errors) {
        throw new Error(`${entry.label}: ${entry.counter.errors} msgs ended with an error, last: ${entry.counter.lastError && entry.counter.lastError.message}`);
      }
    }

    const med = Object.fromEntries(NODES.map((n) => [n.id, median(times.get(n.id))]));
    console.log('');
    console.log('node                              | µs/msg median (min..max) | µs/datapoint | datapoints/s | x change | x function');
    console.log('----------------------------------|--------------------------|--------------|--------------|----------|-----------');
    for (const entry of NODES) {
      const ts = times.get(entry.id);
      const m = med[entry.id];
      const range = `${fmt(m)} (${fmt(Math.min(...ts))}..${fmt(Math.max(...ts))})`;
      console.log(`${entry.label.padEnd(33)} | ${range.padStart(24)} | ${fmt(m / DATAPOINTS, 3).padStart(12)} | ${int(DATAPOINTS * 1e6 / m).padStart(12)} | ${fmt(m / med.chg).padStart(8)} | ${fmt(m / med.fn).padStart(9)}`);
    }
    const rounds = ROUNDS;
    const perRound = (x) => Math.round(x / rounds);
    console.log('');
    console.log(`actuators node outputs per round: ${perRound(busOutputs[0])} MQTT commands, ${perRound(busOutputs[1])} returned group commands, ${perRound(busOutputs[2])} events`
      + ` (${fmt(busOutputs[2] / (rounds * MSGS), 3)} events/msg)`);
    const added = med.bus - med.chg;
    console.log(`added by the actuators node over the floor: ${fmt(added)} µs/msg (${fmt(added / DATAPOINTS, 3)} µs/datapoint); `
      + `actuators / function node: ${fmt(med.bus / med.fn)}x`);
    const perSecond = PANELS.length * med.bus;
    console.log(`the case-study plant's ${PANELS.length} panel batches per second: ${fmt(perSecond, 1)} µs of CPU per second = ${fmt(perSecond / 1e4, 4)} % of one core`);
  } finally {
    await helper.unload().catch(() => {});
    await new Promise((resolve) => helper.stopServer(resolve));
  }
}

main().then(() => process.exit(0), (err) => {
  console.error(`actuator-node-bench: ${err.stack || err}`);
  process.exit(1);
});
