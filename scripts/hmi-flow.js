'use strict';
// Writes the operator's window on FlowFuse Dashboard 2, from one source:
// - flows/hmi.json: npm start's HMI at /dashboard, on flows/case-study.json's
//   interlock and plant;
// - node-red-contrib-sugarshack/examples/hmi-dashboard.json: the same HMI with
//   the case study's plant, interlock and broker nodes and a field bus, for
//   users to import (into npm start's flows, or alone).
// Both are built only from the palette's plant state node, interlock events,
// fault, clear and group command nodes. The line table and the alarm list are
// two subflows ("sugarshack lines panel", "sugarshack alarms panel") a user can
// drop into their own Dashboard 2, configured by their properties (group,
// interlock, shelf time). Every rule stays in the core.
//   node scripts/hmi-flow.js          (writes both)
//   node scripts/hmi-flow.js --check  (exits 1 when either file differs)
const fs = require('fs');
const path = require('path');

const ROOT = path.join(__dirname, '..');
const read = (name) => fs.readFileSync(path.join(__dirname, 'hmi', name), 'utf8');
const LINES_VUE = read('lines.vue');
const ALARMS_VUE = read('alarms.vue');
const PLANT_VUE = read('plant.vue');
const TIMING_VUE = read('timing.vue');

const CASE_STUDY = JSON.parse(fs.readFileSync(path.join(ROOT, 'flows', 'case-study.json'), 'utf8'));
const CASE_INTERLOCK = 'cc5ae58600998c24'; // flows/case-study.json's "lines"
const CASE_PLANT = '2da9f0df9956d284';

const BREAKPOINTS = [{ name: 'Default', px: '0', cols: '3' }, { name: 'Tablet', px: '576', cols: '6' }, { name: 'Desktop', px: '1024', cols: '12' }];

/** Ids of 16 hex digits, as Node-RED exports them: a 12-digit prefix and a counter. */
function idMaker(prefix) {
  let n = 0x100;
  return () => `${prefix}${(n++).toString(16).padStart(4, '0')}`;
}

const template = ({ id, z, group, name, format, order = 1, width = '0', x, y, wires }) => ({
  id, type: 'ui-template', z, group, page: '', ui: '', name, order, width: String(width), height: '0',
  head: '', format, storeOutMessages: true, passthru: false, resendOnRefresh: true, templateScope: 'local',
  className: '', x, y, wires,
});

/** msg.panel from the subflow's properties: which interlock, how long a shelf lasts. */
const panelOf = (id, z, x, y, wires) => ({
  id, type: 'change', z, name: 'panel settings', rules: [{ t: 'set', p: 'panel', pt: 'msg',
    to: '{ "interlock": $env("INTERLOCK"), "shelveMinutes": $env("SHELVE_MINUTES") }', tot: 'jsonata' }],
  x, y, wires: [wires],
});

const groupEnv = { name: 'GROUP', type: 'conf-type', value: '', ui: { label: { 'en-US': 'Group' }, type: 'conf-types', opts: { types: ['ui-group'] } } };
const interlockEnv = { name: 'INTERLOCK', type: 'str', value: '', ui: { label: { 'en-US': 'Interlock (id or name; empty: the first)' }, type: 'input', opts: { types: ['str'] } } };

