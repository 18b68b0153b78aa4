'use strict';
// The wasm primer (lib/wasm.js) calls each facade method once at load so that
// no msg pays V8's first-call compilation. A method added to the facade and
// left out of the primer fails here, by name.
const assert = require('node:assert/strict');
const path = require('path');

const wasm = require(path.join(__dirname, '..', '..', 'node-red-contrib-sugarshack', 'lib', 'wasm.js'));

// wasm-bindgen's own plumbing, and calls a primer cannot make without breaking its objects.
const NOT_PRIMED = new Set([
  'constructor', 'free', '__destroy_into_raw', '__wrap', '__wbg_ptr',
  // Only reached after a refused call: the numeric variants' way to fetch the error.
  'Interlock.takeError',
]);
// The devices' side of the topic contract: the plant simulator's, never loaded by the palette's nodes.
const NOT_PRIMED_CLASSES = new Set(['DeviceSide']);

/** Every method and getter of each class the facade exports, wrapped to record its calls; `restore()` undoes it. */
function spyOn(facade) {
  const called = new Set();
  const methods = [];
  const undo = [];
  for (const [className, cls] of Object.entries(facade)) {
    if (typeof cls !== 'function' || !cls.prototype || Object.getOwnPropertyNames(cls.prototype).length <= 1) continue;
    if (NOT_PRIMED_CLASSES.has(className)) continue;
    for (const [target, prefix] of [[cls.prototype, className], [cls, className]]) {
      for (const name of Object.getOwnPropertyNames(target)) {
        if (['length', 'name', 'prototype'].includes(name) || NOT_PRIMED.has(name)) continue;
        const key = `${prefix}.${name}`;
        if (NOT_PRIMED.has(key)) continue;
        const descriptor = Object.getOwnPropertyDescriptor(target, name);
        const wrapped = { ...descriptor };
        if (typeof descriptor.value === 'function') {
          const original = descriptor.value;
          wrapped.value = function (...args) { called.add(key); return original.apply(this, args); };
        } else if (descriptor.get) {
          const original = descriptor.get;
          wrapped.get = function () { called.add(key); return original.call(this); };
        } else {
          continue;
        }
        methods.push(key);
        Object.defineProperty(target, name, wrapped);
        undo.push(() => Object.defineProperty(target, name, descriptor));
      }
    }
  }
  return { called, methods, restore: () => undo.forEach((fn) => fn()) };
}

describe('the wasm primer', function () {
  it('calls every method and getter of every facade class', function () {
    const facade = wasm.load();
    const spy = spyOn(facade);
    try {
      wasm.prime(facade);
    } finally {
      spy.restore();
    }
    assert.ok(spy.methods.length > 100, `found only ${spy.methods.length} methods: is the facade loaded?`);
    assert.ok(spy.methods.includes('Tracker.ingest') && spy.methods.includes('Interlock.restore'), 'instance and static methods are both seen');
    const missed = spy.methods.filter((key) => !spy.called.has(key));
    assert.deepEqual(missed, [], `the primer (lib/wasm.js) does not call: ${missed.join(', ')}`);
  });

  it('would name a method it does not call', function () {
    const facade = wasm.load();
    const spy = spyOn(facade);
    try {
      facade.Tracker.prototype.counts.call(Object.create(facade.Tracker.prototype)); // a call that throws still counts as made
    } catch {
      // the receiver is not a real tracker
    } finally {
      spy.restore();
    }
    assert.ok(spy.called.has('Tracker.counts'));
    assert.ok(!spy.called.has('Tracker.ingest'), 'only the calls made are recorded');
  });
});
