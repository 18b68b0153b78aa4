// @ts-check
'use strict';
// Carries a group command msg to the core, which reads it in one call
// (plant/group_msg.rs): whether it is a lockout, the lines its command must
// keep within (C2), and its payload as the command reads it. The read is kept
// until the call that took the msg in returns, so the node that takes it in
// and the command it issues at once read it once. Whether the command is
// allowed is the core's call too.
const { SugarshackError } = require('./errors');
const wasm = require('./wasm');
const i18n = require('./i18n');

/** @typedef {{ lockout: boolean, within: string[] | null, payload: any }} GroupRead */

/**
 * The last read and its msg. Dropped once the current call returns: a msg
 * that waits (a deploy's drain) or comes back changed is read anew.
 * @type {{ msg: object, read: GroupRead } | null}
 */
let last = null;

/** The core's read of a group command msg; throws its refusal for a Catch node. @returns {GroupRead} */
function readGroup(msg) {
  if (last && last.msg === msg) return last.read;
  const read = wasm.load().readGroupMsg(msg.topic, msg.lockout, msg.interlock, msg.payload);
  if ('refusal' in read) throw new SugarshackError(read.refusal.code, i18n.textOf(read.refusal.key, read.refusal.params));
  if (!last) queueMicrotask(() => { last = null; });
  last = { msg, read };
  return read;
}

/** msg.payload as the command reads it (JSON text parsed). */
function groupPayload(msg) {
  return readGroup(msg).payload;
}

/** A lockout (its topic, or msg.lockout): a standing order that never waits for a deploy's drain. Its payload is not read. */
function isLockout(msg) {
  if (last && last.msg === msg) return last.read.lockout;
  return wasm.load().isLockoutMsg(msg.topic, msg.lockout);
}

/** The lines the msg's acquire node granted it, which its command must keep within (C2); undefined when none. */
function heldResources(msg) {
  return readGroup(msg).within || undefined;
}

/** The actuator ids a (read) group command names, in order. */
function actuatorIds(payload) {
  const ids = [];
  if (!payload || typeof payload !== 'object') return ids;
  for (const members of Object.values(payload)) {
    if (members && typeof members === 'object') ids.push(...Object.keys(members));
  }
  return ids;
}

module.exports = { readGroup, groupPayload, isLockout, heldResources, actuatorIds };
