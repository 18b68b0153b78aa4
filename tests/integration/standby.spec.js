'use strict';
// Hot standby with real processes: two Node-RED instances run the routines
// flow against one real etcd cluster, a real Mosquitto and the simulator. One
// is active, the other shows `standby` and acts on nothing (the msgs both get
// are answered once, by the leader). The leader is killed with SIGKILL just
// after a grant and an e-stop: the standby takes over from the committed
// state as a restart would (the e-stopped line still faulted, the granted
// lines faulted "interrupted"), sends every faulted line's lockout again,
// stamps its events with a newer fencing token, and the old leader, started
// again, stands by.
//
// Run: npx mocha --timeout 30000 --exit tests/integration/standby.spec.js
const assert = require('node:assert/strict');
const path = require('path');
const { Etcd3 } = require('etcd3');
const { readJournal } = require('../../node-red-contrib-sugarshack/lib/journal/files');
const { startEtcd } = require('./support/etcd');
const { startMosquitto } = require('./support/mosquitto');
const { connectProbe } = require('./support/mqtt-probe');
const { startTestSimulator } = require('./support/simulator');
const { waitFor } = require('./support/node-red');
const { StandbyPair } = require('./support/standby');
const { PLANT_FILE, OPERATIONS, lockoutSeen: lockoutSeenAmong } = require('./support/routines-flow');

const TTL_S = 2;
const journalOf = (red) => readJournal(path.join(red.dir, 'journal'));

