#!/usr/bin/env node
'use strict';
// Interlock benchmark: prints figures, asserts nothing about speed.
//
// Three implementations run the same seeded workloads in one run:
//   baseline  plain-JS Algorithms 1 and 2 (tests/bench/baseline-interlock.js)
//   engine    the core's Engine as the nodes call it (lib/interlock/engine-runtime.js):
//             one call per msg with Date.now() and the msg's handle, the node's
//             configured operation, priority and lines resolved by the core; a
//             release follows msg.interlock.operation. Each call's outputs are
//             read from the typed wire (lib/wasm/wire.js) by a visitor that keeps
//             what the carrier keeps: the held msg taken by its handle,
//             msg.interlock set on a grant, the counts. Not included: the state
//             write a grant waits for (tests/bench/durable-bench.js) and Node-RED.
//   facade    the raw Interlock facade (acquire/release by handle, a Map from
//             handle to pending msg): what the core costs through wasm without
//             the engine's msg handling. No node calls it this way.
//   native    the Rust core, via `cargo run --release --example interlock_bench`
// The baseline gets the same msg glue (its Map is keyed by _msgId) and the
// same clock reads (one Date.now() per call, stamped as the paper's warnings need).
//
// Workloads (mirrored in rust/sugarshack-core/examples/interlock_bench.rs):
//   case   the 16 operations of Fig. 8 on the 5 lines.
//          pair:    acquire (granted at once) + release (nobody waiting) of each
//                   operation in turn on an idle interlock; the implementations'
//                   batches interleaved, so none runs on a cooler machine.
//          release: 128 independent interlocks, each with all 16 operations
//                   started; every sample releases one random holder in each
//                   (the release re-evaluates the waiting requests), then,
//                   untimed, the released operation acquires again.
//          Single calls take 100-1000 ns, so both are timed in batches of 128 calls;
//          median and p99 are over batch means.
//   large  1,024 resources; operations with random sets of 1-8 resources and
//          priorities 1-100 acquire until 10,000 requests wait.
//          release: a random holder releases (timed alone), then acquires again
//                   with a fresh random set; new operations top the queue back
//                   up to 10,000.
//          pair:    after each step, a probe operation acquires one free
//                   resource (granted) and releases it (re-evaluating the
//                   requests that wait on it, which stay blocked), timed alone.
// Policy greedy (the paper's), event recording off unless a row says otherwise.
//
// usage: node tests/bench/interlock-bench.js [--quick] [--no-native] [--no-events]
// (--no-events: no facade row with event recording on)

const path = require('path');
const os = require('os');
const { spawnSync } = require('child_process');
const { BaselineInterlock } = require('./baseline-interlock');

const ROOT = path.resolve(__dirname, '../..');
// SUGARSHACK_PALETTE: another build of the palette, to compare two in one sitting.
const PALETTE = process.env.SUGARSHACK_PALETTE || path.join(ROOT, 'node-red-contrib-sugarshack');
// Loaded as the nodes load it.
const WASM_LOADER = path.join(PALETTE, 'lib/wasm/index.js');
const WIRE = path.join(PALETTE, 'lib/wasm/wire.js');
const argv = new Set(process.argv.slice(2));
const QUICK = argv.has('--quick');

const PARAMS = {
  case: { seed: 0x5eed0c5e, instances: 128, pairBatch: 128, warmup: QUICK ? 50 : 500, samples: QUICK ? 200 : 3000 },
  large: {
    seed: 0x5eed1a26,
    resources: 1024,
    waiting: 10000,
    maxSet: 8,
    pool: 16384,
    priorities: 100,
    queueBound: 20000,
    warmup: QUICK ? 30 : 300,
    samples: QUICK ? 200 : 3000,
  },
};

const LINES = ['YEL', 'GRN', 'BLU', 'PUR', 'RED'];
// Fig. 8: [id, priority, lines]
const FIG8 = [
  [10, 20, ['YEL']],
  [11, 23, ['YEL']],
  [12, 22, ['YEL']],
  [20, 78, ['YEL']],
  [15, 77, ['YEL']],
  [18, 92, ['YEL', 'RED']],
  [19, 91, ['YEL']],
  [21, 101, ['GRN']],
  [23, 99, ['GRN', 'RED']],
  [24, 100, ['GRN', 'RED']],
  [33, 88, ['BLU', 'RED']],
  [41, 69, ['PUR', 'RED']],
  [42, 55, ['PUR', 'RED']],
  [48, 97, ['PUR', 'RED']],
  [49, 96, ['PUR', 'RED']],
  [51, 1, ['RED']],
];

