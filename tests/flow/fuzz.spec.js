'use strict';
// A seeded, bounded fuzz of every node that takes msgs: a few hundred msgs per
// node type, with random values at every field the node reads (strings, huge
// strings, odd numbers, BigInt, null, arrays, nested objects, circular ones,
// getters that throw, Buffers, proxies, deep nesting) and random topics,
// device topics included. The seed is printed; FUZZ_SEED=<n> replays a run.
//
// Asserted: no uncaught exception and no wasm trap; every msg completes once
// (done, with or without an error) or is sent on; no error is INTERNAL or
// uncoded; the interlock's event log never shows two holders of a line nor a
// faulted line granted; and afterwards the interlock follows its rules.
const assert = require('node:assert/strict');
const path = require('path');
const { mulberry32 } = require('../../scripts/simulator/random');
const helper = require('node-red-node-test-helper');
const {
  PALETTE, paletteNodes, collect, until, startServer, stopServer, settled, clock,
} = require('./support');
const { SINKS, plantDocument: plantOf, everyNodeFlow } = require('./every-node');

const wasm = require(path.join(PALETTE, 'lib', 'wasm', 'index.js'));
const { hooks } = require('@node-red/util');

const { truckRoutine } = require('./fake-panel');

helper.init(require.resolve('node-red'));

const SEED = process.env.FUZZ_SEED !== undefined ? Number(process.env.FUZZ_SEED) >>> 0 : 0x5eed5ac5;
const ROUNDS = 40; // x PER_ROUND msgs per node type and round
const PER_ROUND = 5;

// ---- the plant ------------------------------------------------------------------

function plantDocument() {
  return plantOf({
    actuatorStaleMs: 600000, retries: 1, sensorStaleMs: 5000,
    operations: [
      { id: '10', priority: 20, resources: ['YEL'], steps: [{ command: { valves: { V101: 100 } }, timeoutMs: 8000 }] },
      { id: '18', priority: 90, resources: ['YEL', 'RED'], steps: [
        { command: { valves: { V102: 100, V501: 100 } }, timeoutMs: 8000 },
        { wait: '`LT-3` >= 100', sensors: ['LT-3'], timeoutMs: 3000 },
      ] },
    ],
    routines: [truckRoutine(
      { from: 'full', to: 'empty', operation: '18', trigger: { msg: 'unload' } },
      { from: 'fault', to: 'empty', operation: '10', trigger: { when: '`LT-3` < 50', sensors: ['LT-3'], everyMs: 1000 } },
    )],
  });
}

/** A line's lockout as a fault node words it: each member actuator at its lockout state. */
function lockoutOf(line) {
  const command = {};
  for (const a of plantDocument().actuators.filter((x) => x.resource === line)) {
    const group = `${a.type}s`;
    command[group] = { ...command[group], [a.id]: a.lockout };
  }
  return command;
}

// The node each kind of msg goes to.
const TARGETS = {
  acquire: 'acq', release: 'rel', fault: 'flt', estop: 'stop', clear: 'clr', cancel: 'cnl', group: 'gc',
  actuators: 'bus', operation: 'op', wait: 'wt', routine: 'rt', pid: 'pid', rcc: 'rcc', rccio: 'io',
};

const flow = () => everyNodeFlow(plantDocument(), {
  gc: { timeout: 10 },
  acq: { timeout: 30 },
  stop: { resources: 'GRN' },
  wt: { timeout: 5 },
  pid: { fallback: '5', smith: 'adaptive', maxSamples: '50' },
  rcc: { controller: '2' },
  io: { periodS: '0.5' },
});

// ---- seeded random msgs -----------------------------------------------------------


// Shared big values: strings are immutable and no node changes a nested value.
const HUGE = 'x'.repeat(1000000);
let DEEP = [];
for (let i = 0; i < 10000; i++) DEEP = [DEEP];
let DEEP_OBJECT = { end: true };
for (let i = 0; i < 3000; i++) DEEP_OBJECT = { valves: DEEP_OBJECT };
const DEEP_TEXT = `${'['.repeat(20000)}${']'.repeat(20000)}`;

