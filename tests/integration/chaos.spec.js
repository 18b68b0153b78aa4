'use strict';
// Chaos under a hot standby. A real three-member etcd cluster (Debian's
// etcd-server) on loopback ports, two real Node-RED processes running the
// routines flow as one cluster, Mosquitto with its dynamic-security plugin
// (each instance its own account and client id, `log_type all`), and the
// simulator. While operations, routines, e-stops, clears and stuck valves run
// at random, at random moments the test:
//
// - kills the leader with SIGKILL (KILLS times);
// - stops it with SIGSTOP for longer than its lease, then SIGCONT (STOPS times);
// - kills one etcd member, then two (quorum lost), and brings them back.
//
// And checks, from both instances' interlock events (each stamped with its
// instance and fencing token), the broker's log and a watch on the leader key:
//
// - never two holders: tokens only grow along the events, one instance per
//   token, and replaying every event (a failover faulting held lines, as a
//   restart does) never grants a line held by another or faulted;
// - no latched fault is lost: every line seen faulted before a failover is
//   faulted on the new leader (unless a clear was sent around then);
// - every line faulted at takeover gets its lockout again from the new leader;
// - no PUBLISH reaches the broker from an instance outside its leadership
//   (from its key's creation to its deletion by etcd when the lease ran out);
// - quorum lost: an e-stop's lockout still goes out within the lease, no
//   grant is made, and the leader resumes by itself when etcd is back.
//
// Run: npx mocha --timeout 30000 --exit tests/integration/chaos.spec.js
// (CHAOS_LOG=1 prints each step.)
const assert = require('node:assert/strict');
const { Etcd3 } = require('etcd3');
const { mulberry32: random } = require('../../scripts/simulator/random');
const { startEtcd } = require('./support/etcd');
const { startDynsecMosquitto } = require('./support/dynsec');
const { connectProbe } = require('./support/mqtt-probe');
const { startTestSimulator } = require('./support/simulator');
const { sleep, waitFor } = require('./support/node-red');
const { StandbyPair } = require('./support/standby');
const { LineModel } = require('./support/line-model');
const {
  PLANT_FILE, PLANT, LINES, OPERATIONS, ROUTINES, lockoutSeen, randomStep,
} = require('./support/routines-flow');

const KILLS = 10;
const STOPS = 3;
const TTL_S = 2;
const SEED = 20261127;
// A new leader's first publish may be logged before the test's own watch hears of its election.
const ELECTION_SEEN_LATE_MS = 1000;
const log = (...args) => { if (process.env.CHAOS_LOG) console.log('      ', ...args); };

