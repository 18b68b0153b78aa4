'use strict';
// Sends granted msgs on, each from the acquire node that holds it, with that
// node's own send/done so a link call returns to the right caller.

/**
 * The operations granted by the last release, cancel or clear. The core
 * returns only their count, which spares a typed array on every call.
 */
function grantedBy(interlock, count) {
  const handles = new Array(count);
  for (let i = 0; i < count; i++) handles[i] = interlock.granted(i);
  return handles;
}

function deliver(entry, nowMs) {
  const { msg } = entry;
  msg.interlock = {
    operation: entry.operation,
    priority: entry.priority,
    resources: entry.resources.slice(),
    waitedMs: Math.max(0, nowMs - entry.sinceMs),
  };
  entry.send(msg);
  entry.done();
}

/**
 * Delivers the msg of every granted operation, in grant order. A grant without
 * a waiting msg has nobody to do the work, so it is released at once (which may
 * grant more).
 */
function routeGrants(interlock, pending, grants, { nowMs, warn }) {
  const todo = Array.from(grants);
  while (todo.length > 0) {
    const handle = todo.shift();
    const entry = pending.take(handle);
    if (entry) {
      deliver(entry, nowMs);
      continue;
    }
    const name = interlock.operationName(handle);
    warn(`operation '${name}' was granted but no msg waits for it; releasing it`);
    todo.push(...grantedBy(interlock, interlock.release(handle, nowMs)));
  }
}

module.exports = { deliver, grantedBy, routeGrants };
