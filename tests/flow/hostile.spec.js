'use strict';
// Hostile input, in process: values no flow should send (10,000 levels deep,
// circular, a megabyte, BigInt, getters that throw, proxies) at every msg field
// the nodes read. Each msg is refused with a coded error, never INTERNAL and
// never an exception out of the handler, its node shows a red status, and the
// interlock and the plant go on as if nothing happened. Then: errors quote
// little of what they refuse, C2 cannot be bypassed with a malformed
// msg.interlock, device clocks ahead or behind ours, a msg sent in from inside
// another's read is refused without a rebuild, and a wasm instance that really
// traps is replaced without taking the process or the saved state along.
const assert = require('node:assert/strict');
const path = require('path');
const helper = require('node-red-node-test-helper');
const {
  PALETTE, paletteNodes, collect, until, serverPerTest, completions, settled, clock,
} = require('./support');
const { SINKS, plantDocument: plantOf, everyNodeFlow } = require('./every-node');

const wasm = require(path.join(PALETTE, 'lib', 'wasm', 'index.js'));
const { settle } = require(path.join(PALETTE, 'lib', 'host', 'clock.js'));

const { truckRoutine } = require('./fake-panel');
const { spyOnFacade } = require('../facade-spy');

helper.init(require.resolve('node-red'));

// ---- the plant ------------------------------------------------------------------

function plantDocument() {
  return plantOf({
    actuatorStaleMs: 3600000, retries: 0, sensorStaleMs: 60000,
    operations: [
      { id: '10', priority: 20, resources: ['YEL'], steps: [{ command: { valves: { V101: 100 } }, timeoutMs: 10000 }] },
    ],
    routines: [truckRoutine(
      { from: 'full', to: 'empty', operation: '10', trigger: { msg: 'unload' } },
    )],
  });
}

const flow = () => everyNodeFlow(plantDocument());

// ---- hostile values -------------------------------------------------------------

function deep(levels = 10000) {
  let value = [];
  for (let i = 0; i < levels; i++) value = [value];
  return value;
}

function circular() {
  const value = { name: 'loop' };
  value.self = value;
  value.list = [value];
  return value;
}

/** Tunings that refer to themselves at the fields a pid node reads. */
function circularTunings() {
  const tunings = {};
  tunings.kp = tunings;
  tunings.ti = [tunings];
  return tunings;
}

const MEGABYTE = 1024 * 1024;
const bigObject = () => ({ blob: 'x'.repeat(MEGABYTE) });
const bigArray = () => new Array(200000).fill(123456); // about 1.4 MB of JSON

/** A msg whose `field` is a getter that throws (`make()`, an Error by default). */
function throwingGetter(fields, field, make = () => new Error(`no ${field} for you`)) {
  const msg = { ...fields };
  Object.defineProperty(msg, field, { enumerable: true, get() { throw make(); } });
  return msg;
}

// wasm-bindgen's words for a borrow it refuses (its runtime's BORROW_ERROR and OWNERSHIP_ERROR).
const BORROW_WORDS = 'recursive use of an object detected which would lead to unsafe aliasing in rust';
const OWNERSHIP_WORDS = 'attempted to take ownership of Rust value while it was borrowed';

/** The errors wasm-bindgen's glue throws for a borrow it refuses, made for real: calls on an RCC object from inside its own `decide`. */
function gluesBorrowErrors() {
  const rcc = new (wasm.load().Rcc)({ id: 2, thresholdsMs: [1000, 2000], tsMs: 500, smoothHandover: true });
  const thrown = {};
  const attempt = (name, fn) => {
    try {
      fn();
    } catch (err) {
      thrown[name] = err;
    }
  };
  // `free` inside is let through: the object goes once `decide` ends.
  rcc.decide({ lastAction: 1, get agesMs() { attempt('borrow', () => rcc.nextTickMs()); attempt('ownership', () => rcc.free()); return [null, null]; } }, 0);
  return thrown;
}

/** A msg that is a Proxy: `_msgid` and `fields` read through, every other read throws. */
function proxyMsg(fields = {}) {
  const target = { ...fields };
  return new Proxy(target, {
    get(t, key) {
      // Node-RED itself reads _msgid and calls Object.prototype methods on every msg.
      if (key === '_msgid' || typeof key === 'symbol' || key in Object.prototype || Object.prototype.hasOwnProperty.call(fields, key)) return t[key];
      throw new Error(`proxy refuses to give ${String(key)}`);
    },
    set(t, key, value) {
      t[key] = value;
      return true;
    },
  });
}

/** A Proxy value: every operation on it throws (revoked). */
function revoked() {
  const { proxy, revoke } = Proxy.revocable({}, {});
  revoke();
  return proxy;
}

// ---- helpers --------------------------------------------------------------------

const runtimeOf = (id) => helper.getNode(id).runtime;
const quiet = () => settled(helper, 'il');
const statusCalls = (id) => helper.getNode(id).status.getCalls().filter((c) => c.thisValue.id === id).map((c) => c.args[0]);
const errorCalls = (id) => helper.getNode(id).error.getCalls().filter((c) => c.thisValue.id === id);
const allTexts = () => {
  const any = helper.getNode('il');
  const texts = [...any.warn.getCalls(), ...any.error.getCalls()].map((c) => String(c.args[0] && c.args[0].message !== undefined ? c.args[0].message : c.args[0]));
  const log = helper.log();
  for (const call of log.getCalls()) {
    const entry = call.args[0];
    if (entry && (entry.level === log.ERROR || entry.level === log.WARN)) texts.push(String(entry.msg && entry.msg.message !== undefined ? entry.msg.message : entry.msg));
  }
  return texts;
};
const liveLines = () => Object.fromEntries(runtimeOf('il').core.snapshot(0).resources
  .map((r) => [r.name, r.state.state === 'faulted' ? `faulted:${r.state.cause}` : r.state.state]));
const malformed = (seen) => seen.ev.filter((m) => m.topic.startsWith('actuator/malformed/')).map((m) => m.payload);
const badCount = () => runtimeOf('pl').buses.find((b) => b.nodeId === 'bus').bad;

/** A panel that obeys every command at once and reports the whole device, stamped `offsetMs` from our clock. */
function fakePanel(seen) {
  const positions = { valve: { 1: 0, 2: 0, 3: 0, 5: 0 }, pump: { 1: false } };
  const panel = {
    positions,
    offsetMs: 0,
    mute: false,
    report() {
      helper.getNode('bus').receive({ topic: 'ctrl-1/state', payload: { ts: clock().now() + panel.offsetMs, ...positions } });
    },
  };
  helper.getNode('mqtt').on('input', (msg) => {
    const [, type, io] = msg.topic.split('/');
    if (panel.mute || !(type in positions)) return;
    positions[type][io] = type === 'pump' ? msg.payload === 'ON' : Number(msg.payload);
    setImmediate(() => panel.report());
  });
  return panel;
}

/** `extra`: nodes beside every node's. */
async function start(extra = []) {
  await helper.load(paletteNodes, [...flow(), ...extra]);
  const seen = {};
  for (const id of SINKS) seen[id] = collect(helper, id);
  await until(() => runtimeOf('il').state === 'ready' && runtimeOf('pl').state === 'ready', 'the runtimes ready');
  await quiet();
  const panel = fakePanel(seen);
  panel.report();
  sensorSample({ ts: clock().now(), value: 0 });
  // Op h holds YEL for the whole test: "one on a held line queues".
  helper.getNode('acq').receive({ operation: 'h', resources: 'YEL' });
  await until(() => seen.granted.length === 1, 'op h holding YEL');
  await quiet();
  return { seen, panel };
}

function sensorSample(payload) {
  helper.getNode('bus').receive({ topic: 'station-3/sensor/volume/state', payload });
}

const completionsOf = (id, msg) => completions().filter((c) => c.nodeId === id && c.msgid === msg._msgid);

/**
 * Gives `msg` to node `id` and checks it is refused as it should be: exactly one
 * completion, with a coded error (`code`: a string or a RegExp, never INTERNAL),
 * no exception out of the handler, a red status, a short message.
 */
async function refused(id, msg, code) {
  const statusBefore = statusCalls(id).length;
  helper.getNode(id).receive(msg);
  await until(() => completionsOf(id, msg).length > 0, `node ${id} to complete the msg`);
  await settle();
  const mine = completionsOf(id, msg);
  assert.equal(mine.length, 1, `node ${id}: one completion`);
  const err = mine[0].error;
  assert.ok(err, `node ${id}: completed with an error`);
  assert.equal(typeof err.code, 'string', `node ${id}: a coded error, got ${err && err.stack}`);
  assert.notEqual(err.code, 'INTERNAL', `node ${id}: ${err.message}`);
  if (code instanceof RegExp) assert.match(err.code, code, `node ${id}: ${err.code} ${err.message}`);
  else assert.equal(err.code, code, `node ${id}: ${err.message}`);
  assert.ok(err.message.length < 400, `node ${id}: a message of ${err.message.length} characters`);
  // done(err) reports the error once; an exception escaping the handler would be a second report.
  assert.equal(errorCalls(id).filter((c) => c.args[1] === msg).length, 1, `node ${id}: no exception out of the handler`);
  // A status is only set when it changes: the same refusal twice shows once.
  const shown = statusCalls(id);
  assert.ok(shown.length > 0 && shown.at(-1).fill === 'red', `node ${id}: a red status, got ${JSON.stringify(shown.slice(statusBefore))}`);
  return err;
}

