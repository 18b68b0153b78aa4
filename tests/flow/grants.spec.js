'use strict';
// Grants as the engine hands them to the host (lib/wasm/wire.js reads them):
// after the commit that saves them, each to its own held msg, in grant order;
// and a grant nobody waits for is released at once, which may grant more.
const assert = require('node:assert/strict');
const path = require('path');
const { PALETTE } = require('./support');
const wasm = require(path.join(PALETTE, 'lib', 'wasm.js'));
const { Wire } = require(path.join(PALETTE, 'lib', 'wasm', 'wire.js'));

/** What a batch holds, in order, as short lines. */
function read(wire) {
  const log = [];
  wire.read({
    commit: (urgent) => log.push(urgent ? 'commit urgent' : 'commit'),
    after: () => log.push('after'),
    send: (msg, port, set) => log.push(set ? ['send', msg, port, set] : `send ${msg} on ${port}`),
    emit: (msg, port, msgs) => log.push(`emit ${msgs.length} from ${msg} on ${port}`),
    complete: (msg, refusal) => log.push(refusal ? `fail ${msg} ${refusal.code}` : `done ${msg}`),
    counts: () => {},
    other: (o) => log.push(o),
  });
  return log;
}

function engineOn(lines) {
  const { Engine } = wasm.load();
  const engine = new Engine({ resources: lines.map((name) => ({ name })) }, {});
  engine.addNode(1, { kind: 'acquire', timeoutMs: 0, resources: 'YEL' }, 0);
  engine.addNode(2, { kind: 'release' }, 0);
  return { engine, wire: new Wire(engine) };
}

describe('grant routing', function () {
  it('answers each grant once its state is saved, each to its own msg, in grant order, with msg.interlock', function () {
    const { engine, wire } = engineOn(['YEL']);
    // Each call's outputs are read before the next call (names cross once, in the batch that first uses them).
    for (const call of [
      () => engine.start(null, undefined, 0),
      () => engine.acquireNamed(1, 1, 'holder', 9, undefined, 0),
      () => engine.acquireNamed(1, 4, 'a', 1, undefined, 100),
      () => engine.acquireNamed(1, 7, 'b', 2, undefined, 250),
    ]) {
      call();
      read(wire);
    }
    engine.release(2, 9, 'holder', undefined, 1000);
    const log = read(wire);
    assert.deepEqual(log.slice(0, 2), ['commit', 'send 9 on 0'], 'nothing is sent before the commit; the release first');
    const grants = log.filter((o) => Array.isArray(o));
    assert.deepEqual(grants.map(([, msg]) => msg), [7], 'b (priority 2) goes first; a waits for YEL');
    assert.deepEqual(grants[0][3], { kind: 'interlock', operation: 'b', priority: 2, resources: ['YEL'], waitedMs: 750 });
    engine.release(2, 10, 'b', undefined, 1100);
    assert.deepEqual(read(wire).filter((o) => Array.isArray(o)).map(([, msg]) => msg), [4]);
    engine.free();
  });

  it('releases a grant that nothing waits for, and takes what that release grants', function () {
    const { engine: first, wire: firstWire } = engineOn(['YEL']);
    for (const call of [
      () => first.start(null, undefined, 0),
      () => first.acquireNamed(1, 1, 'holder', 9, undefined, 0),
      () => first.acquireNamed(1, 2, 'orphan', 5, undefined, 5),
    ]) {
      call();
      read(firstWire);
    }
    // The state a standby takes over knows the waiting request, not the msg that waited.
    const doc = JSON.parse(first.stateText(10, {}));
    delete doc.engine;
    const { engine, wire } = engineOn(['YEL']);
    engine.handOver(JSON.stringify(doc), 10);
    read(wire);
    engine.acquireNamed(1, 3, 'c', 1, undefined, 20);
    read(wire);
    engine.release(2, 4, 'holder', undefined, 30);
    const log = read(wire);
    const warnings = log.filter((o) => o && o.kind === 'log');
    assert.deepEqual(warnings.map((w) => [w.level, w.text.key, w.text.params]), [['warn', 'logs.grantedUnclaimed', [['operation', { kind: 'text', value: 'orphan' }]]]]);
    assert.deepEqual(log.filter((o) => Array.isArray(o)).map(([, msg, , set]) => [msg, set.operation]), [[3, 'c']], 'c granted once orphan let go');
    first.free();
    engine.free();
  });
});