const KEYS = ['valves', 'pumps', 'valve', 'pump', 'V101', 'V501', 'P1', '1', '5', 'ts', 'value', 'kp', 'ti', 'td', 'min', 'max',
  'procVar', 'lastAction', 'agesMs', 'operation', 'resources', 'message', 'id', 'engaged', 'firstCycle', 'track', '__proto__', 'toJSON'];

class Gen {
  constructor(seed) {
    this.rand = mulberry32(seed);
    this.shape = []; // what was generated, to show two runs of a seed make the same msgs
  }

  int(n) {
    return Math.floor(this.rand() * n);
  }

  pick(list) {
    return list[this.int(list.length)];
  }

  chance(p) {
    return this.rand() < p;
  }

  text() {
    const alphabet = 'abcXYZ019 ,/-_.é€\u0000\n"\'{}[]';
    let s = '';
    for (let i = this.int(12); i > 0; i--) s += alphabet[this.int(alphabet.length)];
    return s;
  }

  /** A value of any kind, hostile more often than not. */
  any(depth = 0) {
    const kind = this.pick(['string', 'string', 'huge', 'number', 'number', 'bigint', 'null', 'undefined', 'bool', 'array', 'object',
      'object', 'circular', 'getter', 'buffer', 'deep', 'proxy', 'function', 'symbol', 'date']);
    this.shape.push(kind);
    switch (kind) {
      case 'string': return this.text();
      case 'huge': return HUGE.slice(0, this.pick([70000, 300000, 1000000]));
      case 'number': return this.pick([0, -0, 1, -1, 7, 42, 0.5, 1e308, -1e308, NaN, Infinity, -Infinity, 2 ** 31, -(2 ** 31) - 1, 2 ** 53 + 2, Number.MIN_VALUE, this.int(200)]);
      case 'bigint': return this.pick([0n, 10n, 2n ** 70n, -5n]);
      case 'null': return null;
      case 'undefined': return undefined;
      case 'bool': return this.chance(0.5);
      case 'array': return depth > 2 ? [] : Array.from({ length: this.int(4) }, () => this.any(depth + 1));
      case 'object': {
        const o = {};
        // Own data properties, "__proto__" included (as JSON.parse would make it).
        if (depth <= 2) {
          for (let i = this.int(4); i > 0; i--) {
            Object.defineProperty(o, this.pick(KEYS), { value: this.any(depth + 1), enumerable: true, writable: true, configurable: true });
          }
        }
        return o;
      }
      case 'circular': {
        const o = { [this.pick(KEYS)]: 1 };
        o[this.pick(KEYS.filter((k) => k !== '__proto__'))] = o;
        o.list = [o];
        return o;
      }
      case 'getter': {
        const o = {};
        const key = this.pick(KEYS);
        Object.defineProperty(o, key, { enumerable: true, get() { throw new Error(`getter ${key} throws`); } });
        return o;
      }
      case 'buffer': return Buffer.from(this.pick(['{"valves":{"V101":100}}', 'online', '{"ts":0,"value":120}', this.text(), '\u00ff\u00fe']));
      case 'deep': return this.pick([DEEP, DEEP_OBJECT, DEEP_TEXT]);
      case 'proxy': {
        if (this.chance(0.5)) {
          const { proxy, revoke } = Proxy.revocable({}, {});
          revoke();
          return proxy;
        }
        const target = this.chance(0.5) ? [] : {};
        return new Proxy(target, { get(t, key) { if (typeof key === 'symbol') return t[key]; throw new Error(`proxy get ${String(key)}`); } });
      }
      case 'function': return () => 1;
      case 'symbol': return Symbol('s');
      default: return new Date(this.int(2e12));
    }
  }

  /** A sane value from `pool` (a function of the generator) or any value. */
  value(pool, saneShare = 0.55) {
    if (pool && this.chance(saneShare)) {
      this.shape.push('sane');
      return pool(this);
    }
    return this.any();
  }
}

