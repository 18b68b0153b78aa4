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

  publish(records) {
    if (!records || records.length === 0) return;
    journal.interlockEvents(records);
    for (const node of this.nodes) {
      for (const record of records) node.send({ topic: `interlock/${record.kind}`, payload: record });
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

module.exports = { EventFanout, describeWarning };
