// @ts-check
'use strict';
// What changed in a plant, for readers that keep their own copy of its values
// (the OPC UA server): the actuators, devices and sensors that the core's
// effects and samples touched, gathered and handed over once per turn of the
// event loop. By exception: nothing is read on a timer. With nobody listening
// a batch of effects costs one check.

/** @typedef {{ actuators: Set<number>, devices: Set<number>, sensors: Set<number>, rebuilt: boolean }} PlantChange */

class PlantChanges {
  /** `onError(err)`: a listener threw (the others still hear of the change). */
  constructor(onError) {
    this.onError = onError;
    /** @type {Set<(change: PlantChange) => void>} */
    this.listeners = new Set();
    /** @type {PlantChange | null} */
    this.pending = null;
  }

  /** Calls `fn(change)` after every turn with changes; returns the function that stops it. */
  listen(fn) {
    this.listeners.add(fn);
    return () => this.listeners.delete(fn);
  }

  get active() {
    return this.listeners.size > 0;
  }

  /** The core's effects: the actuator each names, else the device (a publish, a device status). */
  effects(effects) {
    if (!this.active || effects.length === 0) return;
    const change = this.due();
    for (const e of effects) {
      if (typeof e.actuator === 'number') change.actuators.add(e.actuator);
      else if (typeof e.device === 'number') change.devices.add(e.device);
    }
  }

  /** New samples of these sensors (handles). */
  sensors(handles) {
    if (!this.active) return;
    const change = this.due();
    for (const h of handles) change.sensors.add(h);
  }

  /** A new tracker (a new document, or a rebuild after a trap): every handle may mean something else. */
  rebuilt() {
    if (this.active) this.due().rebuilt = true;
  }

  due() {
    if (!this.pending) {
      this.pending = { actuators: new Set(), devices: new Set(), sensors: new Set(), rebuilt: false };
      setImmediate(() => {
        const change = /** @type {PlantChange} */ (this.pending);
        this.pending = null;
        for (const fn of [...this.listeners]) {
          try {
            fn(change);
          } catch (err) {
            this.onError(err);
          }
        }
      });
    }
    return this.pending;
  }
}

module.exports = { PlantChanges };
