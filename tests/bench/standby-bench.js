#!/usr/bin/env node
'use strict';
// What the hot standby costs and how fast it takes over, on a real
// three-member etcd cluster on loopback (Debian's etcd-server), against the
// file store measured in the same run:
//
//   commit     one grant at a time, from the call to the msg leaving: the state
//              written as a fenced etcd transaction, or fsynced to a file
//   nodes      grants/s through Node-RED nodes (acquire -> release -> out) with
//              the state in etcd, and in a file: the case study's 16 operations
//              arriving at once on 16 lines (what the target is about: all
//              granted within 0.1 s), and one at a time in a closed loop
//   failover   two real Node-RED processes (passive standby: flows running,
//              acting on nothing), Mosquitto with dynamic security, one line
//              e-stopped: the leader is killed with SIGKILL, and the time runs
//              to the new leader's first PUBLISH at the broker (the lockout it
//              sends again), split into the lease running out (kill -> etcd
//              deletes the leader key) and the takeover (deletion -> first
//              publish); then the same with the standby's flows stopped
//              (Node-RED's runtime flow state) and started on its election.
//
// usage: node tests/bench/standby-bench.js [--quick] [--failovers N] [--stopped N] [--only commit,nodes,failover]
const fs = require('fs');
const os = require('os');
const path = require('path');
const { EventEmitter } = require('events');
const helper = require('node-red-node-test-helper');
const { Etcd3 } = require('etcd3');
const { verdict, median, quantile } = require('./verdict');
const { fakeRuntime, latency, CASE_LINES } = require('./durable-bench');
const { startEtcd } = require('../integration/support/etcd');
const { startDynsecMosquitto } = require('../integration/support/dynsec');
const { connectProbe } = require('../integration/support/mqtt-probe');
const { waitFor, sleep } = require('../integration/support/node-red');
const { StandbyPair } = require('../integration/support/standby');

const ROOT = path.resolve(__dirname, '../..');
const PALETTE = path.join(ROOT, 'node-red-contrib-sugarshack');
const QUICK = process.argv.includes('--quick');
const argOf = (name, dflt) => (process.argv.includes(name) ? Number(process.argv[process.argv.indexOf(name) + 1]) : dflt);
const FAILOVERS = argOf('--failovers', QUICK ? 20 : 40);
const STOPPED = argOf('--stopped', QUICK ? 5 : 10);
const SAMPLES = QUICK ? 200 : 1000;
const NODE_OPS = QUICK ? 300 : 1000;
const BURST = 16; // the case study's operations
const BURSTS = QUICK ? 20 : 50;
const TTL_S = 3; // the default (lib/cluster/settings.js)
const GRANTS_TARGET_PER_S = 160;
const ONLY = process.argv.includes('--only') ? new Set(process.argv[process.argv.indexOf('--only') + 1].split(',')) : null;
const FAILOVER_P99_TARGET_MS = 5000;

const clusterSection = (etcd, name) => ({ name, instance: `bench-${process.pid}`, etcd: { hosts: etcd.endpoints }, leaseTtlS: TTL_S });
const fmt = (x) => x.toFixed(2).padStart(9);

async function commitCost(etcd) {
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'sugarshack-standby-bench-'));
  const file = fakeRuntime(true, dir, CASE_LINES);
  const RED = { settings: { userDir: dir, sugarshack: { cluster: clusterSection(etcd, 'commit') } }, events: new EventEmitter(), log: { info() {}, warn() {}, error() {} } };
  const onEtcd = fakeRuntime(true, dir, CASE_LINES, RED, 'bench-etcd');
  await file.start();
  await onEtcd.start();
  await waitFor(() => onEtcd.state === 'ready', 'the etcd-backed interlock active', 20000);
  const lf = await latency(file, SAMPLES);
  const le = await latency(onEtcd, SAMPLES);
  console.log(`\ncommit cost of one grant on the case study's 5 lines, call to msg out (ms, ${SAMPLES} grants)`);
  console.log(`  ${'state'.padEnd(28)} ${'median'.padStart(9)} ${'p99'.padStart(9)}`);
  console.log(`  ${'file (fsync, baseline)'.padEnd(28)} ${fmt(lf.median)} ${fmt(lf.p99)}`);
  console.log(`  ${'etcd (fenced transaction)'.padEnd(28)} ${fmt(le.median)} ${fmt(le.p99)}`);
  console.log(`  etcd/file: median ${(le.median / lf.median).toFixed(2)}x, p99 ${(le.p99 / lf.p99).toFixed(2)}x`);
  await file.shutdown();
  await onEtcd.shutdown();
  await onEtcd.cluster.stop();
  fs.rmSync(dir, { recursive: true, force: true });
}