// ---- deterministic randomness (mulberry32; same bits in the Rust example) ----

function rng(seed) {
  let a = seed | 0;
  const next = () => {
    a = (a + 0x6d2b79f5) | 0;
    let t = Math.imul(a ^ (a >>> 15), 1 | a);
    t = (t + Math.imul(t ^ (t >>> 7), 61 | t)) ^ t;
    return (t ^ (t >>> 14)) >>> 0;
  };
  // Uniform in [0, n): exact for n < 2^21, matching (x * n) >> 32 in Rust.
  return { int: (n) => Math.floor((next() * n) / 4294967296) };
}

// ---- what was granted, in order: the fairness guard ----

const ACQ_GRANTED = 1 << 28;
const ACQ_QUEUED = 2 << 28;
const REL_GRANT = 3 << 28;
const REL_END = 4 << 28;

class GrantLog {
  constructor() {
    this.values = [];
    this.hash = 2166136261;
  }
  add(v) {
    this.values.push(v);
    this.hash = Math.imul(this.hash ^ v, 16777619) >>> 0;
  }
  acquired(op, granted) {
    this.add((granted ? ACQ_GRANTED : ACQ_QUEUED) | op);
  }
  released(op, msgs) {
    for (const m of msgs) this.add(REL_GRANT | m.op);
    this.add(REL_END | op);
  }
}

// ---- the implementations, each wrapped as a node holds it ----

class BaselineNode {
  constructor(resources) {
    this.il = new BaselineInterlock(resources);
    this.pending = new Map();
  }
  op(id) {
    return id;
  }
  set(names) {
    return names;
  }
  acquire(op, priority, set, msg) {
    if (this.il.acquire(op, set, priority, msg._msgId, Date.now()) !== null) return true;
    this.pending.set(msg._msgId, msg);
    return false;
  }
  release(op) {
    const granted = this.il.release(op, Date.now());
    const msgs = [];
    for (const id of granted) {
      msgs.push(this.pending.get(id));
      this.pending.delete(id);
    }
    return msgs;
  }
  drain() {}
  free() {}
}

let Interlock;
let Engine;
let Wire;

// The release node's handle; acquire nodes take 2, 3, ... (one per operation at case scale).
const RELEASE_NODE = 1;
// At large scale each msg names its operation, priority and lines: one acquire node reads them.
const NAMED_NODE = 2;
const HANDLES = 2 ** 32;

/**
 * The interlock as the nodes run it: the core Engine, one call per msg, its
 * outputs read from the typed wire. `configured`: one acquire node per
 * operation with its operation, priority and lines deployed (the case-study
 * flows); otherwise one node to which each msg names them.
 */
