'use strict';
// The engine's outputs performed by the state rule (lib/interlock/engine-carrier.js):
// a real engine, a real state file and the interlock's Committer. A grant
// leaves only once a restart from the file would see its line held; a
// fault's msg and lockouts leave even when the write fails, but not from an
// instance that may not act (a standby, a leader whose lease ran out).
const path = require('path');
const fs = require('fs');
const os = require('os');
const assert = require('node:assert/strict');

const LIB = path.join(__dirname, '..', '..', 'node-red-contrib-sugarshack', 'lib');
const { EngineCarrier } = require(path.join(LIB, 'interlock', 'engine-carrier.js'));
const { FileStore, Committer } = require(path.join(LIB, 'host', 'durable.js'));
const { ManualClock } = require(path.join(LIB, 'host', 'clock.js'));
const { heldMsg } = require(path.join(LIB, 'interlock', 'pending.js'));
const { Wire } = require(path.join(LIB, 'wasm', 'wire.js'));
const wasm = require(path.join(LIB, 'wasm', 'index.js'));

const CONFIG = { resources: [{ name: 'A' }, { name: 'B' }] };
const ACQUIRE = 1;
const RELEASE = 3;
const FAULT = 5;
const WAITER = 7;
const WAITER_SPEC = { kind: 'acquire', timeoutMs: 500, operation: 'rinse', priority: 5, resources: 'A' };

const turns = async (n = 5) => {
  for (let i = 0; i < n; i++) await new Promise((resolve) => setImmediate(resolve));
};

/** An engine with an acquire, a release and a fault node, its outputs carried onto `store`. */
function bench(store, { mayAct = () => true } = {}) {
  const { Engine } = wasm.load();
  const engine = new Engine(CONFIG, {});
  const wire = new Wire(engine);
  const errors = [];
  const others = [];
  const clock = new ManualClock(0);
  const committer = new Committer({
    store,
    clock,
    snapshot: () => engine.seal('il-1', undefined, {}, 0),
    mayAct,
    onError: (err) => errors.push(err),
  });
  const call = (fn) => {
    fn(engine);
    carrier.perform(wire);
  };
  const due = () => call((e) => e.tick(clock.now()));
  const carrier = new EngineCarrier({ committer, clock, due, other: (o, effect) => effect(() => others.push(o)) });
  call((e) => e.addNode(ACQUIRE, { kind: 'acquire', timeoutMs: 0, operation: 'boil', priority: 20, resources: 'A' }, 0));
  call((e) => e.addNode(RELEASE, { kind: 'release' }, 0));
  call((e) => e.addNode(FAULT, { kind: 'fault', byResources: false, failMsg: false }, 0));
  call((e) => e.addNode(WAITER, WAITER_SPEC, 0));
  call((e) => e.start(null, undefined, 0));
  /** A msg held under handle `k`; what its node sends and how it completes are recorded. */
  const msg = (k, ports = 1, node = null) => {
    const seen = { sent: [], done: [] };
    const entry = heldMsg({
      node, msg: { payload: k }, sinceMs: 0, ports,
      send: (out) => seen.sent.push(out),
      done: (err) => seen.done.push(err || null),
    });
    carrier.hold(k, entry);
    return { seen, entry };
  };
  return {
    engine, clock, committer, carrier, call, msg, errors, others,
    end: async () => {
      carrier.stop();
      await committer.freeze();
      engine.free();
    },
  };
}

/** A store whose writes fail, as a full disk or a fenced etcd write does. */
function failingStore() {
  return { durable: true, where: 'a full disk', write: () => Promise.reject(new Error('ENOSPC: no space left on device')) };
}

