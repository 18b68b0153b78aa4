// @ts-check
'use strict';
// Reads what a msg asks for (operation, priority, resources), falling back to
// the node's configuration. Only shapes are checked here; whether a request is
// allowed is for the core to say.
const { SugarshackError } = require('./errors');
const i18n = require('./i18n');
const { isTrap } = require('./wasm');

const I32_MIN = -2147483648;
const I32_MAX = 2147483647;
// A refusal quotes at most this much of the value it refuses.
const QUOTE_MAX = 100;

/** A value as a short quote for a message, whatever it is (BigInt, circular, huge). */
function quote(value) {
  let text;
  try {
    text = typeof value === 'string' ? JSON.stringify(value) : typeof value === 'bigint' ? `${value}n` : JSON.stringify(value);
  } catch {
    text = undefined;
  }
  if (text === undefined) text = Array.isArray(value) ? i18n.text('labels.anArray') : typeof value;
  return text.length > QUOTE_MAX ? `${text.slice(0, QUOTE_MAX - 1)}…` : text;
}

/**
 * Reads what a msg asks for. A refusal of ours passes unchanged; anything else a
 * msg makes the reading throw (a getter that throws, a proxy) is the sender's
 * error: INVALID_INPUT.
 */
function readMsg(read) {
  try {
    return read();
  } catch (err) {
    if (err instanceof SugarshackError || isTrap(err)) throw err;
    const why = err && typeof err.message === 'string' ? err.message : String(err);
    throw SugarshackError.of('INVALID_INPUT', 'msgUnreadable', { why: why.slice(0, QUOTE_MAX) });
  }
}

function present(value) {
  return value !== undefined && value !== null && value !== '';
}

// An operation id is a name a person gave; past this it is not one.
const MAX_OPERATION_NAME = 200;

function asOperationName(value, from) {
  if (typeof value === 'number' && Number.isFinite(value)) return String(value);
  if (typeof value === 'string' && value.length > MAX_OPERATION_NAME) {
    throw SugarshackError.of('INVALID_OPERATION', 'operationTooLong', { from, length: value.length, max: MAX_OPERATION_NAME });
  }
  if (typeof value === 'string') return value.trim();
  throw SugarshackError.of('INVALID_OPERATION', 'operationNotName', { from, got: quote(value) });
}

/**
 * The operation id: msg.operation, else the configured one, else (for calls
 * that follow an acquire) msg.interlock.operation.
 */
function operationOf(msg, configured, { followAcquire = false } = {}) {
  if (present(msg.operation)) return asOperationName(msg.operation, 'msg.operation');
  if (present(configured)) return asOperationName(configured, i18n.text('labels.configuredOperation'));
  if (followAcquire && msg.interlock && present(msg.interlock.operation)) {
    return asOperationName(msg.interlock.operation, 'msg.interlock.operation');
  }
  throw SugarshackError.of('MISSING_OPERATION', 'operationMissing');
}

function priorityOf(msg, configured) {
  const [value, from] = present(msg.priority) ? [msg.priority, 'msg.priority'] : [configured, i18n.text('labels.configuredPriority')];
  if (!present(value)) return 0;
  let number = NaN;
  if (typeof value === 'number') number = value;
  else if (typeof value === 'string' && /^\s*[-+]?\d+\s*$/.test(value)) number = Number(value);
  if (!Number.isInteger(number) || number < I32_MIN || number > I32_MAX) {
    throw SugarshackError.of('INVALID_PRIORITY', 'priorityNotInteger', { from, got: quote(value) });
  }
  return number;
}

// More names than any plant has lines, longer than any name a person gives: not a list of lines.
const MAX_NAMES = 4096;
const MAX_NAME = 200;

function splitNames(value, from) {
  let names = null;
  if (typeof value === 'string' && value.length <= MAX_NAMES * (MAX_NAME + 1)) names = value.split(',');
  else if (Array.isArray(value) && value.length <= MAX_NAMES && value.every((v) => typeof v === 'string')) names = value;
  if (!names || names.length > MAX_NAMES || names.some((n) => n.length > MAX_NAME)) {
    throw SugarshackError.of('INVALID_RESOURCES', 'notNames', { from, names: MAX_NAMES, length: MAX_NAME, got: quote(value) });
  }
  return names.map((s) => s.trim()).filter(Boolean);
}

/** Resource names from msg.resources, else the configured list (possibly empty). */
function resourcesOf(msg, configured) {
  if (present(msg.resources)) return splitNames(msg.resources, 'msg.resources');
  if (present(configured)) return splitNames(configured, i18n.text('labels.configuredResources'));
  return [];
}

/**
 * A fault note: a Catch node's msg.error.message, else `reason` (an
 * operator's, for an e-stop), else a string payload. A msg.error.message that
 * is not text is kept as a note saying so: isolating the line comes first.
 */
// The interlock keeps 500 characters of a note; no more than a little above that crosses into it.
const MAX_NOTE = 1000;

function noteOf(msg, reason = null) {
  const message = msg.error ? msg.error.message : undefined;
  // A note that is not text never stops a fault: isolating the line comes first.
  if (message !== undefined && message !== null && typeof message !== 'string') return i18n.text('labels.noteNotText', { got: quote(message) });
  const text = message || reason || (typeof msg.payload === 'string' && msg.payload) || undefined;
  return text === undefined ? undefined : text.slice(0, MAX_NOTE);
}

// The core keeps 100 characters of a name and 500 of a reason; a little above that crosses into it.
const MAX_BY = 200;
const MAX_REASON = 1000;

/**
 * Who asks for a clear or an emergency stop, and why: msg.by, else the
 * dashboard's signed-in user (msg._client.user), else "unknown"; msg.reason;
 * msg.force === true overrides a clear's refusal (recorded as forced).
 */
function attributionOf(msg) {
  const client = msg._client && typeof msg._client === 'object' ? msg._client : null;
  const user = client && client.user && typeof client.user === 'object' ? client.user : null;
  // A signed-in dashboard user outranks msg.by, so a page cannot record a clear under another name.
  const candidates = [user && (user.username || user.name || user.email || user.userId), msg.by];
  const by = candidates.find((v) => typeof v === 'string' && v.trim() !== '');
  if (present(msg.by) && typeof msg.by !== 'string') {
    throw SugarshackError.of('INVALID_INPUT', 'byNotName', { got: quote(msg.by) });
  }
  if (present(msg.reason) && typeof msg.reason !== 'string') {
    throw SugarshackError.of('INVALID_INPUT', 'reasonNotText', { got: quote(msg.reason) });
  }
  return {
    by: by === undefined ? null : by.slice(0, MAX_BY),
    reason: present(msg.reason) ? msg.reason.slice(0, MAX_REASON) : null,
    force: msg.force === true,
  };
}

module.exports = { operationOf, priorityOf, resourcesOf, noteOf, attributionOf, splitNames, readMsg, quote };
