// @ts-check
'use strict';
// A condition over live sensor values, written in JSONata against an object of
// the listed sensors by id: `LT-3` >= 12000. It passes only on fresh values: the
// core refuses a read with a stale or missing sensor, and the condition then
// does not hold (it never passes on old data).
const { SugarshackError } = require('./errors');
const { text } = require('./i18n');
const { performance } = require('perf_hooks');
const { stats } = require('./stats');
const { clock } = require('./clock');

class Condition {
  /**
   * Compiles `expression` now, so a typo is refused at deploy; `sensors` are ids of
   * the plant; `layer` names whose overhead its evaluations count as (lib/stats.js).
   */
  constructor(RED, node, expression, sensors, plant, layer) {
    this.layer = layer;
    this.text = expression;
    this.sensors = sensors;
    this.handles = sensors.map((id) => plant.sensorHandle(id));
    try {
      this.expression = RED.util.prepareJSONataExpression(expression, node);
    } catch (err) {
      throw SugarshackError.of('INVALID_CONDITION', 'conditionNotJsonata', { condition: expression, message: err.message });
    }
    this.RED = RED;
    this.plant = plant;
  }

  /**
   * Evaluates at `now`: resolves { met, values, reason } where reason says why
   * it did not hold (a stale sensor, or the values). Rejects on a result that
   * is not true or false.
   */
  check(now) {
    // The overhead sample is the synchronous part only (the sensors read from
    // the core, the input, JSONata started): JSONata goes on in promise jobs,
    // between which any other work of the event loop may run, and a span to
    // the answer timed that work as ours.
    const started = performance.now();
    try {
      return this.evaluate(now);
    } finally {
      stats.overhead(this.layer, started);
    }
  }

  evaluate(now) {
    let values;
    try {
      values = this.plant.readSensors(this.handles, now);
    } catch (err) {
      return Promise.resolve({ met: false, values: null, reason: err.message });
    }
    const input = {};
    this.sensors.forEach((id, i) => { input[id] = values[i]; });
    return new Promise((resolve, reject) => {
      this.RED.util.evaluateJSONataExpression(this.expression, input, (err, result) => {
        if (err) {
          reject(SugarshackError.of('INVALID_CONDITION', 'conditionFailed', { condition: this.text, message: err.message }));
        } else if (typeof result !== 'boolean') {
          reject(SugarshackError.of('INVALID_CONDITION', 'conditionNotBoolean', { condition: this.text, got: JSON.stringify(result) }));
        } else {
          resolve({ met: result, values: input, reason: result ? null : text('labels.values', { values: JSON.stringify(input) }) });
        }
      });
    });
  }

  /**
   * Resolves with the values once the condition holds; rejects with
   * CONDITION_TIMEOUT after `timeoutMs` (saying why it last failed). Checked
   * at once, then on every sample of its sensors. `signal.cancelled` stops it quietly.
   */
  waitUntil(timeoutMs, signal = {}) {
    return new Promise((resolve, reject) => {
      let busy = false;
      let again = false;
      let lastReason = text('labels.neverChecked');
      let finished = false;
      const finish = (fn, value) => {
        if (finished) return;
        finished = true;
        clock.clearTimeout(timer);
        unwatch();
        signal.cancel = null;
        fn(value);
      };
      const evaluate = () => {
        if (finished) return;
        if (busy) {
          again = true;
          return;
        }
        busy = true;
        this.check(clock.now()).then((outcome) => {
          busy = false;
          if (outcome.met) finish(resolve, outcome.values);
          else {
            lastReason = outcome.reason;
            if (again) {
              again = false;
              evaluate();
            }
          }
        }, (err) => finish(reject, err));
      };
      const timer = clock.setTimeout(() => finish(reject, SugarshackError.of(
        'CONDITION_TIMEOUT',
        'conditionTimeout',
        { condition: this.text, seconds: timeoutMs / 1000, reason: lastReason },
      )), timeoutMs);
      const unwatch = this.plant.watchSensors(this.handles, evaluate);
      signal.cancel = (reason) => finish(reject, new SugarshackError('ABORTED', reason));
      evaluate();
    });
  }
}

module.exports = { Condition };