/** Grants/s through acquire -> release -> out, the state in etcd or in a file (one Node-RED each, in turn). */
async function throughNodes(etcd) {
  helper.init(require.resolve('node-red'));
  const nodeFiles = ['interlock', 'acquire', 'release'].map((f) => require(path.join(PALETTE, 'nodes', `${f}.js`)));
  const flow = [
    { id: 'f1', type: 'tab' },
    { id: 'il', type: 'sugarshack-interlock', name: 'bench', resources: Array.from({ length: BURST }, (_, i) => ({ name: `L${i}` })), policy: 'greedy', persist: true },
    { id: 'acq', z: 'f1', type: 'sugarshack-acquire', interlock: 'il', operation: '', priority: '1', resources: 'L0', wires: [['rel']] },
    { id: 'rel', z: 'f1', type: 'sugarshack-release', interlock: 'il', operation: '', wires: [['out']] },
    { id: 'out', z: 'f1', type: 'helper' },
  ];
  const rates = {};
  const bursts = {};
  for (const [label, extra] of [['file', {}], ['etcd', { sugarshack: { cluster: clusterSection(etcd, 'nodes') } }]]) {
    const userDir = fs.mkdtempSync(path.join(os.tmpdir(), 'sugarshack-standby-nodes-'));
    helper.settings({ userDir, ...extra });
    await new Promise((resolve) => helper.startServer(resolve));
    await helper.load(nodeFiles, flow);
    const il = helper.getNode('il');
    await waitFor(() => il.runtime.state === 'ready', `the ${label} interlock running`, 20000);
    const started = process.hrtime.bigint();
    for (let k = 0; k < NODE_OPS; k++) {
      await new Promise((resolve) => {
        helper.getNode('out').once('input', resolve);
        helper.getNode('acq').receive({ operation: `op${k}`, payload: k });
      });
    }
    rates[label] = NODE_OPS / (Number(process.hrtime.bigint() - started) / 1e9);
    // 16 operations at once, each on its own line: group commit makes their grants one write, their releases another.
    const times = [];
    for (let b = 0; b < BURSTS; b++) {
      const t0 = process.hrtime.bigint();
      await new Promise((resolve) => {
        let left = BURST;
        const out = helper.getNode('out');
        const seen = () => {
          if (--left > 0) return;
          out.removeListener('input', seen);
          resolve();
        };
        out.on('input', seen);
        for (let k = 0; k < BURST; k++) helper.getNode('acq').receive({ operation: `b${b}-${k}`, resources: [`L${k}`] });
      });
      times.push(Number(process.hrtime.bigint() - t0) / 1e6);
    }
    bursts[label] = { median: median(times), p99: quantile(times, 0.99) };
    const { cluster } = il.runtime;
    await helper.unload();
    await new Promise((resolve) => helper.stopServer(resolve));
    if (cluster) await cluster.stop();
    fs.rmSync(userDir, { recursive: true, force: true });
  }
  const perS = (label) => BURST / (bursts[label].median / 1000);
  console.log(`\ngrants through the nodes (acquire -> release -> out)`);
  console.log(`  ${''.padEnd(24)} ${`${BURST} at once: ms (median, p99)`.padStart(30)} ${'grants/s'.padStart(9)} ${'one at a time/s'.padStart(16)}`);
  for (const label of ['file', 'etcd']) {
    const b = bursts[label];
    console.log(`  ${(label === 'file' ? 'file (fsync, baseline)' : 'etcd').padEnd(24)} ${`${b.median.toFixed(1)}, ${b.p99.toFixed(1)}`.padStart(30)} ${String(Math.round(perS(label))).padStart(9)} ${String(Math.round(rates[label])).padStart(16)}`);
  }
  console.log(`  etcd/file: ${(perS('etcd') / perS('file')).toFixed(2)}x at once, ${(rates.etcd / rates.file).toFixed(2)}x one at a time`);
  return { burst: perS('etcd'), burstMs: bursts.etcd.median, single: rates.etcd };
}

