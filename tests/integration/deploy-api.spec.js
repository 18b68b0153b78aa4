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
//   only it has runs, after waiting through the drain);
// - an acquire sent while such a deploy drains waits in the core, its timeout
//   running on the process's clock: it is refused (ACQUIRE_TIMEOUT, to a Catch
//   node) while the drain still goes on, and never granted after it.
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

  /** The suite's flows, their plant document changed by `change(plant)` on a copy. */
  const withPlant = (change) => flows.map((n) => {
    if (n.type !== 'sugarshack-plant') return n;
    const plant = JSON.parse(JSON.stringify(n.plant));
    change(plant);
    return { ...n, plant };
  });

  /** No event since `since` says a line faulted or was interrupted, and every line ends free. */
  async function noFaultAndFree(since) {
    const kinds = events(since).map((e) => e.kind);
    for (const bad of ['faulted', 'resource-faulted', 'interrupted', 'state-unknown']) {
      assert.equal(kinds.includes(bad), false, `no ${bad} event: ${kinds.join(', ')}`);
    }
    await waitLong(async () => Object.values(await red.lines('il')).every((s) => s === 'free'), 'every line free');
  }

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
    await noFaultAndFree(since);
    assert.ok(red.alive);
  });

  it('a deploy that changes the plant document while an operation runs drains, then applies the new document', async function () {
    // V101 slowed: op 10 is still running while the deploy drains.
    await sim.inject({ fault: 'slow', device: 'ctrl-1', valve: 1, factor: 5 });
    const since = Date.now();
    await probe.publish('test/op/10', 'go');
    await waitLong(() => events(since).some((e) => e.kind === 'granted' && e.operation === '10'), 'op 10 granted');

    // The new document has an operation 99 on PUR, and the new flows a node and a topic for it.
    const changed = withPlant((plant) => {
      plant.operations.push({ id: '99', priority: 5, resources: ['PUR'], steps: [{ command: { valves: { V401: 100 } }, timeoutMs: 5000 }] });
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

  it('an acquire sent while a deploy drains times out on the process\'s clock (ACQUIRE_TIMEOUT to a Catch node) before the drain ends', async function () {
    // Op 97 holds YEL in a wait on LT-9, a sensor of station-9, which this test plays:
    // the drain lasts until the test lets the wait hold (or op 97's 60 s timeout).
    const withHold = (threshold) => {
      const nodes = withPlant((plant) => {
        plant.devices.push({ id: 'station-9', kind: 'sensor-station' });
        plant.sensors.push({ id: 'LT-9', device: 'station-9', name: 'volume', unit: 'L' });
        plant.operations.push({ id: '97', priority: 5, resources: ['YEL'], steps: [{ wait: `\`LT-9\` >= ${threshold}`, sensors: ['LT-9'], timeoutMs: 60000 }] });
      });
      const mqttIn = flows.find((n) => n.id === 'in-station-3');
      return [
        ...nodes,
        { ...mqttIn, id: 'in-station-9', topic: 'station-9/#' },
        // Injects, as the editor's inject button does (POST /inject/:id): no wait for an mqtt in's subscription.
        { id: 'inj-97', z: 'tab', type: 'inject', props: [{ p: 'payload' }], payload: 'go', payloadType: 'str', repeat: '', once: false, wires: [['op-97']] },
        { id: 'op-97', z: 'tab', type: 'sugarshack-operation', interlock: 'il', operation: '97', wires: [['opdone']] },
        { id: 'inj-acq', z: 'tab', type: 'inject', props: [{ p: 'payload' }], payload: 'by hand', payloadType: 'str', repeat: '', once: false, wires: [['acq']] },
        {
          id: 'acq', z: 'tab', type: 'sugarshack-acquire', interlock: 'il', operation: 'by hand', priority: 0, resources: 'YEL', timeout: 1, wires: [['grantedout']],
        },
        { id: 'grantedout', z: 'tab', type: 'mqtt out', topic: 'test/granted', qos: '1', retain: 'false', broker: 'br', wires: [] },
      ];
    };
    // A deploy's flows run, and publish (an mqtt out drops what it gets before its broker is connected).
    const deploy = async (nodes, what) => {
      const deploys = red.logOfThisRun().split('Updated flows').length;
      await red.deploy(nodes, 'full');
      await waitLong(() => {
        const parts = red.logOfThisRun().split('Updated flows');
        return parts.length > deploys && ['Started flows', 'Connected to broker'].every((line) => parts.at(-1).includes(line));
      }, what);
    };
    const draining = async () => (await red.get('/sugarshack/state')).interlocks[0].draining;
    let level = 0;
    const station = setInterval(() => probe.publish('station-9/sensor/volume/state', { ts: Date.now(), value: level }).catch(() => {}), 200);
    try {
      // Nothing runs: this deploy's drain ends at once.
      await deploy(withHold(1), 'the flows with op 97 running');
      await waitLong(async () => !(await draining()), 'the document with op 97 applied');
      const since = Date.now();
      await red.request('POST', '/inject/inj-97');
      await waitLong(() => events(since).some((e) => e.kind === 'granted' && e.operation === '97'), 'op 97 granted');

      // The new document wants LT-9 at 2: op 97, started on the old one, holds at 1.
      await deploy(withHold(2), 'the new flows running');
      assert.equal(await draining(), true, 'the interlock drains while op 97 runs');
      const sentAt = Date.now();
      await red.request('POST', '/inject/inj-acq');
      const timedOut = () => probe.on('test/errors').find((m) => m.at >= since && m.json.code === 'ACQUIRE_TIMEOUT' && m.json.source && m.json.source.id === 'acq');
      await waitLong(timedOut, 'the acquire refused with ACQUIRE_TIMEOUT');
      const answeredAt = timedOut().at;
      // Checked as soon as the refusal is seen: the drain still goes on, op 97 still holds YEL.
      assert.equal(await draining(), true, 'still draining when the acquire timed out');
      assert.equal((await red.lines('il')).YEL, 'held:97');
      assert.equal(done(since).some((d) => d.id === '97'), false, 'op 97 still running');
      assert.ok(answeredAt - sentAt >= 950, `refused after its 1 s timeout ran, not at once (${answeredAt - sentAt} ms)`);

      level = 1;
      await waitLong(() => done(since).some((d) => d.id === '97'), 'op 97 returned, on the document it started with');
      await waitLong(async () => !(await draining()), 'the drain over');
      assert.deepEqual(errors(since).map((e) => [e.code, e.source && e.source.id]), [['ACQUIRE_TIMEOUT', 'acq']], 'the timeout is the only error');
      assert.equal(probe.on('test/granted').length, 0, 'the timed-out acquire is never granted');
      await noFaultAndFree(since);
      assert.equal(probe.on('test/granted').length, 0, 'still not granted once the lines are free');
    } finally {
      clearInterval(station);
    }
  });
});
