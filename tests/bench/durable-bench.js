#!/usr/bin/env node
'use strict';
// What durability costs: an interlock whose every grant waits until its state
// is on disk (temp file, fsync, rename, fsync of the directory) against the
// same interlock keeping its state in memory, in one run on the same machine.
// Prints figures, asserts nothing about speed.
//
//   latency    one acquire at a time on a free line, timed from the call to the
//              msg leaving (the grant delivered): median and p99
//   burst      N acquires of free lines in one turn of the event loop (one
//              write for all of them): time until the last grant is delivered,
//              per change, and the number of writes
//
// usage: node tests/bench/durable-bench.js [--quick] [--dir <path>]
//   --dir  where the state files go (default: a temp dir; pass a directory on
//          the disk Node-RED's user directory lives on to measure that disk)
const fs = require('fs');
const os = require('os');
const path = require('path');

const ROOT = path.resolve(__dirname, '../..');
const { EngineRuntime } = require(path.join(ROOT, 'node-red-contrib-sugarshack/lib/interlock/engine-runtime.js'));

const args = process.argv.slice(2);
const QUICK = args.includes('--quick');
const dirArg = args.indexOf('--dir') >= 0 ? args[args.indexOf('--dir') + 1] : null;
const SAMPLES = QUICK ? 100 : 500;
const BURSTS = [1, 10, 100, 1000];
// The case study's five lines for one grant at a time; enough lines for the largest burst to be granted at once.
const CASE_LINES = ['YEL', 'GRN', 'BLU', 'PUR', 'RED'];
const LINES = Array.from({ length: 1024 }, (_, i) => `L${i}`);

/** An interlock runtime outside Node-RED; `RED` may bring settings of its own (a cluster: tests/bench/standby-bench.js). */
function fakeRuntime(persist, userDir, lines, RED = { settings: { userDir } }, id = `bench-${persist ? 'file' : 'memory'}-${lines.length}`) {
  const quiet = { error() {}, warn() {}, log() {}, context: () => ({ global: { get: (k, s, cb) => cb(null, undefined) } }) };
  const rt = new EngineRuntime({
    RED: { util: { generateId: () => Math.random().toString(16).slice(2) }, ...RED },
    id,
    settings: { config: { resources: lines.map((name) => ({ name, lockout: null })), policy: 'greedy', recordEvents: true }, persist, plantBound: false },
  });
  rt.palette = { whenStarted() {}, draining: false, started: true, pokeDrain() {}, changes: { touch() {} } };
  rt.attach(quiet);
  return rt;
}

function entry(operation, resources, onGrant) {
  return {
    node: null, nodeId: null, operation, priority: 1, resources, sinceMs: 0, timer: null, timeoutMs: 0,
    grant: onGrant, refuse: (err) => { throw err; }, abandon() {}, detach() {}, adopt() {},
  };
}

const ms = (ns) => Number(ns) / 1e6;
function summary(values) {
  const sorted = Float64Array.from(values).sort();
  const at = (p) => sorted[Math.min(sorted.length - 1, Math.ceil(p * sorted.length) - 1)];
  return { median: at(0.5), p99: at(0.99) };
}

/** One grant at a time: acquire, wait for the msg to leave, release. */
async function latency(rt, samples = SAMPLES) {
  const times = [];
  for (let i = 0; i < samples; i++) {
    const started = process.hrtime.bigint();
    await new Promise((resolve) => rt.request(entry(`op${i}`, ['YEL'], resolve)));
    times.push(ms(process.hrtime.bigint() - started));
    await new Promise((resolve) => rt.release(`op${i}`, resolve));
  }
  return summary(times);
}

/** N acquires of N free lines in one turn: until every grant has left. */
async function burst(rt, n) {
  await rt.settled();
  const writesBefore = rt.committer.writes;
  const started = process.hrtime.bigint();
  await new Promise((resolve) => {
    let left = n;
    for (let i = 0; i < n; i++) rt.request(entry(`b${n}-${i}`, [LINES[i]], () => { if (--left === 0) resolve(); }));
  });
  const total = ms(process.hrtime.bigint() - started);
  const writes = rt.committer.writes - writesBefore;
  for (let i = 0; i < n; i++) rt.release(`b${n}-${i}`, () => {});
  await rt.settled();
  return { total, perChange: total / n, writes };
}

async function main() {
  const dir = dirArg || fs.mkdtempSync(path.join(os.tmpdir(), 'sugarshack-durable-bench-'));
  console.log(`durable-bench: state files in ${dir} (${QUICK ? 'quick' : 'full'} run, ${SAMPLES} samples)`);
  const [file, memory, bigFile, bigMemory] = [
    fakeRuntime(true, dir, CASE_LINES), fakeRuntime(false, dir, CASE_LINES), fakeRuntime(true, dir, LINES), fakeRuntime(false, dir, LINES),
  ];
  for (const rt of [file, memory, bigFile, bigMemory]) await rt.start();

  const lm = await latency(memory);
  const lf = await latency(file);
  console.log('\nlatency of one grant on the case study\'s 5 lines, call to msg out (ms)');
  console.log(`  ${'state'.padEnd(20)} ${'median'.padStart(9)} ${'p99'.padStart(9)}`);
  console.log(`  ${'memory'.padEnd(20)} ${lm.median.toFixed(3).padStart(9)} ${lm.p99.toFixed(3).padStart(9)}`);
  console.log(`  ${'file (fsync)'.padEnd(20)} ${lf.median.toFixed(3).padStart(9)} ${lf.p99.toFixed(3).padStart(9)}`);
  console.log(`  file/memory: median ${(lf.median / lm.median).toFixed(1)}x, p99 ${(lf.p99 / lm.p99).toFixed(1)}x`);

  console.log(`\nN acquires in one turn on ${LINES.length} lines (ms; writes = durable writes it took)`);
  console.log(`  ${'N'.padStart(6)} ${'memory total'.padStart(13)} ${'file total'.padStart(11)} ${'file/change'.padStart(12)} ${'writes'.padStart(7)}`);
  for (const n of BURSTS) {
    const bm = await burst(bigMemory, n);
    const bf = await burst(bigFile, n);
    console.log(`  ${String(n).padStart(6)} ${bm.total.toFixed(2).padStart(13)} ${bf.total.toFixed(2).padStart(11)} ${bf.perChange.toFixed(4).padStart(12)} ${String(bf.writes).padStart(7)}`);
  }
  for (const rt of [file, memory, bigFile, bigMemory]) await rt.shutdown();
  if (!dirArg) fs.rmSync(dir, { recursive: true, force: true });
}

if (require.main === module) {
  main().catch((err) => {
    console.error(err);
    process.exit(1);
  });
}

module.exports = { fakeRuntime, latency, CASE_LINES };
