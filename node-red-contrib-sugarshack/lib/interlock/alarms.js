// @ts-check
'use strict';
// The alarms of one interlock and its plant. The core keeps the ISA-18.2
// states, acknowledgements and shelves; this reads which conditions hold now
// off the interlock and plant (what GET /sugarshack/state reports) and hands
// them over. Observed once a second, after every batch of interlock events
// and before every answer, so an alarm's time is at most a second late.
const wasm = require('../wasm');
const i18n = require('../host/i18n');

// Interlock events an operator looks back on, kept in memory for a page opened late: the core says which.
const NOTABLE = new Set(wasm.load().abnormalEventKinds());
const RECENT_EVENTS = 50;
const RECENT_CHANGES = 50;

/** @typedef {import('../../wasm/sugarshack_wasm').Alarms} Alarms */
/** @typedef {import('../../wasm/sugarshack_wasm').AlarmChange} AlarmChange */
/** @typedef {import('../../wasm/sugarshack_wasm').EventRecord} EventRecord */

class AlarmBook {
  /** saved: the `alarms` of a saved interlock state, or undefined; warn(text) logs. */
  constructor(saved, warn) {
    const { Alarms } = wasm.load();
    /** @type {Alarms | null} */
    let restored = null;
    if (saved !== undefined && saved !== null) {
      try {
        restored = Alarms.restore(saved);
      } catch (err) {
        if (wasm.isTrap(err)) throw err;
        warn(i18n.text('logs.alarmsUnreadable', { message: err.message }));
      }
    }
    this.core = restored || new Alarms();
    /** @type {AlarmChange[]} the latest alarm changes, newest last */
    this.changes = [];
    /** @type {EventRecord[]} the latest notable interlock events, newest last */
    this.events = [];
  }

  free() {
    wasm.release(this.core);
    this.core = /** @type {any} */ (null); // never read again
  }

  /** Hands the conditions holding at `now` to the core; true when an alarm changed. */
  observe(conditions, now) {
    return this.keep(this.core.observe(conditions, now));
  }

  acknowledge(ids, who, now) {
    return this.keep(this.core.acknowledge(ids, who.by || null, who.reason || null, now));
  }

  /** `oneShot`: the shelf also ends when the alarm's condition next ends. */
  shelve(id, untilMs, who, now, oneShot = false) {
    const shelf = oneShot ? this.core.shelveOneShot : this.core.shelve;
    return this.keep(shelf.call(this.core, id, untilMs, who.by || null, who.reason || null, now));
  }

  unshelve(id, who, now) {
    return this.keep(this.core.unshelve(id, who.by || null, who.reason || null, now));
  }

  keep(changes) {
    if (changes.length) this.changes = this.changes.concat(changes).slice(-RECENT_CHANGES);
    return changes;
  }

  /**
   * Keeps notable interlock event records (with their one-line summary) for
   * the event list; true when there were any (a grant or a release changes no alarm).
   */
  noteEvents(records, describe) {
    const notable = records.filter((r) => NOTABLE.has(r.kind));
    if (notable.length) this.events = this.events.concat(notable.map((r) => ({ ...r, summary: describe(r) }))).slice(-RECENT_EVENTS);
    return notable.length > 0;
  }

  list() {
    return this.core.list();
  }

  has(id) {
    return this.core.list().some((a) => a.id === id);
  }

  snapshot() {
    return this.core.snapshot();
  }

  nextExpiryMs() {
    return this.core.nextExpiryMs();
  }
}

/**
 * The abnormal conditions of an interlock (what its core reports: faulted
 * lines, waits and holds past the warning times), of its store, of its
 * plant's devices and buses, and of its hot-standby cluster (a failover just
 * made, etcd members down), as the core's alarm conditions. The core words
 * them all: a store or a bus is named only by its subject.
 * @param {{ interlock: any[], saveFailing: boolean, store: string, plant: any, cluster?: { kind: string, subject: string }[] }} o
 */
function conditionsOf({ interlock, saveFailing, store, plant, cluster = [] }) {
  const conditions = [...interlock, ...cluster];
  if (saveFailing) conditions.push({ kind: 'state-not-saved', subject: store });
  if (plant) {
    conditions.push(...plant.devices);
    for (const b of plant.buses || []) {
      if (b.connected === false) conditions.push({ kind: 'bus-disconnected', subject: b.node });
    }
  }
  return conditions;
}

module.exports = { AlarmBook, conditionsOf };
