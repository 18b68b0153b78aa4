// @ts-check
'use strict';
// Fans interlock event records out to every `interlock events` node.
const { journal } = require('./journal/bus');

class EventFanout {
  constructor() {
    this.nodes = new Set();
  }

  add(node) {
    this.nodes.add(node);
  }

  remove(node) {
    this.nodes.delete(node);
  }

  /** Whether records would go anywhere: an events node, or the journal. */
  listened() {
    return this.nodes.size > 0 || journal.active;
  }

  publish(records) {
    if (!records || records.length === 0) return;
    journal.interlockEvents(records);
    for (const node of this.nodes) {
      for (const record of records) node.send({ topic: `interlock/${record.kind}`, summary: describeEvent(record), payload: record });
    }
  }
}

/** One line for a node.warn about an elapsed-time warning record. */
function describeWarning(record) {
  const resources = record.resources.join(', ');
  if (record.kind === 'warn-queued') {
    return `operation '${record.operation}' has waited ${Math.round(record.waitedMs / 1000)} s for ${resources}`;
  }
  return `operation '${record.operation}' has held ${resources} for ${Math.round(record.heldMs / 1000)} s`;
}

const secs = (ms) => `${Math.round(ms / 1000)} s`;

/** One readable line for an interlock event record (msg.summary), e.g. "granted 20 (YEL) after 31 s". */
function describeEvent(r) {
  const lines = r.resources.join('+');
  const op = r.operation === undefined ? '' : ` ${r.operation}`;
  const who = `${r.by ? ` by ${r.by}` : ''}${r.forced ? ' (forced)' : ''}${r.reason ? `: ${r.reason}` : ''}`;
  switch (r.kind) {
    case 'granted': return `granted${op} (${lines})${r.waitedMs ? ` after ${secs(r.waitedMs)}` : ''}`;
    case 'queued': return `queued${op} (${lines}), prio ${r.priority}`;
    case 'released': return `released${op} (${lines})${r.heldMs !== undefined ? ` after ${secs(r.heldMs)}` : ''}`;
    case 'cancelled': return `cancelled${op} (${lines})`;
    case 'faulted': return `faulted${op}: ${lines} locked out${r.note ? `: ${r.note}` : ''}`;
    case 'dropped': return `dropped${op} (${lines}): its operation faulted while waiting`;
    case 'resource-faulted': return `e-stop ${lines}${r.by ? ` by ${r.by}` : ''}${r.reason || r.note ? `: ${r.reason || r.note}` : ''}`;
    case 'cleared': return `cleared ${lines}${who}`;
    case 'interrupted': return `interrupted${op}: ${lines} held at the restart, now faulted`;
    case 'resource-added': return `added ${lines}, free`;
    case 'state-unknown': return `state unknown: ${lines} faulted until cleared`;
    case 'warn-queued': case 'warn-held': return describeWarning(r);
    default: return `${r.kind}${op} (${lines})`;
  }
}

module.exports = { EventFanout, describeWarning, describeEvent };
