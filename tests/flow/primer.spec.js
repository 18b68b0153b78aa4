'use strict';
// The wasm primer (lib/wasm/index.js) calls each facade method once at load so that
// no msg pays V8's first-call compilation. A method added to the facade and
// left out of the primer fails here, by name.
const assert = require('node:assert/strict');
const path = require('path');

const wasm = require(path.join(__dirname, '..', '..', 'node-red-contrib-sugarshack', 'lib', 'wasm', 'index.js'));
const { spyOnFacade } = require('../facade-spy');

// wasm-bindgen's own plumbing, and calls a primer cannot make without breaking its objects.
const NOT_PRIMED = new Set([
  'constructor', 'free', '__destroy_into_raw', '__wrap', '__wbg_ptr',
  // Only reached after a refused call: the numeric variants' way to fetch the error.
  'Interlock.takeError',
]);
// The devices' side of the topic contract: the plant simulator's, never loaded by the palette's nodes.
const NOT_PRIMED_CLASSES = new Set(['DeviceSide']);

/** The facade's methods and getters the primer must call, wrapped to record their calls; `restore()` undoes it. */
function spyOn(facade) {
  const called = new Set();
  const skip = (className, name) => NOT_PRIMED_CLASSES.has(className) || NOT_PRIMED.has(name) || NOT_PRIMED.has(`${className}.${name}`);
  const { methods, restore } = spyOnFacade(facade, (key) => called.add(key), { skip });
  return { called, methods, restore };
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
    assert.deepEqual(missed, [], `the primer (lib/wasm/index.js) does not call: ${missed.join(', ')}`);
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
