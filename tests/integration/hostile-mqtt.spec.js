'use strict';
// Anyone who can publish to the broker can send anything. A real Node-RED
// process runs the palette's nodes behind `mqtt in`, against a real Mosquitto;
// each node that reads msgs gets, over MQTT, a payload nested 10,000 levels
// deep, the same made circular (by a function node, as a flow could), and a
// 1 MB payload. Each msg ends with a coded error a Catch node sees (never
// INTERNAL) or is counted as bad feedback; the process stays alive; the
// interlock still grants a free line and queues on a held one afterwards.
//
// Run: npx mocha --timeout 30000 --exit tests/integration/hostile-mqtt.spec.js
const assert = require('node:assert/strict');
const fs = require('fs');
const path = require('path');
const { startMosquitto } = require('./support/mosquitto');
const { connectProbe } = require('./support/mqtt-probe');
const { NodeRedProcess, mqttBroker, sleep, waitFor, waitWhileMoving } = require('./support/node-red');
const { loadPlant } = require('../../scripts/simulator/plant');

const PLANT = loadPlant(path.join(__dirname, 'fixtures', 'plant-routines.json'));
const DEPTH = 10000;
const deepArray = () => `${'['.repeat(DEPTH)}1${']'.repeat(DEPTH)}`;
const deepObject = () => `${'{"a":'.repeat(DEPTH)}1${'}'.repeat(DEPTH)}`;
const megabyte = () => JSON.stringify({ valves: { V101: 'x'.repeat(1024 * 1024) } });

// Where each hostile value lands in the msg, per node (the function node's body).
// `text`: a node reading a name or a number there gets the megabyte as a string.
const TARGETS = {
  'group-command': { node: { type: 'sugarshack-group-command', plant: 'pl', timeout: 5 }, put: 'msg.payload = v;' },
  'actuators-command': { node: { type: 'sugarshack-actuators', plant: 'pl', devices: '', broker: 'br' }, put: 'msg.topic = "cmd"; msg.payload = v;', outputs: 3 },
  'actuators-batch': { node: { type: 'sugarshack-actuators', plant: 'pl', devices: '', broker: 'br' }, put: 'msg.topic = "ctrl-1/state"; msg.payload = v;', outputs: 3, counted: true },
  'actuators-sensor': { node: { type: 'sugarshack-actuators', plant: 'pl', devices: '', broker: 'br' }, put: 'msg.topic = "station-3/sensor/volume/state"; msg.payload = v;', outputs: 3, counted: true },
  'acquire-resources': { node: { type: 'sugarshack-acquire', interlock: 'il', operation: 'x1', priority: 1, resources: '', timeout: 0 }, put: 'msg.resources = v;', text: true },
  'acquire-priority': { node: { type: 'sugarshack-acquire', interlock: 'il', operation: 'x2', priority: '', resources: 'PUR', timeout: 0 }, put: 'msg.priority = v;', text: true },
  'acquire-operation': { node: { type: 'sugarshack-acquire', interlock: 'il', operation: '', priority: 1, resources: 'PUR', timeout: 0 }, put: 'msg.operation = v;', text: true },
  'release-operation': { node: { type: 'sugarshack-release', interlock: 'il', operation: '' }, put: 'msg.operation = v;', text: true },
  'fault-operation': { node: { type: 'sugarshack-fault', interlock: 'il', mode: 'operation', operation: '', resources: '' }, put: 'msg.operation = v;', outputs: 2, text: true },
  'clear-resources': { node: { type: 'sugarshack-clear', interlock: 'il', mode: 'list', resources: '' }, put: 'msg.resources = v;', text: true },
  'routine-topic': { node: { type: 'sugarshack-routine', interlock: 'il', routine: 'truck' }, put: 'msg.topic = v;', text: true },
  'pid-tunings': {
    node: { type: 'sugarshack-pid', kp: '1', ti: '10', td: '0', outMin: '0', outMax: '100', action: 'reverse', ts: '1', setpoint: '50', smith: 'off', mode: 'auto', persist: false },
    put: 'msg.tunings = { kp: v };',
    text: true,
  },
  'rcc-state': { node: { type: 'sugarshack-rcc', controller: '1', thresholdsS: '1,2', tsS: '0.5', pollTimeoutS: '' }, put: 'msg.payload = { procVar: 1, lastAction: 1, agesMs: v };' },
};