/**
 * An e-stop of GRN whose note is not text: the line is faulted all the same (isolating it comes
 * first), with a short note saying so; then cleared again.
 */
async function noteNotText(note) {
  const msg = { resources: 'GRN', error: { message: note } };
  helper.getNode('stop').receive(msg);
  await until(() => liveLines().GRN === 'faulted:manual', 'GRN faulted');
  await until(() => completionsOf('stop', msg).length === 1, 'the e-stop completed');
  assert.equal(completionsOf('stop', msg)[0].error, undefined);
  const saved = runtimeOf('il').core.snapshot(0).resources.find((r) => r.name === 'GRN').state.note;
  assert.match(saved, /^\(a note that is not text: /);
  assert.ok(saved.length < 200, `a note of ${saved.length} characters`);
  helper.getNode('clr').receive({ resources: 'GRN' });
  await until(() => liveLines().GRN === 'free', 'GRN cleared');
}

/** Device feedback is telemetry: a bad one completes without an error, warned about and counted. */
async function ignored(seen, msg, reason) {
  const bad = badCount();
  const events = malformed(seen).length;
  helper.getNode('bus').receive(msg);
  await until(() => completionsOf('bus', msg).length > 0, 'the feedback msg to complete');
  await settle();
  const mine = completionsOf('bus', msg);
  assert.equal(mine.length, 1);
  assert.equal(mine[0].error, undefined, `feedback completes without an error: ${mine[0].error && mine[0].error.message}`);
  assert.equal(errorCalls('bus').filter((c) => c.args[1] === msg).length, 0, 'no exception out of the handler');
  assert.equal(badCount(), bad + 1, 'counted once');
  await until(() => malformed(seen).length === events + 1, 'the malformed event');
  const event = malformed(seen).at(-1);
  if (reason instanceof RegExp) assert.match(event.reason, reason, JSON.stringify(event).slice(0, 300));
  else if (reason) assert.equal(event.reason, reason, JSON.stringify(event).slice(0, 300));
  assert.ok(event.message.length < 400);
  return event;
}

/**
 * A group command opening V201, published with the panel muted: it completes on the
 * feedback the test sends. Returns the count of completed commands before it, and V201's io.
 */
async function commandUnanswered(seen, panel) {
  panel.mute = true;
  const out = seen.gcout.length;
  const mqtt = seen.mqtt.length;
  helper.getNode('gc').receive({ payload: { valves: { V201: 100 } } });
  await until(() => seen.mqtt.length > mqtt, 'the command published');
  return { out, io: seen.mqtt.at(-1).topic.split('/')[2] };
}

/** The interlock still grants a free line at once and queues on a held one; the plant still completes a command. */
async function stillWorks(seen, tag) {
  const granted = seen.granted.length;
  helper.getNode('acq').receive({ operation: `free-${tag}`, resources: 'RED' });
  await until(() => seen.granted.length === granted + 1, 'the grant on the free line RED');
  assert.equal(seen.granted.at(-1).interlock.operation, `free-${tag}`);
  const waiter = { operation: `wait-${tag}`, resources: 'YEL' };
  helper.getNode('acq').receive(waiter);
  await quiet();
  assert.ok(runtimeOf('il').core.snapshot(0).queue.some((q) => q.operation === `wait-${tag}`), 'the request on the held line YEL queues');
  assert.equal(seen.granted.length, granted + 1, 'nothing else granted');
  // Tidy up: the free line released, the waiter withdrawn.
  helper.getNode('rel').receive({ operation: `free-${tag}` });
  helper.getNode('cnl').receive({ operation: `wait-${tag}` });
  await quiet();
  const out = seen.gcout.length;
  const target = seen.gcout.length % 2 === 0 ? 100 : 0;
  helper.getNode('gc').receive({ payload: { valves: { V201: target } } });
  await until(() => seen.gcout.length === out + 1, 'the group command to complete');
  assert.equal(seen.gcout.at(-1).command.actuators[0].actuator, 'V201');
}

// ---- the tests ------------------------------------------------------------------

describe('sugarshack hostile input', function () {
  this.timeout(30000);

  serverPerTest();

  for (const [name, make, codes] of [
    ['a 10,000-level nested array', () => deep(), { wasm: 'INPUT_TOO_DEEP', ages: 'INPUT_TOO_DEEP', tunings: deep, topic: 'INVALID_INPUT' }],
    ['a circular object', () => circular(), { wasm: 'INPUT_CIRCULAR', ages: 'INPUT_CIRCULAR', tunings: circularTunings, topic: 'NO_TRANSITION' }],
    ['a 1 MB object', () => bigObject(), { wasm: 'INPUT_TOO_LARGE', ages: 'INPUT_TOO_LARGE', agesValue: bigArray, tunings: () => ({ kp: bigObject() }), topic: 'NO_TRANSITION' }],
  ]) {
    it(`${name} at every field read is refused with a code; the interlock and the plant go on`, async function () {
      const { seen } = await start();
      const generation = wasm.currentGeneration();
      const v = make;

      // Group commands: the group command node, and an actuators node on a topic that is not a device's.
      await refused('gc', { payload: v() }, codes.wasm);
      await refused('bus', { topic: 'plant/command', payload: v() }, codes.wasm);
      await refused('bus', { payload: v() }, codes.wasm);
      // An acquire's fields.
      await refused('acq', { operation: v(), resources: 'RED' }, 'INVALID_OPERATION');
      await refused('acq', { operation: 'x', priority: v(), resources: 'RED' }, 'INVALID_PRIORITY');
      await refused('acq', { operation: 'x', resources: v() }, 'INVALID_RESOURCES');
      // A fault's note, as a Catch node would give it: one that is not text never stops the fault.
      await noteNotText(v());
      // A routine's trigger: a topic that cannot even be turned into text, or one no transition has.
      await refused('rt', { topic: v() }, codes.topic);
      // Control: an rcc node's ages, a pid node's tunings.
      await refused('rcc', { payload: { procVar: 40, lastAction: 10, agesMs: (codes.agesValue || v)() } }, codes.ages);
      await refused('pid', { tunings: codes.tunings() }, 'INVALID_INPUT');
      await refused('pid', { tunings: { kp: v() } }, 'INVALID_INPUT');
      await refused('pid', { limits: { min: 0, max: v() } }, 'INVALID_INPUT');

      // Device feedback: ignored with a warning and counted, nothing else touched.
      await ignored(seen, { topic: 'ctrl-1/state', payload: v() });
      await ignored(seen, { topic: 'ctrl-1/valve/1/state', payload: v() });
      await ignored(seen, { topic: 'ctrl-1/valve/1/state', payload: { ts: clock().now(), value: v() } }, 'non-numeric value');
      await ignored(seen, { topic: 'station-3/sensor/volume/state', payload: v() });
      await ignored(seen, { topic: 'station-3/sensor/volume/state', payload: { ts: clock().now(), value: v() } }, 'non-numeric value');

      assert.equal(wasm.currentGeneration(), generation, 'no input was taken for a broken wasm instance');
      assert.deepEqual(liveLines(), { YEL: 'held', GRN: 'free', RED: 'free' });
      for (const text of allTexts()) assert.ok(text.length < 400, `a log text of ${text.length} characters: ${text.slice(0, 200)}`);
      await stillWorks(seen, 'after');
    });
  }

  it('a 1 MB group command as text, and as a Buffer, is refused before it is parsed', async function () {
    const { seen } = await start();
    const text = JSON.stringify({ valves: { V201: 100 }, pad: 'x'.repeat(MEGABYTE) });
    await refused('gc', { payload: text }, 'INPUT_TOO_LARGE');
    await refused('gc', { payload: Buffer.from(text) }, 'INPUT_TOO_LARGE');
    await refused('bus', { topic: 'plant/command', payload: text }, 'INPUT_TOO_LARGE');
    assert.equal(seen.mqtt.length, 0, 'nothing published');
    await stillWorks(seen, 'after');
  });

  it('a refusal Node-RED cannot hand to a Catch node (too deep to clone) keeps its worded status; the interlock carries on', async function () {
    await helper.load(paletteNodes, [...flow(), { id: 'c1', z: 'f1', type: 'catch', scope: null, uncaught: false, wires: [[]] }]);
    await until(() => runtimeOf('il').state === 'ready' && runtimeOf('pl').state === 'ready', 'the runtimes ready');
    await quiet();
    const granted = collect(helper, 'granted');
    // Node-RED's clone for the Catch node throws RangeError out of done(err).
    helper.getNode('acq').receive({ operation: 'deep', resources: deep() });
    await quiet();
    const shown = statusCalls('acq');
    assert.ok(shown.length > 0, 'a status');
    assert.equal(shown.at(-1).fill, 'red');
    assert.notEqual(shown.at(-1).text, 'internal error');
    const warned = helper.getNode('acq').warn.getCalls().map((c) => String(c.args[0]));
    assert.ok(warned.some((w) => /could not pass this msg on/.test(w)), JSON.stringify(warned));
    helper.getNode('acq').receive({ operation: 'after', resources: 'RED' });
    await until(() => granted.length === 1, 'the grant after it');
    assert.equal(granted[0].interlock.operation, 'after');
  });

  it('hostile JS values: BigInt, getters that throw, proxies are INVALID_*, never INTERNAL', async function () {
    const { seen } = await start();
    const generation = wasm.currentGeneration();

    await refused('acq', { operation: 'x', priority: 10n, resources: 'RED' }, 'INVALID_PRIORITY');
    await refused('acq', { operation: 'x', priority: 2n ** 70n, resources: 'RED' }, 'INVALID_PRIORITY');
    await refused('acq', throwingGetter({ operation: 'x', resources: 'RED' }, 'priority'), 'INVALID_INPUT');
    await refused('acq', throwingGetter({ resources: 'RED' }, 'operation'), 'INVALID_INPUT');
    // A getter that recurses overflows the stack: a RangeError, which is no wasm trap.
    const recursing = { operation: 'x', resources: 'RED' };
    Object.defineProperty(recursing, 'priority', { enumerable: true, get() { return this.priority; } });
    await refused('acq', recursing, 'INVALID_INPUT');
    const recursingTopic = {};
    Object.defineProperty(recursingTopic, 'topic', { enumerable: true, get() { return this.topic; } });
    await refused('rt', recursingTopic, 'INVALID_INPUT');
    await refused('gc', recursingTopic, 'INVALID_INPUT');
    await refused('acq', { operation: 'x', resources: revoked() }, /^INVALID_/);
    await refused('acq', proxyMsg({ operation: 'x' }), 'INVALID_INPUT');
    await refused('rel', throwingGetter({}, 'operation'), 'INVALID_INPUT');
    await refused('cnl', proxyMsg({}), 'INVALID_INPUT');
    await refused('flt', throwingGetter({ operation: 'h' }, 'payload'), 'INVALID_INPUT');
    await refused('flt', { operation: 'h', error: { get message() { throw new Error('nope'); } } }, 'INVALID_INPUT');
    await noteNotText(10n);
    await refused('clr', throwingGetter({}, 'resources'), 'INVALID_INPUT');
    assert.deepEqual(liveLines(), { YEL: 'held', GRN: 'free', RED: 'free' }, 'no refused fault or clear changed anything');

    await refused('gc', throwingGetter({}, 'payload'), 'INVALID_INPUT');
    await refused('gc', throwingGetter({ payload: { valves: { V201: 100 } } }, 'topic'), 'INVALID_INPUT');
    await refused('gc', { payload: revoked() }, 'INVALID_INPUT');
    await refused('gc', { payload: new Proxy({}, { get() { throw new Error('proxy payload'); }, ownKeys() { throw new Error('no keys'); } }) }, 'INVALID_INPUT');
    await refused('gc', { payload: { valves: { V201: 10n } } }, 'INVALID_INPUT');
    await refused('gc', proxyMsg({}), 'INVALID_INPUT');
    await refused('bus', throwingGetter({ payload: { valves: { V201: 100 } } }, 'topic'), 'INVALID_INPUT');
    await refused('bus', throwingGetter({ topic: 'ctrl-1/state' }, 'payload'), 'INVALID_INPUT');
    await refused('bus', throwingGetter({ topic: 'plant/command' }, 'payload'), 'INVALID_INPUT');
    await refused('bus', proxyMsg({ topic: 'plant/command' }), 'INVALID_INPUT');

    await refused('rt', throwingGetter({}, 'topic'), 'INVALID_INPUT');
    await refused('rt', { topic: 10n }, 'NO_TRANSITION');
    await refused('rt', { topic: revoked() }, 'INVALID_INPUT');
    await refused('rt', { topic: { toString() { throw new Error('no text'); } } }, 'INVALID_INPUT');
    await refused('pid', throwingGetter({}, 'payload'), 'INVALID_INPUT');
    await refused('pid', throwingGetter({ payload: 40 }, 'topic'), 'INVALID_INPUT');
    await refused('pid', { tunings: { get kp() { throw new Error('no kp'); } } }, 'INVALID_INPUT');
    await refused('pid', proxyMsg({}), 'INVALID_INPUT');
    await refused('rcc', throwingGetter({}, 'payload'), 'INVALID_INPUT');
    await refused('rcc', { payload: { procVar: 40, lastAction: 10n, agesMs: [null, null] } }, 'INVALID_INPUT');
    await refused('rcc', { payload: { procVar: 40, lastAction: 10, get agesMs() { throw new Error('no ages'); } } }, 'INVALID_INPUT');
    await refused('rcc', { payload: revoked() }, 'INVALID_INPUT');
    await refused('io', throwingGetter({ payload: 5, controller: 1 }, 'topic'), 'INVALID_INPUT');
    await refused('io', throwingGetter({ topic: 'measurement' }, 'payload'), 'INVALID_INPUT');
    await refused('io', { payload: 5, controller: 1n }, /^(INVALID_INPUT|UNKNOWN_CONTROLLER)$/);
    await refused('io', proxyMsg({}), 'INVALID_INPUT');

    // Feedback whose payload cannot be read at all is still only telemetry.
    await ignored(seen, { topic: 'ctrl-1/state', payload: { ts: clock().now(), get valve() { throw new Error('no valves'); } } });
    await ignored(seen, { topic: 'ctrl-1/valve/1/state', payload: revoked() });
    // A timestamp that is no number is taken as none: the sample counts from its reception.
    const odd = { topic: 'station-3/sensor/volume/state', payload: { ts: 10n, value: 5 } };
    helper.getNode('bus').receive(odd);
    await until(() => completionsOf('bus', odd).length === 1, 'the sample with a BigInt timestamp');
    assert.equal(completionsOf('bus', odd)[0].error, undefined);

    assert.equal(wasm.currentGeneration(), generation);
    await stillWorks(seen, 'after');
    // The pid and rcc nodes still step.
    const pidOut = seen.pidout.length;
    helper.getNode('pid').receive({ payload: 40 });
    await until(() => seen.pidout.length === pidOut + 1, 'a pid step');
    const rccOut = seen.rccout.length;
    helper.getNode('rcc').receive({ payload: { procVar: 40, lastAction: 10, agesMs: [null, null] } });
    await until(() => seen.rccout.length === rccOut + 1, 'an rcc decision');
  });

  // What a broken wasm instance throws, thrown by a msg's own getter or toJSON: the sender's error all the same.
  for (const [name, make, deepCode] of [
    ['wasm-bindgen\'s words for a borrow left open', () => new Error(BORROW_WORDS), 'INVALID_INPUT'],
    ['wasm-bindgen\'s words for an object taken while borrowed', () => new Error(OWNERSHIP_WORDS), 'INVALID_INPUT'],
    ['a WebAssembly.RuntimeError', () => new WebAssembly.RuntimeError('unreachable'), 'INVALID_INPUT'],
    // The core takes a stack overflow in its read of a value for one too deep.
    ['a stack overflow\'s RangeError', () => new RangeError('Maximum call stack size exceeded'), 'INPUT_TOO_DEEP'],
  ]) {
    it(`a msg whose getter or toJSON throws ${name} is refused with a code, never taken for a trap: nothing rebuilt`, async function () {
      const { seen } = await start();
      const generation = wasm.currentGeneration();
      const core = runtimeOf('il').core;
      const tracker = runtimeOf('pl').t;
      const boom = () => { throw make(); };
      /** A list of `names` whose first element's getter throws. */
      const lines = (names) => {
        const list = [...names];
        Object.defineProperty(list, 0, { enumerable: true, get: boom });
        return list;
      };
      const badValves = () => ({ valves: { get V201() { return boom(); } } });

      await refused('acq', throwingGetter({ operation: 'x', resources: 'RED' }, 'priority', make), 'INVALID_INPUT');
      await refused('acq', { operation: 'x', resources: lines(['RED']) }, 'INVALID_RESOURCES');
      await refused('flt', { operation: 'h', error: { get message() { return boom(); } } }, 'INVALID_INPUT');
      await noteNotText({ toJSON: boom });
      await refused('clr', throwingGetter({}, 'resources', make), 'INVALID_INPUT');
      await refused('clr', { resources: lines(['GRN']) }, 'INVALID_RESOURCES');
      await refused('rt', throwingGetter({}, 'topic', make), 'INVALID_INPUT');
      await refused('gc', throwingGetter({}, 'payload', make), 'INVALID_INPUT');
      await refused('gc', { payload: badValves() }, deepCode);
      await refused('gc', { payload: { toJSON: boom } }, deepCode);
      await refused('bus', { topic: 'plant/command', payload: badValves() }, deepCode);
      await refused('bus', { topic: 'plant/command', payload: { toJSON: boom } }, deepCode);
      await ignored(seen, { topic: 'ctrl-1/state', payload: { ts: clock().now(), get valve() { return boom(); } } });
      await ignored(seen, { topic: 'ctrl-1/state', payload: { toJSON: boom } });
      await ignored(seen, { topic: 'station-3/sensor/volume/state', payload: { ts: clock().now(), get value() { return boom(); } } });
      await refused('pid', { tunings: { get kp() { return boom(); } } }, 'INVALID_INPUT');
      await refused('rcc', { payload: { procVar: 40, lastAction: 10, get agesMs() { return boom(); } } }, 'INVALID_INPUT');
      await refused('io', throwingGetter({ topic: 'measurement' }, 'payload', make), 'INVALID_INPUT');

      await quiet();
      assert.equal(wasm.currentGeneration(), generation, 'no input was taken for a broken wasm instance');
      assert.equal(runtimeOf('il').core, core);
      assert.equal(runtimeOf('pl').t, tracker);
      assert.ok(!allTexts().some((t) => /trapped|core failed/.test(t)), 'no trap logged');
      assert.deepEqual(liveLines(), { YEL: 'held', GRN: 'free', RED: 'free' });
      await stillWorks(seen, 'after');
    });
  }

  it('a getter that throws a proxy which throws on being looked at (its prototype, its message) is refused INVALID_INPUT by every node, nothing rebuilt', async function () {
    const { seen } = await start();
    const generation = wasm.currentGeneration();
    const looked = () => { throw new Error(BORROW_WORDS); };
    const thrown = () => new Proxy({}, { get: looked, getPrototypeOf: looked, has: looked, ownKeys: looked });
    for (const [id, fields, field] of [
      ['acq', { operation: 'x', resources: 'RED' }, 'priority'], ['rel', {}, 'operation'], ['flt', { operation: 'h' }, 'payload'],
      ['clr', {}, 'resources'], ['rt', {}, 'topic'], ['gc', {}, 'payload'], ['bus', { topic: 'plant/command' }, 'payload'],
      ['pid', {}, 'payload'], ['rcc', {}, 'payload'], ['io', { topic: 'measurement' }, 'payload'],
    ]) {
      const err = await refused(id, throwingGetter(fields, field, thrown), 'INVALID_INPUT');
      assert.match(err.message, /could not read the msg: object/, id);
    }
    await quiet();
    assert.equal(wasm.currentGeneration(), generation, 'no rebuild');
    assert.deepEqual(liveLines(), { YEL: 'held', GRN: 'free', RED: 'free' });
    await stillWorks(seen, 'after');
  });

  it('whatever was thrown, even a proxy that throws on being looked at, becomes a coded error, never a second throw', function () {
    const { asSugarshackError } = require(path.join(PALETTE, 'lib', 'host', 'errors.js'));
    const looked = () => { throw new Error('looked at'); };
    const { proxy, revoke } = Proxy.revocable({}, {});
    revoke();
    for (const thrown of [new Proxy({}, { get: looked, getPrototypeOf: looked, has: looked, ownKeys: looked }), proxy]) {
      const err = asSugarshackError(thrown);
      assert.equal(err.code, 'INTERNAL');
      assert.equal(err.message, 'object');
    }
    assert.equal(asSugarshackError(new TypeError('x is not a function')).message, 'x is not a function');
    const coded = Object.assign(new Error('queue full'), { code: 'QUEUE_FULL' });
    assert.equal(asSugarshackError(coded), coded);
  });

  describe('one reader of what was thrown (asSugarshackError)', function () {
    const { SugarshackError, asSugarshackError } = require(path.join(PALETTE, 'lib', 'host', 'errors.js'));
    const refuse = (words) => new SugarshackError('INVALID_INPUT', `could not read: ${words}`);
    const boom = () => { throw new Error('looked at'); };
    /** The error `thrown` becomes, both ways; every code and message of it readable (twice: a getter may throw once). */
    const readBoth = (thrown) => [asSugarshackError(thrown), asSugarshackError(thrown, refuse)].map((err) => {
      assert.ok(err instanceof SugarshackError || err === thrown);
      for (let i = 0; i < 2; i++) {
        assert.equal(typeof err.code, 'string');
        assert.equal(typeof err.message, 'string');
      }
      return err;
    });

    it('a value that throws when its message, code or constructor is read, or turned into text, is told by its type', function () {
      const noPrototype = Object.create(null);
      const primitiveThrows = { [Symbol.toPrimitive]: boom };
      const messageThrows = { get message() { return boom(); } };
      const messageAnObjectThatThrows = { message: primitiveThrows, toString: boom };
      for (const thrown of [noPrototype, primitiveThrows, messageThrows, messageAnObjectThatThrows]) {
        const [internal, refused] = readBoth(thrown);
        assert.deepEqual([internal.code, internal.message], ['INTERNAL', 'object']);
        assert.deepEqual([refused.code, refused.message], ['INVALID_INPUT', 'could not read: object']);
      }
      const codeThrows = Object.defineProperty(new Error('disk gone'), 'code', { get: boom });
      const constructorThrows = Object.defineProperty(new Error('no class'), 'constructor', { get: boom });
      assert.deepEqual(readBoth(codeThrows).map((e) => [e.code, e.message]), [['INTERNAL', 'disk gone'], ['INVALID_INPUT', 'could not read: disk gone']]);
      assert.deepEqual(readBoth(constructorThrows).map((e) => [e.code, e.message]), [['INTERNAL', 'no class'], ['INVALID_INPUT', 'could not read: no class']]);
    });

    it('a code that reads once, or a proxy around a coded error, is never passed on: its code may throw when the caller reads it', function () {
      let reads = 0;
      const onceCoded = Object.defineProperty(new Error('once'), 'code', { get: () => (reads++ === 0 ? 'QUEUE_FULL' : boom()) });
      assert.deepEqual(readBoth(onceCoded).map((e) => e.code), ['INTERNAL', 'INVALID_INPUT']);
      const ours = new SugarshackError('QUEUE_FULL', 'queue full');
      const wrapped = new Proxy(ours, { get: (target, key) => (key === 'code' ? boom() : Reflect.get(target, key)) });
      assert.deepEqual(readBoth(wrapped).map((e) => [e.code, e.message]), [['INTERNAL', 'queue full'], ['INVALID_INPUT', 'could not read: queue full']]);
      const { proxy, revoke } = Proxy.revocable(ours, {});
      revoke();
      assert.deepEqual(readBoth(proxy).map((e) => [e.code, e.message]), [['INTERNAL', 'object'], ['INVALID_INPUT', 'could not read: object']]);
    });

    it('ours and the core\'s pass as they are; a coded error of another is kept as INTERNAL\'s, refused as a msg\'s', function () {
      const ours = new SugarshackError('QUEUE_FULL', 'queue full');
      const core = Object.assign(new Error('no such line'), { name: 'SugarshackError', code: 'UNKNOWN_RESOURCE' });
      const node = Object.assign(new Error('ENOENT: no such file'), { code: 'ENOENT' });
      assert.equal(asSugarshackError(ours), ours);
      assert.equal(asSugarshackError(ours, refuse), ours);
      assert.equal(asSugarshackError(core, refuse), core);
      assert.equal(asSugarshackError(node), node);
      assert.deepEqual([asSugarshackError(node, refuse).code, asSugarshackError(node, refuse).message], ['INVALID_INPUT', 'could not read: ENOENT: no such file']);
      // Without words, a coded error is not kept: it is told as itself.
      const silent = Object.assign(new Error(''), { code: 'X' });
      assert.deepEqual([asSugarshackError(silent).code, asSugarshackError(silent).message], ['INTERNAL', 'Error']);
    });

    it('other values are told as text; the stack of what is wrapped as INTERNAL is kept, even one whose getter throws', function () {
      assert.deepEqual([Symbol('s'), null, undefined, 42, 'plain words'].map((v) => asSugarshackError(v).message),
        ['Symbol(s)', 'null', 'undefined', '42', 'plain words']);
      const typeError = new TypeError('x is not a function');
      assert.equal(asSugarshackError(typeError).stack, typeError.stack);
      const stackThrows = Object.defineProperty(new Error('no stack'), 'stack', { get: boom });
      assert.equal(asSugarshackError(stackThrows).message, 'no stack');
      assert.match(asSugarshackError(stackThrows).stack, /SugarshackError: no stack/);
    });
  });

  it('a getter that throws a coded error of another, or a proxy around one of ours whose code throws, is refused INVALID_INPUT by every node', async function () {
    const { seen } = await start();
    const generation = wasm.currentGeneration();
    const { SugarshackError } = require(path.join(PALETTE, 'lib', 'host', 'errors.js'));
    const looked = () => { throw new Error('code looked at'); };
    for (const [thrown, words] of [
      [() => Object.assign(new Error('ENOENT: disk gone'), { code: 'ENOENT' }), /could not read the msg: ENOENT: disk gone/],
      [() => new Proxy(new SugarshackError('QUEUE_FULL', 'queue full'), { get: (t, key) => (key === 'code' ? looked() : Reflect.get(t, key)) }), /could not read the msg: queue full/],
    ]) {
      for (const [id, fields, field] of [
        ['acq', { operation: 'x', resources: 'RED' }, 'priority'], ['rel', {}, 'operation'], ['flt', { operation: 'h' }, 'payload'],
        ['clr', {}, 'resources'], ['rt', {}, 'topic'], ['gc', {}, 'payload'], ['bus', { topic: 'plant/command' }, 'payload'],
        ['pid', {}, 'payload'], ['rcc', {}, 'payload'], ['io', { topic: 'measurement' }, 'payload'],
      ]) {
        const err = await refused(id, throwingGetter(fields, field, thrown), 'INVALID_INPUT');
        assert.match(err.message, words, id);
      }
    }
    await quiet();
    assert.equal(wasm.currentGeneration(), generation, 'no rebuild');
    await stillWorks(seen, 'after');
  });

  it('feedback as an object circular in one field: the rest is applied, that field alone refused, nothing thrown', async function () {
    const { seen, panel } = await start();
    const generation = wasm.currentGeneration();
    const { out, io } = await commandUnanswered(seen, panel);
    // Circular in `pump` (as a function node could make it): JSON cannot write it whole.
    const loop = {};
    loop.self = loop;
    const report = { ts: clock().now(), valve: { ...panel.positions.valve, [io]: 100 }, pump: loop };
    const bad = badCount();
    helper.getNode('bus').receive({ topic: 'ctrl-1/state', payload: report });
    await until(() => seen.gcout.length === out + 1, 'the command completed by the readable field');
    await until(() => badCount() === bad + 1, 'the circular field counted');
    assert.match(malformed(seen).at(-1).message, /unreadable: Converting circular structure/);
    // A getter that throws at the top: the whole payload is unreadable, refused and counted, never thrown.
    await ignored(seen, { topic: 'ctrl-1/state', payload: { ts: clock().now(), get valve() { throw new Error('no valves'); }, pump: loop } });
    // A proxy passing for a Buffer is no Buffer: refused as unreadable.
    await ignored(seen, { topic: 'ctrl-1/valve/1/state', payload: new Proxy(Buffer.from('1'), { get() { throw new Error('no bytes'); } }) });
    assert.equal(wasm.currentGeneration(), generation, 'no input was taken for a broken wasm instance');
  });

  it('errors quote at most ~100 characters: a 1,000,000-character id, name, payload or topic', async function () {
    const { seen } = await start();
    const huge = (c) => c.repeat(1000000);
    const messages = [];
    const check = async (id, msg, code) => messages.push((await refused(id, msg, code)).message);
    await check('acq', { operation: huge('o'), resources: 'RED' }, 'INVALID_OPERATION');
    await check('rel', { operation: huge('o') }, 'INVALID_OPERATION');
    await check('cnl', { operation: huge('o') }, 'INVALID_OPERATION');
    await check('flt', { operation: huge('o') }, 'INVALID_OPERATION');
    await check('acq', { operation: 'x', resources: huge('R') }, 'INVALID_RESOURCES');
    await check('acq', { operation: 'x', resources: ['RED', huge('R')] }, 'INVALID_RESOURCES');
    await check('acq', { operation: 'x', priority: huge('7'), resources: 'RED' }, 'INVALID_PRIORITY');
    await check('stop', { resources: huge('R') }, 'INVALID_RESOURCES');
    await check('clr', { resources: huge('R') }, 'INVALID_RESOURCES');
    await check('gc', { payload: huge('{') }, 'INPUT_TOO_LARGE');
    await check('gc', { payload: { valves: { [huge('V')]: 100 } } }, 'INPUT_TOO_LARGE');
    await check('gc', { payload: { valves: { [`V${'9'.repeat(60000)}`]: 100 } } }, 'UNKNOWN_ACTUATOR');
    await check('gc', { payload: { [`valve${'s'.repeat(60000)}`]: { V201: 100 } } }, /^(INVALID_GROUP|UNKNOWN_ACTUATOR)$/);
    await check('gc', { payload: { valves: { V201: huge('1') } } }, /^(INVALID_TARGET|INVALID_GROUP|INPUT_TOO_LARGE)$/);
    await check('gc', { payload: { valves: { V501: 100 } }, interlock: { resources: [huge('R')] } }, 'INVALID_RESOURCES');
    await check('gc', { payload: { valves: { V501: 100 } }, interlock: { resources: huge('R') } }, 'INVALID_RESOURCES');
    await check('bus', { topic: 'plant/command', payload: huge('[') }, 'INPUT_TOO_LARGE');
    await check('rt', { topic: huge('t') }, 'INVALID_INPUT');
    await check('pid', { payload: 40, tunings: { kp: huge('2') } }, 'INVALID_INPUT');
    await check('io', { payload: huge('5'), controller: 1 }, 'INVALID_INPUT');
    await ignored(seen, { topic: 'ctrl-1/valve/1/state', payload: huge('x') }, 'bad JSON');
    await ignored(seen, { topic: 'ctrl-1/status', payload: huge('x') }, 'bad status');
    await ignored(seen, { topic: `${huge('d')}/state`, payload: { ts: clock().now(), valve: { 1: 3 } } }, 'unknown device');
    await ignored(seen, { topic: 'ctrl-1/state', payload: { ts: clock().now(), [huge('k')]: 1 } }, 'no known type');
    assert.equal(seen.mqtt.length, 0, 'nothing published');
    const texts = allTexts();
    assert.ok(texts.length >= messages.length, 'the refusals were logged');
    for (const text of [...messages, ...texts]) assert.ok(text.length < 400, `${text.length} characters: ${text.slice(0, 300)}`);
    for (const event of malformed(seen)) assert.ok(event.message.length < 400, event.message.slice(0, 300));
    await stillWorks(seen, 'after');
  });

  it('C2 cannot be bypassed: a malformed msg.interlock is refused (INVALID_RESOURCES), ["RED"] is published', async function () {
    const { seen } = await start();
    const command = { valves: { V501: 100 } };
    for (const interlock of [{ resources: 'YEL' }, { resources: 'RED' }, { resources: {} }, { resources: [1, 2] }, { resources: null },
      { resources: [['RED']] }, 'x', null, 5, [], { operation: 'op' }]) {
      const err = await refused('gc', { payload: command, interlock }, 'INVALID_RESOURCES');
      assert.match(err.message, /C2/);
      await refused('bus', { topic: 'plant/command', payload: command, interlock }, 'INVALID_RESOURCES');
    }
    await quiet();
    assert.equal(seen.mqtt.length, 0, 'nothing published');
    const err = await refused('gc', { payload: command, interlock: { resources: ['YEL'] } }, 'OUTSIDE_RESOURCES');
    assert.match(err.message, /V501/);
    assert.equal(seen.mqtt.length, 0, 'nothing published');
    helper.getNode('gc').receive({ payload: command, interlock: { resources: ['RED'] } });
    await until(() => seen.gcout.length === 1, 'the command on RED to complete');
    assert.deepEqual(seen.mqtt.map((m) => [m.topic, m.payload]), [['ctrl-1/valve/5/command', '100']]);
  });

  it('device time: a sample from the future is refused and counted, the next real one kept; a clock an hour behind is still heard', async function () {
    const { seen, panel } = await start();
    const now = () => clock().now();

    // A sensor stamped in the future: refused, counted, and a condition waiting for it does not pass on it.
    helper.getNode('wt').receive({ topic: 'waiting' });
    await settle();
    let bad = badCount();
    let events = malformed(seen).length;
    sensorSample({ ts: 9e15, value: 500 });
    await until(() => badCount() === bad + 1 && malformed(seen).length === events + 1, 'the future sample counted');
    let event = malformed(seen).at(-1);
    assert.equal(event.reason, 'FUTURE_TIMESTAMP');
    assert.equal(event.device, 'station-3');
    assert.ok(event.message.length < 400);
    await settle();
    assert.equal(seen.waited.length, 0, 'the condition did not pass on the refused sample');
    sensorSample({ ts: now(), value: 150 });
    await until(() => seen.waited.length === 1, 'the condition over the next real sample');
    assert.deepEqual(seen.waited[0].condition.values, { 'LT-3': 150 });

    // A device whose clock is an hour behind ours is still heard: sensor...
    sensorSample({ ts: now() - 3600000, value: 220 });
    await settle();
    helper.getNode('wt').receive({ topic: 'again' });
    await until(() => seen.waited.length === 2, 'the condition over the late-stamped sample');
    assert.deepEqual(seen.waited[1].condition.values, { 'LT-3': 220 });
    // ...and actuator feedback, as batches and as single states.
    panel.offsetMs = -3600000;
    helper.getNode('gc').receive({ payload: { valves: { V201: 100 } } });
    await until(() => seen.gcout.length === 1, 'a command completed on feedback stamped an hour ago');
    panel.mute = true;
    helper.getNode('gc').receive({ payload: { valves: { V201: 0 } } });
    await until(() => seen.mqtt.length === 2, 'the second command');
    panel.positions.valve[3] = 0;
    helper.getNode('bus').receive({ topic: 'ctrl-1/valve/3/state', payload: { ts: now() - 3600000, value: 0 } });
    await until(() => seen.gcout.length === 2, 'a command completed on a single state stamped an hour ago');

    // An actuator batch stamped in the future is refused whole, counted once.
    bad = badCount();
    events = malformed(seen).length;
    helper.getNode('gc').receive({ payload: { valves: { V201: 100, V501: 100 } } });
    await until(() => seen.mqtt.length === 4, 'two commands');
    const futureBatch = { topic: 'ctrl-1/state', payload: { ts: now() + 3600000, valve: { 1: 0, 2: 0, 3: 100, 5: 100 }, pump: { 1: false } } };
    helper.getNode('bus').receive(futureBatch);
    await until(() => completionsOf('bus', futureBatch).length === 1 && malformed(seen).length > events, 'the batch handled');
    await settle();
    assert.equal(badCount(), bad + 1, 'counted once');
    assert.equal(malformed(seen).length, events + 1);
    event = malformed(seen).at(-1);
    assert.equal(event.reason, 'FUTURE_TIMESTAMP');
    assert.equal(completionsOf('bus', futureBatch)[0].error, undefined);
    assert.equal(seen.gcout.length, 2, 'nothing of the future batch applied: the command waits');
    const pl = runtimeOf('pl');
    for (const id of ['V201', 'V501']) {
      const a = pl.actuators.find((x) => x.id === id);
      assert.notEqual(pl.t.position(a.handle), 100, `${id} not moved by the refused batch`);
    }
    panel.offsetMs = 0;
    panel.positions.valve[3] = 100;
    panel.positions.valve[5] = 100;
    panel.report();
    await until(() => seen.gcout.length === 3, 'the command completes on the next real batch');

    // A panel batch with no type the plant knows is counted.
    bad = badCount();
    events = malformed(seen).length;
    helper.getNode('bus').receive({ topic: 'ctrl-1/state', payload: { ts: now(), relay: { 1: 1 }, valves: { 1: 3 } } });
    await until(() => badCount() === bad + 1 && malformed(seen).length === events + 1, 'the batch counted');
    assert.equal(malformed(seen).at(-1).reason, 'no known type');
  });

  it('an operation run taken out of the queue by a cancel or a fault ends (ABORTED); its routine is not left busy', async function () {
    const { seen } = await start(); // h holds YEL: op 10 queues
    const run = { topic: 'start op 10' };
    helper.getNode('op').receive(run);
    await quiet();
    assert.deepEqual(runtimeOf('il').core.snapshot(0).queue.map((q) => q.operation), ['10']);
    const cancel = { operation: '10' };
    helper.getNode('cnl').receive(cancel);
    await until(() => completionsOf('op', run).length === 1, 'the run to end');
    assert.equal(completionsOf('op', run)[0].error.code, 'ABORTED');
    assert.equal(seen.opout.length, 0, 'nothing ran');
    assert.equal(runtimeOf('il').runs.size, 0);
    await until(() => seen.cancelled.length === 1, 'the cancel msg going on');

    // A routine's operation faulted while it waits: the routine is told (refused) and takes triggers again.
    helper.getNode('rt').receive({ topic: 'load' });
    await quiet();
    assert.deepEqual(runtimeOf('il').core.snapshot(0).queue.map((q) => q.operation), ['10']);
    helper.getNode('flt').receive({ operation: '10', error: { message: 'stop it' } });
    await until(() => seen.rtev.some((m) => m.payload.event === 'refused'), 'the routine told');
    assert.equal(runtimeOf('il').routines.get('truck').machine.pending(), undefined);
    assert.equal(runtimeOf('il').runs.size, 0);
    const again = { topic: 'load' };
    helper.getNode('rt').receive(again);
    await until(() => completionsOf('rt', again).length === 1, 'the second trigger');
    assert.equal(completionsOf('rt', again)[0].error, undefined, 'not ROUTINE_BUSY');
    assert.deepEqual(liveLines(), { YEL: 'held', GRN: 'free', RED: 'free' }, 'h still holds YEL; nothing faulted');
  });

  // A value the core reads inside its call (a payload object, a list of lines) whose getter sends
  // another msg in at once: that msg reaches the core while the first call still runs.
  describe('a msg sent in from inside another msg\'s read', function () {
    /** A list of `lines` whose first element's getter gives `inner` to node `id` first. */
    function sendingLines(id, inner, lines) {
      const list = [...lines];
      Object.defineProperty(list, 0, { enumerable: true, get() { helper.getNode(id).receive(inner); return lines[0]; } });
      return list;
    }

    /** Node `id`'s one completion of `msg`, once there. */
    async function completionOf(id, msg) {
      await until(() => completionsOf(id, msg).length > 0, `node ${id} to complete the msg`);
      await settle();
      assert.equal(completionsOf(id, msg).length, 1);
      return completionsOf(id, msg)[0];
    }

    /** The msg sent from inside the read is refused as the sender's doing, worded so it can be fixed. */
    async function reentered(id, msg) {
      const { error } = await completionOf(id, msg);
      assert.ok(error, `node ${id}: refused`);
      assert.equal(error.code, 'INVALID_INPUT', error.message);
      assert.match(error.message, /while the core was still reading another msg/);
    }

    it('feedback whose payload getter sends feedback and a group command in: those are refused, the first applied, nothing rebuilt', async function () {
      const { seen, panel } = await start();
      const generation = wasm.currentGeneration();
      const tracker = runtimeOf('pl').t;
      const { out, io } = await commandUnanswered(seen, panel);
      const sample = { topic: 'station-3/sensor/volume/state', payload: { ts: clock().now(), value: 7 } };
      const command = { payload: { valves: { V501: 100 } } };
      const valve = { ...panel.positions.valve, [io]: 100 };
      const payload = {
        ts: clock().now(),
        get valve() {
          helper.getNode('bus').receive(sample);
          helper.getNode('gc').receive(command);
          return valve;
        },
      };
      const outer = { topic: 'ctrl-1/state', payload };
      helper.getNode('bus').receive(outer);
      await reentered('bus', sample);
      await reentered('gc', command);
      assert.equal((await completionOf('bus', outer)).error, undefined);
      await until(() => seen.gcout.length === out + 1, 'the command completed by the first msg');
      await quiet();
      assert.equal(wasm.currentGeneration(), generation, 'no rebuild');
      assert.equal(runtimeOf('pl').t, tracker);
      assert.deepEqual(liveLines(), { YEL: 'held', GRN: 'free', RED: 'free' }, 'h still holds YEL');
      assert.ok(!allTexts().some((t) => /trapped|core failed/.test(t)), 'no trap logged');
      // Sent again on its own, the refused sample is applied.
      const again = { topic: sample.topic, payload: { ts: clock().now(), value: 7 } };
      helper.getNode('bus').receive(again);
      assert.equal((await completionOf('bus', again)).error, undefined);
      panel.mute = false;
      await stillWorks(seen, 'after');
    });

    it('an acquire whose lines\' getter sends an acquire and a release into the same interlock: each taken after it, nothing rebuilt', async function () {
      const { seen } = await start();
      const generation = wasm.currentGeneration();
      const core = runtimeOf('il').core;
      helper.getNode('acq').receive({ operation: 'g', resources: 'GRN' });
      await until(() => seen.granted.length === 2, 'g holding GRN');
      const inner = { operation: 'inner', resources: 'RED' };
      const release = { operation: 'g' };
      const outer = { operation: 'outer', resources: sendingLines('rel', release, ['GRN']) };
      // msg.operation is read before the core is called: its getter's msg comes first, as from any function node.
      Object.defineProperty(outer, 'priority', { enumerable: true, get() { helper.getNode('acq').receive(inner); return 5; } });
      helper.getNode('acq').receive(outer);
      assert.equal((await completionOf('rel', release)).error, undefined);
      await until(() => seen.granted.length === 4, 'inner and outer granted');
      assert.deepEqual(seen.granted.slice(2).map((m) => m.interlock.operation).sort(), ['inner', 'outer']);
      await quiet();
      assert.equal(wasm.currentGeneration(), generation, 'no rebuild');
      assert.equal(runtimeOf('il').core, core);
      assert.deepEqual(liveLines(), { YEL: 'held', GRN: 'held', RED: 'held' });
      assert.ok(!allTexts().some((t) => /trapped|core failed/.test(t)), 'no trap logged');
    });

    /**
     * GRN faulted, then given in by `send`, a clear of it whose lines' getter sends feedback to the
     * plant it checks against: the feedback is refused, the clear done, nothing rebuilt.
     */
    async function clearSendingFeedback(send) {
      const generation = wasm.currentGeneration();
      helper.getNode('stop').receive({ resources: 'GRN', payload: 'e-stop GRN' });
      await until(() => liveLines().GRN === 'faulted:manual', 'GRN faulted');
      const sample = { topic: 'station-3/sensor/volume/state', payload: { ts: clock().now(), value: 7 } };
      const clear = { resources: sendingLines('bus', sample, ['GRN']) };
      send(clear);
      await reentered('bus', sample);
      assert.equal((await completionOf('clr', clear)).error, undefined);
      await until(() => liveLines().GRN === 'free', 'GRN cleared');
      await quiet();
      assert.equal(wasm.currentGeneration(), generation, 'no rebuild');
      assert.ok(!allTexts().some((t) => /trapped|core failed/.test(t)), 'no trap logged');
    }

    it('a clear whose lines\' getter sends feedback to the plant it checks against: the feedback is refused, the clear done, nothing rebuilt', async function () {
      const { seen } = await start();
      await clearSendingFeedback((clear) => helper.getNode('clr').receive(clear));
      await stillWorks(seen, 'after');
    });

    it('an rcc msg whose ages\' getter sends another into the same rcc node: that one is refused, the first decided, nothing rebuilt', async function () {
      const { seen } = await start();
      const generation = wasm.currentGeneration();
      const out = seen.rccout.length;
      const inner = { payload: { procVar: 40, lastAction: 10, agesMs: [null, null] } };
      const outer = { payload: { procVar: 40, lastAction: 10, agesMs: [20, null] } };
      Object.defineProperty(outer.payload.agesMs, 0, { enumerable: true, get() { helper.getNode('rcc').receive(inner); return 20; } });
      helper.getNode('rcc').receive(outer);
      await reentered('rcc', inner);
      assert.equal((await completionOf('rcc', outer)).error, undefined);
      assert.equal(seen.rccout.length, out + 1, 'the first msg decided');
      assert.equal(seen.rccout.at(-1).rcc.engaged, true);
      assert.equal(wasm.currentGeneration(), generation, 'no rebuild');
    });

    it('a state node\'s requests sent from inside another msg\'s read (an alarm request in an acquire\'s, a state request in feedback\'s): refused before they reach the core, the first msgs go on, nothing rebuilt', async function () {
      const { seen } = await start([{ id: 'st', z: 'f1', type: 'sugarshack-state', onChange: false, intervalS: '1', wires: [[]] }]);
      const generation = wasm.currentGeneration();
      const core = runtimeOf('il').core;
      const tracker = runtimeOf('pl').t;
      const shelve = { topic: 'shelve', id: 'line-faulted:GRN', forMs: 60000 };
      helper.getNode('acq').receive({ operation: 'outer', resources: sendingLines('st', shelve, ['GRN']) });
      await reentered('st', shelve);
      await until(() => seen.granted.length === 2, 'GRN granted');
      assert.equal(seen.granted[1].interlock.operation, 'outer');
      // The interlock's view is read against the plant's tracker, which the feedback's read holds.
      const request = { topic: 'state please' };
      const feedback = { topic: 'station-3/sensor/volume/state', payload: { ts: clock().now(), get value() { helper.getNode('st').receive(request); return 7; } } };
      helper.getNode('bus').receive(feedback);
      await reentered('st', request);
      assert.equal((await completionOf('bus', feedback)).error, undefined);
      await quiet();
      assert.equal(wasm.currentGeneration(), generation, 'no rebuild');
      assert.equal(runtimeOf('il').core, core);
      assert.equal(runtimeOf('pl').t, tracker);
      assert.ok(!allTexts().some((t) => /trapped|core failed/.test(t)), 'no trap logged');
    });

    it('a clear sent from inside an acquire\'s read waits for it; its own lines\' getter sending feedback to the plant is refused, nothing rebuilt', async function () {
      const { seen } = await start();
      await clearSendingFeedback((clear) => helper.getNode('acq').receive({ operation: 'outer', resources: sendingLines('clr', clear, ['RED']) }));
      await until(() => seen.granted.length === 2, 'RED granted');
      assert.equal(seen.granted[1].interlock.operation, 'outer');
    });

    it('a clear waiting for an acquire sent in from inside a feedback msg\'s read: refused when its turn comes (the plant still reads), and its msg ends with that error', async function () {
      const { seen } = await start();
      const generation = wasm.currentGeneration();
      helper.getNode('stop').receive({ resources: 'GRN', payload: 'e-stop GRN' });
      await until(() => liveLines().GRN === 'faulted:manual', 'GRN faulted');
      const clear = { resources: 'GRN' };
      const acquire = { operation: 'outer', resources: sendingLines('clr', clear, ['RED']) };
      const outer = { topic: 'station-3/sensor/volume/state', payload: { ts: clock().now(), get value() { helper.getNode('acq').receive(acquire); return 7; } } };
      helper.getNode('bus').receive(outer);
      await reentered('clr', clear);
      assert.equal((await completionOf('bus', outer)).error, undefined);
      await until(() => seen.granted.length === 2, 'RED granted');
      assert.equal(seen.granted[1].interlock.operation, 'outer');
      assert.equal(liveLines().GRN, 'faulted:manual', 'the refused clear cleared nothing');
      await quiet();
      assert.equal(wasm.currentGeneration(), generation, 'no rebuild');
    });

    it('the msg sent from inside the read is refused before it reaches the core: no call into wasm for it', async function () {
      const { seen } = await start();
      const calls = [];
      /** Node `id` given `inner`, counting the facade calls it makes. */
      const counted = (id, inner) => {
        const spy = spyOnFacade(wasm.load(), (key) => calls.push(key));
        try {
          helper.getNode(id).receive(inner);
        } finally {
          spy.restore();
        }
      };
      const sample = { topic: 'station-3/sensor/volume/state', payload: { ts: clock().now(), value: 7 } };
      const outer = { topic: sample.topic, payload: { ts: clock().now(), get value() { counted('bus', sample); return 7; } } };
      helper.getNode('bus').receive(outer);
      await reentered('bus', sample);
      assert.deepEqual(calls, [], 'the plant\'s core not called for it');
      const out = seen.rccout.length;
      const inner = { payload: { procVar: 40, lastAction: 10, agesMs: [null, null] } };
      const first = { payload: { procVar: 40, lastAction: 10, agesMs: [20, null] } };
      Object.defineProperty(first.payload.agesMs, 0, { enumerable: true, get() { counted('rcc', inner); return 20; } });
      helper.getNode('rcc').receive(first);
      await reentered('rcc', inner);
      assert.deepEqual(calls, [], 'the rcc\'s core object not called for it');
      assert.equal(seen.rccout.length, out + 1, 'the first msg decided');
    });

    it('refused re-entries leave the core\'s memory as it was (the refused call allocates nothing in wasm)', async function () {
      this.timeout(30000);
      await start();
      const bytes = () => wasm.load().wasmMemory().buffer.byteLength;
      let last = null;
      /** `n` samples, each with a getter that sends another sample in, which is refused. */
      const feed = (n) => {
        for (let i = 0; i < n; i++) {
          const inner = { topic: 'station-3/sensor/volume/state', payload: { ts: clock().now(), value: i } };
          const outer = { topic: inner.topic, payload: { ts: clock().now(), get value() { helper.getNode('bus').receive(inner); return i; } } };
          helper.getNode('bus').receive(outer);
          last = inner;
        }
      };
      feed(1000);
      await quiet();
      const before = bytes();
      // Memory grows in 64 KiB pages: 10,000 refusals leaking 16 bytes each would take more than two.
      feed(10000);
      await quiet();
      console.log(`      wasm memory ${before} -> ${bytes()} bytes over 10,000 refused re-entries`);
      await reentered('bus', last);
      assert.equal(bytes(), before, 'no page added');
    });

    it('a borrow refused is a trap (a borrow left open by an earlier one), in a msg\'s read too: a msg is refused before it could make one', function () {
      const { borrow: err, ownership } = gluesBorrowErrors();
      assert.equal(err.message, BORROW_WORDS);
      assert.equal(ownership.message, OWNERSHIP_WORDS);
      assert.equal(wasm.isTrap(err), true);
      assert.equal(wasm.isTrap(ownership), true);
      assert.equal(wasm.reading({ reading: false }, () => wasm.isTrap(err)), true);
      // The same words thrown by JS code (a msg's getter), or quoted by a refusal, are not.
      assert.equal(wasm.isTrap(new Error(BORROW_WORDS)), false);
      assert.equal(wasm.isTrap(new Error(OWNERSHIP_WORDS)), false);
      assert.equal(wasm.isTrap(new Error(`cannot be turned into JSON (Error: ${BORROW_WORDS})`)), false);
      // Nor a message written to look like the glue's stack.
      const frame = String(err.stack).split('\n')[1];
      assert.equal(wasm.isTrap(new Error(`${BORROW_WORDS}\n${frame}`)), false);
      assert.equal(wasm.isTrap(new WebAssembly.RuntimeError(`unreachable\n    at wasm://wasm/0:wasm-function[1]:0x1`)), false);
      const owner = { reading: false };
      assert.throws(() => wasm.reading(owner, () => wasm.entering(owner)), (e) => e.code === 'INVALID_INPUT' && /while the core was still reading/.test(e.message));
      assert.equal(owner.reading, false, 'unmarked once its read ends');
      assert.equal(wasm.isTrap(new Error('unreachable')), false);
    });
  });

  describe('a wasm instance that really traps', function () {
    let uncaught;
    const onUncaught = (err) => uncaught.push(err);

    beforeEach(function () {
      uncaught = [];
      process.on('uncaughtException', onUncaught);
    });

    afterEach(function () {
      process.removeListener('uncaughtException', onUncaught);
    });

    /** Sets the state every runtime must come back to: h holds YEL, GRN faulted by hand, a routine, loops that ran. */
    async function before() {
      const { seen, panel } = await start();
      helper.getNode('stop').receive({ resources: 'GRN', payload: 'e-stop GRN' });
      await until(() => seen.lockouts.length === 1, 'the GRN lockout');
      await until(() => runtimeOf('il').routines.get('truck'), 'the routine host');
      helper.getNode('pid').receive({ payload: 40 });
      helper.getNode('rcc').receive({ payload: { procVar: 40, lastAction: 10, agesMs: [null, null] } });
      await until(() => seen.pidout.length === 1 && seen.rccout.length === 1, 'the loops stepping');
      await quiet();
      assert.deepEqual(liveLines(), { YEL: 'held', GRN: 'faulted:manual', RED: 'free' });
      return { seen, panel };
    }

    async function after(seen, generation, { core, tracker }) {
      await until(() => wasm.currentGeneration() === generation + 1, 'the new instance');
      await quiet();
      assert.equal(wasm.currentGeneration(), generation + 1, 'one rebuild');
      const il = runtimeOf('il');
      const pl = runtimeOf('pl');
      assert.equal(il.state, 'ready');
      assert.equal(pl.state, 'ready');
      assert.notEqual(il.core, core, 'the interlock rebuilt');
      assert.notEqual(pl.t, tracker, 'the plant tracker rebuilt');
      assert.equal(il.generation, generation + 1);
      assert.equal(pl.generation, generation + 1);
      assert.deepEqual(liveLines(), { YEL: 'faulted:interrupted', GRN: 'faulted:manual', RED: 'free' }, 'from the last saved state');
      // Everything on the new instance: nothing left on the one that trapped.
      const fresh = require(path.join(PALETTE, 'wasm', 'sugarshack_wasm.js'));
      assert.ok(il.core instanceof fresh.Engine);
      assert.ok(pl.t instanceof fresh.Tracker);
      assert.ok(il.routines.get('truck').machine instanceof fresh.Routine, 'the routine rebuilt');
      assert.equal(il.routines.get('truck').machine.state(), 'empty');
      // The loops keep working on the new instance.
      const pidOut = seen.pidout.length;
      helper.getNode('pid').receive({ payload: 41 });
      await until(() => seen.pidout.length === pidOut + 1, 'a pid step after the rebuild');
      assert.ok(Number.isFinite(seen.pidout.at(-1).payload));
      const rccOut = seen.rccout.length;
      helper.getNode('rcc').receive({ payload: { procVar: 41, lastAction: 12, agesMs: [20, null] } });
      await until(() => seen.rccout.length === rccOut + 1, 'an rcc decision after the rebuild');
      assert.equal(seen.rccout.at(-1).rcc.engaged, true);
      // A free line is granted; one faulted by the rebuild queues.
      const granted = seen.granted.length;
      helper.getNode('acq').receive({ operation: 'red', resources: 'RED' });
      await until(() => seen.granted.length === granted + 1, 'the grant on RED');
      helper.getNode('acq').receive({ operation: 'yel', resources: 'YEL' });
      await quiet();
      assert.deepEqual(runtimeOf('il').core.snapshot(0).queue.map((q) => q.operation), ['yel']);
      assert.equal(seen.granted.length, granted + 1);
      // The plant completes a command on its new tracker (the panel reports every position again).
      const out = seen.gcout.length;
      helper.getNode('gc').receive({ payload: { valves: { V501: 100 } } });
      await until(() => seen.gcout.length === out + 1, 'a group command after the rebuild');
      // Clearing the interrupted line lets the waiter through.
      helper.getNode('clr').receive({ resources: 'YEL' });
      await until(() => seen.granted.length === granted + 2, 'the waiter granted once YEL is cleared');
      assert.equal(seen.granted.at(-1).interlock.operation, 'yel');
      assert.deepEqual(uncaught, [], 'no uncaught exception');
    }

    it('a trap in a msg: the msg ends INTERNAL, every runtime rebuilds from its last saved state', async function () {
      const { seen } = await before();
      const generation = wasm.currentGeneration();
      const core = runtimeOf('il').core;
      const tracker = runtimeOf('pl').t;
      core.__wbg_ptr = 0x7ffffff0; // eslint-disable-line no-underscore-dangle
      const msg = { operation: 'x', resources: 'RED' };
      helper.getNode('acq').receive(msg);
      await until(() => completionsOf('acq', msg).length === 1, 'the msg to complete');
      const err = completionsOf('acq', msg)[0].error;
      assert.equal(err.code, 'INTERNAL');
      assert.match(err.message, /rebuilt/);
      assert.ok(err.message.length < 400);
      await after(seen, generation, { core, tracker });
    });

    it('a warm-up that traps the instance made for the rebuild: that one is dropped, every runtime rebuilds on a fresh one', async function () {
      const { seen } = await before();
      const generation = wasm.currentGeneration();
      const core = runtimeOf('il').core;
      const tracker = runtimeOf('pl').t;
      const { prime } = wasm;
      const { emitWarning } = process;
      const warnings = [];
      let warmed = null;
      // As a warm-up calling a changed signature did: a call that traps the instance it warms.
      wasm.prime = (facade) => {
        wasm.prime = prime;
        warmed = facade;
        const t = new facade.Tracker(wasm.SAMPLE_PLANT, 0);
        t.__wbg_ptr = 0x7ffffff0; // eslint-disable-line no-underscore-dangle
        t.counts();
      };
      process.emitWarning = (warning) => warnings.push(String(warning));
      try {
        core.__wbg_ptr = 0x7ffffff0; // eslint-disable-line no-underscore-dangle
        const msg = { operation: 'x', resources: 'RED' };
        helper.getNode('acq').receive(msg);
        await until(() => completionsOf('acq', msg).length === 1, 'the msg to complete');
        assert.equal(completionsOf('acq', msg)[0].error.code, 'INTERNAL');
        await after(seen, generation, { core, tracker });
      } finally {
        wasm.prime = prime;
        process.emitWarning = emitWarning;
      }
      assert.ok(warmed, 'the rebuild warmed its instance');
      assert.notEqual(wasm.load(), warmed, 'the instance the warm-up trapped is not the one in use');
      assert.ok(warnings.some((w) => /warm-up failed/.test(w)), `the failed warm-up is told: ${warnings.join('; ')}`);
    });

    it('a trap in the plant tick (a timer): no uncaught exception, every runtime rebuilds', async function () {
      const { seen } = await before();
      const generation = wasm.currentGeneration();
      const core = runtimeOf('il').core;
      const tracker = runtimeOf('pl').t;
      tracker.__wbg_ptr = 0x7ffffff0; // eslint-disable-line no-underscore-dangle
      // To the plant's one timer: the core's next wake (its first staleness check).
      const timer = runtimeOf('pl').deadline;
      assert.ok(timer, 'the plant keeps a timer');
      await clock().advance(Math.max(1, timer.at - clock().now()));
      await settle();
      assert.deepEqual(uncaught, []);
      assert.ok(allTexts().some((t) => /trapped|core failed/.test(t)), 'the trap was logged');
      await after(seen, generation, { core, tracker });
    });

    /** A pid msg whose loop's `measure` runs `trapping(original, args)` on its wasm object: that msg ends INTERNAL, every runtime rebuilds. */
    async function pidTrapped(trapping) {
      const { seen } = await before();
      const generation = wasm.currentGeneration();
      const core = runtimeOf('il').core;
      const tracker = runtimeOf('pl').t;
      // The pid node's loop is private to it: reach it through the rebuild hook the node registered.
      const mem = require(path.join(PALETTE, 'wasm', 'sugarshack_wasm.js'));
      const original = mem.PidStation.prototype.measure;
      mem.PidStation.prototype.measure = function trapped(...args) {
        return trapping.call(this, original, args);
      };
      try {
        const msg = { payload: 42 };
        helper.getNode('pid').receive(msg);
        await until(() => completionsOf('pid', msg).length === 1, 'the pid msg to complete');
        assert.equal(completionsOf('pid', msg)[0].error.code, 'INTERNAL');
      } finally {
        mem.PidStation.prototype.measure = original;
      }
      await after(seen, generation, { core, tracker });
    }

    it('a trap in a pid node\'s loop: that msg ends INTERNAL, every runtime rebuilds', async function () {
      await pidTrapped(function trapping(original, args) {
        this.__wbg_ptr = 0x7ffffff0; // eslint-disable-line no-underscore-dangle
        return original.apply(this, args);
      });
    });

    it('a borrow wasm-bindgen\'s glue refuses in a pid node\'s loop (as for one left open): that msg ends INTERNAL, every runtime rebuilds', async function () {
      const { borrow } = gluesBorrowErrors();
      await pidTrapped(() => {
        throw borrow;
      });
    });
  });
});
