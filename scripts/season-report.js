#!/usr/bin/env node
'use strict';
// The season report: reads the journal (local files, or a VictoriaMetrics /
// InfluxDB-compatible server's export API) and writes one self-contained HTML
// file with the paper's Figs. 11-15 drawn by Apache ECharts (its build is
// copied into the page, so the file opens offline), the counts behind each
// figure, faults, warnings, operator actions, and who held each line when.
// The journal delivers at least once: a row a retry sent twice is in a
// database that does not deduplicate twice. Rows are counted once per
// (writer, seq), the row's name; how many copies were set aside is reported.
//
// usage: npm run season-report -- [--from 2026-03-01] [--to 2026-05-01]
//          [--journal .run/journal | --url http://host:8428] [--out report/season.html]
//          [--svg DIR]   (also writes each figure as an SVG, rendered in Node)

const fs = require('fs');
const path = require('path');
const { readJournal } = require('../node-red-contrib-sugarshack/lib/journal/files');
const { TABLES } = require('../node-red-contrib-sugarshack/lib/journal/schema');

const ROOT = path.join(__dirname, '..');

function parseArgs(argv) {
  const o = { journal: path.join(ROOT, '.run', 'journal'), out: path.join(ROOT, 'report', 'season.html') };
  for (let i = 0; i < argv.length; i++) {
    const a = argv[i];
    const next = () => {
      if (i + 1 >= argv.length) throw new Error(`${a} needs a value`);
      return argv[++i];
    };
    if (a === '--from') o.from = timeOf(next(), a);
    else if (a === '--to') o.to = timeOf(next(), a);
    else if (a === '--journal') o.journal = path.resolve(next());
    else if (a === '--url') o.url = next();
    else if (a === '--out') o.out = path.resolve(next());
    else if (a === '--svg') o.svg = path.resolve(next());
    else if (a === '-h' || a === '--help') o.help = true;
    else throw new Error(`unknown option ${a} (see --help)`);
  }
  return o;
}

function timeOf(text, what) {
  const ms = /^\d+$/.test(text) ? Number(text) : Date.parse(text);
  if (!Number.isFinite(ms)) throw new Error(`${what}: '${text}' is not a date (2026-03-01, 2026-03-01T08:00Z) or epoch milliseconds`);
  return ms;
}

/**
 * Rows from a server's export API (VictoriaMetrics): one row per `<table>_seq`
 * sample (a row sent twice is two samples there), its other fields gathered back
 * from the samples of the same series and time.
 */
async function readServer(url, { fromMs, toMs }) {
  const params = new URLSearchParams({ 'match[]': '{__name__=~"sugarshack_.*"}', start: String(Math.floor((Number.isFinite(fromMs) ? fromMs : 0) / 1000)) });
  if (Number.isFinite(toMs)) params.set('end', String(Math.ceil(toMs / 1000)));
  const res = await fetch(`${url.replace(/\/$/, '')}/api/v1/export`, { method: 'POST', body: params });
  if (!res.ok) throw new Error(`${url}: ${res.status} ${await res.text()}`);
  const tables = Object.values(TABLES).map((t) => t.name);
  const rows = [];
  const fields = new Map(); // table, tags and time -> the fields written there
  for (const line of (await res.text()).split('\n').filter(Boolean)) {
    const { metric, values, timestamps } = JSON.parse(line);
    const { __name__: name, ...tags } = metric;
    const table = tables.find((t) => name.startsWith(`${t}_`));
    if (!table) continue;
    const field = name.slice(table.length + 1);
    values.forEach((v, i) => {
      const key = `${table}\u0000${JSON.stringify(tags)}\u0000${timestamps[i]}`;
      if (!fields.has(key)) fields.set(key, {});
      fields.get(key)[field] = v;
      if (field === 'seq') rows.push({ table, tags, fields: { seq: v }, at: timestamps[i], key });
    });
  }
  return rows
    .map(({ key, ...row }) => ({ ...row, fields: { ...fields.get(key), seq: row.fields.seq } }))
    .filter((r) => r.at >= fromMs && r.at < toMs)
    .sort((a, b) => a.at - b.at || a.fields.seq - b.fields.seq);
}

/**
 * Each row once: a row is named by its writer and seq, and copies of it (sent
 * again after an unanswered request) are set aside and counted. Rows without a
 * writer (journals of earlier versions, whose seq began again at each start)
 * cannot be told apart and are all kept.
 */
function uniqueRows(rows) {
  const seen = new Set();
  const kept = [];
  let duplicates = 0;
  for (const row of rows) {
    const key = row.tags.writer ? `${row.tags.writer}\u0000${row.fields.seq}` : null;
    if (key !== null && seen.has(key)) {
      duplicates++;
      continue;
    }
    if (key !== null) seen.add(key);
    kept.push(row);
  }
  return { rows: kept, duplicates };
}