function flow(port) {
  const nodes = [
    { id: 'tab', type: 'tab', label: 'hostile' },
    mqttBroker('br', port),
    { id: 'pl', type: 'sugarshack-plant', name: 'routines plant', plant: PLANT },
    { id: 'il', type: 'sugarshack-interlock', name: 'lines', plant: 'pl', resources: [], policy: 'greedy', persist: true },
    // The interlock still working: test/acquire/<op> acquires YEL, test/release/<op> releases it.
    { id: 'in-acq', z: 'tab', type: 'mqtt in', topic: 'test/acquire/+', qos: '1', datatype: 'utf8', broker: 'br', nl: false, rap: true, rh: 0, inputs: 0, wires: [['opname']] },
    {
      id: 'opname', z: 'tab', type: 'function', func: 'msg.operation = msg.topic.split("/")[2]; return msg;', outputs: 1, wires: [['acq']],
    },
    { id: 'acq', z: 'tab', type: 'sugarshack-acquire', interlock: 'il', operation: '', priority: 1, resources: 'YEL', timeout: 0, wires: [['grant']] },
    {
      id: 'grant', z: 'tab', type: 'function', func: 'msg.payload = msg.interlock; return msg;', outputs: 1, wires: [['granted']],
    },
    { id: 'granted', z: 'tab', type: 'mqtt out', topic: 'test/granted', qos: '1', retain: 'false', broker: 'br', wires: [] },
    { id: 'in-rel', z: 'tab', type: 'mqtt in', topic: 'test/release/+', qos: '1', datatype: 'utf8', broker: 'br', nl: false, rap: true, rh: 0, inputs: 0, wires: [['relname']] },
    {
      id: 'relname', z: 'tab', type: 'function', func: 'msg.operation = msg.topic.split("/")[2]; return msg;', outputs: 1, wires: [['rel']],
    },
    { id: 'rel', z: 'tab', type: 'sugarshack-release', interlock: 'il', operation: '', wires: [[]] },
    // Every error, summed up: which node, its code, how long its message is.
    { id: 'catchall', z: 'tab', type: 'catch', scope: null, uncaught: false, wires: [['summary']] },
    {
      id: 'summary',
      z: 'tab',
      type: 'function',
      func: 'msg.payload = { source: msg.error.source && msg.error.source.id, code: msg.error.code || null, length: String(msg.error.message).length }; '
        + 'delete msg.error; for (const k of Object.keys(msg)) if (!["payload", "_msgid"].includes(k)) delete msg[k]; return msg;',
      outputs: 1,
      wires: [['errors']],
    },
    { id: 'errors', z: 'tab', type: 'mqtt out', topic: 'test/errors', qos: '1', retain: 'false', broker: 'br', wires: [] },
    // Statuses too: a Catch node clones the msg it gets, and Node-RED's own clone cannot go 10,000 levels deep.
    { id: 'statusall', z: 'tab', type: 'status', scope: null, wires: [['statussummary']] },
    {
      id: 'statussummary', z: 'tab', type: 'function', func: 'msg.payload = { source: msg.status.source.id, fill: msg.status.fill, text: msg.status.text }; return msg;',
      outputs: 1, wires: [['statusout']],
    },
    { id: 'statusout', z: 'tab', type: 'mqtt out', topic: 'test/status', qos: '1', retain: 'false', broker: 'br', wires: [] },
    // Bad feedback counted by an actuators node: its malformed events.
    {
      id: 'badcount', z: 'tab', type: 'function', func: 'if (msg.payload && msg.payload.kind === "malformed") { msg.payload = { node: msg.bus, reason: msg.payload.reason, count: msg.payload.count }; return msg; } return null;',
      outputs: 1, wires: [['bad']],
    },
    { id: 'bad', z: 'tab', type: 'mqtt out', topic: 'test/bad', qos: '1', retain: 'false', broker: 'br', wires: [] },
  ];
  for (const [name, target] of Object.entries(TARGETS)) {
    for (const variant of ['deep', 'circular', 'big']) {
      nodes.push({
        id: `in-${name}-${variant}`, z: 'tab', type: 'mqtt in', topic: `hostile/${variant}/${name}`, qos: '1', datatype: 'json', broker: 'br',
        nl: false, rap: true, rh: 0, inputs: 0, wires: [[`shape-${name}-${variant}`]],
      });
      const cycle = variant === 'circular' ? 'v = { valves: { V101: 1 }, list: [1, 2] }; v.self = v; v.list.push(v); ' : '';
      const text = variant === 'big' && target.text ? 'v = v.valves.V101; ' : '';
      nodes.push({
        id: `shape-${name}-${variant}`, z: 'tab', type: 'function', func: `let v = msg.payload; ${cycle}${text}${target.put} return msg;`, outputs: 1, wires: [[`t-${name}`]],
      });
    }
    const outputs = target.outputs || 1;
    const wires = Array.from({ length: outputs }, () => []);
    if (target.counted) wires[2] = ['tagbus'];
    nodes.push({ id: `t-${name}`, z: 'tab', ...target.node, wires });
  }
  nodes.push({
    id: 'tagbus', z: 'tab', type: 'function', func: 'msg.bus = "actuators"; return msg;', outputs: 1, wires: [['badcount']],
  });
  return nodes;
}

