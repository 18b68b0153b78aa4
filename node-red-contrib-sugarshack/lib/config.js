// @ts-check
'use strict';
// Translates the interlock config node's properties into the core's configuration.
const { SugarshackError } = require('./errors');

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

function coreConfig(props) {
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
  return config;
}

module.exports = { coreConfig, secondsToMs };
