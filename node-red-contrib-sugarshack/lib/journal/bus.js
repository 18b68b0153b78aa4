// @ts-check
'use strict';
// The palette-wide journal bus: the runtimes say what happened in one call
// each, and every journal writer attached gets the row. With no writer
// attached a call costs one check. Rows are plain objects
// { table, tags, fields, at }; the writer adds `plant` and `seq`.

const { clock } = require('../host/clock');
const { TABLES, EVENT_FIELDS, SERIES_WITH_SUBJECT } = require('./schema');

const MAX_TEXT = 200;

const text = (v) => (v === undefined || v === null ? '' : String(v).slice(0, MAX_TEXT));
const finite = (v) => (typeof v === 'number' && Number.isFinite(v) ? v : undefined);

class JournalBus {
  constructor() {
    this.sinks = new Set();
    /** @type {Set<() => void>} told when `active` may have changed */
    this.watchers = new Set();
  }

  get active() {
    return this.sinks.size > 0;
  }

  attach(sink) {
    this.sinks.add(sink);
    this.changed();
    return () => {
      this.sinks.delete(sink);
      this.changed();
    };
  }

  /** Calls `fn` whenever a writer attaches or leaves; returns the unsubscribe function. @param {() => void} fn */
  watch(fn) {
    this.watchers.add(fn);
    return () => this.watchers.delete(fn);
  }

  changed() {
    for (const fn of this.watchers) fn();
  }

  publish(row) {
    for (const sink of this.sinks) {
      try {
        sink.row(row);
      } catch (err) {
        // A writer's failure is its own (it reports it); the plant goes on.
        if (sink.failed) sink.failed(err);
      }
    }
  }

  /** A datapoint as received: `entity` is the plant's id of the actuator or sensor. */
  datapoint(device, entity, value, deviceTs, receivedMs) {
    if (!this.active) return;
    const v = typeof value === 'boolean' ? Number(value) : finite(value);
    if (v === undefined) return;
    this.publish({
      table: TABLES.datapoint.name,
      tags: { device: text(device), entity: text(entity) },
      fields: { value: v, device_ts: finite(deviceTs) },
      at: finite(receivedMs) ?? clock.now(),
    });
  }

  /** An event of a layer; `details`' numbers named in EVENT_FIELDS become fields. */
  event(layer, kind, subject, details = {}, atMs) {
    if (!this.active) return;
    const fields = {};
    for (const [from, to] of Object.entries(EVENT_FIELDS)) fields[to] = finite(details[from]);
    const resources = Array.isArray(details.resources) ? details.resources.join(' ') : details.resources;
    this.publish({
      table: TABLES.event.name,
      tags: { layer: text(layer), kind: text(kind), subject: text(subject), resources: text(resources), note: text(details.note) },
      fields,
      at: finite(atMs) ?? finite(details.atMs) ?? clock.now(),
    });
  }

  /** Interlock event records as the core describes them. */
  interlockEvents(records) {
    if (!this.active || !records) return;
    for (const r of records) this.event('interlock', r.kind, r.operation, r, r.atMs);
  }

  /** An operator's action, with who did it and why, from the msg that asked for it. */
  action(action, msg, target) {
    if (!this.active) return;
    const m = msg && typeof msg === 'object' ? msg : {};
    const targetText = Array.isArray(target) ? target.join(' ') : target;
    this.publish({
      table: TABLES.action.name,
      tags: { action: text(action), who: text(m.by ?? m.who ?? m.user), why: text(m.reason ?? m.why ?? m.note), target: text(targetText) },
      fields: {},
      at: clock.now(),
    });
  }

  /** A timing figure from lib/host/stats.js, named as there (`tof/ctrl-1`, `command/completion`...). */
  timing(name, valueMs) {
    if (!this.active || name.startsWith('overhead/')) return;
    const prefix = SERIES_WITH_SUBJECT.find((p) => name.startsWith(`${p}/`));
    this.publish({
      table: TABLES.timing.name,
      tags: { series: prefix || name, subject: prefix ? name.slice(prefix.length + 1) : '' },
      fields: { value_ms: valueMs },
      at: clock.now(),
    });
  }
}

const journal = new JournalBus();

module.exports = { journal, JournalBus };
