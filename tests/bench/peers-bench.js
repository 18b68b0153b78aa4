#!/usr/bin/env node
'use strict';
// Side by side with the Node-RED packages a user would install instead, in
// one Node-RED (node-red-node-test-helper), each driven through its nodes in
// a closed loop: the next msg goes in once the previous one came out, so every
// figure is the time of one round trip through the nodes (Node-RED's own
// per-hop cost included, alike for all).
//
//   mutex: acquire + release of one resource, nobody else waiting
//     sugarshack  interlock (one line): msg in -> acquire -> out, then a
//                 release msg in, as the peers' rows (compared); and
//                 acquire -> release -> out, one Node-RED hop more (shown);
//                 persist off, and on (every grant waits for its state on
//                 disk: the durable state of the safety issue)
//     simple-message-queue (node-red-contrib-simple-message-queue): first
//                 msg passes, the next wait until a {trigger} msg: msg in ->
//                 out, then {trigger} in (the release)
//     queue-gate (node-red-contrib-queue-gate): a gate left queueing: msg in
//                 (queued), then the 'trigger' control msg lets it out
//   pid step: one measurement in -> the output out
//     sugarshack-pid, against a positional PID with anti-windup written in a
//     function node (node-red-contrib-pid, which the issue names, and
//     node-red-contrib-semaphore are not on the npm registry reachable here).
//
// Rounds alternate between the rows so drift and GC fall on every row alike;
// the median over rounds is printed, with ratios peer / sugarshack (above 1x:
// ours is faster).
//
// usage: node tests/bench/peers-bench.js [--quick] [--only <row id>,...]

const fs = require('fs');
const os = require('os');
const path = require('path');
const helper = require('node-red-node-test-helper');
const { verdict, median } = require('./verdict');

const ROOT = path.resolve(__dirname, '../..');
// SUGARSHACK_PALETTE: another build of the palette, to compare two in one sitting.
const PALETTE = process.env.SUGARSHACK_PALETTE || path.join(ROOT, 'node-red-contrib-sugarshack');
const QUICK = process.argv.includes('--quick');
const onlyAt = process.argv.indexOf('--only');
const ONLY = onlyAt >= 0 ? new Set(process.argv[onlyAt + 1].split(',')) : null;
const OPS = QUICK ? 2000 : 10000;
const ROUNDS = QUICK ? 5 : 9;
const PERSIST_OPS = QUICK ? 100 : 400; // fsync per grant: far fewer
// Durable grants: the case study's 16 operations must be granted well within its 1 s control tick.
const PERSIST_TARGET_PER_S = 160;

helper.init(require.resolve('node-red'));
// The pid steps once per sample period (1 s here) and holds a faster
// measurement; its stale watch sends after 3 s without one. On the system
// clock a closed loop would wait for that watch. The palette's clock is moved
// 1 s per measurement instead (its timers are never run: none is due).
const { useClock, ManualClock } = require(path.join(PALETTE, 'lib', 'host', 'clock.js'));
const manual = useClock(new ManualClock());

const coreDir = path.dirname(require.resolve('node-red/package.json'));
const coreNodesDir = path.join(path.dirname(require.resolve('@node-red/nodes/package.json')));
const nodeFiles = [
  ...['interlock', 'acquire', 'release', 'pid', 'plant'].map((f) => require(path.join(PALETTE, 'nodes', `${f}.js`))),
  require(path.join(coreNodesDir, 'core', 'function', '10-function.js')),
  require('node-red-contrib-simple-message-queue/simple-message-queue.js'),
  require('node-red-contrib-queue-gate/q-gate.js'),
];
void coreDir;

const LINE = [{ name: 'YEL', lockout: null }];
const PID_FUNC = `// Positional PID, reverse acting, output clamped with conditional integration.
const kp = 1, ti = 20, td = 0, sp = 60, lo = 0, hi = 100;
const pv = msg.payload;
const t = msg.timestamp;
const s = context.get('s') || { i: 0, e: null, t: null };
const dt = s.t === null ? 1 : (t - s.t) / 1000;
const e = pv - sp; // reverse acting
const d = s.e === null || dt <= 0 ? 0 : (e - s.e) / dt;
let i = s.i + (kp / ti) * e * dt;
let u = kp * e + i + kp * td * d;
if (u > hi) { u = hi; i = s.i; } else if (u < lo) { u = lo; i = s.i; }
context.set('s', { i, e, t });
msg.payload = u;
return msg;`;

