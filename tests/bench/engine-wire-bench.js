#!/usr/bin/env node
'use strict';
// How an engine call's outputs cross back to JS: one JSON text per batch
// (JSON.parse), or words and a string table read from wasm memory (the
// default, lib/wasm/wire.js). The same inputs through two engines, one per
// wire, each batch read by the same visitor that keeps what a node would
// (msg.interlock and the msgs to send): case-study acquire+release pairs, a
// release granting three waiters, a fault with its lockouts. Rounds alternate
// between the wires; medians are printed, with the ratio json / typed.
//
// usage: node tests/bench/engine-wire-bench.js [--quick]

const path = require('path');
const { median } = require('./verdict');

// SUGARSHACK_PALETTE: another build of the palette, to compare two in one sitting.
const PALETTE = process.env.SUGARSHACK_PALETTE || path.resolve(__dirname, '../../node-red-contrib-sugarshack');
const wasm = require(path.join(PALETTE, 'lib', 'wasm', 'index.js'));
const { Wire } = require(path.join(PALETTE, 'lib', 'wasm', 'wire.js'));

const QUICK = process.argv.includes('--quick');
const ROUNDS = QUICK ? 7 : 15;
const REPEAT = QUICK ? 2000 : 10000;
const LINES = ['YEL', 'GRN', 'BLU', 'PUR', 'RED'];

/** What a node keeps of a batch: the msgs sent, with msg.interlock set. */
class Keeper {
  constructor() {
    this.sent = 0;
    this.last = null;
  }
  commit() {}
  after() {}
  send(msg, port, set) {
    this.sent += 1;
    if (set && set.kind === 'interlock') this.last = { operation: set.operation, priority: set.priority, resources: set.resources, waitedMs: set.waitedMs };
  }
  emit(msg, port, msgs) {
    this.sent += msgs.length;
  }
  complete() {}
  counts() {}
  other() {}
}

function engine(wire) {
  const { Engine } = wasm.load();
  const e = new Engine({ resources: LINES.map((name) => ({ name, lockout: { valves: { [`V-${name}`]: 0 } } })) }, { wire });
  const w = new Wire(e);
  const keeper = new Keeper();
  const call = (fn) => {
    fn(e);
    w.read(keeper);
  };
  call((x) => x.addNode(1, { kind: 'acquire', timeoutMs: 0, operation: 'load truck', priority: 20, resources: 'YEL' }, 0));
  call((x) => x.addNode(2, { kind: 'release' }, 0));
  call((x) => x.addNode(3, { kind: 'acquire', timeoutMs: 0, resources: 'YEL,RED' }, 0));
  call((x) => x.addNode(4, { kind: 'fault', byResources: true, failMsg: false, resources: 'YEL,GRN,BLU' }, 0));
  call((x) => x.addNode(5, { kind: 'clear', allFaulted: true, refusalsWired: false }, 0));
  call((x) => x.start(null, undefined, 0));
  return { e, call, keeper };
}

const SCENARIOS = {
  'acquire + release (case study)': ({ call }, k, now) => {
    call((e) => e.acquire(1, k, now));
    call((e) => e.releaseTexts(2, k + 1, 'load truck', undefined, now));
  },
  'release granting three waiters': ({ call }, k, now) => {
    call((e) => e.acquireNamed(3, k, 'holder', 9, undefined, now));
    for (let i = 1; i <= 3; i++) call((e) => e.acquireNamed(3, k + i, `w${i}`, i, i === 1 ? 'YEL' : i === 2 ? 'RED' : 'GRN', now));
    call((e) => e.releaseTexts(2, k + 4, 'holder', undefined, now));
    for (let i = 1; i <= 3; i++) call((e) => e.releaseTexts(2, k + 4 + i, `w${i}`, undefined, now));
  },
  'fault with three lockouts, then clear': ({ call }, k, now) => {
    call((e) => e.fault(4, k, { reason: 'bench' }, now));
    call((e) => e.clear(5, k + 1, {}, false, now));
  },
};

function main() {
  const runs = { typed: engine('typed'), json: engine('json') };
  console.log(`engine wire: node ${process.version}; ${REPEAT} inputs-sequences per round, ${ROUNDS} rounds, median ns per sequence`);
  console.log('  scenario                              typed ns     json ns   json / typed');
  const verdicts = [];
  for (const [name, scenario] of Object.entries(SCENARIOS)) {
    const times = { typed: [], json: [] };
    let k = 1000;
    for (let round = 0; round < ROUNDS + 1; round++) {
      for (const wire of round % 2 ? ['typed', 'json'] : ['json', 'typed']) {
        const t0 = process.hrtime.bigint();
        for (let i = 0; i < REPEAT; i++) {
          scenario(runs[wire], k, 1000 + round);
          k += 10;
        }
        const ns = Number(process.hrtime.bigint() - t0) / REPEAT;
        if (round > 0) times[wire].push(ns); // round 0 warms up
      }
    }
    const typed = median(times.typed);
    const json = median(times.json);
    if (runs.typed.keeper.sent !== runs.json.keeper.sent) throw new Error(`the wires disagree: ${runs.typed.keeper.sent} vs ${runs.json.keeper.sent} msgs sent`);
    console.log(`  ${name.padEnd(36)} ${typed.toFixed(0).padStart(9)} ${json.toFixed(0).padStart(11)} ${(json / typed).toFixed(2).padStart(12)}x`);
    verdicts.push(json / typed);
  }
  const worst = Math.min(...verdicts);
  console.log(`  ${worst >= 1 ? 'PASS' : 'MISS'}  the typed wire (the default) at least as fast as JSON in every scenario: ${worst.toFixed(2)}x at worst`);
}

main();