const now = () => clock().now();
const OPS = ['a', 'b', 'c', 'd', 'e', '10', '18', ' a ', '', 'op-1'];
const LINES = ['YEL', 'RED', 'GRN', 'YEL,RED', 'RED, GRN', ['YEL'], ['GRN', 'RED'], 'BLU', '', [], ['YEL', 'YEL'], 'YEL,,RED'];
const GROUPS = [
  { valves: { V101: 100 } }, { valves: { V501: 0 } }, { pumps: { P1: true } }, { valves: { V201: 50, V501: 100 } },
  '{"valves":{"V201":100}}', {}, { valves: {} }, { valves: { V999: 1 } }, { valves: { V101: 150 } }, { pumps: { P1: 'on' } },
  { valves: { V101: 0, V102: 0 }, pumps: { P1: false } }, { valve: { V201: 0 } },
];
const sensorValue = (g) => ({ ts: g.pick([now(), now() - 3600000, now() + 60000, 9e15, 0, -5]), value: g.pick([0, 20, 60, 120, 300, NaN, '7']) });
const DEVICE_TOPICS = [
  'ctrl-1/state', 'ctrl-1/state', 'ctrl-1/valve/1/state', 'ctrl-1/valve/5/state', 'ctrl-1/valve/7/state', 'ctrl-1/pump/1/state',
  'ctrl-1/status', 'station-3/sensor/volume/state', 'station-3/sensor/volume/state', 'station-3/sensor/other/state',
  'station-3/status', 'ctrl-9/state', 'ctrl-1/telemetry', 'ctrl-1/valve/1/command', 'lockout/YEL', 'lockout/RED', 'lockout/',
  '/state', 'ctrl-1/', 'plant/command', 'x',
];
function devicePayload(g, topic) {
  if (topic.endsWith('/status')) return g.pick(['online', 'online', 'offline', Buffer.from('online'), 'maybe']);
  if (topic.includes('/sensor/')) return g.pick([sensorValue(g), JSON.stringify(sensorValue(g))]);
  if (topic.endsWith('/state') && topic.split('/').length === 2) {
    const batch = { ts: g.pick([now(), now(), now() - 3600000, now() + 60000]), valve: { 1: g.int(101), 5: g.pick([0, 100, 50]) }, pump: { 1: g.chance(0.5) } };
    return g.pick([batch, JSON.stringify(batch), Buffer.from(JSON.stringify(batch))]);
  }
  if (topic.endsWith('/state')) return g.pick([{ ts: now(), value: g.pick([0, 100, 1, 0.5, true]) }, '{"ts":1,"value":3}', 42]);
  return g.pick(GROUPS);
}
const INTERLOCKS = (g) => g.pick([{ operation: g.pick(OPS), resources: ['YEL'] }, { resources: ['RED'] }, { operation: 'a' }, { resources: 'YEL' }, null, 'x', { resources: ['YEL', 'RED', 'GRN'] }]);

