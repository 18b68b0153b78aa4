'use strict';
const assert = require('node:assert/strict');
const path = require('path');
const { PALETTE } = require('./support');
const { statusText, compact, shortReason, countsStatus, MAX_STATUS_LENGTH } = require(path.join(PALETTE, 'lib', 'host', 'status.js'));

describe('status text', function () {
  it('reads naturally for everyday counts', function () {
    assert.equal(statusText({ holding: 0, queued: 0, faulted: 0 }), 'idle');
    assert.equal(statusText({ holding: 2, queued: 3, faulted: 0 }), 'held 2 · queued 3');
    assert.equal(statusText({ holding: 2, queued: 0, faulted: 1 }), 'faulted 1 · held 2');
    assert.equal(statusText({ holding: 1, queued: 1, faulted: 1 }), 'flt 1 · hld 1 · q 1');
    assert.equal(statusText({ holding: 1, queued: 119, faulted: 1 }), 'flt 1·hld 1·q 119');
    assert.equal(statusText({ holding: 0, queued: 12345, faulted: 0 }), 'queued 12345');
    assert.equal(statusText({ holding: 3, queued: 12345, faulted: 5 }), 'flt 5·hld 3·q 12k');
    assert.equal(statusText({ holding: 1234, queued: 12345, faulted: 5 }), 'F5 H1.2k Q12k');
  });

  it('compacts counts to at most 4 characters', function () {
    const cases = [[0, '0'], [999, '999'], [1000, '1k'], [1250, '1.2k'], [9999, '9.9k'], [10000, '10k'],
      [999999, '999k'], [1e6, '1M'], [9.99e6, '9.9M'], [5e8, '500M'], [1e9, '>1G'], [1e15, '>1G']];
    for (const [n, text] of cases) assert.equal(compact(n), text, String(n));
  });

  it('is always under 20 characters', function () {
    const values = [0, 1, 9, 10, 99, 100, 999, 1000, 1001, 9999, 10000, 99999, 123456, 999999, 1e6, 12345678, 999999999, 1e9, 2 ** 32, Number.MAX_SAFE_INTEGER];
    let checked = 0;
    for (const faulted of values) {
      for (const holding of values) {
        for (const queued of values) {
          const text = statusText({ holding, queued, faulted });
          assert.ok(text.length <= MAX_STATUS_LENGTH && text.length < 20, `${faulted}/${holding}/${queued}: "${text}"`);
          checked++;
        }
      }
    }
    assert.equal(checked, values.length ** 3);
  });

  it('shows faults in red and short refusal reasons', function () {
    assert.equal(countsStatus({ holding: 1, queued: 0, faulted: 1 }).fill, 'red');
    assert.equal(countsStatus({ holding: 1, queued: 4, faulted: 0 }).fill, 'green');
    // A state lost at start leads; the counts beside it take their short forms, then letters, then the least important go: never cut.
    assert.equal(countsStatus({ holding: 0, queued: 0, faulted: 3, lost: true }).text, 'lost · faulted 3');
    assert.equal(countsStatus({ holding: 1, queued: 0, faulted: 3, lost: true }).text, 'lost · flt 3·hld 1');
    assert.equal(countsStatus({ holding: 1, queued: 2, faulted: 3, lost: true }).text, 'lost · F3 H1 Q2');
    assert.equal(countsStatus({ holding: 1234, queued: 12345, faulted: 5, lost: true }).text, 'lost · F5 H1.2k');
    assert.equal(shortReason('UNKNOWN_RESOURCE'), 'unknown resource');
    const long = shortReason('SOME_VERY_LONG_FUTURE_ERROR_CODE');
    assert.ok(long.length < 20 && long.endsWith('…'), long);
  });
});

describe('error codes', function () {
  const fs = require('fs');
  const { isKnownCode } = require(path.join(PALETTE, 'lib', 'host', 'status.js'));

  function sources(dir) {
    return fs.readdirSync(dir, { withFileTypes: true }).flatMap((entry) => {
      const file = path.join(dir, entry.name);
      if (entry.isDirectory()) return sources(file);
      return entry.name.endsWith('.js') ? [file] : [];
    });
  }

  it('every code the nodes raise or test for is in the core table, so its status text comes from there', function () {
    const raised = new Map();
    const uses = /SugarshackError(?:\.of)?\(\s*'([A-Z_]+)'|code: '([A-Z_]+)'|errorStatus\('([A-Z_]+)'\)|code [!=]== '([A-Z_]+)'/g;
    // What Node.js itself throws, tested for where a file or module may be missing.
    const fromNode = new Set(['ENOENT', 'MODULE_NOT_FOUND']);
    for (const file of [...sources(path.join(PALETTE, 'lib')), ...sources(path.join(PALETTE, 'nodes'))]) {
      const text = fs.readFileSync(file, 'utf8');
      for (const m of text.matchAll(uses)) {
        for (const code of m.slice(1).filter(Boolean)) if (!fromNode.has(code)) raised.set(code, path.relative(PALETTE, file));
      }
    }
    assert.ok(raised.size > 10, `found ${raised.size} codes`);
    const unknown = [...raised].filter(([code]) => !isKnownCode(code));
    assert.deepEqual(unknown, [], 'codes missing from the core table (rust/sugarshack-core/src/code.rs)');
  });

  it('reads each status text from the core and words an unknown code plainly', function () {
    assert.equal(shortReason('SENSOR_UNAVAILABLE'), 'sensor unavailable');
    assert.equal(shortReason('INVALID_INPUT'), 'invalid input');
    assert.equal(shortReason('ECONNREFUSED'), 'econnrefused');
  });
});

describe('status pacing', function () {
  const { StatusPacer, WINDOW_MS, BURST } = require(path.join(PALETTE, 'lib', 'host', 'status-pacer.js'));
  const { useClock, ManualClock } = require(path.join(PALETTE, 'lib', 'host', 'clock.js'));
  let manual;
  beforeEach(function () {
    manual = useClock(new ManualClock());
  });
  afterEach(function () {
    useClock();
  });

  it('shows the first updates of a window at once and the last state at its end, never a stale one', async function () {
    let state = 0;
    const shown = [];
    const pacer = new StatusPacer(() => shown.push(state), () => true);
    for (state = 1; state <= 50; state++) pacer.request();
    state = 50;
    assert.deepEqual(shown, Array.from({ length: BURST }, (_, i) => i + 1));
    await manual.advance(WINDOW_MS - 1);
    assert.equal(shown.length, BURST, 'nothing more within the window');
    await manual.advance(1);
    assert.equal(shown[shown.length - 1], 50, 'the last state shows when the window ends');
    assert.equal(shown.length, BURST + 1);
    // A quiet window later, updates show at once again.
    await manual.advance(WINDOW_MS);
    state = 51;
    pacer.request();
    assert.equal(shown[shown.length - 1], 51);
  });

  it('shows nothing after the runtime stopped, and stop() drops the pending update', async function () {
    const shown = [];
    let live = true;
    const pacer = new StatusPacer(() => shown.push(1), () => live);
    for (let i = 0; i < BURST + 5; i++) pacer.request();
    live = false;
    await manual.advance(WINDOW_MS);
    assert.equal(shown.length, BURST);
    live = true;
    for (let i = 0; i < BURST * 3; i++) pacer.request();
    const before = shown.length;
    pacer.stop();
    await manual.advance(WINDOW_MS * 2);
    assert.equal(shown.length, before);
  });
});
