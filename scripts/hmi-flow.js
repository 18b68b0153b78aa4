'use strict';
// Writes flows/hmi.json: the operator's window on FlowFuse Dashboard 2 at
// /dashboard, built only from the palette's state node, interlock events,
// fault and clear nodes. The line table is one ui-template (Vue) that renders
// the state document and sends requests; every rule stays in the core.
//   node scripts/hmi-flow.js [out]
const fs = require('fs');
const path = require('path');

const INTERLOCK = 'cc5ae58600998c24'; // flows/case-study.json's "lines"
const PLANT = '2da9f0df9956d284';
const TAB = 'd5a0b0a000000001';
let n = 0;
const id = () => `d5a0b0a0000001${(++n).toString(16).padStart(2, '0')}`;

const base = id(); const theme = id(); const plantPage = id(); const timingPage = id();
const gLines = id(); const gAlarms = id(); const gPlant = id(); const gTiming = id();
const tLines = id(); const tAlarms = id(); const tPlant = id();
const state = id(); const events = id(); const route = id(); const estop = id(); const clear = id();
const lockouts = id(); const toAlarms = id(); const waits = id(); const chart = id(); const refusedBack = id();

const LINES_VUE = fs.readFileSync(path.join(__dirname, 'hmi', 'lines.vue'), 'utf8');
const ALARMS_VUE = fs.readFileSync(path.join(__dirname, 'hmi', 'alarms.vue'), 'utf8');
const PLANT_VUE = fs.readFileSync(path.join(__dirname, 'hmi', 'plant.vue'), 'utf8');
const TIMING_VUE = fs.readFileSync(path.join(__dirname, 'hmi', 'timing.vue'), 'utf8');

const template = (nid, group, name, format, order, width, wires) => ({
  id: nid, type: 'ui-template', z: TAB, group, page: '', ui: '', name, order, width: String(width), height: '0',
  head: '', format, storeOutMessages: true, passthru: false, resendOnRefresh: true, templateScope: 'local',
  className: '', x: 560, y: 60 + order * 60, wires: [wires],
});

const flow = [
  { id: TAB, type: 'tab', label: 'HMI (dashboard)', disabled: false,
    info: 'The operator\'s window at /dashboard: the plant page (lines by state with holder and queue, routines, tanks and sensors, device health, alarms with acknowledge, E-STOP and CLEAR per line and for the plant) and the timing page. Everything drawn comes from the plant state node (the same document as GET /sugarshack/state) and the interlock events; buttons send requests to the fault and clear nodes, and the core decides.' },
  { id: base, type: 'ui-base', name: 'sugar shack', path: '/dashboard', appIcon: '', includeClientData: true,
    acceptsClientConfig: ['ui-notification', 'ui-control'], showPathInSidebar: false, showPageTitle: true, navigationStyle: 'default', titleBarStyle: 'default' },
  { id: theme, type: 'ui-theme', name: 'plant', colors: { surface: '#5b3a1a', primary: '#b5651d', bgPage: '#eeeeee', groupBg: '#ffffff', groupOutline: '#cccccc' },
    sizes: { density: 'default', pagePadding: '12px', groupGap: '12px', groupBorderRadius: '4px', widgetGap: '12px' } },
  { id: plantPage, type: 'ui-page', name: 'Plant', ui: base, path: '/plant', icon: 'factory', layout: 'grid', theme, breakpoints: [{ name: 'Default', px: '0', cols: '3' }, { name: 'Tablet', px: '576', cols: '6' }, { name: 'Desktop', px: '1024', cols: '12' }], order: 1, className: '', visible: 'true', disabled: 'false' },
  { id: timingPage, type: 'ui-page', name: 'Timing', ui: base, path: '/timing', icon: 'chart-line', layout: 'grid', theme, breakpoints: [{ name: 'Default', px: '0', cols: '3' }, { name: 'Tablet', px: '576', cols: '6' }, { name: 'Desktop', px: '1024', cols: '12' }], order: 2, className: '', visible: 'true', disabled: 'false' },
  { id: gLines, type: 'ui-group', name: 'Lines', page: plantPage, width: '8', height: '1', order: 1, showTitle: true, className: '', visible: 'true', disabled: 'false', groupType: 'default' },
  { id: gAlarms, type: 'ui-group', name: 'Alarms', page: plantPage, width: '4', height: '1', order: 2, showTitle: true, className: '', visible: 'true', disabled: 'false', groupType: 'default' },
  { id: gPlant, type: 'ui-group', name: 'Tanks, sensors and devices', page: plantPage, width: '12', height: '1', order: 3, showTitle: true, className: '', visible: 'true', disabled: 'false', groupType: 'default' },
  { id: gTiming, type: 'ui-group', name: 'Queue waits per grant (s)', page: timingPage, width: '12', height: '1', order: 2, showTitle: true, className: '', visible: 'true', disabled: 'false', groupType: 'default' },
  { id: id(), type: 'comment', z: TAB, name: 'The plant state (on change, at most once a second) draws the page; requests from its buttons go to the core', info: '', x: 330, y: 20, wires: [] },
  { id: state, type: 'sugarshack-state', z: TAB, name: 'plant state', onChange: true, intervalMs: 1000, x: 330, y: 120, wires: [[tLines, tPlant]] },
  template(tLines, gLines, 'lines', LINES_VUE, 1, 8, [route]),
  template(tPlant, gPlant, 'plant', PLANT_VUE, 3, 12, []),
  { id: route, type: 'switch', z: TAB, name: 'request', property: 'topic', propertyType: 'msg',
    rules: [{ t: 'eq', v: 'e-stop', vt: 'str' }, { t: 'eq', v: 'clear', vt: 'str' }, { t: 'eq', v: 'state', vt: 'str' }], checkall: 'false', repair: false, outputs: 3,
    x: 780, y: 120, wires: [[estop], [clear], [state]] },
  { id: estop, type: 'sugarshack-fault', z: TAB, name: 'e-stop', interlock: INTERLOCK, mode: 'resources', operation: '', resources: '', after: 'send', x: 960, y: 80, wires: [[], [lockouts]] },
  { id: lockouts, type: 'sugarshack-group-command', z: TAB, name: 'lockout', plant: PLANT, timeout: 0, x: 1140, y: 80, wires: [[]] },
  { id: clear, type: 'sugarshack-clear', z: TAB, name: 'clear', interlock: INTERLOCK, mode: 'resources', resources: '', x: 960, y: 160, wires: [[], [refusedBack]] },
  { id: refusedBack, type: 'change', z: TAB, name: 'refusal to the table', rules: [{ t: 'set', p: 'topic', pt: 'msg', to: 'refused', tot: 'str' }, { t: 'set', p: 'payload', pt: 'msg', to: 'refused', tot: 'msg' }],
    x: 1160, y: 160, wires: [[tLines]] },
  { id: id(), type: 'comment', z: TAB, name: 'Alarms: interlock events (faults, warnings, clears) with time; acknowledge and return to normal in the list', info: '', x: 380, y: 260, wires: [] },
  { id: events, type: 'sugarshack-interlock-events', z: TAB, name: '', interlock: INTERLOCK, x: 170, y: 300, wires: [[toAlarms, waits]] },
  { id: toAlarms, type: 'change', z: TAB, name: 'event', rules: [{ t: 'set', p: 'topic', pt: 'msg', to: 'event', tot: 'str' }], x: 360, y: 300, wires: [[tAlarms]] },
  template(tAlarms, gAlarms, 'alarms', ALARMS_VUE, 2, 4, []),
  { id: waits, type: 'switch', z: TAB, name: 'grants', property: 'payload.kind', propertyType: 'msg', rules: [{ t: 'eq', v: 'granted', vt: 'str' }], checkall: 'true', repair: false, outputs: 1, x: 360, y: 360, wires: [[id()]] },
];
// A grant's queue wait on the timing page, one series per line set (Figs. 13-15).
const toPoint = flow[flow.length - 1].wires[0][0];
flow.push({ id: toPoint, type: 'change', z: TAB, name: 'wait in s', rules: [
  { t: 'set', p: 'topic', pt: 'msg', to: '$join(payload.resources, "+")', tot: 'jsonata' },
  { t: 'set', p: 'payload', pt: 'msg', to: 'payload.waitedMs / 1000', tot: 'jsonata' }], x: 540, y: 360, wires: [[chart]] });
