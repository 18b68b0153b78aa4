'use strict';
const assert = require('node:assert/strict');
const path = require('path');
const { PALETTE } = require('./support');
const { Stats, SAMPLES, PER_SUBJECT_SAMPLES, overlapsPause } = require(path.join(PALETTE, 'lib', 'host', 'stats.js'));

const pauses = (...spans) => ({
  starts: Float64Array.from(spans, ([s]) => s),
  ends: Float64Array.from(spans, ([, e]) => e),
});

describe('stats: per-layer overhead with GC pauses told apart', function () {
  it('a call overlaps a pause that starts, ends or lies inside it, or that covers it', function () {
    const p = pauses([10, 12], [20, 30], [50, 51]);
    assert.equal(overlapsPause(p, 0, 5), false, 'before every pause');
    assert.equal(overlapsPause(p, 9, 1.5), true, 'the pause starts during the call');
    assert.equal(overlapsPause(p, 11.5, 2), true, 'the pause ends during the call');
    assert.equal(overlapsPause(p, 22, 1), true, 'the call lies inside the pause');
    assert.equal(overlapsPause(p, 19, 20), true, 'the pause lies inside the call');
    assert.equal(overlapsPause(p, 31, 18), false, 'between two pauses');
    assert.equal(overlapsPause(p, 60, 1), false, 'after every pause');
    assert.equal(overlapsPause(pauses(), 0, 100), false, 'no pause seen');
  });

  it('the summary keeps every call in p99 and gives the figures without the calls a pause overlapped', function () {
    const s = new Stats();
    // 99 short calls, one every 10 ms; one long call (5 ms) during a GC pause.
    for (let i = 0; i < 99; i++) s.add('overhead/interlock', 0.01 + i * 1e-5, i * 10);
    s.add('overhead/interlock', 5, 2000);
    const r = s.series.get('overhead/interlock').summary(pauses([2001, 2004]));
    assert.equal(r.n, 100);
    assert.equal(r.max, 5);
    assert.equal(r.gcOverlapped, 1);
    assert.ok(r.withoutGc.max < 0.02, `without the paused call the worst is ours: ${r.withoutGc.max}`);
    assert.ok(Math.abs(r.withoutGc.p99 - (0.01 + 98 * 1e-5)) < 1e-9);
  });

  it('a series keeps which call was its slowest, for the layer verdict to name', function () {
    const s = new Stats();
    s.add('overhead/interlock', 0.2, 0, 'acquire');
    s.add('overhead/interlock', 1.4, 10, 'clear');
    s.add('overhead/interlock', 0.3, 20, 'release');
    assert.deepEqual(s.series.get('overhead/interlock').summary(pauses()).slowest, { ms: 1.4, call: 'clear' });
  });

  it('series without start times are summarised as before', function () {
    const s = new Stats();
    for (let i = 1; i <= 100; i++) s.add('tof/ctrl-1', i);
    const r = s.series.get('tof/ctrl-1').summary(pauses([0, 1e9]));
    assert.deepEqual(r, { n: 100, median: 50, p90: 90, p99: 99, max: 100 });
  });

  it('time() records the call and returns what the work returns, also when it throws', function () {
    const s = new Stats();
    assert.equal(s.time('routine', () => 7), 7);
    assert.throws(() => s.time('routine', () => { throw new Error('boom'); }), /boom/);
    const r = s.report()['overhead/routine'];
    assert.equal(r.n, 2);
    assert.ok(r.max >= 0 && r.max < 1000);
    assert.equal(typeof r.gcOverlapped, 'number');
  });

  it('a series holds what came so far in a buffer that grows, then its last values: fewer per device', function () {
    const s = new Stats();
    s.add('command/completion', 1);
    s.add('tof/ctrl-1', 1);
    assert.ok(s.series.get('command/completion').values.length < 100, 'one value takes a small buffer');
    for (let i = 2; i <= SAMPLES + 10; i++) {
      s.add('command/completion', i, i);
      s.add('tof/ctrl-1', i);
    }
    const r = s.report();
    assert.deepEqual(r['command/completion'], { n: SAMPLES + 10, median: 10010, p90: 18010, p99: 19810, max: SAMPLES + 10 });
    assert.equal(s.series.get('command/completion').values.length, SAMPLES);
    assert.equal(s.series.get('tof/ctrl-1').values.length, PER_SUBJECT_SAMPLES);
    assert.equal(r['tof/ctrl-1'].n, SAMPLES + 10);
    assert.equal(r['tof/ctrl-1'].max, SAMPLES + 10);
    assert.equal(r['tof/ctrl-1'].median, SAMPLES + 10 - PER_SUBJECT_SAMPLES / 2, 'the last values only');
  });
});
