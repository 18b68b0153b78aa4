#!/usr/bin/env node
'use strict';
// Feedback ingest benchmark: prints figures, asserts nothing about speed.
//
// Actuator panels (16 valves + 1 pump, the paper's ctrl-N) each publish one
// batch per plant second, as JSON on `<panel>/state`. The ways in:
//   native          the core, via `cargo run --release --example tracker_bench`
//   wasm, arrays    the facade given ready typed arrays (the boundary alone)
//   wasm, as nodes  from the topic and JSON text: the core's topics module
//                   reads it and answers in one JSON text (Tracker.ingestMsg)
//   ingest+getters  the same before: ingest, lastDevice, lastTs, queued, takeEffects
//   ~typed answer   ingest and one Float64Array back: a typed answer's cost, approximated
// Target: >= 100,000 datapoints/s through wasm (95,000 I/O at 1 Hz).
// usage: node tests/bench/tracker-bench.js [PANELS] [SECONDS]

const path = require('path');
const { spawnSync } = require('child_process');
const ROOT = path.join(__dirname, '..', '..');
const { Tracker } = require(path.join(ROOT, 'node-red-contrib-sugarshack', 'wasm', 'sugarshack_wasm.js'));

const PANELS = Number(process.argv[2]) || 1000;
const SECONDS = Number(process.argv[3]) || 20;
const VALVES = 16;
const TARGET = 100000;

function plant(panels) {
  const devices = [];
  const actuators = [];
  for (let p = 1; p <= panels; p++) {
    devices.push({ id: `ctrl-${p}`, kind: 'actuator-panel' });
    for (let io = 1; io <= VALVES; io++) {
      actuators.push({ id: `V${p}-${io}`, type: 'valve', device: `ctrl-${p}`, io, idle: 0, lockout: 0 });
    }
    actuators.push({ id: `P${p}`, type: 'pump', device: `ctrl-${p}`, io: 1, idle: false, lockout: false });
  }
  return {
    actuatorTypes: {
      valve: { signal: 'analog', tolerance: 3, noMotionMs: 4000, completionMs: 15000, staleMs: 5000 },
      pump: { signal: 'binary', noMotionMs: 4000, completionMs: 6000, staleMs: 5000 },
    },
    devices,
    actuators,
  };
}

/** Same values as the native example's `sample`. */
function sample(panel, slot, second) {
  if (slot === VALVES) return (panel + Math.floor(second / 30)) % 2;
  const noise = ((panel * 31 + slot * 17 + second * 13) % 5) * 0.5 - 1.0;
  if ((panel + slot) % 7 === 0) return ((second * 25) % 100) + Math.abs(noise);
  return 50 + noise;
}

function payloads() {
  const out = [];
  for (let s = 0; s < SECONDS; s++) {
    const now = 1000 * (s + 1);
    for (let p = 1; p <= PANELS; p++) {
      const valve = {};
      for (let io = 1; io <= VALVES; io++) valve[io] = sample(p, io - 1, s);
      out.push({ now, device: `ctrl-${p}`, text: JSON.stringify({ ts: now - 80, valve, pump: { 1: sample(p, VALVES, s) === 1 } }) });
    }
  }
  return out;
}

/**
 * What the actuators node does with one `<panel>/state` msg: one call, the
 * core reads and applies it and answers all of it as one JSON text.
 */
class BatchReader {
  constructor(tracker) {
    this.tracker = tracker;
  }
  ingest(device, text, now) {
    const answer = JSON.parse(this.tracker.ingestMsg(`${device}/state`, text, now, undefined, false));
    return answer.effects ? answer.effects.length : 0;
  }
}

/** The same before one-call answers: ingest, then getters for device, time and effects (four calls). */
class GetterReader extends BatchReader {
  ingest(device, text, now) {
    const t = this.tracker;
    t.ingest(`${device}/state`, text, now);
    t.lastDevice();
    t.lastTs();
    return t.queued() > 0 ? t.takeEffects().length : 0;
  }
}

/**
 * A typed answer's cost, approximated: ingest and one Float64Array back (what
 * a header of kind, device, time and sensors would cost), effects as objects
 * when there are any (a string table would add to it).
 */
class TypedReader extends BatchReader {
  ingest(device, text, now) {
    const t = this.tracker;
    t.ingest(`${device}/state`, text, now);
    t.lastSamples();
    return t.queued() > 0 ? t.takeEffects().length : 0;
  }
}

