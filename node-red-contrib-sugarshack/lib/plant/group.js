// @ts-check
'use strict';
// Carries a group command msg to the core, which reads it in one call
// (plant/group_msg.rs): whether it is a lockout, the lines its command must
// keep within (C2), and its payload as the command reads it. A command msg
// is read and issued in one call (Tracker.commandMsg); this reads one that
// must wait for a deploy's drain unless it is a lockout.
const { SugarshackError } = require('../host/errors');
const wasm = require('../wasm');
const i18n = require('../host/i18n');

/** @typedef {{ lockout: boolean, within: string[] | null, payload: any }} GroupRead */

/** The core's read of a group command msg; throws its refusal for a Catch node. @returns {GroupRead} */
function readGroup(msg) {
  const read = wasm.load().readGroupMsg(msg.topic, msg.lockout, msg.interlock, msg.payload);
  if ('refusal' in read) throw refusalError(read.refusal);
  return read;
}

/** The core's refusal of a group command msg ({ code, key, params }), worded by the catalog. */
function refusalError(refusal) {
  return new SugarshackError(refusal.code, i18n.textOf(refusal.key, refusal.params));
}

/** A lockout (its topic, or msg.lockout): a standing order that never waits for a deploy's drain. Its payload is not read. */
function isLockout(msg) {
  return wasm.load().isLockoutMsg(msg.topic, msg.lockout);
}

module.exports = { readGroup, refusalError, isLockout };
