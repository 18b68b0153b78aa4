#!/usr/bin/env node
'use strict';
// The OPC UA server's cost (node-red-contrib-sugarshack-opcua): what it adds
// to install, and Node-RED's CPU and memory with it, every value subscribed
// by an independent client (Python's asyncua), against the same plant without
// it, measured in the same run:
//
//   install      the package's dependency tree (node-opcua) on disk, against the palette's own files
//   case study   flows/case-study.json on the simulator: the palette alone; the package installed
//                but no server node (node-opcua is loaded with the first server only); a server
//                with no client; a server with every variable (about 1,100) subscribed at 250 ms and
//                the alarms' events
//   95,200 I/O   the cloud paper's Table 1 plant (5,600 panels of 17 I/O, tests/bench/scaling.js's
//                plant and publisher, every datapoint at 1 Hz): the palette alone, and a server with
//                every device variable (33,600) subscribed at 250 ms (above its actuator limit the
//                server carries each device's actuators in arrays, so it makes no node per actuator)
//
// CPU is Node-RED's threads' run time over the window (/proc/<pid>/task/*/schedstat),
// RSS its /proc/<pid>/status VmRSS at the window's end, the event loop's delay p99 over
// the window from a monitor started by settings.js. Figures and ratios are printed,
// never asserted.
//
// usage: node tests/bench/opcua-load.js [--quick] [--skip-large | --only-large]
//   --quick: 10 s warm-up and 20 s windows (else 20 s and 60 s)
const fs = require('fs');
const os = require('os');
const path = require('path');
const { execFileSync, spawn } = require('child_process');
const { startOpcuaPlant, NS_URI, ROOT } = require('../integration/support/opcua');
const { flowOf, cpuTicks, rssMB, lagMonitor, CLK_TCK, IO_PER_PANEL } = require('./scaling');

const args = process.argv.slice(2);
const QUICK = args.includes('--quick');
const WARMUP_MS = QUICK ? 10000 : 20000;
const WINDOW_MS = QUICK ? 20000 : 60000;
const PANELS = 5600;
const SAMPLING_MS = 250;
const PACKAGE = path.join(ROOT, 'node-red-contrib-sugarshack-opcua');
const PALETTE = path.join(ROOT, 'node-red-contrib-sugarshack');
const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

function du(dir, exclude) {
  const out = execFileSync('du', ['-sk', ...(exclude ? [`--exclude=${exclude}`] : []), dir], { encoding: 'utf8' });
  return Number(out.split('\t')[0]) / 1024;
}

/** CPU (% of a core), RSS (MB) and event-loop delay p99 (ms) of Node-RED over a window. */
async function measure(red, lagFile) {
  await sleep(WARMUP_MS);
  const pid = red.child.pid;
  fs.writeFileSync(`${lagFile}.window`, '');
  const [t0, c0] = [process.hrtime.bigint(), cpuTicks(pid)];
  await sleep(WINDOW_MS);
  const seconds = Number(process.hrtime.bigint() - t0) / 1e9;
  const cpu = ((cpuTicks(pid) - c0) / CLK_TCK / seconds) * 100;
  const lags = fs.readFileSync(lagFile, 'utf8').trim().split('\n').map((l) => JSON.parse(l));
  return { cpu, rss: rssMB(pid), lagP99: lags[lags.length - 1].windowP99 };
}

/** A run: Node-RED on `plantFlows` (case study when null) with `servers`; `client(ua, ns)` subscribes. */
async function run(label, { servers = [], installed = true, plantFlows = null, simPlant, client = null, publisher = false, startTimeoutMs }) {
  const lagFile = path.join(os.tmpdir(), `sugarshack-opcua-lag-${process.pid}-${label.replace(/\W+/g, '-')}.jsonl`);
  const plant = await startOpcuaPlant({
    tag: 'opcua-bench', speed: 1, servers, installed, plantFlows, ...(simPlant === undefined ? {} : { simPlant }), preamble: lagMonitor(lagFile), startTimeoutMs,
  });
  let pub = null;
  let subscribed = 0;
  try {
    if (publisher) {
      pub = spawn(process.execPath, [path.join(__dirname, 'scaling', 'publisher.js'), plant.broker.url, String(PANELS)], { stdio: ['ignore', 'ignore', 'inherit'] });
    }
    if (client) {
      await plant.ua.ask('connect', { name: 'scada', url: plant.urls.tryout, count_only: true, timeout: 120 });
      const ns = await plant.ua.ask('namespace', { name: 'scada', uri: NS_URI });
      subscribed = (await client(plant.ua, ns)).count;
    }
    const before = client ? await plant.ua.ask('count', { name: 'scada' }) : 0;
    const figures = await measure(plant.red, lagFile);
    const notifications = client ? (await plant.ua.ask('count', { name: 'scada' })) - before : 0;
    return { label, ...figures, subscribed, notificationsPerS: notifications / ((WARMUP_MS + WINDOW_MS) / 1000) };
  } finally {
    if (pub) pub.kill('SIGTERM');
    await plant.stop();
    fs.rmSync(lagFile, { force: true });
    fs.rmSync(`${lagFile}.window`, { force: true });
  }
}

