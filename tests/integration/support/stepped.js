'use strict';
// Devices on clocks of their own and Node-RED on the palette's manual clock,
// moved together: each slice the devices move, what they sent is delivered,
// the clock moves, what Node-RED sent is delivered. Thresholds are clock time.
const { clock, sinkNode } = require('../../flow/support');

/**
 * `advance(ms)` moves the devices; `delivered()` resolves once what was sent
 * on either side has arrived. Returns { tick(ms, slice), tickUntil(predicate, what, maxMs) }.
 */
function stepper({ advance, delivered }) {
  async function tick(ms, slice = 100) {
    for (let passed = 0; passed < ms; passed += slice) {
      await advance(slice);
      await delivered();
      await clock().advance(slice);
      await delivered();
    }
  }

  /** Ticks 100 ms at a time until `predicate` holds; returns the clock time it took. */
  async function tickUntil(predicate, what, maxMs = 30000) {
    let passed = 0;
    while (!predicate()) {
      if (passed >= maxMs) throw new Error(`${what} did not happen within ${maxMs} ms of clock time`);
      await tick(100);
      passed += 100;
    }
    return passed;
  }

  return { tick, tickUntil };
}

/** Operation node 'op' (operation 'fill', to sink 'opdone'), a Catch to 'caught', and the sinks. */
function operationAndSinks(sinks) {
  return [
    { id: 'op', z: 'f1', type: 'sugarshack-operation', interlock: 'il', operation: 'fill', wires: [['opdone']] },
    { id: 'c1', z: 'f1', type: 'catch', scope: null, uncaught: false, wires: [['caught']] },
    ...sinks.map(sinkNode),
  ];
}

module.exports = { stepper, operationAndSinks };