flow.push({ id: chart, type: 'ui-chart', z: TAB, group: gTiming, name: 'queue waits', label: 'queue wait per grant (s)', order: 1, chartType: 'line', category: 'topic', categoryType: 'msg',
  xAxisLabel: '', xAxisProperty: '', xAxisPropertyType: 'timestamp', xAxisType: 'time', xAxisFormat: '', xAxisFormatType: 'auto', yAxisLabel: 's', yAxisProperty: 'payload', yAxisPropertyType: 'msg',
  ymin: '', ymax: '', bins: 10, action: 'append', stackSeries: false, pointShape: 'circle', pointRadius: 4, showLegend: true, removeOlder: 1, removeOlderUnit: '3600', removeOlderPoints: '200',
  colors: ['#0095ff', '#ff0000', '#ff7f0e', '#2ca02c', '#a347e1', '#d62728', '#ff9896', '#9467bd', '#c5b0d5'], textColor: ['#666666'], textColorDefault: true, gridColor: ['#e5e5e5'], gridColorDefault: true,
  width: '12', height: '6', className: '', interpolation: 'linear', x: 740, y: 360, wires: [[]] });

// The paper's Figs. 11-15 from the timing figures, asked for every 2 s and when the page opens.
const gFigures = id(); const tick = id(); const statsOf = id(); const tFigures = id();
flow.push(
  { id: gFigures, type: 'ui-group', name: 'The paper\'s timing figures (Figs. 11-15)', page: timingPage, width: '12', height: '1', order: 1, showTitle: true, className: '', visible: 'true', disabled: 'false', groupType: 'default' },
  { id: id(), type: 'comment', z: TAB, name: 'Timing page: the figures of GET /sugarshack/stats, from the state node asked with topic sugarshack/stats', info: '', x: 380, y: 440, wires: [] },
  { id: tick, type: 'inject', z: TAB, name: 'every 2 s', props: [{ p: 'topic', vt: 'str' }], repeat: '2', crontab: '', once: true, onceDelay: '1', topic: 'sugarshack/stats', x: 150, y: 480, wires: [[statsOf]] },
  { id: statsOf, type: 'sugarshack-state', z: TAB, name: 'timing figures', onChange: false, intervalMs: 1000, x: 340, y: 480, wires: [[tFigures]] },
  { ...template(tFigures, gFigures, 'timing figures', TIMING_VUE, 1, 12, [statsOf]), x: 560, y: 480 },
);

const out = process.argv[2] || path.join(__dirname, '..', 'flows', 'hmi.json');
fs.writeFileSync(out, `${JSON.stringify(flow, null, 2)}\n`);
console.log(`hmi-flow: wrote ${path.relative(process.cwd(), out)} (${flow.length} nodes)`);
