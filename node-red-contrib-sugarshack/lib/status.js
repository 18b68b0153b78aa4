'use strict';
// Node status: what the interlock or the actuators are doing, in fewer than
// 20 characters so the editor never truncates it.

const MAX_STATUS_LENGTH = 19;

/** A count in at most 4 characters: 999, 9.9k, 999k, 9.9M, 999M, >1G. */
function compact(n) {
  if (!Number.isFinite(n) || n < 0) return '?';
  n = Math.floor(n);
  if (n < 1e3) return String(n);
  if (n < 1e4) return `${Math.floor(n / 1e2) / 10}k`;
  if (n < 1e6) return `${Math.floor(n / 1e3)}k`;
  if (n < 1e7) return `${Math.floor(n / 1e5) / 10}M`;
  if (n < 1e9) return `${Math.floor(n / 1e6)}M`;
  return '>1G';
}

function fits(text) {
  return text.length <= MAX_STATUS_LENGTH;
}

/**
 * Counts as text that fits: `items` are [long, short, letter, n], most important
 * first; zero counts are left out. "held 2 · queued 3", then shorter forms, and
 * as a last resort the least important items are dropped.
 */
function countsText(items, empty = 'idle') {
  const shown = items.filter((item) => item[3] > 0);
  if (shown.length === 0) return empty;
  const candidates = [
    shown.map(([long, , , n]) => `${long} ${n}`).join(' · '),
    shown.map(([, short, , n]) => `${short} ${n}`).join(' · '),
    shown.map(([, short, , n]) => `${short} ${compact(n)}`).join('·'),
  ];
  const text = candidates.find(fits);
  if (text) return text;
  // Each letter form is at most 1 + 4 characters: three items and two spaces always fit.
  for (let count = shown.length; count > 0; count--) {
    const letters = shown.slice(0, count).map(([, , letter, n]) => `${letter}${compact(n)}`).join(' ');
    if (fits(letters)) return letters;
  }
  return '?';
}

/** "held 2 · queued 3", "faulted 1 · held 2", "idle"; shorter forms when needed. */
function statusText({ holding = 0, queued = 0, faulted = 0 }) {
  return countsText([
    ['faulted', 'flt', 'F', faulted],
    ['held', 'hld', 'H', holding],
    ['queued', 'q', 'Q', queued],
  ]);
}

function countsStatus(counts) {
  return { fill: counts.faulted > 0 ? 'red' : 'green', shape: 'dot', text: statusText(counts) };
}

/**
 * Actuators: "moving 2", "mov 2 · stop 14", "flt 1·mov 2·stop 14"; `lockouts`
 * counts lockouts not yet confirmed by feedback, `bad` bad feedback, `ignored`
 * msgs on topics of no device of the plant.
 */
function actuatorText({ moving = 0, stopped = 0, faulted = 0, lockouts = 0, bad = 0, ignored = 0 }) {
  return countsText([
    ['lockout', 'lock', 'L', lockouts],
    ['faulted', 'flt', 'F', faulted],
    ['moving', 'mov', 'M', moving],
    ['stopped', 'stop', 'S', stopped],
    ['bad', 'bad', 'B', bad],
    ['ignored', 'ign', 'I', ignored],
  ]);
}

/** Red when any actuator is faulted; a ring when a device is offline. */
function actuatorStatus(counts, { offline = 0 } = {}) {
  return {
    fill: counts.faulted > 0 || counts.lockouts > 0 ? 'red' : 'green',
    shape: offline > 0 ? 'ring' : 'dot',
    text: actuatorText(counts),
  };
}

const REASONS = {
  INVALID_CONFIG: 'config error',
  EMPTY_RESOURCE_SET: 'no resources',
  UNKNOWN_RESOURCE: 'unknown resource',
  UNKNOWN_RESOURCE_SET: 'unknown resources',
  UNKNOWN_OPERATION: 'unknown operation',
  MISSING_OPERATION: 'no operation id',
  INVALID_OPERATION: 'bad operation id',
  ALREADY_HOLDING: 'already holding',
  ALREADY_QUEUED: 'already queued',
  NOT_HOLDING: 'holds nothing',
  NOT_QUEUED: 'not queued',
  NOT_FAULTED: 'not faulted',
  CLEAR_REFUSED: 'clear refused',
  QUEUE_FULL: 'queue full',
  INVALID_PRIORITY: 'bad priority',
  INVALID_RESOURCES: 'bad resources',
  INVALID_SNAPSHOT: 'state error',
  ACQUIRE_TIMEOUT: 'timed out',
  NO_INTERLOCK: 'no interlock',
  INTERLOCK_STOPPED: 'stopped',
  NO_PLANT: 'no plant',
  INVALID_PLANT: 'plant invalid',
  UNKNOWN_ACTUATOR: 'unknown actuator',
  UNKNOWN_DEVICE: 'unknown device',
  EMPTY_COMMAND: 'empty command',
  INVALID_GROUP: 'bad command',
  DUPLICATE_ACTUATOR: 'duplicate actuator',
  INVALID_TARGET: 'bad target',
  STILL_MOVING: 'still moving',
  DEVICE_OFFLINE: 'device offline',
  CALLER_BUSY: 'busy',
  INVALID_FEEDBACK: 'bad feedback',
  COMMAND_FAILED: 'command failed',
  COMMAND_TIMEOUT: 'timed out',
  LOCKED_OUT: 'locked out',
  OPERATION_RUNNING: 'already running',
  OUTSIDE_RESOURCES: 'C2: outside lines',
  CONDITION_TIMEOUT: 'condition timeout',
  INVALID_CONDITION: 'bad condition',
  UNKNOWN_SENSOR: 'unknown sensor',
  SENSOR_STALE: 'sensor stale',
  UNKNOWN_ROUTINE: 'unknown routine',
  ROUTINE_BUSY: 'busy',
  NO_TRANSITION: 'no transition',
  ROUTINE_HALTED: 'halted',
  ABORTED: 'stopped',
  INPUT_TOO_DEEP: 'input too deep',
  INPUT_TOO_LARGE: 'input too large',
  INPUT_CIRCULAR: 'circular input',
  INTERNAL: 'internal error',
  LOCKOUT_PENDING: 'lockout pending',
  FUTURE_TIMESTAMP: 'clock ahead',
  ROUTINE_TAKEN: 'routine taken',
  SENSOR_NO_VALUE: 'no sensor value',
  INVALID_SENSOR_VALUE: 'bad sensor value',
  BAD_MEASUREMENT: 'bad measurement',
  UNKNOWN_CONTROLLER: 'unknown controller',
  INVALID_TIME: 'bad time',
  NOT_PENDING: 'nothing pending',
};

function shortReason(code) {
  const reason = REASONS[code] || String(code || 'error').toLowerCase().replace(/_/g, ' ');
  return fits(reason) ? reason : `${reason.slice(0, MAX_STATUS_LENGTH - 1)}…`;
}

function errorStatus(code) {
  return { fill: 'red', shape: 'ring', text: shortReason(code) };
}

/** Sets a node's status only when it changes: every call goes out to the editor. */
class StatusBoard {
  constructor() {
    this.shown = new WeakMap();
  }

  set(node, status) {
    const key = `${status.fill}|${status.shape}|${status.text}`;
    if (this.shown.get(node) === key) return;
    this.shown.set(node, key);
    node.status(status);
  }
}

module.exports = {
  StatusBoard,
  MAX_STATUS_LENGTH, compact, countsText, statusText, countsStatus, actuatorText, actuatorStatus, shortReason, errorStatus,
};
