'use strict';
// Node status: what the interlock is doing, in fewer than 20 characters so the
// editor never truncates it.

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

/** "held 2 · queued 3", "faulted 1 · held 2", "idle"; shorter forms when needed. */
function statusText({ holding = 0, queued = 0, faulted = 0 }) {
  const items = [
    ['faulted', 'flt', 'F', faulted],
    ['held', 'hld', 'H', holding],
    ['queued', 'q', 'Q', queued],
  ].filter((item) => item[3] > 0);
  if (items.length === 0) return 'idle';
  const candidates = [
    items.map(([long, , , n]) => `${long} ${n}`).join(' · '),
    items.map(([, short, , n]) => `${short} ${n}`).join(' · '),
    items.map(([, short, , n]) => `${short} ${compact(n)}`).join('·'),
  ];
  const text = candidates.find(fits);
  // Always fits: three items of at most 1 + 4 characters and two spaces.
  return text || items.map(([, , letter, n]) => `${letter}${compact(n)}`).join(' ');
}

function countsStatus(counts) {
  return { fill: counts.faulted > 0 ? 'red' : 'green', shape: 'dot', text: statusText(counts) };
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
  QUEUE_FULL: 'queue full',
  INVALID_PRIORITY: 'bad priority',
  INVALID_RESOURCES: 'bad resources',
  INVALID_SNAPSHOT: 'state error',
  ACQUIRE_TIMEOUT: 'timed out',
  NO_INTERLOCK: 'no interlock',
  INTERLOCK_STOPPED: 'stopped',
};

function shortReason(code) {
  const reason = REASONS[code] || String(code || 'error').toLowerCase().replace(/_/g, ' ');
  return fits(reason) ? reason : `${reason.slice(0, MAX_STATUS_LENGTH - 1)}…`;
}

function errorStatus(code) {
  return { fill: 'red', shape: 'ring', text: shortReason(code) };
}

module.exports = { MAX_STATUS_LENGTH, compact, statusText, countsStatus, shortReason, errorStatus };