// The fields each node reads, with a pool of sane values for each.
const FIELDS = {
  acquire: { operation: (g) => g.pick(OPS), priority: (g) => g.pick([0, 1, 5, 20, -3, '7', ' 12 ', 2147483647, -2147483648]), resources: (g) => g.pick(LINES) },
  release: { operation: (g) => g.pick(OPS), interlock: INTERLOCKS },
  fault: { operation: (g) => g.pick(OPS), interlock: INTERLOCKS, error: (g) => g.pick([{ message: 'pump ran dry' }, { message: '' }, 'text', { message: g.any() }]), payload: (g) => g.pick(['e-stop', '', 5]) },
  estop: { resources: (g) => g.pick(LINES), error: (g) => g.pick([{ message: 'leak' }, { message: g.any() }]), payload: (g) => g.pick(['e-stop', 5]) },
  clear: { resources: (g) => g.pick(LINES) },
  cancel: { operation: (g) => g.pick(OPS), interlock: INTERLOCKS },
  group: { payload: (g) => g.pick(GROUPS), topic: (g) => g.pick(['a', 'lockout/YEL', 'lockout/RED', 'ctrl-1/state']), lockout: (g) => g.pick([true, false, 'true']), interlock: INTERLOCKS },
  actuators: { topic: (g) => g.pick(DEVICE_TOPICS), payload: (g) => g.pick(GROUPS), lockout: (g) => g.pick([true, false]), interlock: INTERLOCKS },
  operation: { topic: (g) => g.text(), payload: (g) => g.text() },
  wait: { topic: (g) => g.text(), payload: (g) => g.text() },
  routine: { topic: (g) => g.pick(['load', 'unload', 'reset', 'go', '', 7]) },
  pid: {
    topic: (g) => g.pick(['setpoint', 'measurement', 'x']),
    payload: (g) => g.pick([40, 50, 55.5, 0, NaN, '40', null]),
    setpoint: (g) => g.pick([50, 40, '50', NaN]),
    mode: (g) => g.pick(['auto', 'manual', 'x']),
    manual: (g) => g.pick([10, 200, null]),
    tunings: (g) => g.pick([{ kp: 1 }, { kp: 2, ti: 5, td: 0 }, { ti: 0 }, { kp: -1 }]),
    limits: (g) => g.pick([{ min: 0, max: 100 }, { min: 50, max: 10 }, { max: 80 }]),
    roundTripMs: (g) => g.pick([100, 1500, -1, 0]),
    rcc: (g) => g.pick([{ id: 1, engaged: true, firstCycle: false, track: null }, { engaged: false, firstCycle: true, track: 5 }, { engaged: 'yes' }]),
    track: (g) => g.pick([5, 50]),
    timestamp: (g) => g.pick([now(), now() + 100, 0, -1]),
  },
  rcc: {
    payload: (g) => g.pick([
      { procVar: 40, lastAction: 10, agesMs: [null, null] }, { procVar: 41, lastAction: 12, agesMs: [150, 20] },
      { procVar: 41, lastAction: 12, agesMs: [250, null] }, { agesMs: [1] }, { procVar: 1, lastAction: 1, agesMs: [-1, 1e308] },
    ]),
  },
  rccio: {
    topic: (g) => g.pick(['measurement', 'write', '']),
    payload: (g) => g.pick([5, 42.5, 'n/a', NaN]),
    controller: (g) => g.pick([1, 2, 3, 0, 1.5]),
    rcc: (g) => g.pick([{ id: 1 }, { id: 2, engaged: true }]),
  },
};

// How often a field gets a sane value: more for the interlock's nodes, so that operations get granted, queue and fault.
const SANE_SHARE = { acquire: 0.75, release: 0.75, cancel: 0.7, fault: 0.6, clear: 0.6 };
// How often a field is there at all.
const PRESENT = { acquire: 0.85, release: 0.85, cancel: 0.85, fault: 0.8 };

// Node-RED itself reads msg.error (and its source) when a node reports an error: a hostile
// msg.error there would test Node-RED, not the palette. Hostile values go inside it.
const NOT_A_GETTER = new Set(['error']);

let serial = 0;

/** One msg for node kind `kind`: some of the fields it reads, sane or not, sometimes as a throwing getter or a proxy msg. */
function msgFor(g, kind) {
  const msg = {};
  const fields = FIELDS[kind];
  for (const [field, pool] of Object.entries(fields)) {
    if (!g.chance(PRESENT[kind] || 0.6)) continue;
    if (!NOT_A_GETTER.has(field) && g.chance(0.05)) {
      g.shape.push(`getter:${field}`);
      Object.defineProperty(msg, field, { enumerable: true, configurable: true, get() { throw new Error(`msg.${field} refuses to be read`); } });
      continue;
    }
    // msg.error stays a plain object or a primitive (see NOT_A_GETTER); its message may be anything.
    let value;
    if (field === 'error') value = g.chance(0.5) ? { message: g.any() } : pool(g);
    else value = g.value(pool, SANE_SHARE[kind] || 0.55);
    if (field === 'topic' && kind === 'actuators' && typeof value === 'string' && DEVICE_TOPICS.includes(value) && g.chance(0.5)) {
      msg.payload = devicePayload(g, value);
    }
    if (field === 'payload' && kind === 'actuators' && Object.prototype.hasOwnProperty.call(msg, 'payload')) continue;
    msg[field] = value;
  }
  // Nodes that do not read the topic get one anyway, a device's included.
  if (!('topic' in fields) && g.chance(0.3)) msg.topic = g.chance(0.7) ? g.pick(DEVICE_TOPICS) : g.any();
  msg._msgid = `fz-${kind}-${serial++}`;
  if (g.chance(0.02)) {
    g.shape.push('proxy-msg');
    const target = msg;
    return new Proxy(target, {
      get(t, key) {
        if (key === '_msgid' || NOT_A_GETTER.has(key) || typeof key === 'symbol' || key in Object.prototype) return t[key];
        throw new Error(`the msg refuses ${String(key)}`);
      },
    });
  }
  return msg;
}

