'use strict';
// Reads a group command msg. Whether the command is allowed is the core's call.
const { SugarshackError } = require('./errors');

/** msg.payload as an object; JSON text is parsed (an inject or MQTT may send text). */
function groupPayload(msg) {
  const { payload } = msg;
  if (typeof payload !== 'string' && !Buffer.isBuffer(payload)) return payload;
  try {
    return JSON.parse(payload.toString());
  } catch (err) {
    throw new SugarshackError('INVALID_GROUP', `invalid group command: msg.payload is text but not JSON (${err.message})`);
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
 * command carried by it may only command actuators on them (C2). Undefined when absent.
 */
function heldResources(msg) {
  const held = msg.interlock && msg.interlock.resources;
  return Array.isArray(held) && held.every((r) => typeof r === 'string') ? held : undefined;
}

module.exports = { groupPayload, isLockout, actuatorIds, targetOf, heldResources };
