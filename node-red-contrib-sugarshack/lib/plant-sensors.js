// @ts-check
'use strict';
// What a plant does with the samples each device msg brings: the conditions
// (wait steps, routine transitions, wait nodes) watching its sensors are
// evaluated again, the values go to the journal, the device's time of flight
// to the stats. Conditions over the same text and sensors are read once.
const { Condition } = require('./condition');
const { stats } = require('./stats');
const { journal } = require('./journal/bus');

class SensorWatch {
  /** plant: the PlantRuntime (its core `t` and ids by handle). */
  constructor(plant) {
    this.plant = plant;
    this.watchers = new Map(); // sensor handle -> Set of functions called on each new sample
    this.conditions = new Map(); // condition text + sensors -> Condition
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

  /** Whether any condition waits on a sensor (its sensor handles are this document's). */
  waiting() {
    for (const watching of this.watchers.values()) if (watching.size > 0) return true;
    return false;
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

module.exports = { SensorWatch };
