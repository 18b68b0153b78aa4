#!/usr/bin/env node
'use strict';
// Footprint: the wasm module's size, and what installing the palette costs a
// Node-RED at start: RSS once its flows run, and the time from spawn to
// "Started flows". Node-RED 4.1 runs in its own process and temporary user
// directory, alternately without and with the palette, N times each (the
// median of each is compared, so the machine's other load falls on both):
//   bare      Node-RED, the interlock example's flow minus the palette's nodes
//   palette   the palette linked into node_modules, the interlock example
//             (examples/interlock-yel-contention.json: the wasm is instantiated)
// RSS is read from /proc/<pid>/status 3 s after "Started flows".
// A breakdown of the palette's share comes from a bare `node` process:
// RSS before and after requiring the wasm bindings (compile + instantiate).
//
// usage: node tests/bench/footprint.js [--runs N] [--json]

const fs = require('fs');
const os = require('os');
const path = require('path');
const { spawn, execFileSync } = require('child_process');
const { settingsFile, freePort, sleep, ROOT, PALETTE } = require('../../scripts/lib/node-red-process');
const { verdict, median } = require('./verdict');

const RED_JS = path.join(ROOT, 'node_modules', 'node-red', 'red.js');
const WASM = path.join(PALETTE, 'wasm', 'sugarshack_wasm_bg.wasm');
const args = process.argv.slice(2);
const runsAt = args.indexOf('--runs');
const RUNS = runsAt >= 0 ? Number(args[runsAt + 1]) : 3;
const SETTLE_MS = 3000;
const TARGETS = { wasmKB: 300, addedRssMB: 15, startupRatio: 1.2 };

const EXAMPLE = JSON.parse(fs.readFileSync(path.join(PALETTE, 'examples', 'interlock-yel-contention.json'), 'utf8'));
// Without the palette the same tab, comments, injects and debugs (its nodes dropped, wires cut).
const BARE = EXAMPLE.filter((n) => !String(n.type).startsWith('sugarshack-') && n.type !== 'catch')
  .map((n) => ({ ...n, wires: (n.wires || []).map(() => []) }));

function rssMB(pid) {
  const m = /VmRSS:\s+(\d+) kB/.exec(fs.readFileSync(`/proc/${pid}/status`, 'utf8'));
  return m ? Number(m[1]) / 1024 : NaN;
}

async function startOnce(label, flow, withPalette) {
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), `sugarshack-footprint-${label}-`));
  try {
    fs.writeFileSync(path.join(dir, 'settings.js'), settingsFile(dir));
    fs.writeFileSync(path.join(dir, 'flows.json'), JSON.stringify(flow));
    if (withPalette) {
      fs.mkdirSync(path.join(dir, 'node_modules'));
      fs.symlinkSync(PALETTE, path.join(dir, 'node_modules', 'node-red-contrib-sugarshack'), 'dir');
    }
    const port = await freePort();
    const t0 = process.hrtime.bigint();
    const red = spawn(process.execPath, [RED_JS, '-u', dir, '-p', String(port), '-s', path.join(dir, 'settings.js'), '--no-telemetry'], {
      cwd: dir, stdio: ['ignore', 'pipe', 'pipe'],
    });
    let log = '';
    const started = await new Promise((resolve, reject) => {
      const timer = setTimeout(() => reject(new Error(`${label}: not started after 60 s:\n${log.slice(-2000)}`)), 60000);
      const onData = (chunk) => {
        log += chunk;
        if (log.includes('Started flows')) {
          clearTimeout(timer);
          resolve(Number(process.hrtime.bigint() - t0) / 1e6);
        }
      };
      red.stdout.on('data', onData);
      red.stderr.on('data', onData);
      red.once('exit', (code) => reject(new Error(`${label}: exited ${code} during start-up:\n${log.slice(-2000)}`)));
    });
    if (/\[error\]/.test(log)) throw new Error(`${label}: errors at start-up:\n${log.slice(-2000)}`);
    await sleep(SETTLE_MS);
    const rss = rssMB(red.pid);
    const exited = new Promise((resolve) => red.once('exit', resolve));
    red.kill('SIGTERM');
    await exited;
    return { startMs: started, rss };
  } finally {
    fs.rmSync(dir, { recursive: true, force: true });
  }
}

// RSS a bare node process adds by loading the wasm bindings (compile + instantiate).
function wasmLoadMB() {
  const probe = `const f=()=>{const m=/VmRSS:\\s+(\\d+)/.exec(require('fs').readFileSync('/proc/self/status','utf8'));return m[1]/1024};
    global.gc&&gc();const a=f();require(${JSON.stringify(path.join(PALETTE, 'wasm', 'sugarshack_wasm.js'))});global.gc&&gc();console.log(JSON.stringify({before:a,after:f()}))`;
  const out = JSON.parse(execFileSync(process.execPath, ['--expose-gc', '-e', probe], { encoding: 'utf8' }));
  return out.after - out.before;
}

async function main() {
  const json = args.includes('--json');
  const bare = [];
  const pal = [];
  for (let i = 0; i < RUNS; i++) {
    bare.push(await startOnce('bare', BARE, false));
    pal.push(await startOnce('palette', EXAMPLE, true));
  }
  const m = (rows, k) => median(rows.map((r) => r[k]));
  const figures = {
    wasmKB: fs.statSync(WASM).size / 1024,
    bareRss: m(bare, 'rss'),
    paletteRss: m(pal, 'rss'),
    bareStart: m(bare, 'startMs'),
    paletteStart: m(pal, 'startMs'),
    wasmLoadMB: wasmLoadMB(),
  };
  figures.addedRss = figures.paletteRss - figures.bareRss;
  figures.startupRatio = figures.paletteStart / figures.bareStart;
  if (json) {
    console.log(JSON.stringify(figures));
    return;
  }
  console.log(`footprint: Node-RED ${require('node-red/package.json').version}, node ${process.version}, ${os.cpus().length} cores, load average ${os.loadavg()[0].toFixed(2)}; median of ${RUNS} starts each, alternating`);
  console.log(`  bare Node-RED     RSS ${figures.bareRss.toFixed(1)} MB, start ${figures.bareStart.toFixed(0)} ms`);
  console.log(`  with the palette  RSS ${figures.paletteRss.toFixed(1)} MB, start ${figures.paletteStart.toFixed(0)} ms (interlock example deployed)`);
  console.log(`  of which the wasm bindings in a bare node process: +${figures.wasmLoadMB.toFixed(1)} MB RSS`);
  console.log(verdict('wasm module size (wasm-opt -Oz)', `${figures.wasmKB.toFixed(0)} KB`, figures.wasmKB < TARGETS.wasmKB, `< ${TARGETS.wasmKB} KB`));
  console.log(verdict("palette's added RSS at start", `+${figures.addedRss.toFixed(1)} MB`, figures.addedRss < TARGETS.addedRssMB, `< ${TARGETS.addedRssMB} MB`));
  console.log(verdict('startup with the palette vs without', `${figures.startupRatio.toFixed(2)}x`, figures.startupRatio <= TARGETS.startupRatio, `<= ${TARGETS.startupRatio}x`));
}

if (require.main === module) {
  main().catch((err) => {
    console.error(`footprint: ${err.stack || err}`);
    process.exit(1);
  });
}
