'use strict';
// Power cuts. A real Node-RED process runs the routines plant against a real
// Mosquitto and the simulator, with the interlock persisted and the context
// store as users have it (localfilesystem, default cache). It is killed with
// SIGKILL at random moments while operations run, lines are e-stopped and
// cleared, and restarted on the same user directory, 24 times. After each
// restart, from outside (the admin API and MQTT):
//
// - no line that was held or faulted before the kill comes back free: an
//   operation granted a moment before is faulted "interrupted", an e-stop whose
//   lockout went out stays faulted; a clear that went out stays cleared;
// - the lockouts of every faulted line are sent again;
// - nothing is granted twice: replaying every interlock event of every run, a
//   line is never granted while another operation holds it or while it is
//   faulted.
//
// Run: npx mocha --timeout 30000 --exit tests/integration/crash.spec.js
// (CRASH_LOG=1 prints each kill and what was checked.)
const assert = require('node:assert/strict');
const { mulberry32: random } = require('../../scripts/simulator/random');
const { startMosquitto } = require('./support/mosquitto');
const { connectProbe } = require('./support/mqtt-probe');
const { startTestSimulator } = require('./support/simulator');
const { NodeRedProcess, sleep, waitFor } = require('./support/node-red');
const {
  PLANT_FILE, LINES, OPERATIONS, ROUTINES, flow, lockoutSeen: lockoutSeenAmong, randomStep,
} = require('./support/routines-flow');
const { LineModel } = require('./support/line-model');

const KILLS = 24;
const SEED = 20261123;
// Within this of seeing a grant, its operation cannot have finished: its first
// valve takes longer than that to travel, even at the simulator's 10x speed.
const JUST_GRANTED_MS = 40;

const log = (...args) => { if (process.env.CRASH_LOG) console.log('      ', ...args); };

