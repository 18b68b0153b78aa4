'use strict';
// Deploys as the editor's Deploy button makes them (POST /flows on the admin
// API of a real Node-RED process), while operations run against a real
// Mosquitto and the simulator:
//
// - a full deploy of unchanged flows: every running operation returns its msg
//   normally, the one waiting in the queue is granted later, nothing faults,
//   no line is interrupted, every line ends free;
// - a deploy that changes the plant document while an operation runs: the
//   interlock drains (the state API says so), the operation finishes with the
//   document it started with, then the new document applies (an operation
//   only it has runs, after waiting through the drain).
//
// Run: npx mocha --timeout 30000 --exit tests/integration/deploy-api.spec.js
const assert = require('node:assert/strict');
const { startMosquitto } = require('./support/mosquitto');
const { connectProbe } = require('./support/mqtt-probe');
const { startTestSimulator } = require('./support/simulator');
const { NodeRedProcess, sleep, waitFor } = require('./support/node-red');
const { PLANT_FILE, LINES, flow } = require('./support/routines-flow');

describe('deploys through the admin API of a real Node-RED process, operations running', function () {
  this.timeout(120000);
  let broker;
  let sim;
  let probe;
  let red;
  let flows;

  before(async function () {
    broker = await startMosquitto();
    sim = await startTestSimulator(broker.url, { plant: PLANT_FILE, speed: 10, sweepS: 1, pumpDelayMs: 200 });
    probe = await connectProbe(broker.url, ['test/#']);
    flows = flow(broker.port, 'deploys');
    red = new NodeRedProcess({ flows, tag: 'deploy' });
    await red.start();
    await subscribed();
  });

  // "Connected to broker" is logged before the mqtt in nodes subscribe: until the
  // broker has their subscriptions, a request published is lost. The clear nodes
  // subscribe after the operations' nodes; clearing a free line answers on test/errors.
  // Probes answered late would count as a test's errors: once one is answered, a last
  // clear of another line is, and its answer comes after every probe's (one connection, in order).
  // Even so, a probe's answer has been seen once after a test began. These tests clear nothing
  // themselves, so a clear's refusal is always a probe's answer: no test counts it.
  async function subscribed() {
    const line = LINES[LINES.length - 1];
    for (const deadline = Date.now() + 20000; ; await sleep(200)) {
      if (probe.on('test/errors').length > 0) break;
      if (Date.now() > deadline) throw new Error('Node-RED never answered on test/errors');
      await probe.publish(`test/clear/${line}`, 'probe');
    }
    const last = LINES[0];
    await probe.publish(`test/clear/${last}`, 'probe');
    await waitFor(() => probe.on('test/errors').some((m) => m.json.source && m.json.source.id === `clear-${last}`), 'the last probe answered', 20000);
  }

  after(async function () {
    if (red) await red.finish(this.currentTest);
    if (probe) await probe.end();
    if (sim) await sim.stop();
    if (broker) await broker.stop();
  });

  const waitLong = (predicate, what) => waitFor(predicate, what, 20000);
  const events = (since) => probe.on('test/events').filter((m) => m.at >= since).map((m) => m.json);
  const done = (since) => probe.on('test/done').filter((m) => m.at >= since).map((m) => ({ ...m.json, at: m.at }));
  const probeAnswer = (m) => m.json.code === 'NOT_FAULTED' && m.json.source && /^clear-/.test(m.json.source.id);
  const errors = (since) => probe.on('test/errors').filter((m) => m.at >= since && !probeAnswer(m)).map((m) => m.json);

  it('a full deploy of unchanged flows: running operations return normally, the waiting one is granted later, nothing faults', async function () {
    const since = Date.now();
    await probe.publish('test/op/10', 'go'); // YEL
    await probe.publish('test/op/51', 'go'); // RED
    await waitLong(() => ['10', '51'].every((op) => events(since).some((e) => e.kind === 'granted' && e.operation === op)), 'ops 10 and 51 granted');
    await probe.publish('test/op/41', 'go'); // PUR and RED: waits behind 51
    await waitLong(() => events(since).some((e) => e.kind === 'queued' && e.operation === '41'), 'op 41 queued');
    assert.equal(done(since).length, 0, 'nothing has returned before the deploy');

    await red.deploy(flows, 'full');
    await waitLong(() => /Started flows/.test(red.logOfThisRun().split('Updated flows').slice(1).join('')), 'the deploy to start the flows again');
    const restartedAt = Date.now();

    await waitLong(() => ['10', '51', '41'].every((op) => done(since).some((d) => d.id === op)), 'all three operations returned');
    // Op 41 was still waiting when the flows restarted: it ran, and returned, through the new node instances.
    assert.ok(done(since).find((d) => d.id === '41').at > restartedAt, 'op 41 returned after the deploy');
    assert.deepEqual(errors(since), [], 'no error reached a Catch node');
    const kinds = events(since).map((e) => e.kind);
    for (const bad of ['faulted', 'resource-faulted', 'interrupted', 'state-unknown']) {
      assert.equal(kinds.includes(bad), false, `no ${bad} event: ${kinds.join(', ')}`);
    }
    await waitLong(async () => Object.values(await red.lines('il')).every((s) => s === 'free'), 'every line free');
    assert.ok(red.alive);
  });

  it('a deploy that changes the plant document while an operation runs drains, then applies the new document', async function () {
    // V101 slowed: op 10 is still running while the deploy drains.
    await sim.inject({ fault: 'slow', device: 'ctrl-1', valve: 1, factor: 5 });
    const since = Date.now();
    await probe.publish('test/op/10', 'go');
    await waitLong(() => events(since).some((e) => e.kind === 'granted' && e.operation === '10'), 'op 10 granted');

    // The new document has an operation 99 on PUR, and the new flows a node and a topic for it.
    const changed = flows.map((n) => {
      if (n.type !== 'sugarshack-plant') return n;
      const plant = JSON.parse(JSON.stringify(n.plant));
      plant.operations.push({ id: '99', priority: 5, resources: ['PUR'], steps: [{ command: { valves: { V401: 100 } }, timeoutMs: 5000 }] });
      return { ...n, plant };
    });
    const op99 = flows.filter((n) => n.id === 'in-op-12' || n.id === 'op-12').map((n) => JSON.parse(JSON.stringify(n).replace(/12/g, '99')));
    await red.deploy([...changed, ...op99], 'full');
    await waitLong(async () => (await red.get('/sugarshack/state')).interlocks[0].draining, 'the interlock draining');
    await waitLong(() => /Connected to broker/.test(red.logOfThisRun().split('Updated flows').pop()), 'the new flows subscribed');
    await sleep(100);
    await probe.publish('test/op/99', 'go'); // waits for the drain: op 99 is in the new document only
    await sleep(200);
    assert.equal(done(since).some((d) => d.id === '99'), false, 'op 99 waits while op 10 runs');

    await waitLong(() => done(since).some((d) => d.id === '10'), 'op 10 returned');
    await sim.inject({ fault: 'clear' });
    await waitLong(async () => !(await red.get('/sugarshack/state')).interlocks[0].draining, 'the drain over');
    await waitLong(() => done(since).some((d) => d.id === '99'), 'op 99 returned, run from the new document');
    assert.ok(done(since).find((d) => d.id === '99').at > done(since).find((d) => d.id === '10').at, 'after op 10');
    assert.deepEqual(errors(since), []);
    assert.equal(events(since).some((e) => ['faulted', 'interrupted'].includes(e.kind)), false);
    await waitLong(async () => Object.values(await red.lines('il')).every((s) => s === 'free'), 'every line free');
  });
});
