// @ts-check
'use strict';
// Reads msgs and node settings: a msg whose reading throws (a getter, a
// proxy) is the sender's error; a list of names from a node's settings.
// What a request asks for, and whether it is allowed, is the core's to say.
const { SugarshackError } = require('./errors');
const i18n = require('./i18n');
const { isTrap } = require('./wasm');

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

module.exports = { splitNames, readMsg, quote };