class EngineNode {
  constructor(resources, { queueBound = 1024, named = false } = {}) {
    const configured = !named;
    this.e = new Engine({ resources: resources.map((name) => ({ name })), queueBound }, {});
    this.wire = new Wire(this.e);
    this.configured = configured;
    this.names = [];
    this.nodes = [];
    this.nextNode = NAMED_NODE + 1;
    this.nextMsg = 1;
    // Held msgs by handle; the one held last apart, as the carrier keeps it (engine-carrier.js).
    this.held = new Map();
    this.lastKey = -1;
    this.last = null;
    this.granted = [];
    this.answered = null;
    this.refused = null;
    this.shown = [0, 0, 0];
    this.call((e) => e.addNode(RELEASE_NODE, { kind: 'release' }, Date.now()));
    if (!configured) this.call((e) => e.addNode(NAMED_NODE, { kind: 'acquire', timeoutMs: 0 }, Date.now()));
    this.call((e) => e.start(null, undefined, Date.now()));
  }
  call(fn) {
    fn(this.e);
    this.wire.read(this);
  }
  op(id, name) {
    this.names[id] = name;
    return id;
  }
  set(names) {
    return names;
  }
  hold(k, msg) {
    if (this.lastKey !== -1) this.held.set(this.lastKey, this.last);
    this.lastKey = k;
    this.last = msg;
  }
  take(k) {
    if (k === this.lastKey) {
      const msg = this.last;
      this.lastKey = -1;
      this.last = null;
      return msg;
    }
    const msg = this.held.get(k);
    this.held.delete(k);
    return msg;
  }
  /** A msg in, held under a new handle; its handle, for the call. */
  admit(msg) {
    const k = this.nextMsg;
    this.nextMsg = (this.nextMsg + 1) % HANDLES;
    this.hold(k, msg);
    this.answered = null;
    this.refused = null;
    // Setting an array's length is a V8 runtime call: only when something was left.
    if (this.granted.length !== 0) this.granted.length = 0;
    return k;
  }
  /** The call's outputs, read; the msg's own answer, if it came in this call. */
  answer() {
    this.wire.read(this);
    if (this.refused) fail(`engine refused a msg: ${JSON.stringify(this.refused)}`);
    return this.answered;
  }
  acquire(op, priority, set, msg) {
    let node = this.nodes[op];
    if (node === undefined && this.configured) {
      node = this.nextNode++;
      this.nodes[op] = node;
      const spec = { kind: 'acquire', timeoutMs: 0, operation: this.names[op], priority, resources: set.join(',') };
      this.call((e) => e.addNode(node, spec, Date.now()));
    }
    const k = this.admit(msg);
    if (this.configured) this.e.acquire(node, k, Date.now());
    else this.e.acquireNamed(NAMED_NODE, k, this.names[op], priority, set, Date.now());
    return this.answer() === msg;
  }
  release(op) {
    // The msg that went through the acquire node: the release follows msg.interlock.
    const msg = { _msgId: `release-${op}`, interlock: { operation: this.names[op] } };
    const k = this.admit(msg);
    this.e.releaseTexts(RELEASE_NODE, k, undefined, msg.interlock.operation, Date.now());
    this.answer();
    return this.granted.slice();
  }
  drain() {}
  free() {
    this.e.free();
  }
  // ---- the wire's visitor: what the carrier does with each output ----
  commit() {}
  after() {}
  send(k, port, set) {
    const msg = this.take(k);
    if (!msg) return;
    if (set && set.kind === 'interlock') {
      msg.interlock = { operation: set.operation, priority: set.priority, resources: set.resources, waitedMs: set.waitedMs };
      if (msg.op !== undefined) this.granted.push(msg);
    }
    if (k === this.nextMsg - 1) this.answered = msg;
  }
  emit() {}
  complete(k, refusal) {
    this.take(k);
    if (refusal) this.refused = refusal;
  }
  counts(holding, queued, faulted) {
    this.shown[0] = holding;
    this.shown[1] = queued;
    this.shown[2] = faulted;
  }
  other() {}
}

class WasmNode {
  constructor(resources, { recordEvents = false, queueBound = 1024 } = {}) {
    this.il = new Interlock({ resources: resources.map((name) => ({ name })), queueBound, recordEvents });
    this.recordEvents = recordEvents;
    this.pending = new Map();
    this.names = [];
    this.handles = [];
    this.epoch = this.il.handleEpoch();
  }
  op(id, name) {
    this.names[id] = name;
    this.handle(id);
    return id;
  }
  /** The core's handle of operation `id`, asked again once the core forgot idle names (as the nodes do). */
  handle(id) {
    let handle = this.handles[id];
    if (handle === undefined) {
      handle = this.il.operation(this.names[id]);
      if (this.il.handleEpoch() !== this.epoch) {
        this.epoch = this.il.handleEpoch();
        this.handles = [];
      }
      this.handles[id] = handle;
    }
    return handle;
  }
  set(names) {
    return this.il.resourceSet(names);
  }
  acquire(op, priority, set, msg) {
    const handle = this.handle(op);
    if (this.il.acquire(handle, priority, set, Date.now())) return true;
    this.pending.set(handle, msg);
    return false;
  }
  release(op) {
    const count = this.il.release(this.handle(op), Date.now());
    const msgs = [];
    for (let i = 0; i < count; i++) {
      const h = this.il.granted(i);
      msgs.push(this.pending.get(h));
      this.pending.delete(h);
    }
    return msgs;
  }
  drain() {
    if (this.recordEvents) this.il.drainEvents();
  }
  free() {
    this.il.free();
  }
}

// ---- measuring ----