// ---- the interlock's event log ----------------------------------------------------

/** Replays interlock events: no line granted while another operation holds it or while it is faulted. */
function replay(events) {
  const lines = new Map(); // line -> { holder, faulted }
  const line = (r) => {
    if (!lines.has(r)) lines.set(r, { holder: null, faulted: false });
    return lines.get(r);
  };
  const violations = [];
  let grants = 0;
  for (const e of events) {
    const resources = e.resources || [];
    switch (e.kind) {
      case 'granted':
        grants++;
        for (const r of resources) {
          const l = line(r);
          if (l.holder !== null && l.holder !== e.operation) violations.push(`${r} granted to ${e.operation} while ${l.holder} held it`);
          if (l.faulted) violations.push(`${r} granted to ${e.operation} while faulted`);
          l.holder = e.operation;
        }
        break;
      case 'released':
        for (const r of resources) if (line(r).holder === e.operation) line(r).holder = null;
        break;
      case 'faulted':
      case 'resource-faulted':
      case 'interrupted':
      case 'state-unknown':
        for (const r of resources) Object.assign(line(r), { holder: null, faulted: true });
        break;
      case 'cleared':
        for (const r of resources) line(r).faulted = false;
        break;
      default:
    }
  }
  return { violations, grants, lines };
}

// ---- the test ---------------------------------------------------------------------