// ---- figures ------------------------------------------------------------------

function quantile(sorted, p) {
  if (!sorted.length) return null;
  const pos = (sorted.length - 1) * p;
  const lo = Math.floor(pos);
  const hi = Math.ceil(pos);
  return sorted[lo] + (sorted[hi] - sorted[lo]) * (pos - lo);
}

const box = (values) => {
  const s = [...values].sort((a, b) => a - b);
  return [s[0], quantile(s, 0.25), quantile(s, 0.5), quantile(s, 0.75), s[s.length - 1]].map((v) => Math.round(v * 10) / 10);
};

function histogram(values, bins = 40) {
  if (!values.length) return { labels: [], counts: [] };
  const max = Math.max(...values);
  const min = Math.min(0, ...values);
  const width = Math.max(1, (max - min) / bins);
  const counts = new Array(bins).fill(0);
  for (const v of values) counts[Math.min(bins - 1, Math.floor((v - min) / width))]++;
  return { labels: counts.map((_, i) => `${Math.round((min + i * width) / 100) / 10}`), counts };
}

const bySubject = (rows) => {
  const out = new Map();
  for (const r of rows) {
    const k = r.tags.subject || '';
    if (!out.has(k)) out.set(k, []);
    out.get(k).push(r.fields.value_ms);
  }
  return new Map([...out.entries()].sort(([a], [b]) => a.localeCompare(b, undefined, { numeric: true })));
};

function boxFigure(title, unit, groups, axisName) {
  const names = [...groups.keys()];
  return {
    title: { text: title, left: 'center' },
    tooltip: { trigger: 'item' },
    grid: { left: 90, right: 30, top: 50, bottom: 50 },
    xAxis: { type: 'value', name: unit, nameLocation: 'middle', nameGap: 30 },
    yAxis: { type: 'category', data: names, name: axisName },
    series: [{ type: 'boxplot', data: names.map((n) => box(groups.get(n))) }],
  };
}

function histogramFigure(title, values) {
  const h = histogram(values);
  return {
    title: { text: title, left: 'center' },
    tooltip: { trigger: 'axis' },
    grid: { left: 60, right: 30, top: 50, bottom: 50 },
    xAxis: { type: 'category', data: h.labels, name: 's', nameLocation: 'middle', nameGap: 30 },
    yAxis: { type: 'value', name: 'count' },
    series: [{ type: 'bar', data: h.counts, barCategoryGap: '5%' }],
  };
}

/** Who held each line when: [line, operation, from, to] from the interlock's granted/released/faulted/cleared events. */
function occupancy(events, endMs) {
  const held = new Map(); // line -> { operation, from }
  const spans = [];
  const close = (line, at) => {
    const h = held.get(line);
    if (h) spans.push({ line, operation: h.operation, from: h.from, to: at, faulted: h.faulted || false });
    held.delete(line);
  };
  for (const e of events.filter((r) => r.tags.layer === 'interlock')) {
    const lines = (e.tags.resources || '').split(' ').filter(Boolean);
    const { kind } = e.tags;
    if (kind === 'granted') lines.forEach((l) => { close(l, e.at); held.set(l, { operation: e.tags.subject, from: e.at }); });
    else if (['released', 'dropped', 'cancelled'].includes(kind)) lines.forEach((l) => { if (held.has(l) && held.get(l).operation === e.tags.subject) close(l, e.at); });
    else if (kind === 'faulted' || kind === 'resource-faulted') lines.forEach((l) => { close(l, e.at); held.set(l, { operation: `fault: ${e.tags.subject || 'lines'}`, from: e.at, faulted: true }); });
    else if (kind === 'cleared') lines.forEach((l) => close(l, e.at));
  }
  for (const line of [...held.keys()]) close(line, endMs);
  return spans;
}

function occupancyFigure(spans) {
  const lines = [...new Set(spans.map((s) => s.line))].sort();
  return {
    title: { text: 'Line occupancy: who held each line', left: 'center' },
    tooltip: { trigger: 'item' },
    grid: { left: 70, right: 30, top: 50, bottom: 50 },
    xAxis: { type: 'time' },
    yAxis: { type: 'category', data: lines },
    series: [{
      type: 'custom',
      encode: { x: [1, 2], y: 0 },
      data: spans.map((s) => ({ name: s.operation, value: [lines.indexOf(s.line), s.from, s.to, s.operation], itemStyle: { color: s.faulted ? '#d9534f' : '#5470c6' } })),
    }],
  };
}