const now = () => process.hrtime.bigint();

function summary(samples) {
  const s = Float64Array.from(samples).sort();
  const rank = (q) => s[Math.max(0, Math.ceil(q * s.length) - 1)];
  return { median: rank(0.5), p99: rank(0.99), samples: s.length };
}

function swapRemove(array, index) {
  const last = array.pop();
  if (index < array.length) array[index] = last;
}

function fail(message) {
  console.error(`interlock-bench: ${message}`);
  process.exit(1);
}

/**
 * Case pair for every implementation, their batches interleaved (the order
 * rotating each sample), so JIT warm-up, GC and a noisy neighbour fall on
 * all of them alike instead of on whichever row ran first.
 */
function runCasePairs(makers) {
  const P = PARAMS.case;
  const runs = makers.map((make) => {
    const node = make(LINES);
    const ops = FIG8.map(([id, priority, lines], i) => ({
      op: node.op(i, `op${id}`),
      priority,
      set: node.set(lines),
      msg: { _msgId: `pair-${id}`, op: i },
    }));
    return { node, ops, samples: [], refused: 0, stray: 0 };
  });
  for (let s = 0; s < P.warmup + P.samples; s++) {
    for (let k = 0; k < runs.length; k++) {
      const run = runs[(s + k) % runs.length];
      const { node, ops } = run;
      const t0 = now();
      for (let b = 0; b < P.pairBatch; b++) {
        const o = ops[b % 16];
        if (!node.acquire(o.op, o.priority, o.set, o.msg)) run.refused++;
        run.stray += node.release(o.op).length;
      }
      const t1 = now();
      if (s >= P.warmup) run.samples.push(Number(t1 - t0) / P.pairBatch);
      node.drain();
    }
  }
  return runs.map((run) => {
    run.node.free();
    if (run.refused || run.stray) fail(`case pair: ${run.refused} acquires queued and ${run.stray} stray grants on an idle interlock`);
    return summary(run.samples);
  });
}

/**
 * The floor under any implementation of the case pair: its two clock reads
 * (one Date.now() per call, as every row makes them and as the core needs
 * each input's time), with nothing else. Its own loop, so the rows' call
 * sites see no fifth implementation.
 */
function runClockFloor() {
  const P = PARAMS.case;
  const samples = [];
  let sink = 0;
  for (let s = 0; s < P.warmup + P.samples; s++) {
    const t0 = now();
    for (let b = 0; b < P.pairBatch; b++) {
      sink += Date.now();
      sink -= Date.now();
    }
    const t1 = now();
    if (s >= P.warmup) samples.push(Number(t1 - t0) / P.pairBatch);
  }
  if (Number.isNaN(sink)) fail('clock floor: Date.now() read NaN');
  return summary(samples);
}

function runCase(makeNode) {
  const P = PARAMS.case;
  const random = rng(P.seed);
  const log = new GrantLog();

  const n = P.instances;
  const nodes = [];
  const ops = [];
  const holders = [];
  for (let i = 0; i < n; i++) {
    const node = makeNode(LINES);
    nodes.push(node);
    ops.push(
      FIG8.map(([id, priority, lines], k) => ({
        op: node.op(k, `op${id}`),
        priority,
        set: node.set(lines),
        msg: { _msgId: `${i}-${id}`, op: k },
      })),
    );
    holders.push([]);
    for (const o of ops[i]) {
      const granted = node.acquire(o.op, o.priority, o.set, o.msg);
      log.acquired(o.op, granted);
      if (granted) holders[i].push(o.op);
    }
  }
  const release = [];
  const victimIndex = new Int32Array(n);
  const victim = new Int32Array(n);
  const results = new Array(n);
  let waiting = 0;
  for (let s = 0; s < P.warmup + P.samples; s++) {
    for (let i = 0; i < n; i++) {
      victimIndex[i] = random.int(holders[i].length);
      victim[i] = holders[i][victimIndex[i]];
      waiting += 16 - holders[i].length;
    }
    const t0 = now();
    for (let i = 0; i < n; i++) results[i] = nodes[i].release(victim[i]);
    const t1 = now();
    if (s >= P.warmup) release.push(Number(t1 - t0) / n);
    for (let i = 0; i < n; i++) {
      const h = holders[i];
      swapRemove(h, victimIndex[i]);
      log.released(victim[i], results[i]);
      for (const m of results[i]) h.push(m.op);
      const o = ops[i][victim[i]];
      const granted = nodes[i].acquire(o.op, o.priority, o.set, o.msg);
      log.acquired(o.op, granted);
      if (granted) h.push(o.op);
      nodes[i].drain();
    }
  }
  for (const node of nodes) node.free();
  return {
    release: summary(release),
    log,
    waitingAvg: waiting / ((P.warmup + P.samples) * n),
  };
}