/** Failovers of a real pair; `stopped`: the standby's flows stopped until it is elected. */
async function failovers(etcd, count, { stopped }) {
  const publishes = [];
  const broker = await startDynsecMosquitto({ accounts: ['nr-a', 'nr-b', 'probe'], onPublish: (p) => publishes.push(p) });
  const probe = await connectProbe(broker.urlOf('probe'), ['+/+/+/command']);
  const name = stopped ? 'stopped' : 'passive';
  const pair = new StandbyPair({
    etcd, broker, cluster: name, ttlS: TTL_S, dynsec: { admin: broker.admin, accounts: { a: broker.account('nr-a'), b: broker.account('nr-b') } },
    settings: stopped ? '\n  runtimeState: { enabled: true },' : '',
  });
  const watch = new Etcd3({ hosts: etcd.endpoints });
  const deletions = [];
  const watcher = await watch.watch().key(`sugarshack/${name}/leader`).create();
  watcher.on('delete', () => deletions.push(Date.now()));
  const rows = [];
  try {
    let leader = await pair.start();
    await probe.publish('test/estop/RED', 'e-stop'); // every new leader sends RED's lockout again
    for (let i = 0; i < count; i++) {
      const standby = pair.other(leader);
      await waitFor(async () => (await pair.clusterOf(standby) || {}).role === 'standby', 'the standby', 60000);
      await waitFor(() => /Connected to broker/.test(standby.logOfThisRun()), 'the standby\'s MQTT connected', 60000);
      if (stopped) await standby.request('POST', '/flows/state', { state: 'stop' });
      await sleep(300 + Math.random() * 1000); // a random point in the keep-alive cycle
      const killedAt = Date.now();
      await leader.kill();
      if (stopped) {
        await waitFor(async () => (await pair.clusterOf(standby) || {}).role === 'active', 'the stopped standby elected', 30000);
        await standby.request('POST', '/flows/state', { state: 'start' });
      }
      const client = `nr-${standby.instance}`;
      await waitFor(() => publishes.some((p) => p.client === client && p.at >= killedAt), `the first publish of ${standby.instance}`, 30000);
      const first = publishes.find((p) => p.client === client && p.at >= killedAt).at;
      const deleted = deletions.find((d) => d >= killedAt) || NaN;
      rows.push({ total: first - killedAt, lease: deleted - killedAt, takeover: first - deleted });
      if (process.env.BENCH_LOG) console.log(`  ${name} failover ${i + 1}: ${first - killedAt} ms`);
      await leader.start({ waitForBroker: false });
      leader = standby;
    }
  } finally {
    await watcher.cancel().catch(() => {});
    watch.close();
    await pair.finish();
    await probe.end();
    await broker.stop();
  }
  return rows;
}

function failoverTable(label, rows) {
  const col = (k) => rows.map((r) => r[k]).filter(Number.isFinite);
  const line = (what, k) => `  ${what.padEnd(34)} ${String(Math.round(median(col(k)))).padStart(7)} ${String(Math.round(quantile(col(k), 0.99))).padStart(7)} ${String(Math.round(Math.max(...col(k)))).padStart(7)}`;
  console.log(`\nfailover, ${label} standby: ${rows.length} SIGKILLs of the leader, lease TTL ${TTL_S} s (ms)`);
  console.log(`  ${''.padEnd(34)} ${'median'.padStart(7)} ${'p99'.padStart(7)} ${'max'.padStart(7)}`);
  console.log(line('kill -> lease expired (key deleted)', 'lease'));
  console.log(line('key deleted -> first publish', 'takeover'));
  console.log(line('kill -> new leader\'s first effect', 'total'));
}

async function main() {
  console.log(`standby-bench: node ${process.version}, ${os.cpus().length} cores, load average ${os.loadavg()[0].toFixed(2)}; etcd ${require('child_process').execFileSync('etcd', ['--version'], { encoding: 'utf8' }).split('\n')[0]}`);
  const etcd = await startEtcd();
  try {
    if (!ONLY || ONLY.has('commit')) await commitCost(etcd);
    const nodes = !ONLY || ONLY.has('nodes') ? await throughNodes(etcd) : null;
    if (ONLY && !ONLY.has('failover')) return;
    const passive = await failovers(etcd, FAILOVERS, { stopped: false });
    failoverTable('passive (flows running, acting on nothing)', passive);
    const cold = await failovers(etcd, STOPPED, { stopped: true });
    failoverTable('stopped (flows started on election)', cold);
    const p99 = quantile(passive.map((r) => r.total), 0.99);
    console.log(`  passive vs stopped: median ${Math.round(median(passive.map((r) => r.total)))} vs ${Math.round(median(cold.map((r) => r.total)))} ms`);
    if (nodes) console.log(verdict(`grants/s through the nodes with the state in etcd, ${BURST} operations at once`, `${Math.round(nodes.burst)}/s (${BURST} in ${nodes.burstMs.toFixed(1)} ms)`, nodes.burst >= GRANTS_TARGET_PER_S, `>= ${GRANTS_TARGET_PER_S}/s: the case study's 16 operations within 0.1 s`));
    console.log(verdict(`failover p99, kill to first effect (${passive.length} failovers)`, `${Math.round(p99)} ms`, p99 < FAILOVER_P99_TARGET_MS, `< ${FAILOVER_P99_TARGET_MS} ms`));
  } finally {
    await etcd.stop();
  }
}

main().then(() => process.exit(0), (err) => {
  console.error(err);
  process.exit(1);
});