describe('hot standby chaos: leaders killed and paused, etcd members killed, two Node-REDs, real etcd and Mosquitto', function () {
  this.timeout(5 * 60 * 1000);
  let etcd;
  let broker;
  let sim;
  let probe;
  let pair;
  let watchClient;
  const publishes = []; // { client, topic, at } from the broker's log
  const leadership = []; // { instance, token, from, to } from the test's own watch on the leader key

  before(async function () {
    etcd = await startEtcd();
    broker = await startDynsecMosquitto({ accounts: ['nr-a', 'nr-b', 'sim', 'probe'], onPublish: (p) => publishes.push(p) });
    sim = await startTestSimulator(broker.urlOf('sim'), { plant: PLANT_FILE, speed: 10, sweepS: 1, pumpDelayMs: 200 });
    probe = await connectProbe(broker.urlOf('probe'), ['test/#', '+/+/+/command'], { clientId: 'probe' });
    watchClient = new Etcd3({ hosts: etcd.endpoints });
    const watcher = await watchClient.watch().key('sugarshack/chaos/leader').create();
    watcher.on('put', (kv) => {
      if (leadership.length && leadership.at(-1).to === Infinity) return;
      leadership.push({ instance: JSON.parse(kv.value.toString()).instance, token: String(kv.mod_revision), from: Date.now(), to: Infinity });
    });
    watcher.on('delete', () => {
      if (leadership.length) leadership.at(-1).to = Date.now();
    });
    pair = new StandbyPair({
      etcd, broker, cluster: 'chaos', ttlS: TTL_S, dynsec: { admin: broker.admin, accounts: { a: broker.account('nr-a'), b: broker.account('nr-b') } },
    });
  });

  after(async function () {
    if (pair) await pair.finish(this.currentTest);
    if (watchClient) watchClient.close();
    if (probe) await probe.end();
    if (sim) await sim.stop();
    if (broker) await broker.stop();
    if (etcd) await etcd.stop();
  });

  const events = (since = 0) => probe.on('test/events').filter((m) => m.at >= since).map((m) => ({ ...m.json, seenAt: m.at }));
  const commands = () => probe.on('+/+/+/command');

  it(`keeps one fenced holder across ${KILLS} leader kills, ${STOPS} pauses past the lease and etcd losing quorum`, async function () {
    const rnd = random(SEED);
    const pick = (list) => list[Math.floor(rnd() * list.length)];
    const model = new LineModel();
    const clearsSent = {};
    let consumed = 0;
    let lastToken = 0;
    const tokenOwner = new Map();
    const checks = [];
    // Replays the events so far: tokens only grow, one instance per token, a new token faults what was held.
    const replay = () => {
      const all = probe.on('test/events');
      for (; consumed < all.length; consumed++) {
        const { json: e, at } = all[consumed];
        const token = Number(e.token);
        assert.ok(token >= lastToken, `event ${JSON.stringify(e)} under token ${token} after token ${lastToken}: two holders`);
        if (token > lastToken) {
          if (lastToken) model.failover(at);
          lastToken = token;
        }
        if (!tokenOwner.has(token)) tokenOwner.set(token, e.instance);
        assert.equal(tokenOwner.get(token), e.instance, `token ${token} used by ${tokenOwner.get(token)} and ${e.instance}`);
        model.apply(e, at);
      }
    };

    // Random work, sent to both instances over MQTT (the leader does it, the standby answers nothing).
    let working = true;
    let quiet = false; // no work while the quorum test watches for grants
    const work = (async () => {
      while (working) {
        if (quiet) {
          await sleep(50);
          continue;
        }
        try {
          // Stuck valves freed now and then, so that lines can be cleared and operations run again.
          if (rnd() < 0.05) await sim.inject({ fault: 'clear' });
          else await randomStep({ probe, sim, rnd, clearsSent });
        } catch {
          // the broker is there throughout; a publish that failed is just work not done
        }
        await sleep(50 + Math.floor(rnd() * 200));
      }
    })();

    /** After a failover to `next`: faults stay latched and every faulted line's lockout is sent again. */
    async function checkTakeover(next, faultedBefore, at) {
      const lines = await next.lines('il');
      for (const line of faultedBefore) {
        // A clear sent around the failover may have committed without its event getting out.
        if (clearsSent[line] > model.lines[line].faultSeenAt - 1000) continue;
        assert.ok(lines[line].startsWith('faulted'), `${line} was seen faulted before the failover, but the new leader has it ${lines[line]}`);
        checks.push(`${line} still latched on ${next.instance}`);
      }
      const faulted = LINES.filter((l) => lines[l].startsWith('faulted'));
      // Seen by the probe, and published by the new leader's own client as the broker logged it.
      const fromNext = (line) => PLANT.actuators.filter((a) => a.resource === line)
        .every((a) => publishes.some((p) => p.client === `nr-${next.instance}` && p.topic === `${a.device}/${a.type}/${a.io}/command` && p.at >= at));
      for (const line of faulted) {
        await waitFor(() => lockoutSeen(commands(), line, at) && fromNext(line), `the lockout of ${line} sent again by ${next.instance}`, 20000);
        checks.push(`${line}'s lockout re-sent by ${next.instance}`);
      }
    }

    /** Both running, one active and the other standing by with its MQTT connected (warm). */
    async function bothUp() {
      const leader = await pair.start();
      const standby = pair.other(leader);
      await waitFor(async () => (await pair.clusterOf(standby) || {}).role === 'standby', `${standby.instance} standby`, 30000);
      await waitFor(() => /Connected to broker/.test(standby.logOfThisRun()), `${standby.instance}'s MQTT connected`, 30000);
      return leader;
    }

    const plan = [];
    for (let i = 0; i < KILLS; i++) plan.push('kill');
    for (let i = 0; i < STOPS; i++) plan.splice(1 + Math.floor(rnd() * plan.length), 0, 'stop');
    plan.splice(4, 0, 'etcd-one');
    plan.splice(9, 0, 'etcd-quorum');
    const startedAt = Date.now();
    await bothUp();
    for (const [n, step] of plan.entries()) {
      // Routines left in their error state by the last failover start over.
      for (const r of ROUTINES) await probe.publish(`test/routine/${r.id}`, 'reset');
      await sleep(500 + Math.floor(rnd() * 2500));
      const leader = await pair.leader();
      const standby = pair.other(leader);
      replay();
      const faultedBefore = model.faulted();
      const at = Date.now();
      if (step === 'kill' || step === 'stop') {
        const token = Number((await pair.clusterOf(leader)).token);
        if (step === 'kill') await leader.kill();
        else leader.signal('SIGSTOP');
        const next = await pair.leader(TTL_S * 1000 + 20000);
        assert.equal(next, standby, `the standby took over after ${step} ${n}`);
        const nextToken = Number((await pair.clusterOf(next)).token);
        assert.ok(nextToken > token, `a newer token (${nextToken} after ${token})`);
        log(`${step} ${leader.instance}: ${next.instance} active after ${Date.now() - at} ms (token ${nextToken})`);
        if (step === 'stop') {
          // Past its lease, then woken: it must find out by itself and stand by, acting on nothing meanwhile.
          await sleep(TTL_S * 1000 + 500 - (Date.now() - at));
          leader.signal('SIGCONT');
          await waitFor(async () => (await pair.clusterOf(leader) || {}).role === 'standby', `${leader.instance} standby after SIGCONT`, 20000);
        }
        await checkTakeover(next, faultedBefore, at);
        await bothUp();
      } else if (step === 'etcd-one') {
        const tokenBefore = (await pair.clusterOf(leader)).token;
        await etcd.kill(Math.floor(rnd() * 3));
        const since = Date.now();
        const op = pick(OPERATIONS);
        await probe.publish(`test/estop/${op.lines[0]}`, 'e-stop');
        await waitFor(() => lockoutSeen(commands(), op.lines[0], since), 'a lockout with one etcd member down', 10000);
        // Keep-alives on the killed member may suspend the leader for a moment (its 2 s lease): it comes back under the same token.
        await waitFor(async () => (await pair.clusterOf(leader) || {}).role === 'active', 'the leader active with one member down', 10000);
        assert.equal((await pair.clusterOf(leader)).token, tokenBefore, 'one member down: nothing changes');
        checks.push('one etcd member down: the leader acts');
        for (let i = 0; i < 3; i++) if (!etcd.alive(i)) await etcd.restart(i);
      } else {
        // Quorum lost: isolation still goes out within the lease, nothing is granted, and it resumes alone.
        quiet = true;
        await leader.request('GET', '/sugarshack/state');
        await sleep(500); // what was committed before has gone out
        const victims = [0, 1, 2].sort(() => rnd() - 0.5).slice(0, 2);
        const line = pick(LINES);
        const op = pick(OPERATIONS.filter((o) => !o.lines.includes(line)));
        for (const v of victims) await etcd.kill(v);
        const since = Date.now();
        await probe.publish(`test/estop/${line}`, 'e-stop');
        await waitFor(() => lockoutSeen(commands(), line, since), `${line}'s lockout with etcd's quorum lost`, 5000);
        checks.push('quorum lost: the lockout went out');
        await probe.publish(`test/op/${op.id}`, 'go');
        await waitFor(async () => (await pair.clusterOf(leader) || {}).role === 'suspended', 'the leader suspended', TTL_S * 1000 + 5000);
        // By the event's own time: a grant committed before the kills may arrive after them.
        assert.equal(events(since).filter((e) => e.kind === 'granted' && e.atMs >= since).length, 0, 'nothing granted without quorum');
        assert.equal((await pair.clusterOf(standby)).role, 'standby', 'nobody took over');
        for (const v of victims) await etcd.restart(v);
        await waitFor(async () => (await pair.clusterOf(leader) || {}).role === 'active', 'the leader active again by itself', 30000);
        await waitFor(() => events(since).some((e) => e.kind === 'resource-faulted' && e.resources.includes(line)), `${line}'s fault committed after etcd's return`, 20000);
        checks.push('quorum back: the same leader resumed');
        quiet = false;
        log(`quorum lost and back: ${leader.instance} resumed after ${Date.now() - since} ms`);
      }
      replay();
    }
    working = false;
    await work;
    replay();

    assert.deepEqual(model.violations, [], 'no line granted while held by another or faulted');
    // No PUBLISH from an instance outside its leadership, as etcd saw it.
    const outside = publishes.filter((p) => /^nr-[ab]$/.test(p.client)).filter((p) => {
      const instance = p.client.slice(3);
      return !leadership.some((l) => l.instance === instance && p.at >= l.from - ELECTION_SEEN_LATE_MS && p.at <= l.to);
    });
    const held = leadership.map((l) => `${l.instance}:${l.token} ${l.from - startedAt}..${l.to - startedAt}`).join(', ');
    assert.deepEqual(outside.slice(0, 5).map((p) => ({ ...p, at: p.at - startedAt })), [], `${outside.length} publishes from an instance that did not hold the leader key (ms from the start; leaderships ${held})`);
    for (const client of ['nr-a', 'nr-b']) assert.ok(publishes.some((p) => p.client === client), `the broker logged publishes from ${client}`);
    assert.ok(leadership.length >= KILLS + STOPS + 1, `${leadership.length} leaderships seen`);
    assert.ok(checks.length >= KILLS + STOPS, `${checks.length} checks`);
    log(`${checks.length} checks, ${leadership.length} leaderships, ${publishes.length} publishes, ${consumed} events in ${Math.round((Date.now() - startedAt) / 1000)} s`);
  });
});
