// @ts-check
'use strict';
// Shared by the pid, rcc and rcc-io nodes (and read by others for their
// settings): reading configuration fields into numbers, checking msg fields,
// numbers short enough for a status, and wasm objects that survive a trap.
// The control rules themselves (PID, Smith predictor, RCC, their defaults)
// live in the core; the pid node's runtime is in ./pid-node.js.
const { SugarshackError } = require('../host/errors');
const wasm = require('../wasm');
const i18n = require('../host/i18n');

const isNumber = (v) => typeof v === 'number' && Number.isFinite(v);
const blank = (v) => v === undefined || v === null || String(v).trim() === '';

/**
 * @overload
 * @param {unknown} value
 * @param {string} label
 * @param {{ required: true } | { fallback: number }} options
 * @returns {number}
 */
/**
 * @overload
 * @param {unknown} value
 * @param {string} label
 * @param {{ required?: boolean, fallback?: number | null }} [options]
 * @returns {number | null | undefined}
 */
/**
 * A configuration field as a number. Blank gives `fallback` (undefined when the
 * field is required, which refuses it); text that is not a number is refused.
 * @param {unknown} value
 * @param {string} label
 * @param {{ required?: boolean, fallback?: number | null }} [options]
 * @returns {number | null | undefined}
 */
function configNumber(value, label, { required = false, fallback } = {}) {
  if (blank(value)) {
    if (required && fallback === undefined) throw SugarshackError.of('INVALID_CONFIG', 'configRequired', { label });
    return fallback;
  }
  const n = Number(String(value).trim());
  if (!Number.isFinite(n)) throw SugarshackError.of('INVALID_CONFIG', 'configNotNumber', { label, got: value });
  return n;
}

/** "1000, 2000, 4000" -> [1000, 2000, 4000]; the order rules are the core's. */
function parseList(text, label, example = '1000, 2000') {
  const items = String(text ?? '').split(',').map((s) => s.trim()).filter((s) => s !== '');
  if (items.length === 0) throw SugarshackError.of('INVALID_CONFIG', 'configEmptyList', { label, example });
  return items.map((s, i) => configNumber(s, i18n.text('labels.listItem', { label, n: i + 1 }), { required: true }));
}

// Seconds to ms without float noise (1.1 s is 1100 ms, not 1100.0000000000002).
const secondsToMs = (s) => Math.round(s * 1e6) / 1e3;

/**
 * @overload
 * @param {Record<string, any>} props the node's properties
 * @param {string} name
 * @param {string} legacyMs
 * @param {string} label
 * @param {{ required: true } | { fallbackMs: number }} options
 * @returns {number}
 */
/**
 * @overload
 * @param {Record<string, any>} props the node's properties
 * @param {string} name
 * @param {string} legacyMs
 * @param {string} label
 * @param {{ required?: boolean, fallbackMs?: number | null }} [options]
 * @returns {number | null | undefined}
 */
/**
 * A duration setting, in ms for the runtime. Settings are in seconds under
 * `name`; flows saved before that carry the same duration in ms under
 * `legacyMs`, read when `name` is blank. Blank both: `fallbackMs`.
 * @param {Record<string, any>} props the node's properties
 * @param {string} name
 * @param {string} legacyMs
 * @param {string} label
 * @param {{ required?: boolean, fallbackMs?: number | null }} [options]
 */
function configDurationMs(props, name, legacyMs, label, { required = false, fallbackMs } = {}) {
  if (!blank(props[name])) return secondsToMs(configNumber(props[name], `${label} (${name}, s)`, { required: true }));
  if (!blank(props[legacyMs])) return configNumber(props[legacyMs], `${label} (${legacyMs}, ms)`, { required: true });
  return configNumber(undefined, `${label} (${name}, s)`, { required, fallback: fallbackMs });
}

/** A list of durations, "1, 2.5" in seconds under `name`, else "1000, 2500" in ms under `legacyMs`; in ms. */
function configDurationListMs(props, name, legacyMs, label) {
  if (blank(props[name]) && !blank(props[legacyMs])) return parseList(props[legacyMs], `${label} (${legacyMs}, ms)`);
  return parseList(props[name], `${label} (${name}, s)`, '1, 2').map(secondsToMs);
}

/** A msg field that must be a finite number when present. */
function msgNumber(value, what) {
  if (!isNumber(value)) {
    throw SugarshackError.of('INVALID_INPUT', 'inputNotNumber', { what, got: describe(value) });
  }
  return value;
}

function describe(value) {
  if (value === undefined) return i18n.text('labels.nothing');
  if (typeof value === 'number') return String(value);
  if (typeof value === 'string') return i18n.text('labels.aString', { text: value.length > 20 ? `${value.slice(0, 20)}…` : value });
  return value === null ? 'null' : typeof value;
}

/** A number in at most 7 characters: 42.13, -0.5, 1.2e+6. */
function fmt(x) {
  if (!Number.isFinite(x)) return '?';
  const a = Math.abs(x);
  if (a !== 0 && (a >= 1e5 || a < 1e-3)) return x.toExponential(1);
  return String(Number(x.toPrecision(4)));
}

/**
 * A node's own wasm object (a PID loop, an RCC controller, an I/O module) that
 * survives a trap of the shared instance: `make(bindings)` builds it, again on
 * the fresh instance after any trap. Returns a stand-in whose method calls go to
 * the current object; a trap in one ends that call with INTERNAL and starts the
 * rebuild. `free()` lets it go.
 * @template {{ free(): void }} T
 * @param {(facade: import('../wasm').Facade) => T} make
 * @param {{ onRevive?: () => void }} [options]
 * @returns {T} typed as the object it stands in for
 */
function revivable(make, { onRevive = () => {} } = {}) {
  let object = make(wasm.load());
  let generation = wasm.currentGeneration();
  const stopWatch = wasm.onTrap(() => {
    wasm.forget(object);
    object = make(wasm.load());
    generation = wasm.currentGeneration();
    onRevive();
  });
  // Each call may read a msg's values (see wasm.reading): one on this object from inside it is refused.
  const owner = { reading: false };
  const call = (fn) => {
    try {
      return wasm.reading(owner, fn, object);
    } catch (err) {
      if (!wasm.isTrap(err)) throw err;
      const broken = generation;
      setImmediate(() => wasm.recover(err, broken));
      throw SugarshackError.of('INTERNAL', 'controlTrapped', { message: err.message });
    }
  };
  return /** @type {T} */ (new Proxy({}, {
    get(_, prop) {
      if (prop === 'free') {
        return () => {
          stopWatch();
          wasm.release(object);
        };
      }
      const value = object[prop];
      if (typeof value !== 'function') return call((o) => o[prop]);
      return (...args) => call((o) => o[prop](...args));
    },
  }));
}


module.exports = { isNumber, blank, configNumber, configDurationMs, configDurationListMs, parseList, msgNumber, describe, fmt, revivable };
