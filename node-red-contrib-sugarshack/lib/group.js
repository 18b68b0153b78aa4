// @ts-check
'use strict';
// Reads a group command msg. Whether the command is allowed is the core's call.
const { SugarshackError } = require('./errors');
const { quote } = require('./request');

// More lines than any plant has, longer names than a person gives: not a list an acquire node made.
const MAX_HELD = 4096;
const MAX_NAME = 200;

// Longer JSON text than any group command: refused before it is parsed.
const MAX_GROUP_TEXT = 64 * 1024;

/** msg.payload as an object; JSON text is parsed (an inject or MQTT may send text). */
function groupPayload(msg) {
  const { payload } = msg;
  if (typeof payload !== 'string' && !Buffer.isBuffer(payload)) return payload;
  if (payload.length > MAX_GROUP_TEXT) {
    throw SugarshackError.of('INPUT_TOO_LARGE', 'groupTooLarge', { length: payload.length, max: MAX_GROUP_TEXT });
  }
  try {
    return JSON.parse(payload.toString());
  } catch (err) {
    throw SugarshackError.of('INVALID_GROUP', 'groupNotJson', { message: err.message });
  }
}

/** A lockout from a fault node (topic "lockout/<resource>"), or flagged with msg.lockout = true. */
function isLockout(msg) {
  return msg.lockout === true || (typeof msg.topic === 'string' && msg.topic.startsWith('lockout/'));
}

/** The actuator ids a (validated) group command names, in order. */
function actuatorIds(payload) {
  const ids = [];
  if (!payload || typeof payload !== 'object') return ids;
  for (const members of Object.values(payload)) {
    if (members && typeof members === 'object') ids.push(...Object.keys(members));
  }
  return ids;
}

/** The target a group command gives `id`, if any. */
function targetOf(payload, id) {
  if (!payload || typeof payload !== 'object') return undefined;
  for (const members of Object.values(payload)) {
    if (members && typeof members === 'object' && Object.prototype.hasOwnProperty.call(members, id)) return members[id];
  }
  return undefined;
}

/**
 * The resources an acquire node granted this msg (msg.interlock.resources): a group
 * command carried by it may only command actuators on them (C2). Undefined when the
 * msg carries no msg.interlock; anything else than a list of names there is refused,
 * never taken as "no restriction".
 */
function heldResources(msg) {
  const { interlock } = msg;
  if (interlock === undefined) return undefined;
  const held = interlock !== null && typeof interlock === 'object' ? interlock.resources : undefined;
  if (Array.isArray(held) && held.length <= MAX_HELD && held.every((r) => typeof r === 'string' && r.length <= MAX_NAME)) return held;
  throw SugarshackError.of('INVALID_RESOURCES', 'heldNotListed', { got: quote(held === undefined ? interlock : held) });
}

module.exports = { groupPayload, isLockout, actuatorIds, targetOf, heldResources };