describe('power cuts: SIGKILL of a real Node-RED process, restarted on the same user directory', function () {
  this.timeout(15 * 60 * 1000);
  let broker;
  let sim;
  let probe;
  let red;

  before(async function () {
    broker = await startMosquitto();
    sim = await startTestSimulator(broker.url, { plant: PLANT_FILE, speed: 10, sweepS: 1, pumpDelayMs: 200 });
    probe = await connectProbe(broker.url, ['test/#', '+/+/+/command']);
    red = new NodeRedProcess({ flows: flow(broker.port, 'crash'), tag: 'crash' });
  });

  after(async function () {
    if (red) await red.finish(this.currentTest);
    if (probe) await probe.end();
    if (sim) await sim.stop();
    if (broker) await broker.stop();
  });

  const events = (since) => probe.on('test/events').filter((m) => m.at >= since).map((m) => ({ ...m.json, seenAt: m.at }));
  const lockoutSeen = (line, since) => lockoutSeenAmong(probe.on('+/+/+/command'), line, since);
  // A clear is refused until the line's lockout is confirmed by fresh feedback; an operator asks again.
  async function clearLines(lines, what = 'the lines cleared') {
    const deadline = Date.now() + 20000;
    for (let pending = lines; pending.length > 0;) {
      if (Date.now() > deadline) throw new Error(`timed out waiting for ${what}`);
      const askedAt = Date.now();
      for (const line of pending) await probe.publish(`test/clear/${line}`, 'operator');
      while (Date.now() - askedAt < 1000 && pending.some((l) => !events(askedAt).some((e) => e.kind === 'cleared' && e.resources.includes(l)))) await sleep(10);
      pending = pending.filter((l) => !events(askedAt).some((e) => e.kind === 'cleared' && e.resources.includes(l)));
    }
  }

  it(`keeps every held and faulted line locked out across ${KILLS} kills, re-sends lockouts, grants nothing twice`, async function () {
    const rnd = random(SEED);
    const pick = (list) => list[Math.floor(rnd() * list.length)];
    const model = new LineModel();
    const checks = [];
    let expectations = []; // what must hold after the next restart: [line, test(state), why]
    let consumed = 0; // events replayed so far
    const replay = () => {
      const all = probe.on('test/events');
      for (; consumed < all.length; consumed++) model.apply(all[consumed].json, all[consumed].at);
    };

    for (let kill = 0; kill <= KILLS; kill++) {
      // Before the start: its lockouts may go out before start() sees the log say so.
      const restartedAt = Date.now();
      await red.start();
      const lines = await red.lines('il');
      replay();
      log(`run ${kill}: restarted with ${JSON.stringify(lines)}`);
      for (const [line, test, why] of expectations) {
        checks.push(why);
        assert.ok(test(lines[line]), `after kill ${kill}: ${why}, but ${line} is ${lines[line]}`);
      }
      assert.equal(Object.values(lines).some((s) => s.startsWith('faulted:unknown')), false, 'the saved state was never lost');
      model.reset(lines);
      const faulted = LINES.filter((l) => lines[l].startsWith('faulted'));
      // A loaded machine may take seconds to reconnect after a restart: the deadline is generous, the check is not.
      for (const line of faulted) await waitFor(() => lockoutSeen(line, restartedAt), `the lockout of ${line} sent again`, 20000);
      if (faulted.length) checks.push(`lockouts of ${faulted.join(', ')} sent again`);
      if (kill === KILLS) break;

      // Clear what the last run left faulted and put the routines back, so operations can run.
      // Stuck valves freed first: their standing lockouts then complete, and the clears are accepted.
      await sim.inject({ fault: 'clear' });
      await clearLines(faulted);
      await waitFor(() => { replay(); return LINES.every((l) => !model.lines[l].faulted); }, 'the lines cleared');
      for (const r of ROUTINES) await probe.publish(`test/routine/${r.id}`, 'reset');

      const scenario = ['grant', 'estop', 'clear', 'mixed'][kill % 4];
      const since = Date.now();
      expectations = [];
      if (scenario === 'grant') {
        // Killed within moments of a grant: the operation is mid-run, its lines must come back faulted.
        const op = pick(OPERATIONS);
        await probe.publish(`test/op/${op.id}`, 'go');
        await waitFor(() => events(since).some((e) => e.kind === 'granted' && e.operation === op.id), `op ${op.id} granted`);
        await sleep(Math.floor(rnd() * JUST_GRANTED_MS));
        for (const line of op.lines) expectations.push([line, (s) => s.startsWith('faulted'), `op ${op.id} was granted ${line} just before the kill`]);
      } else if (scenario === 'estop') {
        const line = pick(LINES);
        await probe.publish(`test/estop/${line}`, 'e-stop');
        await waitFor(() => lockoutSeen(line, since), `the lockout of ${line}`);
        await sleep(Math.floor(rnd() * JUST_GRANTED_MS));
        expectations.push([line, (s) => s === 'faulted:manual', `${line}'s e-stop lockout went out before the kill`]);
      } else if (scenario === 'clear') {
        const line = pick(LINES);
        await probe.publish(`test/estop/${line}`, 'e-stop');
        await waitFor(() => events(since).some((e) => e.kind === 'resource-faulted' && e.resources.includes(line)), `${line} faulted`);
        await clearLines([line], `${line} cleared`);
        await sleep(Math.floor(rnd() * JUST_GRANTED_MS));
        expectations.push([line, (s) => !s.startsWith('faulted'), `${line}'s clear went out before the kill`]);
      } else {
        // Anything at all, killed at a random moment.
        const endAt = Date.now() + 300 + Math.floor(rnd() * 2700);
        const clearsSent = {};
        while (Date.now() < endAt) {
          await randomStep({ probe, sim, rnd, clearsSent });
          await sleep(Math.floor(rnd() * 250));
        }
        replay();
        const killAt = Date.now();
        for (const line of LINES) {
          const seen = model.lines[line];
          // A fault stands unless a clear was sent around or after the moment it was seen.
          if (seen.faulted && !(clearsSent[line] > seen.faultSeenAt - 1000)) {
            expectations.push([line, (s) => s.startsWith('faulted'), `${line} was seen faulted before the kill`]);
          } else if (seen.holder && killAt - seen.grantSeenAt < JUST_GRANTED_MS) {
            expectations.push([line, (s) => s.startsWith('faulted'), `${line} was granted to ${seen.holder} just before the kill`]);
          }
        }
      }
      await red.kill();
      replay();
      log(`kill ${kill + 1} (${scenario}) after ${Date.now() - since} ms; expecting ${expectations.map((e) => e[2]).join('; ') || 'nothing'}`);
    }

    assert.deepEqual(model.violations, [], 'no line granted while held by another or faulted');
    assert.equal(red.starts, KILLS + 1);
    assert.ok(checks.length >= KILLS, `${checks.length} checks after ${KILLS} kills`);
    log(`${checks.length} checks passed; ${probe.on('test/events').length} interlock events replayed`);

    // And the plant still works: every line cleared, an operation runs to its release.
    const lines = await red.lines('il');
    await sim.inject({ fault: 'clear' });
    await clearLines(LINES.filter((l) => lines[l].startsWith('faulted')));
    await sleep(500);
    const since = Date.now();
    await probe.publish('test/op/51', 'go');
    await waitFor(() => events(since).some((e) => e.kind === 'released' && e.operation === '51'), 'op 51 run to its release', 20000);
  });
});