/** The two panel subflows: definitions and their inner nodes. */
function panels(id) {
  const sfLines = id(); const sfAlarms = id();
  const lState = id(); const lPanel = id(); const lTemplate = id(); const lRoute = id();
  const aState = id(); const aPanel = id(); const aTemplate = id();
  const lRefused = id();
  return {
    lines: sfLines,
    alarms: sfAlarms,
    nodes: [
      { id: sfLines, type: 'subflow', name: 'sugarshack lines panel', info: 'The plant\'s lines on a Dashboard 2 group: state by colour, holder or fault cause, since when, waiting operations, why a faulted line may not be cleared yet; the running operations with their ISA-88 state (held, holding, ...), the queue and the routines; E-STOP per line and for the plant, CLEAR per line with a reason and a force box; HOLD, RESTART, STOP, ABORT and RESET on each operation and routine, shown when the core allows them (sent to the plant state node inside, a refusal shown under the operations). Drawn from the plant state node inside (GET /sugarshack/state).\n\n**Properties**: *Group*, the ui-group to draw in; *Interlock*, the interlock (id or name) when there are several.\n\n**Output 1**: e-stop requests (`msg.resources`, `msg.reason`): wire to a fault node (mode: lines from msg) and its lockouts to a group command node. **Output 2**: clear requests (`msg.resources`, `msg.reason`, `msg.force`): wire to a clear node. **Input**: a clear node\'s refusals (its output 2, with `msg.topic` "refused" and `msg.payload` its `msg.refused`), shown on the line.',
        category: 'sugarshack', in: [{ x: 60, y: 80, wires: [{ id: lTemplate }] }],
        out: [{ x: 760, y: 60, wires: [{ id: lRoute, port: 0 }] }, { x: 760, y: 100, wires: [{ id: lRoute, port: 1 }] }],
        env: [groupEnv, interlockEnv], meta: {}, color: '#D9A55B', inputLabels: ['clear refusals'], outputLabels: ['e-stop requests', 'clear requests'], icon: 'font-awesome/fa-th-list' },
      { id: lState, type: 'sugarshack-state', z: sfLines, name: 'plant state', onChange: true, intervalS: 1, x: 160, y: 160, wires: [[lPanel]] },
      panelOf(lPanel, sfLines, 340, 160, [lTemplate]),
      template({ id: lTemplate, z: sfLines, group: '${GROUP}', name: 'lines', format: LINES_VUE, x: 400, y: 80, wires: [[lRoute]] }),
      { id: lRoute, type: 'switch', z: sfLines, name: 'request', property: 'topic', propertyType: 'msg',
        // Anything else (a state request, an operator's command to a run) is the plant state node's.
        rules: [{ t: 'eq', v: 'e-stop', vt: 'str' }, { t: 'eq', v: 'clear', vt: 'str' }, { t: 'else' }], checkall: 'false', repair: false, outputs: 3,
        x: 590, y: 80, wires: [[], [], [lState]] },
      // A command the core refused comes back to the panel with its msg.error.
      { id: lRefused, type: 'catch', z: sfLines, name: 'refused command', scope: [lState], uncaught: false, x: 170, y: 220, wires: [[lTemplate]] },
      { id: sfAlarms, type: 'subflow', name: 'sugarshack alarms panel', info: 'The plant\'s alarms on a Dashboard 2 group, ISA-18.2 style: active or returned to normal, acknowledged or not (by whom, when), ACK, ACK ALL, SHELVE for a while and UNSHELVE; below, the latest faults, e-stops and clears with who and why, forced clears marked. The core keeps the alarm states (acknowledgements survive a reload, and a restart when the interlock persists its state); this panel only draws them and sends requests to the plant state node inside.\n\n**Properties**: *Group*, the ui-group to draw in; *Interlock*, the interlock (id or name) when there are several; *Shelve minutes*, how long SHELVE shelves an alarm.',
        category: 'sugarshack', in: [], out: [],
        env: [groupEnv, interlockEnv, { name: 'SHELVE_MINUTES', type: 'num', value: '60', ui: { label: { 'en-US': 'Shelve minutes' }, type: 'input', opts: { types: ['num'] } } }],
        meta: {}, color: '#D9A55B', icon: 'font-awesome/fa-bell' },
      { id: aState, type: 'sugarshack-state', z: sfAlarms, name: 'plant state', onChange: true, intervalS: 1, x: 160, y: 80, wires: [[aPanel]] },
      panelOf(aPanel, sfAlarms, 340, 80, [aTemplate]),
      template({ id: aTemplate, z: sfAlarms, group: '${GROUP}', name: 'alarms', format: ALARMS_VUE, x: 520, y: 80, wires: [[aState]] }),
    ],
  };
}

