'use strict';
// The engine is deterministic: a recorded log of its inputs (msgs, deadlines,
// a drain, a restart from its sealed document) replayed into a fresh engine
// gives the same outputs, batch by batch. Its outputs read through the typed
// wire (lib/wasm/wire.js) are those serde writes in the JSON batch.
const assert = require('node:assert/strict');
const path = require('path');

const PALETTE = path.join(__dirname, '..', '..', 'node-red-contrib-sugarshack');
const wasm = require(path.join(PALETTE, 'lib', 'wasm', 'index.js'));
const { Wire } = require(path.join(PALETTE, 'lib', 'wasm', 'wire.js'));

const NODES = [
  [1, { kind: 'acquire', timeoutMs: 0, operation: 'boil', priority: 20, resources: 'A' }],
  [2, { kind: 'acquire', timeoutMs: 500, operation: 'rinse', priority: 5, resources: 'A, B' }],
  [3, { kind: 'release' }],
  [4, { kind: 'cancel' }],
  [5, { kind: 'fault', byResources: false, failMsg: false }],
  [6, { kind: 'clear', allFaulted: true, refusalsWired: false }],
];

/** A season's morning: grants, a wait that times out, priorities, a fault and its clear, a drain. */
const LOG = [
  ['acquire', 1, 1, 10],
  ['acquire', 2, 2, 20],
  ['acquireNamed', 1, 3, 'wash', 90, 'A', 30],
  ['tick', 520],
  ['acquire', 2, 4, 600],
  ['release', 3, 5, 'boil', undefined, 700],
  ['fault', 5, 6, { operation: 'wash', errorMessage: 'pump P-1 tripped' }, 800],
  ['clear', 6, 7, {}, false, 900],
  ['acquire', 1, 8, 950],
  ['life', 'drain-begin', 1000],
  ['acquireNamed', 1, 9, 'sanitize', 1, 'B', 1010],
  ['life', 'drain-end', 1100],
  ['cancel', 4, 10, { operation: 'sanitize' }, 1200],
  ['tick', 2000],
];

/** Every output of every batch, in order. */
function recorder() {
  const batches = [];
  let batch = [];
  const visitor = {
    commit: (urgent) => batch.push(['commit', urgent]),
    after: () => batch.push(['after']),
    send: (msg, port, set) => batch.push(['send', msg, port, set]),
    emit: (msg, port, msgs) => batch.push(['emit', msg, port, msgs]),
    complete: (msg, refusal) => batch.push(['complete', msg, refusal]),
    counts: (holding, queued, faulted, lost) => batch.push(['counts', holding, queued, faulted, Boolean(lost)]),
    other: (output) => batch.push(['other', output]),
  };
  return {
    visitor,
    end() {
      batches.push(batch);
      batch = [];
    },
    batches,
  };
}

/** Runs `log` into a new engine on `wire` ('typed' or 'json'), started from `saved` (a sealed text) or new. */
function replay(log, wire, saved) {
  const { Engine } = wasm.load();
  const engine = new Engine({ resources: [{ name: 'A' }, { name: 'B' }] }, { wire });
  const reader = new Wire(engine);
  const out = recorder();
  const step = (call) => {
    call();
    reader.read(out.visitor);
    out.end();
  };
  try {
    for (const [node, spec] of NODES) step(() => engine.addNode(node, spec, 0));
    step(() => (saved ? engine.startSealed('il-1', undefined, 'state.json', saved, 0) : engine.start(null, undefined, 0)));
    for (const [method, ...args] of log) step(() => engine[method](...args));
    return { batches: out.batches, sealed: engine.seal('il-1', undefined, {}, 3000), next: reader.nextDeadline() };
  } finally {
    engine.free();
  }
}

describe('the engine replayed', function () {
  it('gives the same outputs for the same recorded inputs, batch by batch', function () {
    const first = replay(LOG, 'typed');
    const again = replay(LOG, 'typed');
    assert.deepEqual(again.batches, first.batches);
    assert.equal(again.sealed, first.sealed);
    // The log did something a replay could get wrong: grants, a timeout, a fault's lockout, a clear.
    const all = first.batches.flat();
    assert.ok(all.filter(([kind, , , set]) => kind === 'send' && set && set.kind === 'interlock').length >= 3);
    assert.ok(all.some(([kind, , refusal]) => kind === 'complete' && refusal));
  });

  it('reads the same outputs through the typed wire as from the JSON batch', function () {
    assert.deepEqual(replay(LOG, 'json').batches, replay(LOG, 'typed').batches);
  });

  it('answers a release alike through its one-string call and the general one', function () {
    // The release node sends text or nothing in msg.operation and msg.interlock.operation through releaseTexts.
    const log = (release) => [['acquire', 1, 1, 10], ['acquire', 2, 2, 20], release, ['acquire', 1, 4, 40]];
    const texts = ['boil', ' boil ', '', '  ', 'nobody', 'x'.repeat(300)];
    for (const follow of texts) {
      const general = replay(log(['releaseFields', 3, 3, { follow }, 30]), 'typed');
      assert.deepEqual(replay(log(['release', 3, 3, undefined, follow, 30]), 'typed').batches, general.batches, follow);
      assert.deepEqual(replay(log(['releaseTexts', 3, 3, undefined, follow, 30]), 'typed').batches, general.batches, follow);
    }
    for (const operation of texts) {
      for (const follow of [undefined, 'rinse', 42]) {
        const general = replay(log(['releaseFields', 3, 3, { operation, follow }, 30]), 'typed');
        assert.deepEqual(replay(log(['release', 3, 3, operation, follow, 30]), 'typed').batches, general.batches, `${operation} ${follow}`);
        if (typeof follow !== 'number') {
          assert.deepEqual(replay(log(['releaseTexts', 3, 3, operation, follow, 30]), 'typed').batches, general.batches, `${operation} ${follow}`);
        }
      }
    }
    const granted = replay([['acquire', 1, 1, 10], ['acquire', 2, 2, 20], ['releaseTexts', 3, 3, undefined, 'boil', 30]], 'typed');
    // Released, and the waiting rinse granted.
    assert.deepEqual(granted.batches.at(-1).filter(([kind]) => kind === 'send').map(([, msg]) => msg), [3, 2]);
  });

  it('starts again from its sealed document alike every time', function () {
    const { sealed } = replay(LOG, 'typed');
    const later = [['acquire', 1, 20, 5000], ['acquire', 2, 21, 5000], ['tick', 6000]];
    const one = replay(later, 'typed', sealed);
    assert.deepEqual(replay(later, 'typed', sealed).batches, one.batches);
  });
});
