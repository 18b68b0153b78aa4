// @ts-check
'use strict';
// A condition over live sensor values (`LT-3` >= 12000), in the core's
// condition language: the core reads it once (refusing a mistake at deploy)
// and checks it in one call: it passes only on fresh values (a stale or
// missing sensor: it does not hold, never on old data) and says why not.
const { SugarshackError } = require('../host/errors');
const { performance } = require('perf_hooks');
const { stats } = require('../host/stats');
const { clock } = require('../host/clock');

class Condition {
  /**
   * Reads `expression` over `sensors` (ids of the plant) in the plant's core now,
   * so that a mistake is refused at deploy (the core's INVALID_CONDITION or
   * UNKNOWN_SENSOR); `layer` names whose overhead its evaluations count as (lib/host/stats.js).
   */
  constructor(expression, sensors, plant, layer) {
    this.layer = layer;
    this.text = expression;
    this.sensors = sensors;
    this.plant = plant;
    this.read();
  }

  /** Its handles in the plant's current core (a new one after a trap knows nothing of the old one's). */
  read() {
    const core = this.plant.t;
    this.core = core;
    this.handles = Uint32Array.from(this.sensors, (id) => core.sensor(id));
    this.handle = core.condition(this.text, this.sensors);
  }

  /**
   * Evaluates at `now`: { met, values, reason } where reason says why it did
   * not hold (a stale sensor, arithmetic with no number, or the values).
   */
  check(now) {
    const started = performance.now();
    try {
      return this.evaluate(now);
    } finally {
      stats.overhead(this.layer, started);
    }
  }

  evaluate(now) {
    try {
      if (this.core !== this.plant.t) this.read();
    } catch (err) {
      // The new core refuses it (its document lacks a sensor): that is why it does not hold.
      return { met: false, values: null, reason: err.message };
    }
    return this.core.checkCondition(this.handle, this.handles, now);
  }

  /**
   * Resolves with the values once the condition holds; rejects with the
   * core's CONDITION_TIMEOUT at its deadline `timeoutMs` from now (saying why
   * it last failed). Checked at once, then on every sample of its sensors.
   * `signal.cancelled` stops it quietly.
   */
  waitUntil(timeoutMs, signal = {}) {
    const { sensors } = this.plant;
    return new Promise((resolve, reject) => {
      let finished = false;
      const finish = (fn, value) => {
        if (finished) return;
        finished = true;
        unwatch();
        signal.cancel = null;
        fn(value);
      };
      const timedOut = ({ code, message }) => finish(reject, new SugarshackError(code, message));
      const evaluate = () => {
        if (finished) return;
        let outcome;
        let checked;
        try {
          const now = clock.now();
          outcome = this.check(now);
          checked = sensors.checked(wait, outcome.met ? undefined : outcome.reason, now);
        } catch (err) {
          sensors.cancelWait(wait);
          finish(reject, err);
          return;
        }
        if (checked.state === 'met') finish(resolve, outcome.values);
        else if (checked.state === 'timedOut') timedOut(checked);
      };
      const wait = sensors.startWait(timeoutMs, this.text, timedOut);
      const unwatch = this.plant.sensors.watch(this.handles, evaluate);
      signal.cancel = (reason) => {
        sensors.cancelWait(wait);
        finish(reject, new SugarshackError('ABORTED', reason));
      };
      evaluate();
    });
  }
}

module.exports = { Condition };