const everyVariable = async (ua) => {
  const count = (await ua.ask('subscribe_all', { name: 'scada', interval: SAMPLING_MS })).count;
  await ua.ask('subscribe_events', { name: 'scada' });
  return { count };
};

/** Every device variable of the 95,200-I/O plant, by its node id (a browse of 40,000 nodes would time the client, not the server). */
const everyDevice = async (ua, ns) => {
  const paths = [];
  for (let p = 1; p <= PANELS; p++) for (const v of ['Online', 'Stale', 'Actuators', 'Positions', 'Targets', 'Phases']) paths.push(`Devices/ctrl-${p}/${v}`);
  return ua.ask('subscribe_ids', { name: 'scada', ns, paths, interval: SAMPLING_MS, sampling: SAMPLING_MS });
};

/**
 * The scaling plant's flow with an interlock bound to its plant (the server
 * serves an interlock), whose one line is panel 1 (an interlock needs a line).
 */
function largeFlows() {
  const flow = flowOf(PANELS, 1883).map((n) => (n.type !== 'sugarshack-plant' ? n : {
    ...n,
    plant: { ...n.plant, resources: [{ id: 'L1' }], actuators: n.plant.actuators.map((a) => (a.device === 'ctrl-1' ? { ...a, resource: 'L1' } : a)) },
  }));
  return [...flow, { id: 'il', type: 'sugarshack-interlock', name: '95,200 I/O', plant: 'pl', resources: [], policy: 'greedy', queueBound: '1024', warnQueued: '', warnHeld: '', persist: false }];
}

const row = (r, base) => `  ${r.label.padEnd(46)} ${r.cpu.toFixed(1).padStart(6)} %${base ? ` (x${(r.cpu / base.cpu).toFixed(2)})`.padEnd(9) : ''.padEnd(9)} `
  + `${r.rss.toFixed(0).padStart(6)} MB${base ? ` (+${(r.rss - base.rss).toFixed(0)})`.padEnd(8) : ''.padEnd(8)} ${r.lagP99.toFixed(1).padStart(7)} ms`
  + `${r.subscribed ? `   ${r.subscribed} items, ${r.notificationsPerS.toFixed(0)} notifications/s` : ''}`;

async function main() {
  console.log(`opcua-load: Node-RED ${require('node-red/package.json').version}, node ${process.version}, ${os.cpus().length} cores, load average ${os.loadavg().map((x) => x.toFixed(2)).join(' ')}; `
    + `${WARMUP_MS / 1000} s warm-up, ${WINDOW_MS / 1000} s window per run`);
  const pkgs = fs.readdirSync(path.join(PACKAGE, 'node_modules')).flatMap((d) => (d.startsWith('@') ? fs.readdirSync(path.join(PACKAGE, 'node_modules', d)) : [d])).length;
  console.log(`  install: node-opcua and its tree ${du(path.join(PACKAGE, 'node_modules')).toFixed(1)} MB in ${pkgs} packages; the OPC UA package's own files `
    + `${du(PACKAGE, 'node_modules').toFixed(2)} MB; the palette's files ${du(PALETTE, 'node_modules').toFixed(1)} MB`);
  console.log(`  ${'run'.padEnd(46)} ${'CPU of a core'.padStart(16)} ${'RSS'.padStart(16)} ${'lag p99'.padStart(10)}`);
  if (!args.includes('--only-large')) {
    const bare = await run('case study, palette alone (package not installed)', { installed: false });
    console.log(row(bare));
    for (const [label, options] of [
      ['case study, package installed, no server node', {}],
      ['case study, a server, no client', { servers: ['tryout'] }],
      ['case study, a server, every value subscribed', { servers: ['tryout'], client: everyVariable }],
    ]) console.log(row(await run(label, options), bare));
  }
  if (args.includes('--skip-large')) return;
  const large = { plantFlows: largeFlows(), simPlant: null, publisher: true, startTimeoutMs: 900000 };
  const bigBare = await run(`${PANELS * IO_PER_PANEL} I/O, palette alone`, { ...large, installed: false });
  console.log(row(bigBare));
  console.log(row(await run(`${PANELS * IO_PER_PANEL} I/O, a server, every value subscribed`, { ...large, servers: ['tryout'], client: everyDevice }), bigBare));
  console.log('  (x: against the palette alone on the same plant, in this run; + MB: RSS added)');
}

main().catch((err) => {
  console.error(`opcua-load: ${err.stack || err}`);
  process.exit(1);
});
