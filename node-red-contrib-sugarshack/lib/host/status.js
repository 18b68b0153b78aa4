// @ts-check
'use strict';
// Node status: what a node is doing, in fewer than 20 characters so the editor
// never truncates it. Every status object is built here; the texts for error
// codes come from the core's table of codes.
const wasm = require('../wasm');
const i18n = require('./i18n');

const core = wasm.load();
const MAX_STATUS_LENGTH = core.maxStatusChars();
/** code -> { status, stem }, as the core defines them. */
const CODES = new Map(core.codes().map(({ code, status, stem }) => [code, { status, stem }]));

/** How a status looks, by what it means. */
const LOOKS = {
  ok: ['green', 'dot'],
  degraded: ['green', 'ring'],
  idle: ['grey', 'ring'],
  standby: ['grey', 'dot'],
  running: ['blue', 'dot'],
  waiting: ['blue', 'ring'],
  warning: ['yellow', 'ring'],
  manual: ['yellow', 'dot'],
  fault: ['red', 'dot'],
  error: ['red', 'ring'],
};

/** Cuts `text` to fit a status, marking the cut. */
function clip(text) {
  const s = String(text);
  return s.length <= MAX_STATUS_LENGTH ? s : `${s.slice(0, MAX_STATUS_LENGTH - 1)}…`;
}

/** The status object for a node: `look` is one of LOOKS' keys, `text` is cut to fit. */
function status(look, text) {
  const [fill, shape] = LOOKS[look] || LOOKS.error;
  return { fill, shape, text: clip(text) };
}

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
 * as a last resort the least important items are dropped. `within(text)` is
 * the whole status around the counts (a "lost · " before them): it must fit.
 */
function countsText(items, empty = i18n.text('status.idle'), within = (text) => text) {
  const shown = items.filter((item) => item[3] > 0);
  if (shown.length === 0) return within(empty);
  const candidates = [
    shown.map(([long, , , n]) => `${long} ${n}`).join(' · '),
    shown.map(([, short, , n]) => `${short} ${n}`).join(' · '),
    shown.map(([, short, , n]) => `${short} ${compact(n)}`).join('·'),
  ].map(within);
  const text = candidates.find(fits);
  if (text) return text;
  // Each letter form is at most 1 + 4 characters: three items and two spaces always fit.
  for (let count = shown.length; count > 0; count--) {
    const letters = within(shown.slice(0, count).map(([, , letter, n]) => `${letter}${compact(n)}`).join(' '));
    if (fits(letters)) return letters;
  }
  return within('?');
}

/**
 * "held 2 · queued 3", "faulted 1 · held 2", "idle"; shorter forms when needed, `within` as in countsText.
 * @param {{ holding?: number, queued?: number, faulted?: number }} counts
 * @param {(text: string) => string} [within]
 */
function statusText({ holding = 0, queued = 0, faulted = 0 }, within) {
  return countsText([
    [i18n.text('status.faulted'), i18n.text('status.faultedShort'), i18n.text('status.faultedLetter'), faulted],
    [i18n.text('status.held'), i18n.text('status.heldShort'), i18n.text('status.heldLetter'), holding],
    [i18n.text('status.queued'), i18n.text('status.queuedShort'), i18n.text('status.queuedLetter'), queued],
  ], undefined, within);
}

/**
 * The interlock's counts; `lost`: its state was unknown at start and lines it
 * faulted for that are not cleared yet ("lost · faulted 3", the counts taking
 * their short forms, then letters, to fit beside it).
 */
function countsStatus(counts) {
  const within = counts.lost ? (text) => i18n.text('status.lost', { counts: text }) : undefined;
  return status(counts.faulted > 0 ? 'fault' : 'ok', statusText(counts, within));
}

/**
 * Actuators: "moving 2", "mov 2 · stop 14", "flt 1·mov 2·stop 14"; `lockouts`
 * counts lockouts not yet confirmed by feedback, `bad` bad feedback, `ignored`
 * msgs on topics of no device of the plant.
 */
function actuatorText({ moving = 0, stopped = 0, faulted = 0, lockouts = 0, bad = 0, ignored = 0 }) {
  return countsText([
    [i18n.text('status.lockout'), i18n.text('status.lockoutShort'), i18n.text('status.lockoutLetter'), lockouts],
    [i18n.text('status.faulted'), i18n.text('status.faultedShort'), i18n.text('status.faultedLetter'), faulted],
    [i18n.text('status.moving'), i18n.text('status.movingShort'), i18n.text('status.movingLetter'), moving],
    [i18n.text('status.stopped'), i18n.text('status.stoppedShort'), i18n.text('status.stoppedLetter'), stopped],
    [i18n.text('status.bad'), i18n.text('status.badShort'), i18n.text('status.badLetter'), bad],
    [i18n.text('status.ignored'), i18n.text('status.ignoredShort'), i18n.text('status.ignoredLetter'), ignored],
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

/** The core's status text for `code`; a code from elsewhere (a device, the OS) in plain words. */
function shortReason(code) {
  const known = CODES.get(code);
  return clip(known ? known.status : String(code || 'error').toLowerCase().replace(/_/g, ' '));
}

/** Whether `code` is one of the core's codes. */
function isKnownCode(code) {
  return CODES.has(code);
}

function errorStatus(code) {
  return status('error', shortReason(code));
}

/** Sets a node's status only when it changes: every call goes out to the editor. */
class StatusBoard {
  constructor() {
    this.shown = new WeakMap();
    this.lastObject = new WeakMap(); // node -> the status object last set: the same one needs no key
  }

  set(node, status) {
    if (this.lastObject.get(node) === status) return;
    this.lastObject.set(node, status);
    const key = `${status.fill}|${status.shape}|${status.text}`;
    if (this.shown.get(node) === key) return;
    this.shown.set(node, key);
    node.status(status);
  }
}

module.exports = {
  StatusBoard, status, clip, isKnownCode,
  MAX_STATUS_LENGTH, compact, countsText, statusText, countsStatus, actuatorText, actuatorStatus, shortReason, errorStatus,
};
