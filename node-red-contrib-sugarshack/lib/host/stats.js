// @ts-check
'use strict';
// Timing figures of a running plant, as the paper reports them (Figs. 11-15):
// time of flight per device, command issuance-to-motion and completion, fault
// lockout time, operation run and queue times, and the time our own code
// takes per layer. Each series keeps its last SAMPLES values (a series per
// device, its last PER_SUBJECT_SAMPLES: 5,600 panels at the cloud paper's
// scale), in buffers that grow as values come; one registry per process,
// read through the editor's admin API (GET /sugarshack/stats).
//
// A garbage collection that runs during one of our calls lengthens it without
// being our code's doing: the overhead series keep when each call started,
// and their summary also gives the figures without the calls a GC pause
// (seen by a PerformanceObserver on 'gc' entries) overlapped.

const { PerformanceObserver, performance } = require('perf_hooks');
const { journal } = require('../journal/bus');

const SAMPLES = 20000;
const PER_SUBJECT_SAMPLES = 1000;
const FIRST_CAPACITY = 64;
// Series with one per subject (`tof/<device>`): many of them, each kept shorter.
const PER_SUBJECT = ['tof/'];
const GC_KEPT = 8192;

/** The last GC_KEPT garbage collections, as [start, end] in performance.now() ms. */
class GcPauses {
  constructor() {
    this.starts = new Float64Array(GC_KEPT);
    this.ends = new Float64Array(GC_KEPT);
    this.count = 0;
    this.observer = null;
  }

  watch() {
    if (this.observer) return;
    this.observer = new PerformanceObserver((list) => {
      for (const e of list.getEntries()) {
        const i = this.count % GC_KEPT;
        this.starts[i] = e.startTime;
        this.ends[i] = e.startTime + e.duration;
        this.count += 1;
      }
    });
    this.observer.observe({ entryTypes: ['gc'] });
  }

  /** The pauses held, ordered by start: { starts, ends } (pauses do not overlap one another). */
  held() {
    const n = Math.min(this.count, GC_KEPT);
    const order = Array.from({ length: n }, (_, k) => (this.count - n + k) % GC_KEPT);
    return { starts: Float64Array.from(order, (i) => this.starts[i]), ends: Float64Array.from(order, (i) => this.ends[i]) };
  }
}

const gc = new GcPauses();

/** Whether [start, start + duration] overlaps a pause of `pauses` (ordered by start). */
function overlapsPause(pauses, start, duration) {
  const { starts, ends } = pauses;
  let lo = 0;
  let hi = starts.length; // first pause starting after the call ended
  const end = start + duration;
  while (lo < hi) {
    const mid = (lo + hi) >> 1;
    if (starts[mid] <= end) lo = mid + 1;
    else hi = mid;
  }
  return lo > 0 && ends[lo - 1] >= start;
}

function rankOf(values) {
  const sorted = Float64Array.from(values).sort();
  const n = sorted.length;
  return (p) => sorted[Math.min(n - 1, Math.max(0, Math.ceil(p * n) - 1))];
}

class Series {
  constructor(withStarts = false, limit = SAMPLES) {
    this.limit = limit;
    this.values = new Float64Array(Math.min(FIRST_CAPACITY, limit));
    this.starts = withStarts ? new Float64Array(this.values.length) : null;
    this.count = 0; // ever recorded; the buffer holds the last `limit`
    this.slowest = { value: -Infinity, what: undefined }; // the largest value ever, and what it was
  }

  add(value, start, what) {
    if (this.count === this.values.length && this.count < this.limit) this.grow();
    const i = this.count % this.values.length;
    this.values[i] = value;
    if (this.starts) this.starts[i] = start;
    this.count += 1;
    if (what !== undefined && value > this.slowest.value) this.slowest = { value, what };
  }

  /** Doubles the buffer (up to the limit) while it has not wrapped yet. */
  grow() {
    const size = Math.min(this.limit, this.values.length * 2);
    const values = new Float64Array(size);
    values.set(this.values);
    this.values = values;
    if (this.starts) {
      const starts = new Float64Array(size);
      starts.set(this.starts);
      this.starts = starts;
    }
  }

  /**
   * { n, median, p90, p99, max } of the values held (nearest rank); for a
   * series with start times also `gcOverlapped` (calls a GC pause overlapped)
   * and `withoutGc` { median, p99, max } of the others.
   */
  summary(pauses) {
    const held = Math.min(this.count, this.values.length);
    if (held === 0) return { n: 0 };
    const values = this.values.subarray(0, held);
    const rank = rankOf(values);
    const out = { n: this.count, median: rank(0.5), p90: rank(0.9), p99: rank(0.99), max: rank(1) };
    if (this.slowest.what !== undefined) out.slowest = { ms: this.slowest.value, call: this.slowest.what };
    if (this.starts && pauses) {
      const ours = [];
      for (let i = 0; i < held; i++) {
        if (!overlapsPause(pauses, this.starts[i], values[i])) ours.push(values[i]);
      }
      out.gcOverlapped = held - ours.length;
      if (ours.length) {
        const r = rankOf(ours);
        out.withoutGc = { median: r(0.5), p99: r(0.99), max: r(1) };
      }
    }
    return out;
  }
}

class Stats {
  constructor() {
    this.series = new Map();
  }

  /** `what`: which call took `value`, kept for the slowest (a layer's method). */
  add(name, value, start, what) {
    if (!Number.isFinite(value)) return;
    if (this === stats) journal.timing(name, value);
    let s = this.series.get(name);
    if (!s) {
      s = new Series(start !== undefined, PER_SUBJECT.some((p) => name.startsWith(p)) ? PER_SUBJECT_SAMPLES : SAMPLES);
      this.series.set(name, s);
    }
    s.add(value, start, what);
  }

  /** Adds the time since `start` (a performance.now() reading) to `overhead/<layer>`. */
  overhead(layer, start) {
    this.overheadOf(`overhead/${layer}`, start);
  }

  /** `overhead` with the series name made once: the per-msg calls spare a string each. */
  overheadOf(series, start, what) {
    gc.watch();
    this.add(series, performance.now() - start, start, what);
  }

  /** Runs `work` and adds its duration (ms) to `overhead/<layer>`; returns what it returns. */
  time(layer, work) {
    const start = performance.now();
    try {
      return work();
    } finally {
      this.overhead(layer, start);
    }
  }

  /** Every series' summary, keyed by name ("tof/ctrl-1", "operation/run/12", ...). */
  report() {
    const pauses = gc.count ? gc.held() : { starts: new Float64Array(0), ends: new Float64Array(0) };
    const out = {};
    for (const name of [...this.series.keys()].sort()) out[name] = this.series.get(name).summary(pauses);
    return out;
  }

  reset() {
    this.series.clear();
  }
}

const stats = new Stats();

/** Wraps `methods` of `Class` so each call's duration counts as `layer`'s overhead. */
function timeLayer(Class, layer, methods) {
  const series = `overhead/${layer}`;
  for (const name of methods) {
    const plain = Class.prototype[name];
    // No closure per call: these run once per msg.
    Class.prototype[name] = function timed(...args) {
      const start = performance.now();
      try {
        return plain.apply(this, args);
      } finally {
        stats.overheadOf(series, start, name);
      }
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

module.exports = { stats, serveStats, timeLayer, Stats, SAMPLES, PER_SUBJECT_SAMPLES, overlapsPause };
