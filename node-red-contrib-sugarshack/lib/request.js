'use strict';
// Reads what a msg asks for (operation, priority, resources), falling back to
// the node's configuration. Only shapes are checked here; whether a request is
// allowed is for the core to say.
const { SugarshackError } = require('./errors');

const I32_MIN = -2147483648;
const I32_MAX = 2147483647;

function present(value) {
  return value !== undefined && value !== null && value !== '';
}

function asOperationName(value, from) {
  if (typeof value === 'number' && Number.isFinite(value)) return String(value);
  if (typeof value === 'string') return value.trim();
  throw new SugarshackError('INVALID_OPERATION', `${from} must be a string or a number, got ${typeof value}`);
}

/**
 * The operation id: msg.operation, else the configured one, else (for calls
 * that follow an acquire) msg.interlock.operation.
 */
function operationOf(msg, configured, { followAcquire = false } = {}) {
  if (present(msg.operation)) return asOperationName(msg.operation, 'msg.operation');
  if (present(configured)) return asOperationName(configured, 'the configured operation');
  if (followAcquire && msg.interlock && present(msg.interlock.operation)) {
    return asOperationName(msg.interlock.operation, 'msg.interlock.operation');
  }
  throw new SugarshackError('MISSING_OPERATION', 'an operation id is required: set msg.operation or configure one in the node');
}

function priorityOf(msg, configured) {
  const [value, from] = present(msg.priority) ? [msg.priority, 'msg.priority'] : [configured, 'the configured priority'];
  if (!present(value)) return 0;
  let number = NaN;
  if (typeof value === 'number') number = value;
  else if (typeof value === 'string' && /^\s*[-+]?\d+\s*$/.test(value)) number = Number(value);
  if (!Number.isInteger(number) || number < I32_MIN || number > I32_MAX) {
    throw new SugarshackError('INVALID_PRIORITY', `${from} must be an integer (higher = more urgent), got ${JSON.stringify(value)}`);
  }
  return number;
}

function splitNames(value, from) {
  if (typeof value === 'string') return value.split(',').map((s) => s.trim()).filter(Boolean);
  if (Array.isArray(value) && value.every((v) => typeof v === 'string')) {
    return value.map((s) => s.trim()).filter(Boolean);
  }
  throw new SugarshackError('INVALID_RESOURCES', `${from} must be an array of resource names or a comma-separated string`);
}

/** Resource names from msg.resources, else the configured list (possibly empty). */
function resourcesOf(msg, configured) {
  if (present(msg.resources)) return splitNames(msg.resources, 'msg.resources');
  if (present(configured)) return splitNames(configured, 'the configured resources');
  return [];
}

/** A fault note: a Catch node's msg.error.message, else a string payload. */
function noteOf(msg) {
  if (msg.error && typeof msg.error.message === 'string' && msg.error.message) return msg.error.message;
  if (typeof msg.payload === 'string' && msg.payload) return msg.payload;
  return undefined;
}

module.exports = { operationOf, priorityOf, resourcesOf, noteOf, splitNames };
