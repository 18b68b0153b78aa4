'use strict';
// Every method and getter of each class the wasm facade exports, wrapped so
// that each call is reported before it runs: the primer's test checks that
// the primer calls every one, the crossings benchmark counts them per msg.

// Names on a class that are no method of the facade.
const NOT_METHODS = new Set(['length', 'name', 'prototype', 'constructor']);

/**
 * Wraps each method and getter, static ones too, of every class `facade`
 * exports (and with `functions`, its free functions); `skip(className, name,
 * fn)` leaves one out. `onCall(key, instance)` hears each call first: `key`
 * is `Class.name` or the free function's name, `instance` whether the call
 * is on an object of the class.
 * @returns {{ methods: string[], restore: () => void }}
 */
function spyOnFacade(facade, onCall, { skip = () => false, functions = false } = {}) {
  const methods = [];
  const undo = [];
  const wrap = (target, name, key, descriptor, instance = false) => {
    const wrapped = { ...descriptor };
    if (typeof descriptor.value === 'function') {
      const original = descriptor.value;
      wrapped.value = function (...args) { onCall(key, instance); return original.apply(this, args); };
    } else {
      const original = descriptor.get;
      wrapped.get = function () { onCall(key, instance); return original.call(this); };
    }
    methods.push(key);
    Object.defineProperty(target, name, wrapped);
    undo.push(() => Object.defineProperty(target, name, descriptor));
  };
  for (const [className, cls] of Object.entries(facade)) {
    if (typeof cls !== 'function') continue;
    if (!cls.prototype || Object.getOwnPropertyNames(cls.prototype).length <= 1) {
      if (functions && !skip('', className, cls)) wrap(facade, className, className, Object.getOwnPropertyDescriptor(facade, className));
      continue;
    }
    for (const target of [cls.prototype, cls]) {
      for (const name of Object.getOwnPropertyNames(target)) {
        if (NOT_METHODS.has(name)) continue;
        const descriptor = Object.getOwnPropertyDescriptor(target, name);
        const fn = typeof descriptor.value === 'function' ? descriptor.value : descriptor.get;
        if (!fn || skip(className, name, fn)) continue;
        wrap(target, name, `${className}.${name}`, descriptor, target === cls.prototype);
      }
    }
  }
  return { methods, restore: () => undo.reverse().forEach((fn) => fn()) };
}

module.exports = { spyOnFacade };