/** The HMI tab on interlock `interlock` and plant `plant`; `extra(TAB, id)` adds nodes (a plant of its own). */
function hmi({ prefix, interlock, plant, tabLabel, info, extra = () => [] }) {
  const id = idMaker(prefix);
  const TAB = id();
  const base = id(); const theme = id(); const plantPage = id(); const timingPage = id();
  const gLines = id(); const gAlarms = id(); const gPlant = id(); const gTiming = id(); const gFigures = id();
  const state = id(); const tPlant = id(); const linesPanel = id(); const alarmsPanel = id();
  const events = id(); const estop = id(); const clear = id(); const lockouts = id(); const refusedBack = id();
  const waits = id(); const toPoint = id(); const chart = id();
  const tick = id(); const statsOf = id(); const tFigures = id();
  const sf = panels(id);
  const plantOf = id();
  const group = (gid, name, page, width, order) => ({ id: gid, type: 'ui-group', name, page, width: String(width), height: '1', order, showTitle: true, className: '', visible: 'true', disabled: 'false', groupType: 'default' });
  const comment = (name, x, y) => ({ id: id(), type: 'comment', z: TAB, name, info: '', x, y, wires: [] });
  return [
    { id: TAB, type: 'tab', label: tabLabel, disabled: false, info },
    ...sf.nodes,
    { id: base, type: 'ui-base', name: 'sugar shack', path: '/dashboard', appIcon: '', includeClientData: true,
      acceptsClientConfig: ['ui-notification', 'ui-control'], showPathInSidebar: false, showPageTitle: true, navigationStyle: 'default', titleBarStyle: 'default' },
    { id: theme, type: 'ui-theme', name: 'plant', colors: { surface: '#5b3a1a', primary: '#b5651d', bgPage: '#eeeeee', groupBg: '#ffffff', groupOutline: '#cccccc' },
      sizes: { density: 'default', pagePadding: '12px', groupGap: '12px', groupBorderRadius: '4px', widgetGap: '12px' } },
    { id: plantPage, type: 'ui-page', name: 'Plant', ui: base, path: '/plant', icon: 'factory', layout: 'grid', theme, breakpoints: BREAKPOINTS, order: 1, className: '', visible: 'true', disabled: 'false' },
    { id: timingPage, type: 'ui-page', name: 'Timing', ui: base, path: '/timing', icon: 'chart-line', layout: 'grid', theme, breakpoints: BREAKPOINTS, order: 2, className: '', visible: 'true', disabled: 'false' },
    group(gLines, 'Lines', plantPage, 8, 1),
    group(gAlarms, 'Alarms', plantPage, 4, 2),
    group(gPlant, 'Tanks, sensors and devices', plantPage, 12, 3),
    group(gFigures, 'The paper\'s timing figures (Figs. 11-15)', timingPage, 12, 1),
    group(gTiming, 'Queue waits per grant (s)', timingPage, 12, 2),

    comment('Lines and alarms: the two panel subflows, each drawing the plant state (GET /sugarshack/state); their requests go to the core', 400, 20),
    { id: linesPanel, type: `subflow:${sf.lines}`, z: TAB, name: 'plant lines', env: [{ name: 'GROUP', type: 'conf-type', value: gLines }, { name: 'INTERLOCK', type: 'str', value: interlock }], x: 170, y: 80, wires: [[estop], [clear]] },
    { id: estop, type: 'sugarshack-fault', z: TAB, name: 'e-stop', interlock, mode: 'resources', operation: '', resources: '', after: 'send', x: 380, y: 60, wires: [[], [lockouts]] },
    { id: lockouts, type: 'sugarshack-group-command', z: TAB, name: 'lockout', plant, timeout: 0, x: 560, y: 60, wires: [[]] },
    { id: clear, type: 'sugarshack-clear', z: TAB, name: 'clear', interlock, mode: 'resources', resources: '', x: 380, y: 120, wires: [[], [refusedBack]] },
    { id: refusedBack, type: 'change', z: TAB, name: 'refusal to the panel', rules: [{ t: 'set', p: 'topic', pt: 'msg', to: 'refused', tot: 'str' }, { t: 'set', p: 'payload', pt: 'msg', to: 'refused', tot: 'msg' }],
      x: 590, y: 120, wires: [[linesPanel]] },
    { id: alarmsPanel, type: `subflow:${sf.alarms}`, z: TAB, name: 'alarms', env: [{ name: 'GROUP', type: 'conf-type', value: gAlarms }, { name: 'INTERLOCK', type: 'str', value: interlock }, { name: 'SHELVE_MINUTES', type: 'num', value: '60' }], x: 160, y: 180, wires: [] },

    comment('Tanks, sensors, device health and unconfirmed lockouts, from the plant state', 300, 240),
    { id: state, type: 'sugarshack-state', z: TAB, name: 'plant state', onChange: true, intervalS: 1, x: 150, y: 280, wires: [[plantOf]] },
    { id: plantOf, type: 'change', z: TAB, name: 'which plant', rules: [{ t: 'set', p: 'panel', pt: 'msg', to: JSON.stringify({ plant }), tot: 'json' }], x: 330, y: 280, wires: [[tPlant]] },
    template({ id: tPlant, z: TAB, group: gPlant, name: 'plant', format: PLANT_VUE, order: 1, width: 12, x: 510, y: 280, wires: [[]] }),

    comment('Timing page: a grant\'s queue wait per line set (Figs. 13-15), from the interlock events', 300, 340),
    { id: events, type: 'sugarshack-interlock-events', z: TAB, name: '', interlock, x: 170, y: 380, wires: [[waits]] },
    { id: waits, type: 'switch', z: TAB, name: 'grants', property: 'payload.kind', propertyType: 'msg', rules: [{ t: 'eq', v: 'granted', vt: 'str' }], checkall: 'true', repair: false, outputs: 1, x: 360, y: 380, wires: [[toPoint]] },
    { id: toPoint, type: 'change', z: TAB, name: 'wait in s', rules: [
      { t: 'set', p: 'topic', pt: 'msg', to: '$join(payload.resources, "+")', tot: 'jsonata' },
      { t: 'set', p: 'payload', pt: 'msg', to: 'payload.waitedMs / 1000', tot: 'jsonata' }], x: 540, y: 380, wires: [[chart]] },
    { id: chart, type: 'ui-chart', z: TAB, group: gTiming, name: 'queue waits', label: 'queue wait per grant (s)', order: 1, chartType: 'line', category: 'topic', categoryType: 'msg',
      xAxisLabel: '', xAxisProperty: '', xAxisPropertyType: 'timestamp', xAxisType: 'time', xAxisFormat: '', xAxisFormatType: 'auto', yAxisLabel: 's', yAxisProperty: 'payload', yAxisPropertyType: 'msg',
      ymin: '', ymax: '', bins: 10, action: 'append', stackSeries: false, pointShape: 'circle', pointRadius: 4, showLegend: true, removeOlder: 1, removeOlderUnit: '3600', removeOlderPoints: '200',
      colors: ['#0095ff', '#ff0000', '#ff7f0e', '#2ca02c', '#a347e1', '#d62728', '#ff9896', '#9467bd', '#c5b0d5'], textColor: ['#666666'], textColorDefault: true, gridColor: ['#e5e5e5'], gridColorDefault: true,
      width: '12', height: '6', className: '', interpolation: 'linear', x: 740, y: 380, wires: [[]] },

    comment('Timing page: the figures of GET /sugarshack/stats, from the state node asked with topic sugarshack/stats', 380, 440),
    { id: tick, type: 'inject', z: TAB, name: 'every 2 s', props: [{ p: 'topic', vt: 'str' }], repeat: '2', crontab: '', once: true, onceDelay: '1', topic: 'sugarshack/stats', x: 150, y: 480, wires: [[statsOf]] },
    { id: statsOf, type: 'sugarshack-state', z: TAB, name: 'timing figures', onChange: false, intervalS: 1, x: 340, y: 480, wires: [[tFigures]] },
    template({ id: tFigures, z: TAB, group: gFigures, name: 'timing figures', format: TIMING_VUE, order: 1, width: 12, x: 560, y: 480, wires: [[statsOf]] }),
    ...extra(TAB, id),
  ];
}

