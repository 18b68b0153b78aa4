'use strict';
// The README's fault walkthrough as written, on npm start's flows and the
// simulated plant: started with V101 jammed, the truck routine's op 10 faults
// YEL within the time the README states (derived from the plant document by
// scripts/walkthrough-times.js), its lockout completes within a sweep; then,
// cleared, with the truck routine in its fault state, "stuck V101" and "run op 10 now"
// fault it again within the stated time after the click; then, cleared, "run
// op 10 now", "hold op 10" and "restart op 10" hold and restart its fill.
// The README must state those figures.
const assert = require('node:assert/strict');
const fs = require('fs');
const path = require('path');
const { NodeRedProcess } = require('./support/node-red');
const { startMosquitto } = require('./support/mosquitto');
const { startSimulator } = require('../../scripts/simulator');
const { walkthroughTimes, readmePhrases } = require('../../scripts/walkthrough-times');

const ROOT = path.resolve(__dirname, '..', '..');
const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));
// MQTT round trips, a feedback period of the simulator, the routine's first check.
const SLACK_MS = 3000;

describe('the README\'s fault walkthrough, as written', function () {
  this.timeout(120000);
  const times = walkthroughTimes();
  let broker; let sim; let red;

  it('the README states the figures derived from the plant document', function () {
    const readme = fs.readFileSync(path.join(ROOT, 'README.md'), 'utf8');
    for (const phrase of readmePhrases(times)) assert.ok(readme.includes(phrase), `README.md says "${phrase}"`);
  });

  describe('on the simulated plant', function () {
    before(async function () {
      broker = await startMosquitto();
      const port = String(new URL(broker.url).port);
      sim = await startSimulator({ broker: broker.url, plant: path.join(ROOT, 'flows', 'plant.json'), seed: 3, faults: ['stuck:V101'], reconnectMs: 200, log: () => {} });
      const flows = JSON.parse(fs.readFileSync(path.join(ROOT, 'flows', 'case-study.json'), 'utf8'))
        .map((n) => (n.type === 'mqtt-broker' ? { ...n, port } : n));
      red = new NodeRedProcess({ flows, tag: 'walkthrough' });
    });

    after(async function () {
      if (red) await red.stop();
      if (sim) await sim.stop();
      if (broker) await broker.stop();
    });

    const yel = async () => (await red.get('/sugarshack/state')).interlocks[0].lines.find((l) => l.name === 'YEL');
    async function waitFor(predicate, what, ms) {
      const deadline = Date.now() + ms;
      while (Date.now() < deadline) {
        const value = await predicate();
        if (value) return value;
        await sleep(200);
      }
      throw new Error(`${what} did not happen within ${ms} ms`);
    }
    // What an inject's button does (it answers "OK", not JSON).
    const click = async (name) => {
      const flows = JSON.parse(fs.readFileSync(path.join(ROOT, 'flows', 'case-study.json'), 'utf8'));
      const res = await fetch(`http://127.0.0.1:${red.port}/inject/${flows.find((n) => n.type === 'inject' && n.name === name).id}`, { method: 'POST' });
      assert.equal(res.status, 200, `the button of '${name}'`);
    };
    const lockoutDone = async () => (await red.get('/sugarshack/state')).plants[0].lockoutsPending.length === 0;

    it('1-2. started with V101 jammed, op 10 faults YEL within the stated time and its lockout completes within a sweep', async function () {
      await red.start(); // resolves once the flows run and MQTT is connected
      const started = Date.now();
      const fault = await waitFor(async () => { const l = await yel(); return l.fault && l; }, 'the YEL fault', 60000);
      const tookMs = Date.now() - started;
      assert.equal(fault.fault.operation, '10');
      assert.ok(tookMs <= times.firstFaultS * 1000 + SLACK_MS, `YEL faulted ${tookMs} ms after the flows started; the README says at most ${times.firstFaultS} s`);
      await waitFor(lockoutDone, `YEL's lockout within a sweep (${times.sweepS} s)`, times.sweepS * 1000 + SLACK_MS);
      // Step 2's words: the truck routine in its error state, not halted.
      const truck = await waitFor(async () => (await red.get('/sugarshack/state')).interlocks[0].routines.find((r) => r.id === 'truck' && r.state === 'fault'), 'the truck routine in its fault state', 10000);
      assert.equal(truck.halted, false);
      const readme = fs.readFileSync(path.join(ROOT, 'README.md'), 'utf8');
      assert.ok(readme.includes('`"state": "fault"`') && readme.includes('`"halted": false`'), 'the README says so');
    });

    it('3. once the valve is repaired and YEL cleared, "stuck V101" then "run op 10 now" fault it again within the stated time after the click', async function () {
      await sim.inject({ fault: 'clear' });
      await waitFor(async () => (await yel()).clearBlockers.length === 0, 'YEL clearable', 20000);
      await red.request('POST', '/sugarshack/clear', { interlock: (await red.get('/sugarshack/state')).interlocks[0].id, lines: ['YEL'] });
      assert.equal((await yel()).state.state, 'free', 'nothing queued for YEL took it: the truck routine is in its fault state');
      await click('stuck V101 (YEL)');
      await sleep(1000); // the simulator takes it over MQTT
      const clicked = Date.now();
      await click('run op 10 now');
      const fault = await waitFor(async () => { const l = await yel(); return l.fault && l; }, 'the YEL fault after the click', 30000);
      const tookMs = Date.now() - clicked;
      assert.equal(fault.fault.operation, '10');
      assert.ok(tookMs <= times.faultS * 1000 + SLACK_MS, `YEL faulted ${tookMs} ms after the click; the README says about ${times.faultS} s`);
      assert.ok(tookMs >= times.faultS * 1000 - SLACK_MS, `YEL faulted ${tookMs} ms after the click, sooner than the ${times.faultS} s the valve is given`);
    });

    it('4. with YEL cleared, "run op 10 now", then "hold op 10" while the truck fills: P1 off and V101 closed, YEL held by op 10; "restart op 10": it fills again', async function () {
      await sim.inject({ fault: 'clear' });
      await waitFor(async () => (await yel()).clearBlockers.length === 0, 'YEL clearable', 20000);
      await red.request('POST', '/sugarshack/clear', { interlock: (await red.get('/sugarshack/state')).interlocks[0].id, lines: ['YEL'] });
      const panel = sim.devices['ctrl-1'];
      const truckL = () => sim.hydraulics.tanks.get('T-truck').volumeL;
      const opRun = async () => {
        const s = await red.get('/sugarshack/state');
        return [...(s.runs || []), ...s.interlocks.flatMap((i) => i.runs || [])].find((r) => r.operation === '10') || {};
      };
      await click('run op 10 now');
      await waitFor(() => panel.pumps[1].running && truckL() > 0, 'op 10 filling the truck', 60000);
      await click('hold op 10');
      await waitFor(async () => (await opRun()).state === 'held', 'op 10 held', 30000);
      await waitFor(() => !panel.pumps[1].running && panel.valves[1].position < 3, 'P1 off and V101 closed (op 10\'s hold command)', 15000);
      const yelHeld = await yel();
      assert.deepEqual([yelHeld.state.state, yelHeld.state.operation], ['held', '10'], 'YEL stays held by op 10');
      const heldL = truckL();
      await sleep(2000);
      assert.ok(Math.abs(truckL() - heldL) < 1, 'the truck stopped filling');
      await click('restart op 10');
      await waitFor(() => panel.pumps[1].running && panel.valves[1].position > 97 && truckL() > heldL + 10, 'V101 open, P1 on and the truck filling again', 30000);
      assert.equal((await opRun()).state, 'running');
      const readme = fs.readFileSync(path.join(ROOT, 'README.md'), 'utf8');
      for (const words of ['*hold op 10*', '*restart op 10*', '`held 3/5`', '(P1 off, V101 closed)']) assert.ok(readme.includes(words), `the README says ${words}`);
    });
  });
});
