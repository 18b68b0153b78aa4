// @ts-check
'use strict';
// Translates the interlock config node's properties into the core's configuration.
const { SugarshackError } = require('../host/errors');

function parseLockout(resource, index) {
  const { lockout } = resource;
  if (typeof lockout !== 'string') return lockout === undefined ? null : lockout;
  if (lockout.trim() === '') return null;
  try {
    return JSON.parse(lockout);
  } catch (err) {
    const name = resource.name || `#${index + 1}`;
    throw SugarshackError.of('INVALID_CONFIG', 'lockoutNotJson', { name, message: err.message });
  }
}

/** Seconds as typed in the editor to milliseconds; blank means off. Nonsense is passed on for the core to refuse. */
function secondsToMs(value) {
  if (value === undefined || value === null || String(value).trim() === '') return null;
  const seconds = Number(value);
  return Number.isFinite(seconds) ? Math.round(seconds * 1000) : value;
}

// The most a bound is read as: past a u32 no count the core keeps reaches it, and the core takes a bound as a u32.
const MAX_BUFFER = 2 ** 32 - 1;

/**
 * Node-RED's bound on the msgs a node buffers (settings.js
 * `nodeMessageBufferMaxLength`), read as its delay node reads it: set or
 * not, 0 for no bound.
 * @param {any} RED
 */
function messageBufferMax(RED) {
  const name = 'nodeMessageBufferMaxLength';
  const settings = RED && RED.settings;
  const value = settings && Object.prototype.hasOwnProperty.call(settings, name) ? Number(settings[name]) : 0;
  return Number.isSafeInteger(value) && value > 0 ? Math.min(value, MAX_BUFFER) : 0;
}

/**
 * @param {Record<string, any>} props the interlock node's properties
 * @param {number} [bufferMax] Node-RED's msg buffer bound (0: none): the queue of held msgs keeps within it too
 */
function coreConfig(props, bufferMax = 0) {
  const resources = Array.isArray(props.resources) ? props.resources : [];
  const config = {
    resources: resources.map((r, i) => ({ name: typeof r.name === 'string' ? r.name.trim() : r.name, lockout: parseLockout(r, i) })),
    policy: props.policy || 'greedy',
    warnQueuedMs: secondsToMs(props.warnQueued),
    warnHeldMs: secondsToMs(props.warnHeld),
    recordEvents: true,
  };
  if (props.queueBound !== undefined && String(props.queueBound).trim() !== '') {
    const bound = Number(props.queueBound);
    config.queueBound = Number.isFinite(bound) ? bound : props.queueBound;
  }
  // Held msgs are buffered msgs: Node-RED's bound caps the queue (a request past it is refused, QUEUE_FULL).
  if (bufferMax > 0 && config.queueBound === undefined) config.queueBound = bufferMax;
  else if (bufferMax > 0 && typeof config.queueBound === 'number') config.queueBound = Math.min(config.queueBound, bufferMax);
  return config;
}

module.exports = { coreConfig, messageBufferMax, secondsToMs };