describe('hot standby: two real Node-RED processes on a real etcd, the leader killed', function () {
  this.timeout(240000);
  let etcd;
  let broker;
  let sim;
  let probe;
  let pair;

  before(async function () {
    etcd = await startEtcd();
    broker = await startMosquitto();
    sim = await startTestSimulator(broker.url, { plant: PLANT_FILE, speed: 10, sweepS: 1, pumpDelayMs: 200 });
    probe = await connectProbe(broker.url, ['test/#', '+/+/+/command']);
    pair = new StandbyPair({ etcd, broker, cluster: 'standby', ttlS: TTL_S });
  });

  after(async function () {
    if (pair) await pair.finish(this.currentTest);
    if (probe) await probe.end();
    if (sim) await sim.stop();
    if (broker) await broker.stop();
    if (etcd) await etcd.stop();
  });

  const events = (since) => probe.on('test/events').filter((m) => m.at >= since).map((m) => m.json);
  const lockoutSeen = (line, since) => lockoutSeenAmong(probe.on('+/+/+/command'), line, since);

  it('stands by visibly, takes over from the committed state, re-sends lockouts, and the old leader stands by on return', async function () {
    const leader = await pair.start();
    const standby = pair.other(leader);
    await waitFor(async () => {
      const c = await pair.clusterOf(standby);
      return c && c.role === 'standby' && c.leader && c.leader.instance === leader.instance;
    }, 'the other instance standby, naming the leader');
    const seenByStandby = await standby.get('/sugarshack/state');
    const il = seenByStandby.interlocks.find((i) => i.id === 'il');
    assert.equal(il.state, 'standby');
    assert.match(il.following.where, /^etcd:sugarshack\/standby\/state\/interlock\/il$/);
    // What operators see: this instance, its role since when, the lease, the members and etcd's health.
    const seen = seenByStandby.cluster;
    assert.deepEqual([seen.name, seen.instance, seen.role], ['standby', standby.instance, 'standby']);
    assert.ok(seen.sinceMs <= Date.now() && seen.lease.ttlS === TTL_S && seen.lease.validForMs > 0);
    // Each instance records its own role in etcd: the standby may have read before the leader wrote.
    const members = [`${leader.instance}:active`, `${standby.instance}:standby`].sort();
    await waitFor(async () => JSON.stringify(((await pair.clusterOf(standby)).members || []).map((m) => `${m.instance}:${m.role}`).sort()) === JSON.stringify(members), 'both members seen by the standby', 10000);
    await waitFor(async () => ((await pair.clusterOf(standby)).etcd || []).filter((m) => m.healthy).length === 3, 'three etcd members answering');
    const leaderState = await leader.get('/sugarshack/state');
    const token = leaderState.cluster.token;
    assert.ok(Number(token) > 0);

    // A control loop's measurement, sent to both: one step out, from the leader (counted again at the end).
    await probe.publish('test/pid', '40');
    const firstStep = await probe.waitFor('test/pid/out', () => true, 10000, { fromHistory: true });

    // An e-stop and an operation, sent to both over MQTT, are done once, by the leader, stamped with its token.
    const since = Date.now();
    await probe.publish('test/estop/RED', 'e-stop');
    await waitFor(() => lockoutSeen('RED', since), 'the lockout of RED');
    const op = OPERATIONS.find((o) => !o.lines.includes('RED'));
    await probe.publish(`test/op/${op.id}`, 'go');
    await waitFor(() => events(since).some((e) => e.kind === 'granted' && e.operation === op.id), `op ${op.id} granted`);
    const before = events(since);
    assert.ok(before.every((e) => e.instance === leader.instance && e.token === token), `every event from ${leader.instance} under token ${token}: ${JSON.stringify(before)}`);
    assert.equal(before.filter((e) => e.kind === 'granted' && e.operation === op.id).length, 1, 'granted once, not by both');

    // Only the leader keeps the journal: the standby hears the same feedback and writes none of it.
    await waitFor(() => journalOf(leader).some((r) => r.table === 'sugarshack_event' && r.tags.kind === 'granted'), 'the grant in the leader\'s journal');
    assert.deepEqual(journalOf(standby), [], 'the standby journals nothing');

    // Before the pid's stale watch (3 s) could send again, a standby's copy of the step would have come long ago.
    const steps = probe.on('test/pid/out').filter((m) => m.at - firstStep.at < 2500);
    assert.equal(steps.length, 1, 'one pid output for one measurement: the standby\'s pid sent nothing');
    const killedAt = Date.now();
    await leader.kill();
    const next = await pair.leader(TTL_S * 1000 + 20000);
    assert.equal(next, standby);
    const failoverMs = Date.now() - killedAt;
    const lines = await next.lines('il');
    assert.equal(lines.RED, 'faulted:manual', 'the e-stop stays latched');
    for (const line of op.lines) assert.ok(lines[line].startsWith('faulted'), `${line}, granted to ${op.id} before the kill, comes back faulted: ${lines[line]}`);
    for (const line of ['RED', ...op.lines]) await waitFor(() => lockoutSeen(line, killedAt), `the lockout of ${line} sent again by the new leader`, 20000);
    const nextToken = (await pair.clusterOf(next)).token;
    assert.ok(Number(nextToken) > Number(token), 'a newer fencing token');
    await waitFor(() => events(killedAt).some((e) => e.token === nextToken), 'the new leader\'s first event');
    const after = events(killedAt);
    // What the old leader published just before its kill may arrive just after; from the new leader's first event on, only it acts.
    const fromNew = after.slice(after.findIndex((e) => e.token === nextToken));
    assert.ok(fromNew.length > 0 && fromNew.every((e) => e.instance === next.instance && e.token === nextToken), `only the new leader acts: ${JSON.stringify(after.map((e) => [e.instance, e.token, e.kind]))}`);
    // What it keeps in etcd is sealed by the core as a state file is: its owner, and a checksum.
    const etcdClient = new Etcd3({ hosts: etcd.endpoints });
    const sealed = JSON.parse(await etcdClient.get('sugarshack/standby/state/interlock/il').string());
    etcdClient.close();
    assert.equal(sealed.owner, 'il');
    assert.match(sealed.checksum, /^sha256:[0-9a-f]{64}$/);
    const cluster = await pair.clusterOf(next);
    assert.equal(cluster.lastFailover.from, leader.instance);
    assert.equal(cluster.lastFailover.to, next.instance);
    // The failover is an alarm, acknowledged like the others.
    const alarmId = `failover:${next.instance}`;
    const alarmOf = async () => (await next.get('/sugarshack/state')).interlocks.find((i) => i.id === 'il').alarms.find((a) => a.id === alarmId);
    await waitFor(async () => Boolean(await alarmOf()), 'the failover alarm');
    assert.match((await alarmOf()).state, /unacknowledged$/);
    await next.request('POST', '/sugarshack/alarms/ack', { interlock: 'il', ids: [alarmId] });
    await waitFor(async () => { const a = await alarmOf(); return !a || a.state === 'active-acknowledged'; }, 'the failover alarm acknowledged');
    // An etcd member that stops answering is seen by operators, and after its on-delay is an alarm.
    await etcd.kill(2);
    const memberDown = `etcd-member-down:${etcd.endpoints[2]}`;
    await waitFor(async () => {
      const state = await next.get('/sugarshack/state');
      const alarm = state.interlocks.find((i) => i.id === 'il').alarms.find((a) => a.id === memberDown);
      return !state.cluster.etcd[2].healthy && alarm && alarm.state.startsWith('active');
    }, 'the etcd member seen down, and its alarm active', 20000);
    await etcd.restart(2);

    // The old leader comes back as the standby; the new one keeps acting.
    await leader.start({ waitForBroker: false });
    await waitFor(async () => (await pair.clusterOf(leader) || {}).role === 'standby', 'the old leader standby');
    assert.equal((await pair.clusterOf(next)).role, 'active');
    if (process.env.STANDBY_LOG) console.log(`      failover observed in ${failoverMs} ms`);
  });
});
