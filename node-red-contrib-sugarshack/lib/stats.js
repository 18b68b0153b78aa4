'use strict';
// Timing figures of a running plant, as the paper reports them (Figs. 11-15):
// time of flight per device, command issuance-to-motion and completion, fault
// lockout time, operation run and queue times, and the time our own code
// takes per layer. Each series keeps its last SAMPLES values; one registry per
// process, read through the editor's admin API (GET /sugarshack/stats).

const { journal } = require('./journal/bus');

const SAMPLES = 20000;

class Series {
  constructor() {
    this.values = new Float64Array(SAMPLES);
    this.count = 0; // ever recorded; the buffer holds the last SAMPLES
  }

  add(value) {
    this.values[this.count % SAMPLES] = value;
    this.count += 1;
  }

  /** { n, median, p90, p99, max } of the values held (nearest rank). */
  summary() {
    const held = Math.min(this.count, SAMPLES);
    if (held === 0) return { n: 0 };
    const sorted = Float64Array.from(this.values.subarray(0, held)).sort();
    const rank = (p) => sorted[Math.min(held - 1, Math.max(0, Math.ceil(p * held) - 1))];
    return { n: this.count, median: rank(0.5), p90: rank(0.9), p99: rank(0.99), max: sorted[held - 1] };
  }
}

class Stats {
  constructor() {
    this.series = new Map();
  }

  add(name, value) {
    if (!Number.isFinite(value)) return;
    if (this === stats) journal.timing(name, value);
    let s = this.series.get(name);
    if (!s) {
      s = new Series();
      this.series.set(name, s);
    }
    s.add(value);
  }

  /** Runs `work` and adds its duration (ms) to `overhead/<layer>`; returns what it returns. */
  time(layer, work) {
    const start = process.hrtime.bigint();
    try {
      return work();
    } finally {
      this.add(`overhead/${layer}`, Number(process.hrtime.bigint() - start) / 1e6);
    }
  }

  /** Every series' summary, keyed by name ("tof/ctrl-1", "operation/run/12", ...). */
  report() {
    const out = {};
    for (const name of [...this.series.keys()].sort()) out[name] = this.series.get(name).summary();
    return out;
  }

  reset() {
    this.series.clear();
  }
}

const stats = new Stats();

/** Wraps `methods` of `Class` so each call's duration counts as `layer`'s overhead. */
function timeLayer(Class, layer, methods) {
  for (const name of methods) {
    const plain = Class.prototype[name];
    Class.prototype[name] = function timed(...args) {
      return stats.time(layer, () => plain.apply(this, args));
    };
  }
}

const served = new WeakSet();

/** Serves the figures to the editor's admin API, once per Node-RED runtime. */
function serveStats(RED) {
  if (!RED.httpAdmin || served.has(RED.httpAdmin)) return;
  served.add(RED.httpAdmin);
  RED.httpAdmin.get('/sugarshack/stats', RED.auth.needsPermission('sugarshack.read'), (req, res) => {
    res.json(stats.report());
  });
  RED.httpAdmin.post('/sugarshack/stats/reset', RED.auth.needsPermission('sugarshack.write'), (req, res) => {
    stats.reset();
    res.sendStatus(204);
  });
}

module.exports = { stats, serveStats, timeLayer, Stats, SAMPLES };