describe('the engine carrier', function () {
  let dir;
  beforeEach(() => {
    dir = fs.mkdtempSync(path.join(os.tmpdir(), 'sugarshack-carrier-'));
  });
  afterEach(() => fs.rmSync(dir, { recursive: true, force: true }));

  it('sends a grant on only once a restart from the state file would find its line held', async function () {
    const store = new FileStore(dir, 'il-1');
    const b = bench(store);
    try {
      const seenAtSend = [];
      const { seen, entry } = b.msg(1);
      const send = entry.send;
      entry.send = (out) => {
        // What a restart now would start from: the line held is faulted, not free.
        const saved = store.read();
        assert.equal(saved.kind, 'saved');
        const { Engine } = wasm.load();
        const restarted = new Engine(CONFIG, {});
        try {
          restarted.startSealed('il-1', undefined, store.where, saved.text, 1);
          seenAtSend.push(restarted.faultedResources());
        } finally {
          restarted.free();
        }
        send(out);
      };
      b.call((e) => e.acquire(ACQUIRE, 1, 10));
      assert.deepEqual(seen.sent, [], 'nothing leaves before the write');
      await b.committer.settled();
      assert.deepEqual(seenAtSend, [['A']]);
      assert.equal(seen.sent.length, 1);
      assert.deepEqual(seen.sent[0].interlock, { operation: 'boil', priority: 20, resources: ['A'], waitedMs: 0 });
      assert.deepEqual(seen.done, [null]);
      assert.equal(b.carrier.held.size, 0);
      assert.deepEqual(b.errors, []);
    } finally {
      await b.end();
    }
  });

  it('refuses at once what changes nothing, with the core\'s code, and keeps the state as it was', async function () {
    const b = bench(new FileStore(dir, 'il-1'));
    try {
      const { seen } = b.msg(2);
      b.call((e) => e.release(RELEASE, 2, 'boil', undefined, 10));
      assert.equal(seen.done.length, 1, 'no write to wait for');
      assert.equal(seen.done[0].code, 'NOT_HOLDING');
      assert.match(seen.done[0].message, /boil/);
      assert.deepEqual(seen.sent, []);
    } finally {
      await b.end();
    }
  });

  it('refuses a waiter when its deadline comes, by the one timer, in words of the catalog, once the state without it is written', async function () {
    const b = bench(new FileStore(dir, 'il-1'));
    try {
      b.msg(1);
      b.call((e) => e.acquire(ACQUIRE, 1, 10));
      const waiter = b.msg(2);
      await b.clock.advance(20);
      b.call((e) => e.acquire(WAITER, 2, b.clock.now()));
      // The one timer calls the engine's tick when the waiter's 500 ms are up, not before.
      await b.clock.advance(499);
      await b.committer.settled();
      assert.deepEqual(waiter.seen.done, []);
      await b.clock.advance(1);
      await b.committer.settled();
      assert.equal(waiter.seen.done.length, 1);
      const err = waiter.seen.done[0];
      assert.equal(err.code, 'ACQUIRE_TIMEOUT');
      assert.match(err.message, /rinse/);
      assert.doesNotMatch(err.message, /errors\.|\{\{/, 'rendered from the catalog, placeholders filled');
      assert.deepEqual(waiter.seen.sent, []);
    } finally {
      await b.end();
    }
  });

  it('completes a waiting msg unsent at a shutdown, and leaves no timer behind', async function () {
    const b = bench(new FileStore(dir, 'il-1'));
    try {
      b.msg(1);
      b.call((e) => e.acquire(ACQUIRE, 1, 10));
      const waiter = b.msg(2);
      b.call((e) => e.acquire(WAITER, 2, 20));
      await b.committer.settled();
      assert.equal(b.clock.timers.size, 1, 'the waiter\'s deadline');
      await b.committer.freeze();
      b.call((e) => e.life('shutdown', 30));
      assert.deepEqual(waiter.seen.done, [null]);
      assert.deepEqual(waiter.seen.sent, []);
      assert.equal(b.clock.timers.size, 0);
      assert.equal(b.carrier.held.size, 0);
    } finally {
      await b.end();
    }
  });

  it('sends a held msg on from the next instance of a node a deploy restarted', async function () {
    const b = bench(new FileStore(dir, 'il-1'));
    try {
      b.msg(1);
      b.call((e) => e.acquire(ACQUIRE, 1, 10));
      const first = { id: 'n-waiter', sent: [], send(m) { this.sent.push(m); } };
      const waiter = b.msg(2, 1, first);
      b.call((e) => e.acquire(WAITER, 2, 20));
      // The deploy: the node closes (Node-RED wants its msg completed) and comes back.
      b.call((e) => e.closeNode(WAITER, false, 30));
      b.carrier.detach(first);
      assert.deepEqual(waiter.seen.done, [null]);
      const next = { id: 'n-waiter', sent: [], send(m) { this.sent.push(m); } };
      b.call((e) => e.addNode(WAITER, WAITER_SPEC, 31));
      b.carrier.adopt(next);
      b.msg(3);
      b.call((e) => e.release(RELEASE, 3, 'boil', undefined, 40));
      await b.committer.settled();
      assert.deepEqual(waiter.seen.sent, [], 'not through the closed instance');
      assert.equal(next.sent.length, 1);
      assert.equal(next.sent[0], waiter.entry.msg);
      assert.equal(next.sent[0].interlock.operation, 'rinse');
      assert.deepEqual(waiter.seen.done, [null], 'completed once, by the first instance');
    } finally {
      await b.end();
    }
  });

  it('sends a fault\'s msg and lockouts even when its write fails, and holds back a grant', async function () {
    const b = bench(failingStore());
    try {
      const grant = b.msg(1);
      b.call((e) => e.acquire(ACQUIRE, 1, 10));
      const fault = b.msg(2, 2);
      fault.entry.msg.error = { message: 'pump tripped' };
      b.call((e) => e.fault(FAULT, 2, { operation: 'boil', errorMessage: 'pump tripped' }, 20));
      await turns();
      assert.ok(b.committer.failing, 'the write failed');
      // Isolation first: the lockout goes out although the state is not saved.
      assert.equal(fault.seen.sent.length, 1);
      const [passed, lockouts] = fault.seen.sent[0];
      assert.equal(passed, fault.entry.msg);
      assert.deepEqual(lockouts.map((l) => [l.topic, l.resource]), [['lockout/A', 'A']]);
      assert.deepEqual(fault.seen.done, [null]);
      // A grant is no emergency: it waits for a write that works.
      assert.deepEqual(grant.seen.sent, []);
      assert.deepEqual(grant.seen.done, []);
    } finally {
      await b.end();
    }
  });

  it('sends nothing, not even a lockout, from an instance that may not act', async function () {
    const b = bench(failingStore(), { mayAct: () => false });
    try {
      b.call((e) => e.acquire(ACQUIRE, 1, 10));
      const fault = b.msg(2, 2);
      b.call((e) => e.fault(FAULT, 2, { operation: 'boil', errorMessage: 'pump tripped' }, 20));
      await turns();
      assert.ok(b.committer.failing);
      assert.deepEqual(fault.seen.sent, []);
      assert.deepEqual(fault.seen.done, []);
      assert.deepEqual(b.others, [], 'no event leaves either');
    } finally {
      await b.end();
    }
  });
});
