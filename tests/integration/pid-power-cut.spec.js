'use strict';
// A persisted pid node in a real Node-RED process, fed over a real Mosquitto,
// killed with SIGKILL: its set point, mode and manual output come back from
// <userDir>/sugarshack/pid-<id>.json. Killed while a stream of set point
// changes is being written, it comes back with one of the set points it was
// sent (the write is atomic: old or new, never a torn file), and never with a
// "saved state lost" warning.
//
// Run: npx mocha --timeout 60000 --exit tests/integration/pid-power-cut.spec.js
const assert = require('node:assert/strict');
const fs = require('fs');
const path = require('path');
const { mulberry32: random } = require('../../scripts/simulator/random');
const { startMosquitto } = require('./support/mosquitto');
const { connectProbe } = require('./support/mqtt-probe');
const { NodeRedProcess, mqttBroker, sleep, waitFor } = require('./support/node-red');

const PID = 'b1b1b1b1b1b1b101';
const KILLS = 6;
const SEED = 20261124;

function flow(port) {
  return [
    { id: 'tab', type: 'tab', label: 'pid power cut' },
    mqttBroker('br', port),
    { id: 'in', z: 'tab', type: 'mqtt in', topic: 'test/pid/in', qos: '1', datatype: 'json', broker: 'br', nl: false, rap: true, rh: 0, inputs: 0, wires: [['unwrap']] },
    // The published JSON is the msg the pid node gets.
    { id: 'unwrap', z: 'tab', type: 'function', func: 'return msg.payload;', outputs: 1, wires: [[PID]] },
    {
      id: PID, z: 'tab', type: 'sugarshack-pid', name: 'level', kp: '2', ti: '10', td: '0', outMin: '0', outMax: '100',
      action: 'reverse', pOn: 'error', fallback: '', setpoint: '50', mode: 'auto', manual: '', ts: '1', staleS: '',
      smith: 'off', persist: true, wires: [['report']],
    },
    { id: 'report', z: 'tab', type: 'function', func: 'return { payload: { output: msg.payload, mode: msg.pid.mode, setpoint: msg.pid.setpoint } };', outputs: 1, wires: [['out']] },
    { id: 'out', z: 'tab', type: 'mqtt out', topic: 'test/pid/out', qos: '1', retain: 'false', broker: 'br', wires: [] },
  ];
}

describe('a persisted pid node: SIGKILL of a real Node-RED process', function () {
  this.timeout(5 * 60 * 1000);
  let broker;
  let probe;
  let red;
  let timestamp = 0;

  const stateFile = () => path.join(red.dir, 'sugarshack', `pid-${PID}.json`);
  const savedState = () => {
    try {
      return JSON.parse(fs.readFileSync(stateFile(), 'utf8')).state;
    } catch {
      return null;
    }
  };
  const outputs = () => probe.on('test/pid/out').map((m) => m.json);
  /**
   * A measurement; resolves with the step it made. Sent again every 0.5 s until
   * a step comes out: just after a start, Node-RED may not have subscribed yet.
   */
  async function measure(value) {
    const before = outputs().length;
    for (let tries = 0; outputs().length === before; tries++) {
      if (tries === 20) throw new Error(`no pid output for 10 s after measurement ${value}`);
      timestamp += 1000;
      await probe.publish('test/pid/in', { payload: value, timestamp });
      await waitFor(() => outputs().length > before, 'the pid output', 500).catch(() => {});
    }
    return outputs()[before];
  }

  before(async function () {
    broker = await startMosquitto();
    probe = await connectProbe(broker.url, ['test/pid/out']);
    red = new NodeRedProcess({ flows: flow(broker.port), tag: 'pid' });
    await red.start();
  });

  after(async function () {
    if (red) await red.finish(this.currentTest);
    if (probe) await probe.end();
    if (broker) await broker.stop();
  });

  it('the set point, manual mode and manual output written before the kill come back', async function () {
    assert.equal((await measure(40)).setpoint, 50, 'the configured set point at first');
    await probe.publish('test/pid/in', { setpoint: 72 });
    await probe.publish('test/pid/in', { mode: 'manual', manual: 33 });
    const step = await measure(41);
    assert.deepEqual(step, { output: 33, mode: 'manual', setpoint: 72 });
    await waitFor(() => {
      const s = savedState();
      return s && s.setpoint === 72 && s.mode === 'manual' && s.manual === 33;
    }, 'the state file holding the change');

    await red.kill();
    await red.start();
    assert.deepEqual(await measure(42), { output: 33, mode: 'manual', setpoint: 72 });
    assert.doesNotMatch(red.logOfThisRun(), /saved PID state is lost|cannot read the saved PID state/);
  });

  it(`killed ${KILLS} times while set point changes are written, it comes back with one it was sent, never lost`, async function () {
    await probe.publish('test/pid/in', { mode: 'auto' });
    const rand = random(SEED);
    let next = 100;
    for (let kill = 0; kill < KILLS; kill++) {
      const sent = [];
      const stream = (async () => {
        while (red.alive && sent.length < 400) {
          next += 1;
          sent.push(next);
          await probe.publish('test/pid/in', { setpoint: next });
        }
      })();
      await sleep(50 + Math.floor(rand() * 250));
      const beforeKill = savedState();
      await red.kill();
      await stream;
      await red.start();
      const { setpoint } = await measure(10);
      const known = beforeKill ? [beforeKill.setpoint, ...sent] : sent;
      assert.ok(known.includes(setpoint), `kill ${kill}: restored set point ${setpoint} is not one sent (${sent[0]}..${sent[sent.length - 1]})`);
      assert.ok(!beforeKill || setpoint >= beforeKill.setpoint, `kill ${kill}: restored ${setpoint} is older than the ${beforeKill && beforeKill.setpoint} on disk before the kill`);
      assert.doesNotMatch(red.logOfThisRun(), /saved PID state is lost|cannot read the saved PID state|cannot be used/, `kill ${kill}`);
    }
  });
});