const HMI_INFO = 'The operator\'s window at /dashboard: the plant page (lines by state with holder and queue, routines, tanks and sensors, device health, alarms with acknowledge and shelve, E-STOP and CLEAR with a reason, a forced clear marked) and the timing page. Everything drawn comes from the plant state node (the same document as GET /sugarshack/state) and the interlock events; buttons send requests to the state, fault and clear nodes, and the core decides.';

const npmStart = () => hmi({ prefix: 'd5a0b0a00000', interlock: CASE_INTERLOCK, plant: CASE_PLANT, tabLabel: 'HMI (dashboard)', info: HMI_INFO });

/**
 * The example: npm start's HMI, ids and all, with the case study's plant,
 * interlock and broker nodes as flows/case-study.json has them (same ids) and a
 * field bus of its own. Imported into npm start's flows, the editor reuses
 * those config nodes (its "Import copy" keeps a config node whose id exists),
 * so it draws the plant npm start runs and adds no second interlock over its
 * valves; alone, it brings them.
 */
function example() {
  const configs = CASE_STUDY.filter((n) => !n.z && n.type !== 'tab');
  const broker = configs.find((n) => n.type === 'mqtt-broker').id;
  return hmi({
    prefix: 'd5a0b0a00000', tabLabel: 'sugarshack HMI (dashboard)',
    info: `${HMI_INFO}\n\nNeeds @flowfuse/node-red-dashboard. It is the HMI of the sugarshack repository's \`npm start\`, on the case-study plant: its plant, interlock and MQTT broker (127.0.0.1:1883) nodes come with it, with the ids they have in npm start's flows, so imported there (choose *Import copy* when the editor says some nodes exist) it draws the plant npm start runs; on its own, \`node scripts/simulator/cli.js --plant flows/plant.json\` of the repository plays its devices. In your own dashboard, use the two panel subflows: set their Group (and Interlock), and wire the lines panel as here.`,
    interlock: CASE_INTERLOCK,
    plant: CASE_PLANT,
    extra: (TAB, id) => {
      const actuators = id(); const commands = id();
      const topics = ['+/status', '+/valve/+/position/state', '+/switch/+/state', '+/sensor/+/state'];
      const ins = topics.map(() => id());
      return [
        ...configs,
        { id: id(), type: 'comment', z: TAB, name: 'The plant\'s devices over MQTT', info: '', x: 300, y: 560, wires: [] },
        ...topics.map((topic, i) => ({ id: ins[i], type: 'mqtt in', z: TAB, name: '', topic, qos: '1', datatype: 'auto-detect', broker, nl: false, rap: true, rh: 0, inputs: 0, x: 170, y: 600 + i * 40, wires: [[actuators]] })),
        { id: actuators, type: 'sugarshack-actuators', z: TAB, name: 'all devices', plant: CASE_PLANT, devices: '', broker, x: 420, y: 640, wires: [[commands], [], []] },
        { id: commands, type: 'mqtt out', z: TAB, name: 'device commands', topic: '', qos: '', retain: '', respTopic: '', contentType: '', userProps: '', correl: '', expiry: '', broker, x: 640, y: 640, wires: [] },
      ];
    },
  });
}

const OUTPUTS = [
  [path.join(ROOT, 'flows', 'hmi.json'), npmStart],
  [path.join(ROOT, 'node-red-contrib-sugarshack', 'examples', 'hmi-dashboard.json'), example],
];

if (require.main === module) {
  const check = process.argv.includes('--check');
  let stale = 0;
  for (const [file, build] of OUTPUTS) {
    const text = `${JSON.stringify(build(), null, 2)}\n`;
    const name = path.relative(process.cwd(), file);
    if (!check) {
      fs.writeFileSync(file, text);
      console.log(`hmi-flow: wrote ${name}`);
    } else if (!fs.existsSync(file) || fs.readFileSync(file, 'utf8') !== text) {
      console.error(`hmi-flow: ${name} is not what scripts/hmi-flow.js makes of scripts/hmi/; run node scripts/hmi-flow.js`);
      stale++;
    }
  }
  process.exit(stale ? 1 : 0);
}

module.exports = { npmStart, example, hmi, HMI_INFO };
