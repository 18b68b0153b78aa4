// @ts-check
'use strict';
// What a plant does with the samples each device msg brings: the conditions
// (wait steps, routine transitions, wait nodes) watching its sensors are
// evaluated again, the values go to the journal, the device's time of flight
// to the stats. Conditions over the same text and sensors are read once.
// A wait's deadline is the core's, on the plant's one timer.
const { Condition } = require('../operations/condition');
const { stats } = require('../host/stats');
const { journal } = require('../journal/bus');
const { clock } = require('../host/clock');
const { SugarshackError } = require('../host/errors');
const wasm = require('../wasm');

class SensorWatch {
  /** plant: the PlantRuntime (its core `t` and ids by handle). */
  constructor(plant) {
    this.plant = plant;
    this.watchers = new Map(); // sensor handle -> Set of functions called on each new sample
    this.conditions = new Map(); // condition text + sensors -> Condition
    /** @type {Map<number, Wait>} the core's waits by number, for `core` (the tracker that numbered them) */
    this.waits = new Map();
    this.core = null;
  }

  /**
   * A wait of `timeoutMs` from now in the core on `condition` (its text);
   * `timedOut(answer)` once its deadline passes, with the core's
   * CONDITION_TIMEOUT error (code, message). Throws QUEUE_FULL.
   * @param {number} timeoutMs @param {string} condition @param {(answer: TimedOutAnswer) => void} timedOut
   * @returns {Wait}
   */
  startWait(timeoutMs, condition, timedOut) {
    const t = this.current();
    const id = t.waitStart(timeoutMs, clock.now(), condition);
    /** @type {Wait} */
    const wait = { id, at: t.waitDeadline(id) ?? clock.now(), timeoutMs, condition, timedOut };
    this.waits.set(id, wait);
    this.plant.followDeadline();
    return wait;
  }

  /**
   * Its condition was checked at `now`: held (`reason` undefined) or not;
   * the core says whether it is met, still waiting, or timed out.
   * @param {Wait} wait @param {string | undefined} reason @param {number} now
   */
  checked(wait, reason, now) {
    const outcome = this.current().waitChecked(wait.id, reason, now);
    if (outcome.state !== 'waiting') this.ended(wait);
    return outcome;
  }

  /** Ends `wait` unmet (its msg went away). @param {Wait} wait */
  cancelWait(wait) {
    if (this.waits.get(wait.id) !== wait) return;
    if (this.plant.t) this.current().waitCancel(wait.id);
    this.ended(wait);
  }

  /** @param {Wait} wait */
  ended(wait) {
    if (this.waits.get(wait.id) === wait) this.waits.delete(wait.id);
    this.plant.followDeadline();
    this.plant.mayBeQuiet();
  }

  /** At the plant's deadline: the waits the core timed out. */
  expire(now) {
    for (const answer of this.current().expireWaits(now)) {
      const wait = this.waits.get(answer.wait);
      this.waits.delete(answer.wait);
      if (wait) wait.timedOut(answer);
    }
    this.plant.mayBeQuiet();
  }

  /**
   * The plant's tracker; after a trap's rebuild, the waits go on in the new one until their deadlines.
   * A trap replaces the wasm instance and its memory with it, so what a wait needs to go on (the
   * deadline the core gave, its timeout and text, both the caller's) is kept here, not in the core.
   */
  current() {
    const { t } = this.plant;
    if (!t) throw SugarshackError.of('NO_PLANT', 'plantNotRunning');
    // A wait started from inside a msg's read of the plant (a run's wait step) is refused, as the plant's own calls are.
    wasm.entering(this.plant);
    if (this.core === t) return t;
    const carried = [...this.waits.values()];
    this.waits.clear();
    for (const wait of carried) {
      wait.id = t.waitUntil(wait.at, wait.timeoutMs, wait.condition);
      this.waits.set(wait.id, wait);
    }
    this.core = t;
    return t;
  }

  /** Calls `fn` on each new sample of any of `handles`; returns the function that stops it. */
  watch(handles, fn) {
    for (const h of handles) {
      if (!this.watchers.has(h)) this.watchers.set(h, new Set());
      this.watchers.get(h).add(fn);
    }
    return () => {
      for (const h of handles) this.watchers.get(h)?.delete(fn);
    };
  }

  /** A condition over sensors of this plant, read by the core once and shared by everything waiting on the same text. */
  condition(text, sensors) {
    const key = `${text}\u0000${sensors.join('\u0000')}`;
    let condition = this.conditions.get(key);
    if (!condition) {
      const { plant } = this;
      condition = new Condition(text, sensors, plant, 'operation');
      this.conditions.set(key, condition);
    }
    return condition;
  }

  /** Whether a msg or a step waits on a condition (its sensor handles are this document's). */
  waiting() {
    return this.waits.size > 0;
  }

  /** A new tracker: conditions read by the old one are read again; with a new document, the watchers go too. */
  forget({ watchers }) {
    this.conditions.clear();
    if (watchers) this.watchers.clear();
  }

  /**
   * After samples: the device time of flight, and the conditions watching
   * updated sensors. `read`: what the core read of the msg ({ device, ts,
   * sensors, samples }, see Tracker.ingestMsg).
   */
  sampled(now, read) {
    const { ts, sensors = [] } = read;
    if (journal.active) this.journalSamples(read, now);
    if (ts !== undefined) stats.add(`tof/${this.plant.devices[read.device]}`, now - ts);
    if (this.plant.changes.active) this.plant.changes.sensors(sensors);
    if (this.watchers.size === 0) return;
    for (const handle of sensors) {
      const watching = this.watchers.get(handle);
      if (watching) for (const fn of [...watching]) fn();
    }
  }

  /** Every value a device msg carried, to the journal (the entity is the actuator's or sensor's id; a null value: no reading). */
  journalSamples({ device: handle, ts, samples = [] }, now) {
    const { devices, actuators, sensorNames } = this.plant;
    const device = devices[handle];
    for (let i = 0; i + 2 < samples.length; i += 3) {
      const entity = samples[i] === 0 ? actuators[samples[i + 1]].id : sensorNames[samples[i + 1]];
      journal.datapoint(device, entity, samples[i + 2] === null ? NaN : samples[i + 2], ts, now);
    }
  }
}

/** @typedef {{ code: string, message: string }} TimedOutAnswer the core's CONDITION_TIMEOUT error for a wait */
/** @typedef {{ id: number, at: number, timeoutMs: number, condition: string, timedOut: (answer: TimedOutAnswer) => void }} Wait a wait in the core, and its deadline */

module.exports = { SensorWatch };