function runLarge(makeNode) {
  const P = PARAMS.large;
  const random = rng(P.seed);
  const log = new GrantLog();
  const names = Array.from({ length: P.resources }, (_, r) => `r${r}`);
  const node = makeNode(names, { queueBound: P.queueBound, named: true });

  // Resource sets are drawn from a pool resolved up front, as a node resolves its sets at deploy.
  const pool = [];
  for (let k = 0; k < P.pool; k++) {
    const size = 1 + random.int(P.maxSet);
    const ids = [];
    while (ids.length < size) {
      const r = random.int(P.resources);
      if (!ids.includes(r)) ids.push(r);
    }
    pool.push({ ids, set: node.set(ids.map((r) => names[r])) });
  }
  const singles = names.map((name) => node.set([name]));

  const owner = new Int32Array(P.resources).fill(-1);
  const priority = [];
  const msg = [];
  const opSet = [];
  const holders = [];
  let queued = 0;
  const take = (op) => {
    holders.push(op);
    for (const r of pool[opSet[op]].ids) owner[r] = op;
  };
  const acquire = (op) => {
    const granted = node.acquire(op, priority[op], pool[opSet[op]].set, msg[op]);
    log.acquired(op, granted);
    if (granted) take(op);
    else queued++;
  };
  const register = (p) => {
    const op = priority.length;
    node.op(op, `op${op}`);
    priority.push(p);
    msg.push({ _msgId: `m${op}`, op });
    opSet.push(-1);
    return op;
  };
  const newOp = () => {
    const op = register(1 + random.int(P.priorities));
    opSet[op] = random.int(P.pool);
    acquire(op);
  };

  const probe = register(0);
  while (queued < P.waiting) newOp();
  const filled = { operations: priority.length - 1, holding: holders.length };

  const release = [];
  const pair = [];
  const free = [];
  let grants = 0;
  let waitingMin = Infinity;
  let waitingMax = 0;
  for (let s = 0; s < P.warmup + P.samples; s++) {
    const index = random.int(holders.length);
    const victim = holders[index];
    waitingMin = Math.min(waitingMin, queued);
    waitingMax = Math.max(waitingMax, queued);
    let t0 = now();
    const result = node.release(victim);
    let t1 = now();
    if (s >= P.warmup) release.push(Number(t1 - t0));
    swapRemove(holders, index);
    for (const r of pool[opSet[victim]].ids) owner[r] = -1;
    log.released(victim, result);
    for (const m of result) take(m.op);
    queued -= result.length;
    grants += result.length;
    opSet[victim] = random.int(P.pool);
    acquire(victim);
    while (queued < P.waiting) newOp();
    node.drain();

    free.length = 0;
    for (let r = 0; r < P.resources; r++) if (owner[r] === -1) free.push(r);
    if (free.length === 0) continue;
    const set = singles[free[random.int(free.length)]];
    t0 = now();
    const granted = node.acquire(probe, 0, set, msg[probe]);
    const stray = node.release(probe);
    t1 = now();
    if (!granted || stray.length) fail('large pair: the probe was refused a free resource or its release granted');
    if (s >= P.warmup) pair.push(Number(t1 - t0));
    node.drain();
  }
  node.free();
  return {
    pair: summary(pair),
    release: summary(release),
    log,
    filled,
    operations: priority.length - 1,
    waiting: [waitingMin, waitingMax],
    grantsPerRelease: grants / (P.warmup + P.samples),
  };
}

// ---- native ----

function runNative() {
  const args = ['run', '--release', '-q', '-p', 'sugarshack-core', '--example', 'interlock_bench', '--'];
  args.push(JSON.stringify(PARAMS));
  if (argv.has('--no-events')) args.push('--no-events');
  const run = spawnSync('cargo', args, { cwd: ROOT, encoding: 'utf8', stdio: ['ignore', 'pipe', 'inherit'] });
  if (run.status !== 0) fail(`native example failed (exit ${run.status})`);
  return run.stdout
    .split('\n')
    .filter((line) => line.startsWith('{'))
    .map((line) => JSON.parse(line));
}

