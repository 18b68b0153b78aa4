'use strict';
// The season report on a journal written during a short simulated run (fake
// panel, manual clock): an operation that completes, one whose wait times
// out (a fault and its lockout), an operator's clear, then another
// operation. The report's figure counts must match the events of the run.
const assert = require('node:assert/strict');
const fs = require('fs');
const path = require('path');
const helper = require('node-red-node-test-helper');
const {
  PALETTE, paletteNodes, linkNodes, TAB, sinkNode, collect, until, startServer, stopServer, userDir, runFor, runUntil,
} = require('./support');
const { fakePanel, sensor, stopPanels, fakePlant, fakeValve, fakePump } = require('./fake-panel');
const { stats } = require(path.join(PALETTE, 'lib', 'host', 'stats.js'));
const { readJournal } = require(path.join(PALETTE, 'lib', 'journal', 'files.js'));
const { main } = require('../../scripts/season-report');

helper.init(require.resolve('node-red'));

const PLANT = {
  ...fakePlant([fakeValve('V101', 1, 'YEL'), fakeValve('V102', 2, 'YEL'), fakePump('YEL')]),
  sensors: [{ id: 'LT-3', device: 'station-3', name: 'volume', staleMs: 400 }],
  resources: [{ id: 'YEL' }],
  operations: [
    {
      id: '10', priority: 20, resources: ['YEL'], steps: [
        { command: { valves: { V101: 100, V102: 100 } }, timeoutMs: 3000 },
        { wait: '`LT-3` >= 100', sensors: ['LT-3'], timeoutMs: 600 },
      ],
    },
    { id: '12', priority: 22, resources: ['YEL'], steps: [{ command: { valves: { V101: 50 } }, timeoutMs: 3000 }] },
  ],
};

const SINKS = ['mqtt', 'ev', 'out', 'caught', 'events'];