// Drawn in the page (and in Node for --svg): a bar per holding, from grant to release.
const RENDER_SPAN = `function (params, api) {
  var y = api.coord([0, api.value(0)])[1];
  var start = api.coord([api.value(1), 0])[0];
  var end = api.coord([api.value(2), 0])[0];
  var h = api.size([0, 1])[1] * 0.6;
  return { type: 'rect', shape: { x: start, y: y - h / 2, width: Math.max(1, end - start), height: h }, style: api.style() };
}`;

/** The report's numbers and the figures' options, from journal rows (each counted once per writer and seq). */
function analyse(allRows, { fromMs = -Infinity, toMs = Infinity } = {}) {
  const { rows, duplicates } = uniqueRows(allRows);
  const timing = (series) => rows.filter((r) => r.table === TABLES.timing.name && r.tags.series === series);
  const events = rows.filter((r) => r.table === TABLES.event.name);
  const tof = bySubject(timing('tof'));
  const runs = bySubject(timing('operation/run'));
  const values = (series) => timing(series).map((r) => r.fields.value_ms);
  const counts = (groups) => Object.fromEntries([...groups].map(([k, v]) => [k, v.length]));
  const figures = {
    fig11: { title: 'Fig. 11 Time of flight per device', n: counts(tof), option: boxFigure('Fig. 11 Time of flight per device', 'ms', tof, 'device') },
    fig12: { title: 'Fig. 12 Command issuance-to-motion latency', n: values('command/issueToMotion').length, option: histogramFigure('Fig. 12 Command issuance-to-motion latency', values('command/issueToMotion')) },
    fig13: { title: 'Fig. 13 Command completion latency', n: values('command/completion').length, option: histogramFigure('Fig. 13 Command completion latency', values('command/completion')) },
    fig14: { title: 'Fig. 14 Fault lockout time', n: values('fault/lockout').length, option: histogramFigure('Fig. 14 Fault lockout time', values('fault/lockout')) },
    fig15: {
      title: 'Fig. 15 Operation run time',
      n: counts(runs),
      option: boxFigure('Fig. 15 Operation run time', 'ms', new Map([...runs].map(([k, v]) => [k, v])), 'operation'),
    },
  };
  const end = Number.isFinite(toMs) ? toMs : Math.max(0, ...rows.map((r) => r.at));
  const spans = occupancy(events, end);
  figures.occupancy = { title: 'Line occupancy', n: spans.length, option: occupancyFigure(spans) };
  const faults = events.filter((e) => ['faulted', 'resource-faulted'].includes(e.tags.kind) || (e.tags.layer === 'actuator' && e.tags.kind === 'fault') || (e.tags.layer === 'operation' && e.tags.kind === 'failed'));
  const warnings = events.filter((e) => e.tags.kind && e.tags.kind.startsWith('warn-'));
  const actions = rows.filter((r) => r.table === TABLES.action.name);
  const datapoints = rows.filter((r) => r.table === TABLES.datapoint.name).length;
  return {
    from: Number.isFinite(fromMs) ? fromMs : (rows[0] ? rows[0].at : null),
    to: Number.isFinite(toMs) ? toMs : end,
    rows: rows.length,
    duplicates,
    datapoints,
    events: events.length,
    figures,
    spans,
    faults: faults.map((e) => ({ at: e.at, layer: e.tags.layer, kind: e.tags.kind, subject: e.tags.subject || '', resources: e.tags.resources || '', note: e.tags.note || '' })),
    warnings: warnings.map((e) => ({ at: e.at, kind: e.tags.kind, subject: e.tags.subject || '', resources: e.tags.resources || '' })),
    actions: actions.map((a) => ({ at: a.at, action: a.tags.action, who: a.tags.who || '', why: a.tags.why || '', target: a.tags.target || '' })),
  };
}

