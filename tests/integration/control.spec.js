'use strict';
// The RCC example end to end over a real Mosquitto: the I/O module publishes
// the state tuple every Ts, three controllers (rcc → pid) decide from it alone
// and write back over MQTT. Cutting the primary's link hands the loop to C2
// within its engagement threshold and without a bump (G1, G3); restoring the
// link gives it back to C1, which starts from C2's last action (G2, G3). C3
// never acts while C1 or C2 lives.
//
// Run: npx mocha --timeout 60000 --exit tests/integration/control.spec.js
const assert = require('node:assert/strict');
const fs = require('fs');
const path = require('path');
const helper = require('node-red-node-test-helper');
const { startMosquitto } = require('./support/mosquitto');
const { connectProbe } = require('./support/mqtt-probe');
const { PALETTE, paletteNodes, catchOnce, startRealTimeServer, stopServer, settings, sleep, until } = require('../flow/support');

helper.init(require.resolve('node-red'));

const coreNodesDir = path.dirname(require.resolve('@node-red/nodes/package.json'));
const coreNodes = ['common/20-inject.js', 'common/21-debug.js', 'function/10-function.js', 'function/15-change.js', 'network/10-mqtt.js']
  .map((f) => require(path.join(coreNodesDir, 'core', f)));

const EXAMPLE = JSON.parse(fs.readFileSync(path.join(PALETTE, 'examples', 'rcc-failover.json'), 'utf8'));
const BASE = 'sugarshack/rcc/flow-1';
const byName = (name) => EXAMPLE.find((n) => n.name === name);
const pidOf = (id) => byName(`flow PI C${id}`);
const rccOf = (id) => byName(`RCC C${id}`);
const TS_MS = Math.round(Number(rccOf(1).tsS) * 1000);
const THRESHOLDS = rccOf(1).thresholdsS.split(',').map((s) => Math.round(Number(s) * 1000));
// MQTT hops and Node-RED's event loop on a busy test machine.
const SLACK_MS = 600;

function flow(port) {
  return EXAMPLE.map((n) => (n.type === 'mqtt-broker' ? { ...n, port: String(port) } : n));
}

describe('RCC over MQTT (examples/rcc-failover.json, Mosquitto)', function () {
  this.timeout(60000);
  let broker;
  let probe;

  before(async function () {
    broker = await startMosquitto();
    probe = await connectProbe(broker.url, [`${BASE}/#`]);
    await new Promise((resolve) => startRealTimeServer(resolve));
    settings({ mqttReconnectTime: 300 });
    await helper.load([...paletteNodes, catchOnce, ...coreNodes], flow(broker.port));
  });

  after(async function () {
    await stopServer();
    if (probe) await probe.end();
    if (broker) await broker.stop();
  });

  const writes = () => probe.on(`${BASE}/write/+`).map((m) => ({ id: Number(m.topic.split('/').pop()), value: Number(m.text), at: m.at }));
  const flowAt = (at) => {
    const seen = probe.on(`${BASE}/flow`).filter((m) => m.at <= at);
    if (!seen.length) throw new Error(`no flow reading by ${at}`);
    return Number(seen[seen.length - 1].text);
  };
  const press = (name) => helper.getNode(byName(name).id).receive({});

  it('cutting C1 hands over to C2 without a bump; restoring C1 takes control back', async function () {
    const { kp, ti } = pidOf(1);
    // Bumpless (§5.3): the new writer's first action differs from the last
    // one applied only by the P change since its last tracking scan and one
    // integration step of the scans in between.
    const bumpBound = (before, after) => {
      const e = Math.abs(1.04 - flowAt(after.at));
      const gapS = (after.at - before.at) / 1000 + TS_MS / 1000;
      return kp * Math.abs(flowAt(after.at) - flowAt(before.at)) + (kp / ti) * e * gapS + 0.005;
    };

    // At start-up every age is infinite (never acted), so all three act on
    // the first state; from C1's first write on, the others stand by.
    await probe.waitFor(`${BASE}/write/1`, () => true, 5000);
    await sleep(2 * TS_MS + SLACK_MS);
    const settledAt = Date.now();
    press('set point 1.04 gal/min');
    await sleep(3000); // into the transient, as the paper's 22 s failure was
    const writers = new Set(writes().filter((w) => w.at >= settledAt).map((w) => w.id));
    assert.deepEqual([...writers], [1], 'only the primary writes while it lives');

    const cutAt = Date.now();
    press("cut C1's link");
    const firstC2 = await probe.waitFor(`${BASE}/write/2`, () => true, THRESHOLDS[1] + 2 * TS_MS + SLACK_MS * 2);
    const handover = writes();
    const lastC1 = handover.filter((w) => w.id === 1).pop();
    const takeover = handover.find((w) => w.id === 2 && w.at >= cutAt);
    assert.ok(takeover.at - lastC1.at <= THRESHOLDS[1] + TS_MS + SLACK_MS,
      `C2 acted ${takeover.at - lastC1.at} ms after C1's last write (D2 ${THRESHOLDS[1]} ms, Ts ${TS_MS} ms)`);
    assert.ok(firstC2.at - cutAt <= THRESHOLDS[1] + 2 * TS_MS + SLACK_MS);
    const bump = Math.abs(takeover.value - lastC1.value);
    assert.ok(bump <= bumpBound(lastC1, takeover), `handover bump ${bump} from ${lastC1.value} to ${takeover.value}`);

    await sleep(3000);
    const state = await probe.waitFor(`${BASE}/state`, () => true, 2000);
    const { agesMs } = JSON.parse(state.text);
    assert.ok(agesMs[0] > 3000, `C1 has not acted since its link was cut (age ${agesMs[0]} ms)`);
    assert.ok(agesMs[1] !== null && agesMs[1] < THRESHOLDS[1], `C2 acts every Ts (age ${agesMs[1]} ms)`);

    const restoredAt = Date.now();
    press("restore C1's link");
    await probe.waitFor(`${BASE}/write/1`, (m) => m.at >= restoredAt, 2 * TS_MS + SLACK_MS * 2);
    const back = writes().filter((w) => w.at >= restoredAt);
    const firstBack = back.find((w) => w.id === 1);
    const lastC2Before = writes().filter((w) => w.id === 2 && w.at < firstBack.at).pop();
    const returnBump = Math.abs(firstBack.value - lastC2Before.value);
    assert.ok(returnBump <= bumpBound(lastC2Before, firstBack), `return bump ${returnBump} from ${lastC2Before.value} to ${firstBack.value}`);

    // C2 sees C1's fresh age and steps back to standby.
    await sleep(THRESHOLDS[1] + 2 * TS_MS + SLACK_MS);
    const stepBackAt = Date.now();
    await sleep(2000);
    const late = writes().filter((w) => w.at >= stepBackAt);
    assert.ok(late.length > 0 && late.every((w) => w.id === 1), `after the return only C1 writes: ${JSON.stringify(late.map((w) => w.id))}`);
    assert.ok(!writes().some((w) => w.id === 3 && w.at >= settledAt), 'C3 never acted after start-up: C1 or C2 was always alive');

    // The loop kept control: the flow approaches the new set point.
    await until(() => Math.abs(flowAt(Date.now()) - 1.04) < 0.03, 'the flow settles near 1.04 gal/min', 15000);
  });
});
