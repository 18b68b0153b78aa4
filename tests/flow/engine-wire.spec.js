'use strict';
// The engine's wire reader (lib/wasm/wire.js) against a real engine.
const path = require('path');
const assert = require('node:assert/strict');

const LIB = path.join(__dirname, '..', '..', 'node-red-contrib-sugarshack', 'lib');
const { Wire } = require(path.join(LIB, 'wasm', 'wire.js'));
const wasm = require(path.join(LIB, 'wasm', 'index.js'));

describe('the engine wire', function () {
  it('reads the batch of a call made after wasm memory grew (its old views detached)', function () {
    const { Engine, wasmMemory } = wasm.load();
    const engine = new Engine({ resources: [{ name: 'A' }] }, {});
    const wire = new Wire(engine);
    const sent = [];
    const visitor = { commit() {}, after() {}, counts() {}, emit() {}, complete() {}, other() {}, send: (k, port, set) => sent.push([k, set && set.operation]) };
    const call = (fn) => {
      fn(engine);
      wire.read(visitor);
    };
    try {
      call((e) => e.addNode(1, { kind: 'acquire', timeoutMs: 0, operation: 'boil', priority: 1, resources: 'A' }, 0));
      call((e) => e.addNode(2, { kind: 'release' }, 0));
      call((e) => e.start(null, undefined, 0));
      call((e) => e.acquire(1, 7, 1));
      wasmMemory().grow(1);
      call((e) => e.releaseTexts(2, 8, undefined, 'boil', 2));
      assert.equal(wire.nextDeadline(), -1);
      wasmMemory().grow(1);
      call((e) => e.acquire(1, 9, 3));
      assert.deepEqual(sent, [[7, 'boil'], [8, null], [9, 'boil']]);
    } finally {
      engine.free();
    }
  });
});