const esc = (s) => String(s).replace(/[&<>"']/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;', "'": '&#39;' })[c]);
const iso = (ms) => (Number.isFinite(ms) ? new Date(ms).toISOString().replace('.000Z', 'Z') : '');
const total = (n) => (typeof n === 'number' ? n : Object.values(n).reduce((a, b) => a + b, 0));

function table(headers, rows) {
  if (!rows.length) return '<p class="none">none</p>';
  return `<table><tr>${headers.map((h) => `<th>${esc(h)}</th>`).join('')}</tr>${rows.map((r) => `<tr>${r.map((c) => `<td>${esc(c)}</td>`).join('')}</tr>`).join('')}</table>`;
}

function html(report, echartsSource) {
  const figs = Object.entries(report.figures);
  const summary = {
    from: report.from, to: report.to, rows: report.rows, duplicates: report.duplicates, datapoints: report.datapoints, events: report.events,
    figures: Object.fromEntries(figs.map(([k, f]) => [k, f.n])), faults: report.faults.length, warnings: report.warnings.length, actions: report.actions.length,
  };
  const options = Object.fromEntries(figs.map(([k, f]) => [k, f.option]));
  const json = (v) => JSON.stringify(v).replace(/</g, '\\u003c');
  return `<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>Season report ${esc(iso(report.from))} to ${esc(iso(report.to))}</title>
<style>body{font-family:sans-serif;max-width:1100px;margin:auto;padding:1em}.fig{height:420px;margin:1em 0}table{border-collapse:collapse;font-size:90%}td,th{border:1px solid #ccc;padding:2px 6px;text-align:left}.none{color:#777}</style>
</head><body>
<h1>Season report</h1>
<p>${esc(iso(report.from))} to ${esc(iso(report.to))}: ${report.rows} journal rows, ${report.datapoints} datapoints, ${report.events} events${report.duplicates ? ` (and ${report.duplicates} copies of rows sent twice, each counted once)` : ''}.</p>
<h2>Counts behind each figure</h2>
${table(['figure', 'n', 'by subject'], figs.map(([, f]) => [f.title, total(f.n), typeof f.n === 'number' ? '' : Object.entries(f.n).map(([k, v]) => `${k}: ${v}`).join(', ')]))}
${figs.map(([k]) => `<div class="fig" id="${k}"></div>`).join('\n')}
<h2>Faults (${report.faults.length})</h2>
${table(['time', 'layer', 'kind', 'subject', 'lines', 'note'], report.faults.map((f) => [iso(f.at), f.layer, f.kind, f.subject, f.resources, f.note]))}
<h2>Warnings (${report.warnings.length})</h2>
${table(['time', 'kind', 'operation', 'lines'], report.warnings.map((w) => [iso(w.at), w.kind, w.subject, w.resources]))}
<h2>Operator actions (${report.actions.length})</h2>
${table(['time', 'action', 'who', 'why', 'target'], report.actions.map((a) => [iso(a.at), a.action, a.who, a.why, a.target]))}
<h2>Line occupancy (${report.spans.length} holdings)</h2>
${table(['line', 'held by', 'from', 'to', 's'], report.spans.map((s) => [s.line, s.operation, iso(s.from), iso(s.to), ((s.to - s.from) / 1000).toFixed(1)]))}
<script type="application/json" id="season-summary">${json(summary)}</script>
<script>${echartsSource}</script>
<script>
var options = ${json(options)};
options.occupancy.series[0].renderItem = ${RENDER_SPAN};
Object.keys(options).forEach(function (id) { echarts.init(document.getElementById(id)).setOption(options[id]); });
</script>
</body></html>
`;
}

/** Each figure as an SVG string, rendered in Node by ECharts' server-side renderer. */
function svgs(report) {
  const echarts = require('echarts');
  const out = {};
  for (const [k, f] of Object.entries(report.figures)) {
    const chart = echarts.init(null, null, { renderer: 'svg', ssr: true, width: 900, height: 420 });
    const option = JSON.parse(JSON.stringify(f.option));
    if (k === 'occupancy') option.series[0].renderItem = new Function(`return ${RENDER_SPAN}`)(); // eslint-disable-line no-new-func
    chart.setOption({ animation: false, backgroundColor: '#fff', ...option });
    out[k] = chart.renderToSVGString();
    chart.dispose();
  }
  return out;
}

async function main(argv) {
  const o = parseArgs(argv);
  if (o.help) {
    process.stdout.write(fs.readFileSync(__filename, 'utf8').split('\n').slice(2, 12).map((l) => l.replace(/^\/\/ ?/, '')).join('\n') + '\n');
    return null;
  }
  const range = { fromMs: o.from ?? -Infinity, toMs: o.to ?? Infinity };
  const rows = o.url ? await readServer(o.url, range) : readJournal(o.journal, range);
  const report = analyse(rows, range);
  const echartsSource = fs.readFileSync(require.resolve('echarts/dist/echarts.min.js'), 'utf8');
  fs.mkdirSync(path.dirname(o.out), { recursive: true });
  fs.writeFileSync(o.out, html(report, echartsSource));
  if (o.svg) {
    fs.mkdirSync(o.svg, { recursive: true });
    for (const [k, svg] of Object.entries(svgs(report))) fs.writeFileSync(path.join(o.svg, `${k}.svg`), svg);
  }
  console.log(`season report: ${o.out} (${report.rows} rows from ${o.url || o.journal}, ${report.duplicates} duplicates set aside; figures: ${Object.entries(report.figures).map(([k, f]) => `${k} n=${total(f.n)}`).join(', ')})`);
  return report;
}

if (require.main === module) {
  main(process.argv.slice(2)).catch((err) => {
    console.error(`season-report: ${err.message}`);
    process.exit(1);
  });
}

module.exports = { analyse, html, svgs, main, parseArgs, occupancy, uniqueRows, readServer };
