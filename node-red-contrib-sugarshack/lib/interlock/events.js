// @ts-check
'use strict';
// Fans interlock event records out to every `interlock events` node.
const { journal } = require('../journal/bus');
const i18n = require('../host/i18n');

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
  const lines = record.resources.join(', ');
  if (record.kind === 'warn-queued') {
    return i18n.text('events.waitedLong', { operation: record.operation, seconds: Math.round(record.waitedMs / 1000), lines });
  }
  return i18n.text('events.heldLong', { operation: record.operation, seconds: Math.round(record.heldMs / 1000), lines });
}

const secs = (ms) => `${Math.round(ms / 1000)} s`;

/** One readable line for an interlock event record (msg.summary), e.g. "granted 20 (YEL) after 31 s". */
function describeEvent(r) {
  const lines = r.resources.join('+');
  // The operation with its leading space, so that a record without one reads "granted (YEL)".
  const op = r.operation === undefined ? '' : ` ${r.operation}`;
  const note = (text) => (text ? `: ${text}` : '');
  const by = r.by ? i18n.text('events.by', { by: r.by }) : '';
  const after = (ms) => i18n.text('events.after', { time: secs(ms) });
  switch (r.kind) {
    case 'granted': return i18n.text('events.granted', { op, lines }) + (r.waitedMs ? after(r.waitedMs) : '');
    case 'queued': return i18n.text('events.queued', { op, lines, priority: r.priority });
    case 'released': return i18n.text('events.released', { op, lines }) + (r.heldMs !== undefined ? after(r.heldMs) : '');
    case 'cancelled': return i18n.text('events.cancelled', { op, lines });
    case 'faulted': return i18n.text('events.faulted', { op, lines }) + note(r.note);
    case 'dropped': return i18n.text('events.dropped', { op, lines });
    case 'resource-faulted': return i18n.text('events.stopped', { lines }) + by + note(r.reason || r.note);
    case 'cleared': return i18n.text('events.cleared', { lines }) + by + (r.forced ? i18n.text('events.forced') : '') + note(r.reason);
    case 'interrupted': return i18n.text('events.interrupted', { op, lines });
    case 'resource-added': return i18n.text('events.added', { lines });
    case 'state-unknown': return i18n.text('events.stateUnknown', { lines });
    case 'warn-queued': case 'warn-held': return describeWarning(r);
    default: return `${r.kind}${op} (${lines})`;
  }
}

module.exports = { EventFanout, describeWarning, describeEvent };