function flow() {
  const tab = { id: 'tab', type: 'tab', label: 'peers' };
  const il = (id, persist) => ({
    id, type: 'sugarshack-interlock', name: `line ${id}`, resources: LINE, policy: 'greedy', queueBound: '1024', persist,
  });
  return [
    tab,
    il('ilMem', false), il('ilFile', true),
    { id: 'acqMem', z: 'tab', type: 'sugarshack-acquire', interlock: 'ilMem', operation: '', priority: 1, resources: 'YEL', timeout: 0, wires: [['relMem']] },
    { id: 'relMem', z: 'tab', type: 'sugarshack-release', interlock: 'ilMem', operation: '', wires: [['outMem']] },
    { id: 'outMem', z: 'tab', type: 'helper' },
    { id: 'acqOne', z: 'tab', type: 'sugarshack-acquire', interlock: 'ilMem', operation: '', priority: 1, resources: 'YEL', timeout: 0, wires: [['outOne']] },
    { id: 'relOne', z: 'tab', type: 'sugarshack-release', interlock: 'ilMem', operation: '', wires: [[]] },
    { id: 'outOne', z: 'tab', type: 'helper' },
    { id: 'acqFile', z: 'tab', type: 'sugarshack-acquire', interlock: 'ilFile', operation: '', priority: 1, resources: 'YEL', timeout: 0, wires: [['relFile']] },
    { id: 'relFile', z: 'tab', type: 'sugarshack-release', interlock: 'ilFile', operation: '', wires: [['outFile']] },
    { id: 'outFile', z: 'tab', type: 'helper' },
    { id: 'smq', z: 'tab', type: 'simple-queue', firstMessageBypass: true, bypassInterval: 0, wires: [['outSmq']] },
    { id: 'outSmq', z: 'tab', type: 'helper' },
    {
      id: 'gate', z: 'tab', type: 'q-gate', controlTopic: 'control', defaultState: 'queueing', openCmd: 'open', closeCmd: 'close',
      toggleCmd: 'toggle', queueCmd: 'queue', triggerCmd: 'trigger', flushCmd: 'flush', resetCmd: 'reset', peekCmd: 'peek',
      dropCmd: 'drop', statusCmd: 'status', defaultCmd: 'default', maxQueueLength: 1000, keepNewest: false, persist: false, wires: [['outGate']],
    },
    { id: 'outGate', z: 'tab', type: 'helper' },
    { id: 'pid', z: 'tab', type: 'sugarshack-pid', kp: '1', ti: '20', td: '0', outMin: '0', outMax: '100', action: 'reverse', fallback: '', setpoint: '60', mode: 'auto', manual: '', ts: '1', staleMs: '', smith: 'off', modelGain: '', modelTau: '', deadSamples: '', alpha: '0.1', h: '3', maxSamples: '400', persist: false, store: 'default', wires: [['outPid']] },
    { id: 'outPid', z: 'tab', type: 'helper' },
    { id: 'fnPid', z: 'tab', type: 'function', func: PID_FUNC, outputs: 1, timeout: 0, noerr: 0, initialize: '', finalize: '', libs: [], wires: [['outFnPid']] },
    { id: 'outFnPid', z: 'tab', type: 'helper' },
  ];
}

/** Sends `count` round trips through `step(i, done)`, one after another; resolves with µs per round trip. */
function closedLoop(count, step) {
  return new Promise((resolve, reject) => {
    let i = 0;
    const t0 = process.hrtime.bigint();
    const next = () => {
      if (i === count) {
        resolve(Number(process.hrtime.bigint() - t0) / 1e3 / count);
        return;
      }
      const k = i++;
      try {
        step(k, next);
      } catch (err) {
        reject(err);
      }
    };
    next();
  });
}

/** One-shot listener on a helper node's input. */
function onceOut(node, fn) {
  node.once('input', fn);
}

function rows(get) {
  let seq = 0;
  const interlockRow = (entry, out, ops) => (n) => closedLoop(Math.min(n, ops), (k, done) => {
    const o = get(out);
    onceOut(o, (msg) => {
      if (msg.error) throw msg.error;
      done();
    });
    get(entry).receive({ operation: `op${seq++}`, payload: k });
  });
  return [
    {
      // The peers' shape: msg in -> out, then the release msg in (no second hop).
      id: 'ours-mutex', label: 'sugarshack acquire, then release', group: 'mutex',
      run: (n) => closedLoop(n, (k, done) => {
        const operation = `op${seq++}`;
        onceOut(get('outOne'), (msg) => {
          if (msg.error) throw msg.error;
          get('relOne').receive({ operation });
          setImmediate(done);
        });
        get('acqOne').receive({ operation, payload: k });
      }),
    },
    { id: 'ours-chain', label: 'sugarshack acquire -> release -> out', group: 'chain', run: interlockRow('acqMem', 'outMem', Infinity) },
    { id: 'ours-mutex-file', label: 'sugarshack, persist on (fsync)', group: 'durable', run: interlockRow('acqFile', 'outFile', PERSIST_OPS) },
    {
      id: 'smq', label: 'simple-message-queue msg+trigger', group: 'mutex',
      run: (n) => closedLoop(n, (k, done) => {
        onceOut(get('outSmq'), () => {
          get('smq').receive({ trigger: true }); // the release: queue empty, not busy
          setImmediate(done);
        });
        get('smq').receive({ payload: k });
      }),
    },
    {
      id: 'gate', label: 'queue-gate msg+trigger', group: 'mutex',
      run: (n) => closedLoop(n, (k, done) => {
        onceOut(get('outGate'), () => done());
        get('gate').receive({ payload: k });
        get('gate').receive({ topic: 'control', payload: 'trigger' });
      }),
    },
    {
      id: 'ours-pid', label: 'sugarshack-pid step', group: 'pid',
      run: (n) => closedLoop(n, (k, done) => {
        onceOut(get('outPid'), () => done());
        manual.ms += 1000;
        get('pid').receive({ payload: 50 + Math.sin(k / 10) * 5, timestamp: manual.ms });
      }),
    },
    {
      id: 'fn-pid', label: 'PID in a function node', group: 'pid',
      run: (n) => closedLoop(n, (k, done) => {
        onceOut(get('outFnPid'), () => done());
        manual.ms += 1000;
        get('fnPid').receive({ payload: 50 + Math.sin(k / 10) * 5, timestamp: manual.ms });
      }),
    },
  ];
}