describe('season report', function () {
  beforeEach(startServer);
  afterEach(async () => {
    stopPanels();
    await stopServer();
  });

  it('draws Figs. 11-15 and line occupancy from a journal, with counts matching the run', async function () {
    stats.reset();
    await helper.load([...paletteNodes, linkNodes], [
      TAB,
      { id: 'pl', type: 'sugarshack-plant', name: 'plant', plant: PLANT },
      { id: 'il', type: 'sugarshack-interlock', name: 'lines', plant: 'pl', resources: [], policy: 'greedy', persist: false },
      { id: 'bus', z: 'f1', type: 'sugarshack-actuators', plant: 'pl', devices: '', wires: [['mqtt'], [], ['ev']] },
      { id: 'ilev', z: 'f1', type: 'sugarshack-interlock-events', interlock: 'il', wires: [['events']] },
      { id: 'c1', z: 'f1', type: 'catch', scope: null, uncaught: false, wires: [['caught']] },
      { id: 'op10', z: 'f1', type: 'sugarshack-operation', interlock: 'il', operation: '10', wires: [['out']] },
      { id: 'op12', z: 'f1', type: 'sugarshack-operation', interlock: 'il', operation: '12', wires: [['out']] },
      { id: 'clr', z: 'f1', type: 'sugarshack-clear', interlock: 'il', resources: 'YEL', wires: [[]] },
      { id: 'j', z: 'f1', type: 'sugarshack-journal', target: 'files', plantId: 'test', flushS: 0.1, wires: [[]] },
      ...SINKS.map(sinkNode),
    ]);
    const seen = Object.fromEntries(SINKS.map((id) => [id, collect(helper, id)]));
    fakePanel(helper, PLANT);
    helper.getNode('op10').receive({ topic: 'fill' });
    await runFor(helper, 100);
    sensor(helper, 150);
    await runUntil(helper, () => seen.out.length === 1, 'operation 10 to finish');
    // The second run finds LT-3 stale: its wait times out and faults the line.
    await runFor(helper, 500);
    helper.getNode('op10').receive({ topic: 'fill again' });
    await runUntil(helper, () => seen.caught.length === 1, 'the fault');
    await runFor(helper, 200);
    helper.getNode('clr').receive({ by: 'Ann', reason: 'float switch checked' });
    helper.getNode('op12').receive({ topic: 'unload' });
    await runUntil(helper, () => seen.out.length === 2, 'operation 12 to finish');
    await runFor(helper, 300);
    await until(() => seen.events.some((e) => e.payload.kind === 'released' && e.payload.operation === '12'), 'the last release');
    await runFor(helper, 200);

    const dir = path.join(userDir(), 'sugarshack-journal', 'files');
    const out = path.join(userDir(), 'season.html');
    // SEASON_REPORT_SVG=dir also writes each figure as an SVG (how the docs' pictures are made).
    const report = await main(['--journal', dir, '--out', out, ...(process.env.SEASON_REPORT_SVG ? ['--svg', process.env.SEASON_REPORT_SVG] : [])]);
    const s = stats.report();
    const n = (name) => (s[name] ? s[name].n : 0);
    // Each figure counts what the run measured, as the stats registry saw it.
    assert.deepEqual(report.figures.fig11.n, { 'ctrl-1': n('tof/ctrl-1'), 'station-3': n('tof/station-3') });
    assert.equal(report.figures.fig12.n, n('command/issueToMotion'));
    assert.equal(report.figures.fig13.n, n('command/completion'));
    assert.ok(report.figures.fig13.n >= 3, 'the valves of op 10 and op 12 moved');
    assert.equal(report.figures.fig14.n, n('fault/lockout'));
    assert.deepEqual(report.figures.fig15.n, { 10: 1, 12: 1 }, 'one finished run each (the faulted run has no run time)');
    // Occupancy: one holding per grant of the line, the fault's lockout counted as one.
    const granted = seen.events.filter((e) => e.payload.kind === 'granted').length;
    const faulted = seen.events.filter((e) => e.payload.kind === 'faulted').length;
    assert.equal(faulted, 1);
    assert.equal(report.figures.occupancy.n, granted + faulted);
    assert.ok(report.faults.some((f) => f.kind === 'faulted' && f.subject === '10'));
    assert.deepEqual(report.actions.map((a) => [a.action, a.who, a.why, a.target]), [['clear', 'Ann', 'float switch checked', 'YEL']]);
    // The page: self-contained, its figures and its summary.
    const page = fs.readFileSync(out, 'utf8');
    assert.ok(page.length > 500_000, 'the plotting library is in the page');
    assert.doesNotMatch(page, /<script[^>]+src=/, 'nothing loaded from elsewhere');
    for (const id of ['fig11', 'fig12', 'fig13', 'fig14', 'fig15', 'occupancy']) assert.match(page, new RegExp(`<div class="fig" id="${id}">`));
    const summary = JSON.parse(/<script type="application\/json" id="season-summary">(.*?)<\/script>/.exec(page)[1]);
    assert.equal(summary.figures.fig13, report.figures.fig13.n);
    assert.equal(summary.datapoints, readJournal(dir).filter((r) => r.table === 'sugarshack_datapoint').length);
    assert.ok(summary.datapoints > 0);
    // A journal in which retries left copies of rows, as a database without deduplication keeps them
    // (chunks whose answer was lost, sent again): the same report, every count the same, the copies counted apart.
    const copied = path.join(userDir(), 'with-copies');
    fs.mkdirSync(copied);
    let copies = 0;
    for (const f of fs.readdirSync(dir).filter((name) => name.endsWith('.lp'))) {
      const lines = fs.readFileSync(path.join(dir, f), 'utf8').split('\n').filter(Boolean);
      const resent = [...lines.slice(0, 40), ...lines.slice(10, 40), ...lines.slice(10, 40), ...lines.slice(40), ...lines.slice(-7)];
      copies += resent.length - lines.length;
      fs.writeFileSync(path.join(copied, f), `${resent.join('\n')}\n`);
    }
    const withCopies = await main(['--journal', copied, '--out', out]);
    const counts = (r) => ({ ...r, figures: Object.fromEntries(Object.entries(r.figures).map(([k, f]) => [k, f.n])), duplicates: undefined });
    assert.deepEqual(counts(withCopies), counts(report));
    assert.deepEqual([report.duplicates, withCopies.duplicates], [0, copies]);
    assert.ok(copies > 10, `${copies} copies`);
    // --from/--to select by time: a range after the run has nothing.
    const later = await main(['--journal', dir, '--out', out, '--from', String(Date.UTC(2100, 0, 1))]);
    assert.equal(later.rows, 0);
  });
});