describe('hostile MQTT payloads against a real Node-RED process', function () {
  this.timeout(180000);
  let broker;
  let probe;
  let red;

  before(async function () {
    broker = await startMosquitto();
    probe = await connectProbe(broker.url, ['test/#']);
    red = new NodeRedProcess({ flows: flow(broker.port), tag: 'hostile' });
    await red.start();
  });

  after(async function () {
    if (red) await red.finish(this.currentTest);
    if (probe) await probe.end();
    if (broker) await broker.stop();
  });

  let probeCount = 0;
  /** The interlock still grants a free line and queues a second request on it until the first releases. */
  async function interlockWorks() {
    probeCount += 1;
    const [a, b] = [`probe-a${probeCount}`, `probe-b${probeCount}`];
    const granted = () => probe.on('test/granted').map((m) => m.json && m.json.operation);
    await probe.publish(`test/acquire/${a}`, 'go');
    await waitFor(() => granted().includes(a), `${a} granted`);
    await probe.publish(`test/acquire/${b}`, 'go');
    await sleep(200);
    assert.equal(granted().includes(b), false, `${b} queues while ${a} holds YEL`);
    await probe.publish(`test/release/${a}`, 'done');
    await waitFor(() => granted().includes(b), `${b} granted after the release`);
    await probe.publish(`test/release/${b}`, 'done');
  }

  for (const variant of ['deep', 'circular', 'big']) {
    it(`${variant} payloads: every node answers with a coded error (or counts bad feedback); Node-RED stays up; the interlock still works`, async function () {
      const payload = variant === 'deep' ? deepArray() : variant === 'big' ? megabyte() : '{"a": 1}';
      for (const [name, target] of Object.entries(TARGETS)) {
        const errorsBefore = probe.on('test/errors').length;
        const badBefore = probe.on('test/bad').length;
        const statusesBefore = probe.on('test/status').length;
        await probe.publish(`hostile/${variant}/${name}`, payload);
        if (variant === 'deep') await probe.publish(`hostile/${variant}/${name}`, deepObject());
        const expected = variant === 'deep' ? 2 : 1;
        if (target.counted) {
          await waitFor(() => probe.on('test/bad').length >= badBefore + expected, `${name}: bad feedback counted`);
        } else if (variant === 'deep') {
          // The refusal shows as the node's red status, worded from its code.
          const refusals = () => probe.on('test/status').slice(statusesBefore).map((m) => m.json).filter((st) => st.source === `t-${name}` && st.fill === 'red');
          await waitFor(() => refusals().length >= 1, `${name}: a red status`);
          for (const st of refusals()) assert.notEqual(st.text, 'internal error', `${name} (${variant})`);
        } else {
          await waitFor(() => probe.on('test/errors').length >= errorsBefore + expected, `${name}: the error at the Catch node`);
          for (const e of probe.on('test/errors').slice(errorsBefore).map((m) => m.json)) {
            assert.equal(e.source, `t-${name}`, JSON.stringify(e));
            assert.ok(e.code && e.code !== 'INTERNAL', `${name} (${variant}): code ${e.code}`);
            assert.ok(e.length < 500, `${name} (${variant}): a ${e.length}-character message`);
          }
        }
        assert.ok(red.alive, `Node-RED alive after ${name}`);
      }
      const state = await red.get('/sugarshack/state');
      assert.equal(state.interlocks[0].state, 'ready');
      assert.equal(state.plants[0].state, 'ready');
      await interlockWorks();
      assert.equal(/uncaught|RuntimeError|recursive use/i.test(red.logOfThisRun()), false, red.logOfThisRun().slice(-2000));
    });
  }

  it('a new operation name per msg, 5,000 from the broker: idle names are forgotten, the saved state stays small, and a SIGKILL brings back the last hold', async function () {
    const granted = () => probe.on('test/granted').map((m) => m.json && m.json.operation);
    const errorsBefore = probe.on('test/errors').length;
    // 'steady' is granted and released first: its handle is cached by name, then forgotten with the idle batches.
    await probe.publish('test/acquire/steady', 'go');
    await waitFor(() => granted().includes('steady'), 'steady granted');
    await probe.publish('test/release/steady', 'done');
    const batches = 5000; // past the 4,096 names an interlock keeps
    // Sent in order on one connection, a hundred pairs at a time, at most 300
    // pairs ahead of the grants: Mosquitto drops QoS 1 msgs past 1,000 queued
    // for a client (max_queued_messages), which would lose a release.
    const batchesGranted = () => granted().filter((op) => op && op.startsWith('batch-')).length;
    for (let i = 0; i < batches; i += 100) {
      await waitWhileMoving(() => batchesGranted() >= i - 300, batchesGranted, `batch-${i - 300} granted`);
      const pairs = [];
      for (let k = i; k < i + 100; k++) pairs.push(probe.publish(`test/acquire/batch-${k}`, 'go'), probe.publish(`test/release/batch-${k}`, 'done'));
      await Promise.all(pairs);
    }
    await waitWhileMoving(() => granted().includes(`batch-${batches - 1}`), batchesGranted, 'the last batch granted');
    // Granted only once the last batch released YEL; then it holds YEL when Node-RED is killed.
    await probe.publish('test/acquire/steady', 'again');
    await waitFor(() => granted().filter((op) => op === 'steady').length === 2, 'steady granted again', 30000);
    assert.deepEqual(probe.on('test/errors').slice(errorsBefore).map((m) => m.json), [], 'no refusal: no stale handle, no lost release');
    const saved = path.join(red.dir, 'sugarshack');
    const largest = Math.max(...fs.readdirSync(saved).map((f) => fs.statSync(path.join(saved, f)).size));
    assert.ok(largest < 64 * 1024, `the largest saved state file is ${largest} bytes after ${batches} names`);

    await red.kill();
    await red.start();
    const lines = await red.lines('il');
    assert.equal(lines.YEL, 'faulted:interrupted', 'the hold of steady comes back faulted, not free and not lost');
    const state = await red.get('/sugarshack/state');
    assert.equal(state.interlocks[0].state, 'ready');
    assert.equal(/uncaught|RuntimeError|recursive use/i.test(red.logOfThisRun()), false, red.logOfThisRun().slice(-2000));
  });
});