describe('sugarshack fuzz', function () {
  this.timeout(60000);
  let uncaught;
  const onUncaught = (err) => uncaught.push(err);

  beforeEach(function (done) {
    uncaught = [];
    process.on('uncaughtException', onUncaught);
    process.on('unhandledRejection', onUncaught);
    startServer(done);
  });

  afterEach(async function () {
    hooks.remove('*.sugarshack-fuzz');
    process.removeListener('uncaughtException', onUncaught);
    process.removeListener('unhandledRejection', onUncaught);
    await stopServer();
  });

  it('the same seed makes the same msgs', function () {
    const describeRun = () => {
      const g = new Gen(SEED);
      const saved = serial;
      serial = 0;
      const shapes = [];
      for (const kind of Object.keys(TARGETS)) for (let i = 0; i < 20; i++) shapes.push(Object.keys(msgFor(g, kind)).join(','));
      serial = saved;
      return JSON.stringify([shapes, g.shape]);
    };
    assert.equal(describeRun(), describeRun());
  });

  it(`every node type, ${ROUNDS * PER_ROUND} msgs each: one completion per msg, never INTERNAL, the interlock sound`, async function () {
    console.log(`      fuzz seed ${SEED} (FUZZ_SEED=${SEED} replays it)`);
    const started = Date.now();
    const completions = new Map(); // msgid -> [{ nodeId, error }]
    const sends = new Map(); // msgid -> [{ nodeId, msg }]
    hooks.add('onComplete.sugarshack-fuzz', (event) => {
      const id = event.msg && event.msg._msgid;
      if (typeof id !== 'string' || !id.startsWith('fz-')) return;
      if (!completions.has(id)) completions.set(id, []);
      completions.get(id).push({ nodeId: event.node.id, error: event.error });
    });
    hooks.add('onSend.sugarshack-fuzz', (events) => {
      for (const e of events) {
        const id = e.msg && e.msg._msgid;
        if (typeof id !== 'string' || !id.startsWith('fz-')) continue;
        if (!sends.has(id)) sends.set(id, []);
        sends.get(id).push({ nodeId: e.source.id, msg: e.msg });
      }
    });

    await helper.load(paletteNodes, flow());
    const seen = {};
    for (const id of SINKS) seen[id] = collect(helper, id);
    const il = () => helper.getNode('il').runtime;
    await until(() => il().state === 'ready' && helper.getNode('pl').runtime.state === 'ready', 'the runtimes ready');
    await settled(helper, 'il');
    const generation = wasm.currentGeneration();

    // A panel that obeys every command and reports at once.
    const positions = { valve: { 1: 0, 2: 0, 3: 0, 5: 0 }, pump: { 1: false } };
    const report = () => helper.getNode('bus')?.receive({ topic: 'ctrl-1/state', payload: { ts: now(), ...positions } });
    helper.getNode('mqtt').on('input', (m) => {
      const [, type, io] = String(m.topic).split('/');
      if (!(type in positions)) return;
      positions[type][io] = type === 'pump' ? m.payload === 'ON' : Number(m.payload);
      setImmediate(report);
    });
    report();

    const g = new Gen(SEED);
    const sent = []; // { kind, nodeId, msgid, msg }
    const thrown = [];
    for (let round = 0; round < ROUNDS; round++) {
      for (const [kind, nodeId] of Object.entries(TARGETS)) {
        for (let i = 0; i < PER_ROUND; i++) {
          const msg = msgFor(g, kind);
          const msgid = msg._msgid;
          sent.push({ kind, nodeId, msgid, msg });
          try {
            helper.getNode(nodeId).receive(msg);
          } catch (err) {
            thrown.push(`${msgid}: ${err && err.stack}`);
          }
        }
      }
      await settled(helper, 'il');
      await clock().advance(g.int(600));
    }

    // Drain: the devices online, faulted lines cleared, holders released, time for every timeout.
    const drain = (id, msg) => helper.getNode(id).receive({ ...msg, _msgid: `drain-${serial++}` });
    const open = () => sent.filter((s) => !completions.has(s.msgid) && !sends.has(s.msgid));
    for (let round = 0; round < 40; round++) {
      drain('bus', { topic: 'ctrl-1/status', payload: 'online' });
      drain('bus', { topic: 'station-3/sensor/volume/state', payload: { ts: now(), value: 120 } });
      report();
      const snapshot = il().core.snapshot(now());
      const faulted = snapshot.resources.filter((r) => r.state.state === 'faulted').map((r) => r.name);
      // A flow wires the fault nodes' lockouts to the actuators; here they reach a sink, so the
      // drain carries each faulted line's lockout to the panel before the clear asks it confirmed.
      for (const line of faulted) drain('bus', { topic: `lockout/${line}`, payload: lockoutOf(line) });
      if (faulted.length > 0) drain('clr', {});
      for (const hold of snapshot.holds) drain('rel', { operation: hold.operation });
      await settled(helper, 'il');
      await clock().advance(2000);
      await settled(helper, 'il');
      const quiet = il().core.snapshot(now());
      if (open().length === 0 && il().runs.size === 0 && quiet.holds.length === 0 && quiet.queue.length === 0
        && !quiet.resources.some((r) => r.state.state === 'faulted')) break;
    }

    // Every msg: exactly one completion (or sent on), never INTERNAL, always a coded error.
    assert.deepEqual(uncaught.map((e) => e && e.stack), [], 'no uncaught exception');
    assert.deepEqual(thrown, [], 'no exception out of receive');
    assert.equal(wasm.currentGeneration(), generation, 'no input made the wasm instance trap (or look as if it had)');
    const problems = [];
    const codes = new Map();
    for (const { kind, nodeId, msgid, msg } of sent) {
      const done = completions.get(msgid) || [];
      const out = sends.get(msgid) || [];
      if (done.length > 1) problems.push(`${msgid}: completed ${done.length} times`);
      if (done.length === 0 && out.length === 0) problems.push(`${msgid}: never completed nor sent`);
      // (Node-RED gives msgs sent along with it, a fault node's lockouts, the same _msgid.)
      const again = out.filter((o) => o.msg === msg).length;
      if (again > 1) problems.push(`${msgid}: sent ${again} times`);
      if (out.some((o) => o.nodeId !== nodeId)) problems.push(`${msgid}: sent by ${out.map((o) => o.nodeId)}, not ${nodeId}`);
      for (const c of done) {
        if (c.nodeId !== nodeId) problems.push(`${msgid}: completed by ${c.nodeId}, not ${nodeId}`);
        if (!c.error) continue;
        const code = c.error.code;
        codes.set(`${kind} ${code}`, (codes.get(`${kind} ${code}`) || 0) + 1);
        if (typeof code !== 'string') problems.push(`${msgid}: an error without a code: ${c.error.stack || c.error}`);
        else if (code === 'INTERNAL') problems.push(`${msgid}: INTERNAL: ${c.error.message}`);
        if (String(c.error.message).length > 1000) problems.push(`${msgid}: a message of ${String(c.error.message).length} characters`);
      }
    }
    // An exception out of a handler is reported by Node-RED with node.error(err, msg) and no completion.
    const any = helper.getNode('il');
    for (const call of any.error.getCalls()) {
      const msg = call.args[1];
      let id;
      try {
        id = msg && msg._msgid;
      } catch {
        id = undefined;
      }
      if (typeof id !== 'string' || !id.startsWith('fz-')) continue;
      const done = completions.get(id) || [];
      if (!done.some((c) => c.error)) problems.push(`${id}: node.error without a failed completion (an exception?): ${call.args[0]}`);
    }
    if (open().length > 0) {
      const runs = [...il().runs].map((r) => ({ operation: r.operation, granted: r.granted, ended: r.ended, step: r.current && r.current.index, state: r.run && r.run.state() }));
      problems.push(`still open: runs ${JSON.stringify(runs)}, interlock ${JSON.stringify(il().describe()).slice(0, 600)}`);
    }
    assert.deepEqual(problems.slice(0, 20), [], `${problems.length} problems`);

    // The interlock's log: never two holders of a line, never a faulted line granted.
    await settled(helper, 'il');
    const log = seen.events.map((m) => m.payload);
    const { violations, grants } = replay(log);
    assert.deepEqual(violations, []);
    assert.ok(grants > 20, `the fuzz got through to the interlock (${grants} grants)`);
    assert.ok(sent.length >= ROUNDS * PER_ROUND * Object.keys(TARGETS).length);

    // Afterwards the interlock follows its rules.
    const snapshot = il().core.snapshot(now());
    assert.deepEqual(snapshot.holds, [], 'drained');
    assert.deepEqual(snapshot.queue, []);
    const lines = () => Object.fromEntries(il().core.snapshot(now()).resources.map((r) => [r.name, r.state.state === 'faulted' ? 'faulted' : r.state.state]));
    assert.deepEqual(lines(), { YEL: 'free', GRN: 'free', RED: 'free' });
    const granted = () => seen.granted.map((m) => m.interlock && m.interlock.operation);
    const before = seen.granted.length;
    const step = async (id, msg) => {
      helper.getNode(id).receive(msg);
      await settled(helper, 'il');
    };
    await step('acq', { operation: 'final-A', resources: 'YEL', priority: 1 });
    await step('acq', { operation: 'final-B', resources: 'YEL,RED', priority: 50 });
    await step('acq', { operation: 'final-C', resources: 'RED', priority: 1 });
    assert.deepEqual(granted().slice(before), ['final-A', 'final-C'], 'A and C granted, B waits for YEL');
    await step('acq', { operation: 'final-A', resources: 'GRN' });
    assert.equal(seen.granted.length, before + 2, 'C1: A holds already');
    await step('flt', { operation: 'final-A', error: { message: 'fuzz fault' } });
    assert.deepEqual(lines(), { YEL: 'faulted', GRN: 'free', RED: 'held' });
    assert.equal(seen.lockouts.at(-1).topic, 'lockout/YEL');
    await step('rel', { operation: 'final-C' });
    assert.equal(seen.granted.length, before + 2, 'B still waits: YEL is faulted');
    await step('clr', { resources: 'YEL' });
    await until(() => seen.granted.length === before + 3, 'B granted once YEL is cleared');
    assert.equal(granted().at(-1), 'final-B');
    await step('rel', { operation: 'final-B' });
    assert.deepEqual(lines(), { YEL: 'free', GRN: 'free', RED: 'free' });
    assert.deepEqual(replay(seen.events.map((m) => m.payload)).violations, []);

    const seconds = (Date.now() - started) / 1000;
    const top = [...codes].sort((a, b) => b[1] - a[1]).slice(0, process.env.FUZZ_VERBOSE ? 200 : 12).map(([k, n]) => `${k}: ${n}`).join(', ');
    console.log(`      ${sent.length} msgs in ${seconds.toFixed(1)} s; ${grants} grants; errors by kind and code: ${top}`);
    assert.ok(seconds < 20, `took ${seconds} s`);
  });
});
