// @ts-check
'use strict';
// Grants of the interlock, answered by whoever waits for them: a msg held by an
// acquire node (sent on with that node's own send/done, so a link call returns
// to the right caller), or an operation's run.
const i18n = require('./i18n');

/**
 * The operations granted by the last release, cancel or clear. The core
 * returns only their count, which spares a typed array on every call.
 */
function grantedBy(interlock, count) {
  const handles = new Array(count);
  for (let i = 0; i < count; i++) handles[i] = interlock.granted(i);
  return handles;
}

/** Sends an acquire node's held msg on with msg.interlock. */
function deliver(entry, nowMs) {
  const { msg } = entry;
  msg.interlock = {
    operation: entry.operation,
    priority: entry.priority,
    resources: entry.resources.slice(),
    waitedMs: Math.max(0, nowMs - entry.sinceMs),
  };
  entry.send(msg);
  if (entry.done) entry.done();
}

/**
 * Takes the waiting entry of every granted operation, in grant order, and
 * returns what answers them (to run once the grants are saved). A grant nobody
 * waits for has nobody to do the work, so it is released at once, which may
 * grant more.
 */
function takeGrants(interlock, pending, grants, { nowMs, warn }) {
  const answers = [];
  const todo = Array.from(grants);
  while (todo.length > 0) {
    const handle = todo.shift();
    const entry = pending.take(handle);
    if (entry) {
      answers.push(() => entry.grant(nowMs));
      continue;
    }
    const name = interlock.operationName(handle);
    warn(i18n.text('logs.grantedUnclaimed', { operation: name }));
    todo.push(...grantedBy(interlock, interlock.release(handle, nowMs)));
  }
  return answers;
}

module.exports = { deliver, grantedBy, takeGrants };