function timeIt(fn) {
  const started = process.hrtime.bigint();
  const passedOn = fn();
  return { elapsedS: Number(process.hrtime.bigint() - started) / 1e9, passedOn };
}

function main() {
  const datapoints = PANELS * SECONDS * (VALVES + 1);
  const msgs = payloads();

  const through = (Reader) => {
    const tracker = new Tracker(plant(PANELS), 0);
    const reader = new Reader(tracker);
    return timeIt(() => {
      let passed = 0;
      let second = msgs[0].now;
      for (const m of msgs) {
        if (m.now !== second) { tracker.tick(second); tracker.takeEffects(); second = m.now; }
        passed += reader.ingest(m.device, m.text, m.now);
      }
      return passed;
    });
  };
  // Alternated, twice each: other work on the machine falls on all of them alike.
  const runs = { getters: [], typed: [], nodes: [] };
  for (let round = 0; round < 2; round++) {
    runs.getters.push(through(GetterReader));
    runs.typed.push(through(TypedReader));
    runs.nodes.push(through(BatchReader));
  }
  const best = (list) => list.reduce((a, b) => (b.elapsedS < a.elapsedS ? b : a));
  const nodes = best(runs.nodes);
  const getters = best(runs.getters);
  const typed = best(runs.typed);

  // The boundary alone: the same batches as ready typed arrays.
  const boundary = new Tracker(plant(PANELS), 0);
  const arrays = msgs.map((m) => {
    const b = JSON.parse(m.text);
    const device = boundary.device(m.device);
    const handles = Uint32Array.from([...Array(VALVES).keys()].map((i) => boundary.slot(device, 'valve', i + 1)).concat([boundary.slot(device, 'pump', 1)]));
    const values = Float64Array.from(Object.values(b.valve).concat([b.pump[1] ? 1 : 0]));
    return { handles, values, ts: b.ts, now: m.now };
  });
  const raw = timeIt(() => {
    let passed = 0;
    for (const a of arrays) {
      if (boundary.feedbackBatch(a.handles, a.values, a.ts, a.now) > 0) passed += boundary.takeEffects().length;
    }
    return passed;
  });

  const native = spawnSync('cargo', ['run', '-q', '--release', '-p', 'sugarshack-core', '--example', 'tracker_bench', '--', String(PANELS), String(SECONDS)],
    { cwd: ROOT, encoding: 'utf8', stdio: ['ignore', 'pipe', 'inherit'] });
  if (native.status !== 0) throw new Error('native tracker bench failed');
  const n = JSON.parse(native.stdout.trim().split('\n').pop());

  const rows = [
    ['native', n.datapoints / n.elapsedS, n.passedOn],
    ['wasm, typed arrays', datapoints / raw.elapsedS, raw.passedOn],
    ['wasm, as the nodes call it', datapoints / nodes.elapsedS, nodes.passedOn],
    ['wasm, ingest + getters', datapoints / getters.elapsedS, getters.passedOn],
    ['wasm, ~typed answer', datapoints / typed.elapsedS, typed.passedOn],
  ];
  console.log(`feedback ingest: ${PANELS} panels x ${VALVES + 1} datapoints x ${SECONDS} plant seconds = ${datapoints} datapoints (node ${process.version})`);
  console.log('impl                        | datapoints/s | passed on (changed, moving, ...)');
  console.log('----------------------------|--------------|---------------------------------');
  for (const [name, rate, passed] of rows) {
    console.log(`${name.padEnd(27)} | ${Math.round(rate).toLocaleString('en').padStart(12)} | ${passed}`);
  }
  const wasmRate = datapoints / nodes.elapsedS;
  console.log(`${wasmRate >= TARGET ? 'PASS' : 'MISS'}  wasm as the nodes call it >= ${TARGET.toLocaleString('en')} datapoints/s: ${Math.round(wasmRate).toLocaleString('en')} (${(wasmRate / TARGET).toFixed(1)}x)`);
  console.log(`one JSON answer vs ingest + getters: ${(getters.elapsedS / nodes.elapsedS).toFixed(2)}x; vs ~typed answer: ${(typed.elapsedS / nodes.elapsedS).toFixed(2)}x (best of 2 alternated runs each)`);
  if (raw.passedOn !== n.passedOn || [nodes, getters, typed].some((r) => r.passedOn !== n.passedOn)) {
    throw new Error(`implementations disagree on what changed: native ${n.passedOn}, arrays ${raw.passedOn}, nodes ${nodes.passedOn}`);
  }
}

main();