// ---- report ----

function time(ns) {
  if (ns < 1e3) return `${ns.toFixed(0)} ns`;
  if (ns < 1e6) return `${(ns / 1e3).toFixed(2)} us`;
  return `${(ns / 1e6).toFixed(2)} ms`;
}

function speedup(base, x) {
  return `${(base / x).toPrecision(3)}x`;
}

function timerOverhead() {
  const s = [];
  for (let i = 0; i < 20000; i++) {
    const t0 = now();
    const t1 = now();
    s.push(Number(t1 - t0));
  }
  return summary(s).median;
}

function main() {
  try {
    ({ Interlock, Engine } = require(WASM_LOADER).load());
    ({ Wire } = require(WIRE));
  } catch (err) {
    fail(`cannot load the wasm package through ${path.relative(ROOT, WASM_LOADER)} (build it: npm run build): ${err.message}`);
  }
  const load = os.loadavg()[0];
  const native = argv.has('--no-native') ? [] : runNative();

  const impls = [
    { impl: 'baseline JS', events: false, make: (r, o) => new BaselineNode(r, o) },
    // Case scale: an acquire node per operation, as deployed; large scale: each msg names its operation, priority and lines.
    { impl: 'engine', events: false, make: (r, o) => new EngineNode(r, o) },
    { impl: 'facade', events: false, make: (r, o) => new WasmNode(r, { ...o, recordEvents: false }) },
  ];
  if (!argv.has('--no-events')) {
    impls.push({ impl: 'facade', events: true, make: (r, o) => new WasmNode(r, { ...o, recordEvents: true }) });
  }

  const rows = [];
  const details = {};
  const casePairs = runCasePairs(impls.map(({ make }) => make));
  const clockFloor = runClockFloor();
  for (const [scale, run] of [
    ['case', runCase],
    ['large', runLarge],
  ]) {
    for (const [k, { impl, events, make }] of impls.entries()) {
      const r = run(make);
      if (scale === 'case') r.pair = casePairs[k];
      rows.push({ scale, impl, events, ...r });
      if (impl === 'baseline JS') details[scale] = r;
    }
    for (const n of native.filter((x) => x.scale === scale)) {
      rows.push({
        scale,
        impl: 'native',
        events: n.events,
        pair: n.pair,
        release: n.release,
        log: { hash: n.log.hash, values: { length: n.log.count } },
      });
    }
  }

  // Fairness guard: every implementation must have granted the same operations in the same order.
  for (const scale of ['case', 'large']) {
    const base = rows.find((r) => r.scale === scale && r.impl === 'baseline JS').log;
    for (const r of rows.filter((x) => x.scale === scale && x.impl !== 'baseline JS')) {
      if (r.log.hash === base.hash && r.log.values.length === base.values.length) continue;
      let at = '';
      if (Array.isArray(r.log.values)) {
        const i = base.values.findIndex((v, k) => v !== r.log.values[k]);
        at = ` first difference at entry ${i}: baseline ${base.values[i]?.toString(16)}, ${r.impl} ${r.log.values[i]?.toString(16)}`;
      }
      fail(`${scale}: ${r.impl}${r.events ? ' (events on)' : ''} diverged from the baseline (${r.log.values.length} vs ${base.values.length} entries, hash ${r.log.hash} vs ${base.hash});${at}`);
    }
  }

  const c = PARAMS.case;
  const l = PARAMS.large;
  const d = details.large;
  const out = [];
  out.push(`interlock benchmark: node ${process.version}, ${os.cpus().length} cores (${os.cpus()[0].model.trim()}), load average ${load.toFixed(2)} at start`);
  out.push(`policy greedy; event recording OFF unless the row says "events on"; timer overhead ~${timerOverhead().toFixed(0)} ns per reading (not subtracted)`);
  out.push(`case : 5 lines, the 16 Fig. 8 operations. pair = acquire+release on an idle interlock; release = one holder of each of ${c.instances} interlocks with all 16 started (avg ${details.case.waitingAvg.toFixed(1)} waiting). Per call, from batches of ${c.pairBatch}/${c.instances} calls: median and p99 over ${c.samples} batch means`);
  out.push(`large: ${l.resources} resources, sets of 1-${l.maxSet}, priorities 1-${l.priorities}; filled with ${d.filled.operations} operations (${d.filled.holding} holding, ${l.waiting} waiting); ${d.operations} operations by the end, ${d.waiting[0]}-${d.waiting[1]} waiting at each release, ${d.grantsPerRelease.toFixed(2)} grants per release. Each call timed alone over ${l.samples} steps; pair = probe acquire+release of a free resource (${d.pair.samples} steps had one)`);
  out.push('engine = the core Engine as the nodes call it (one call per msg with Date.now(), outputs read from the typed wire, held msg taken by handle, msg.interlock set; no state write)');
  out.push('facade = the raw Interlock facade by handle (no node calls it so: the core through wasm without the engine); native = core called directly from Rust');
  const compared = [...new Set(rows.map((r) => r.impl.replace(' JS', '')))].join(', ');
  out.push(`consistency: ${compared} granted the same operations in the same order (case ${details.case.log.values.length} log entries, large ${d.log.values.length})`);
  out.push('');

  const header = ['scale', 'impl', 'pair median', 'pair p99', 'release median', 'release p99', 'pair vs baseline', 'release vs baseline'];
  const table = [header];
  for (const r of rows) {
    const base = rows.find((x) => x.scale === r.scale && x.impl === 'baseline JS');
    table.push([
      r.scale,
      r.impl + (r.events ? ' (events on)' : ''),
      time(r.pair.median),
      time(r.pair.p99),
      time(r.release.median),
      time(r.release.p99),
      r === base ? '1x' : speedup(base.pair.median, r.pair.median),
      r === base ? '1x' : speedup(base.release.median, r.release.median),
    ]);
  }
  const widths = header.map((_, k) => Math.max(...table.map((row) => row[k].length)));
  const line = (row) => row.map((cell, k) => (k < 2 ? cell.padEnd(widths[k]) : cell.padStart(widths[k]))).join(' | ');
  out.push(line(table[0]));
  out.push(widths.map((w) => '-'.repeat(w)).join('-|-'));
  for (const row of table.slice(1)) out.push(line(row));
  out.push('(ratios: baseline median / impl median; above 1x is faster than the baseline)');
  out.push('');

  const get = (scale, impl) => rows.find((r) => r.scale === scale && r.impl === impl && !r.events);
  const verdict = (ok) => (ok ? 'PASS' : 'MISS');
  const bc = get('case', 'baseline JS');
  const ec = get('case', 'engine');
  const bl = get('large', 'baseline JS');
  const el = get('large', 'engine');
  const nl = get('large', 'native');
  out.push('targets:');
  for (const [metric, name] of [
    ['pair', 'acquire+release'],
    ['release', 'release re-evaluation'],
  ]) {
    // Case scale, where most plants live: at least 2x the baseline through the engine, as the nodes call it.
    const x = bc[metric].median / ec[metric].median;
    out.push(`  ${verdict(x >= 2)}  case, engine at least 2x the baseline (${name}): ${x.toPrecision(3)}x`);
  }
  // What 2x leaves for everything but the clock: the baseline spends its pair's two reads too.
  const budget = bc.pair.median / 2;
  out.push(
    `        2x needs a case pair in ${time(budget)}; its two Date.now() reads alone take ${time(clockFloor.median)} (median, ${clockFloor.samples} batches), leaving ${time(Math.max(0, budget - clockFloor.median))} for a wasm call each way, the held msg and the core`,
  );
  for (const [metric, name] of [
    ['pair', 'acquire+release'],
    ['release', 'release re-evaluation'],
  ]) {
    const x = bl[metric].median / el[metric].median;
    out.push(`  ${verdict(x >= 10)}  large, engine at least 10x faster than the baseline (${name}): ${x.toPrecision(3)}x`);
  }
  if (nl) {
    out.push(`  ${verdict(nl.release.p99 <= 50e3)}  large, native release re-evaluation p99 <= 50 us: ${time(nl.release.p99)}`);
  } else {
    out.push('  ----  large, native release re-evaluation p99 <= 50 us: native not run');
  }
  console.log(out.join('\n'));
}

main();