async function main() {
  const userDir = fs.mkdtempSync(path.join(os.tmpdir(), 'sugarshack-peers-'));
  helper.settings({ userDir });
  await new Promise((resolve) => helper.startServer(resolve));
  try {
    // The helper wraps Node's send, status, log... in a sinon spy inside a Proxy
    // that its sandbox's restore leaves in place, and each node took the
    // wrapped send as its own when wired: every hop paid for a spy call record,
    // which real Node-RED does not. The originals go back, on the nodes too.
    const proto = helper._NodePrototype;
    const originals = ['log', 'status', 'warn', 'error', 'debug', 'trace', 'send'].map((m) => [m, proto[m]]);
    await helper.load(nodeFiles, flow());
    const wrappedSend = proto.send;
    helper._sandbox.restore();
    for (const [m, fn] of originals) proto[m] = fn;
    for (const { id } of flow()) {
      const node = helper.getNode(id);
      if (node && node.send === wrappedSend) node.send = proto.send;
    }
    await new Promise((r) => setTimeout(r, 300)); // function node's vm, interlock start
    const table = rows((id) => {
      const n = helper.getNode(id);
      if (!n) throw new Error(`node ${id} did not load`);
      return n;
    }).filter((r) => !ONLY || ONLY.has(r.id));
    const times = new Map(table.map((r) => [r.id, []]));
    for (let round = 0; round <= ROUNDS; round++) {
      for (let k = 0; k < table.length; k++) {
        const row = table[(k + round) % table.length];
        const us = await row.run(round === 0 ? Math.min(OPS, 200) : OPS);
        if (round > 0) times.get(row.id).push(us);
      }
    }
    const med = Object.fromEntries(table.map((r) => [r.id, median(times.get(r.id))]));
    if (ONLY) {
      for (const r of table) console.log(`  ${r.label.padEnd(36)} ${med[r.id].toFixed(1).padStart(14)} µs`);
      return;
    }
    console.log(`peers: node ${process.version}, Node-RED ${require('node-red/package.json').version}, ${os.cpus().length} cores, load average ${os.loadavg()[0].toFixed(2)}; `
      + `${OPS} round trips per row per round (${PERSIST_OPS} with persist on), ${ROUNDS} rounds, median`);
    console.log(`  ${'row'.padEnd(36)} ${'µs/round trip'.padStart(14)} ${'per second'.padStart(11)} ${'vs sugarshack'.padStart(14)}`);
    const base = { mutex: med['ours-mutex'], durable: med['ours-mutex'], chain: med['ours-mutex'], pid: med['ours-pid'] };
    for (const r of table) {
      const ratio = r.id.startsWith('ours') ? '' : `${(med[r.id] / base[r.group]).toFixed(2)}x`;
      console.log(`  ${r.label.padEnd(36)} ${med[r.id].toFixed(1).padStart(14)} ${Math.round(1e6 / med[r.id]).toLocaleString('en').padStart(11)} ${ratio.padStart(14)}`);
    }
    console.log('  (vs sugarshack: the peer\'s time / ours; above 1x ours is faster)');
    const fastestMutexPeer = Math.min(med.smq, med.gate);
    console.log(verdict('interlock acquire+release vs the fastest peer mutex (Node-RED nodes)', `${(fastestMutexPeer / med['ours-mutex']).toFixed(2)}x`, med['ours-mutex'] <= fastestMutexPeer, '>= 1x'));
    console.log(verdict('pid step vs a function-node PID', `${(med['fn-pid'] / med['ours-pid']).toFixed(2)}x`, med['ours-pid'] <= med['fn-pid'], '>= 1x'));
    const durable = 1e6 / med['ours-mutex-file'];
    console.log(verdict('grants/s with persistence on, through the nodes', `${Math.round(durable)}/s`, durable >= PERSIST_TARGET_PER_S, `>= ${PERSIST_TARGET_PER_S}/s: the case study's 16 operations within 0.1 s`));
  } finally {
    await helper.unload().catch(() => {});
    await new Promise((resolve) => helper.stopServer(resolve));
    fs.rmSync(userDir, { recursive: true, force: true });
  }
}

main().then(() => process.exit(0), (err) => {
  console.error(`peers-bench: ${err.stack || err}`);
  process.exit(1);
});
