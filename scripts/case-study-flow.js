#!/usr/bin/env node
// Writes flows/case-study.json, the Node-RED flows of the case-study plant,
// from its plant document flows/plant.json: the field bus over MQTT, the
// interlock bound to the plant, one routine node per routine, a manual start
// for every operation, fault injection into the simulator and clearing.
// usage: node scripts/case-study-flow.js [--check]
//   --check: exit 1 if flows/case-study.json is not what the document gives.
'use strict';
const crypto = require('crypto');
const fs = require('fs');
const path = require('path');

const ROOT = path.resolve(__dirname, '..');
const PLANT_FILE = path.join(ROOT, 'flows', 'plant.json');
const OUT_FILE = path.join(ROOT, 'flows', 'case-study.json');

/** A stable 16-hex node id per name in namespace `ns`, so regenerating changes only what changed. */
const idsIn = (ns) => (name) => crypto.createHash('sha1').update(`${ns}:${name}`).digest('hex').slice(0, 16);
const nid = idsIn('case-study');

/** What the case study's flows say and do beyond what the plant document gives (`build`'s options). */
const CASE_STUDY = {
  ns: 'case-study',
  tabs: {
    plant: ['Sugar shack', 'The case-study plant: field bus, interlock, routines. Built from flows/plant.json by scripts/case-study-flow.js.'],
    ops: ['Operations (manual)', 'Start any of the 16 operations by hand. An operation already running (for example under its routine) refuses a second start (C1).'],
    faults: ['Faults and clearing', 'Inject faults into the simulator, watch the line lock out, clear it; hold and restart a running operation.'],
  },
  faults: [
    ['stuck V101 (YEL)', { fault: 'stuck', actuator: 'V101' }],
    ['stuck V501 (RED)', { fault: 'stuck', actuator: 'V501' }],
    ['station-3 dead (sensors stale)', { fault: 'dead', device: 'station-3' }],
    ['clear simulator faults', { fault: 'clear' }],
  ],
  opsComment: 'Start an operation by hand (priority and lines as in Fig. 8)',
  // The truck routine runs op 10 at start-up: the walkthrough runs it again by hand once its line is cleared.
  faultOp: '10',
  busTopics: null,
};

/**
 * The flows of `plant`: `options` as CASE_STUDY (ids in `ns`, tab labels and
 * infos, the title over the manual operations, the simulator faults offered, the operation run by hand on the faults
 * tab, the field bus's mqtt in topics: null for the case study's ESPHome ones).
 */
function build(plant, options = CASE_STUDY) {
  const nid = idsIn(options.ns);
  const nodes = [];
  const TABS = { plant: nid('tab:plant'), ops: nid('tab:operations'), faults: nid('tab:faults') };
  const add = (node) => {
    nodes.push(node);
    return node;
  };
  const comment = (z, name, info, x, y) => add({ id: nid(`comment:${z}:${name}`), type: 'comment', z, name, info, x, y, wires: [] });
  // `field`: the one msg property to show (a readable line), else the whole msg.
  const debug = (z, key, name, x, y, active = false, field = null) => add({
    id: nid(`debug:${key}`), type: 'debug', z, name, active, tosidebar: true, console: false, tostatus: false,
    complete: field || 'true', targetType: field ? 'msg' : 'full', statusVal: '', statusType: 'auto', x, y, wires: [],
  });
  const inject = (z, key, name, props, x, y, wire) => add({
    id: nid(`inject:${key}`), type: 'inject', z, name, props: [{ p: 'payload' }, { p: 'topic', vt: 'str' }, ...(props.extra || [])],
    repeat: '', crontab: '', once: false, onceDelay: 0.1, topic: props.topic || '', payload: props.payload ?? '',
    payloadType: props.payloadType || 'str', x, y, wires: [[wire]],
  });

  for (const key of ['plant', 'ops', 'faults']) {
    const [label, info] = options.tabs[key];
    nodes.push({ id: TABS[key], type: 'tab', label, disabled: false, info });
  }

  const broker = add({
    id: nid('broker'), type: 'mqtt-broker', name: 'plant broker', broker: '127.0.0.1', port: '1883', clientid: '',
    autoConnect: true, usetls: false, protocolVersion: '4', keepalive: '15', cleansession: true, autoUnsubscribe: true,
    birthTopic: '', closeTopic: '', willTopic: '',
  });
  // `$schema` points a file's editor at the schema from where the file lies; the node's copy lies nowhere.
  const document = { ...plant };
  delete document.$schema;
  const plantNode = add({ id: nid('plant'), type: 'sugarshack-plant', name: plant.name || 'sugar shack', plant: document });
  const interlock = add({
    id: nid('interlock'), type: 'sugarshack-interlock', name: 'lines', plant: plantNode.id, resources: [],
    policy: 'greedy', queueBound: 1024, warnQueued: 900, warnHeld: 1800, persist: true,
  });

  // ---- field bus -------------------------------------------------------------
  const z = TABS.plant;
  const esphome = plant.devices.some((d) => d.profile === 'esphome');
  comment(z, 'Field bus: every device topic into the actuators node, its commands out', options.busTopics
    ? 'Each device\'s topics (under its prefix, the device id unless the plant document gives one) into the actuators node, which reads them by the device\'s profile in the plant document, tracks every actuator and keeps the live sensor values for conditions; its first output carries the device commands to *mqtt out*.'
    : esphome
      ? 'ESPHome devices (stock MQTT): valves publish `<dev>/valve/<id>/position/state`, pumps `<dev>/switch/<id>/state`, stations `<dev>/sensor/<name>/state`, on change, without a timestamp; availability on `<dev>/status`. The actuators node reads them by the plant document\'s device profiles, tracks every actuator and keeps the live sensor values for conditions.'
      : 'Panels publish `<dev>/state` batches, stations `<dev>/sensor/<name>/state`; both carry the device timestamp. The actuators node tracks every actuator and keeps the live sensor values for conditions.', 230, 40);
  const bus = add({ id: nid('actuators'), type: 'sugarshack-actuators', z, name: 'all devices', plant: plantNode.id, devices: '', broker: nid('broker'), x: 520, y: 120, wires: [[nid('mqtt-out')], [], [nid('debug:actuator-events')]] });
  const topics = options.busTopics
    || (esphome ? ['+/status', '+/valve/+/position/state', '+/switch/+/state', '+/sensor/+/state'] : ['+/state', '+/status', '+/sensor/+/state']);
  topics.forEach((topic, i) => add({
    id: nid(`mqtt-in:${topic}`), type: 'mqtt in', z, name: '', topic, qos: '1', datatype: 'auto-detect', broker: broker.id,
    nl: false, rap: true, rh: 0, inputs: 0, x: 170, y: 80 + 40 * i, wires: [[bus.id]],
  }));
  add({ id: nid('mqtt-out'), type: 'mqtt out', z, name: 'device commands', topic: '', qos: '', retain: '', respTopic: '', contentType: '', userProps: '', correl: '', expiry: '', broker: broker.id, x: 800, y: 80, wires: [] });
  debug(z, 'actuator-events', 'actuator events', 800, 160);

  // ---- interlock events, out to MQTT for dashboards and the measurements -----
  comment(z, 'Interlock: grants, queueing, faults and clears', 'Every interlock event, also published on sugarshack/events/interlock for outside tools.', 230, 220);
  add({ id: nid('interlock-events'), type: 'sugarshack-interlock-events', z, name: '', interlock: interlock.id, x: 180, y: 260, wires: [[nid('debug:interlock-events'), nid('events-out')]] });
  debug(z, 'interlock-events', 'interlock events', 480, 240, true, 'summary');
  add({ id: nid('events-out'), type: 'mqtt out', z, name: 'sugarshack/events/interlock', topic: 'sugarshack/events/interlock', qos: '0', retain: 'false', respTopic: '', contentType: '', userProps: '', correl: '', expiry: '', broker: broker.id, x: 530, y: 280, wires: [] });

  // ---- routines ---------------------------------------------------------------
  let y = 360;
  comment(z, 'Routines: each runs its own operations, one at a time', 'Status shows `state › operation`. A msg trigger is sent by its inject; `reset` brings a routine back to its initial state after a fault is cleared.', 230, y - 40);
  for (const r of plant.routines || []) {
    const routine = add({ id: nid(`routine:${r.id}`), type: 'sugarshack-routine', z, name: '', interlock: interlock.id, routine: r.id, x: 520, y, wires: [[nid(`debug:routine:${r.id}`)]] });
    debug(z, `routine:${r.id}`, `routine ${r.id}`, 780, y, true);
    const topics = [...new Set(r.transitions.filter((t) => t.trigger.msg).map((t) => t.trigger.msg)), 'reset'];
    topics.forEach((topic, i) => inject(z, `routine:${r.id}:${topic}`, `${r.id}: ${topic}`, { topic }, 220, y + i * 40 - ((topics.length - 1) * 20), routine.id));
    y += Math.max(80, topics.length * 40 + 20);
  }
  add({ id: nid('catch'), type: 'catch', z, name: 'faults and refusals', scope: null, uncaught: false, x: 180, y: y + 20, wires: [[nid('debug:faults')]] });
  debug(z, 'faults', 'faults and refusals', 480, y + 20, true, 'error.message');

  // ---- manual operations ------------------------------------------------------
  const o = TABS.ops;
  comment(o, options.opsComment, '', 250, 40);
  (plant.operations || []).forEach((op, i) => {
    const oy = 100 + i * 50;
    const node = add({ id: nid(`operation:${op.id}`), type: 'sugarshack-operation', z: o, name: '', interlock: interlock.id, operation: op.id, x: 520, y: oy, wires: [[nid('debug:manual-ops')]] });
    inject(o, `operation:${op.id}`, `${op.id} ${op.description || ''} (${op.resources.join('+')})`.trim(), { topic: `manual ${op.id}` }, 230, oy, node.id);
  });
  debug(o, 'manual-ops', 'completed', 780, 100, true);
  add({ id: nid('catch:ops'), type: 'catch', z: o, name: '', scope: null, uncaught: false, x: 560, y: 160, wires: [[nid('debug:ops-faults')]] });
  debug(o, 'ops-faults', 'faults and refusals', 790, 160, true, 'error.message');

  // ---- faults and clearing ----------------------------------------------------
  const f = TABS.faults;
  comment(f, '1. Inject a fault into the simulator', 'The simulator listens on sim/control (scripts/simulator/README.md). A stuck valve makes the next command to it fail: the operation faults, its lines lock out, the other lines go on.', 230, 40);
  const sim = add({ id: nid('sim-control'), type: 'mqtt out', z: f, name: 'sim/control', topic: 'sim/control', qos: '1', retain: 'false', respTopic: '', contentType: '', userProps: '', correl: '', expiry: '', broker: broker.id, x: 560, y: 140, wires: [] });
  options.faults.forEach(([name, payload], i) => inject(f, `fault:${name}`, name, { payload: JSON.stringify(payload), payloadType: 'json' }, 250, 100 + i * 40, sim.id));
  // The operation that moves the first stuck valve, to run now rather than wait for its routine to.
  const faultOp = (plant.operations || []).find((op) => op.id === options.faultOp);
  if (faultOp) {
    const valve = options.faults[0][1].actuator;
    const id = nid(`fault-op:${faultOp.id}`);
    add({ id, type: 'sugarshack-operation', z: f, name: `op ${faultOp.id} (moves ${valve})`, interlock: interlock.id, operation: faultOp.id, x: 560, y: 320, wires: [[nid('debug:fault-op')]] });
    inject(f, `fault-op:${faultOp.id}`, `run op ${faultOp.id} now`, {}, 250, 320, id);
    // An operator's hold and restart of its run (ISA-88): what the hold does is the document's `hold`.
    for (const [i, command] of ['hold', 'restart'].entries()) {
      inject(f, `fault-op:${faultOp.id}:${command}`, `${command} op ${faultOp.id}`, { topic: command }, 250, 360 + i * 40, id);
    }
    debug(f, 'fault-op', `op ${faultOp.id} done`, 780, 320, true, 'payload');
    // Its fault (the point of running it) shows here, not as an uncaught error in the log.
    add({ id: nid('catch:faults'), type: 'catch', z: f, name: '', scope: null, uncaught: false, x: 560, y: 360, wires: [[nid('debug:fault-op-faults')]] });
    debug(f, 'fault-op-faults', 'faults and refusals', 790, 360, true, 'error.message');
  }
  add({ id: nid('sim-result'), type: 'mqtt in', z: f, name: '', topic: 'sim/control/result', qos: '1', datatype: 'auto-detect', broker: broker.id, nl: false, rap: true, rh: 0, inputs: 0, x: 210, y: 280, wires: [[nid('debug:sim-result')]] });
  debug(f, 'sim-result', 'simulator replies', 480, 280, true);

  comment(f, '2. Clear a line once the cause is fixed (manual intervention), then reset its routine', '', 300, 460);
  const clear = add({ id: nid('clear'), type: 'sugarshack-clear', z: f, name: '', interlock: interlock.id, mode: 'resources', resources: '', x: 520, y: 540, wires: [[nid('debug:cleared')]] });
  (plant.resources || []).forEach((r, i) => inject(f, `clear:${r.id}`, `clear ${r.id}`,
    { topic: 'clear', extra: [{ p: 'resources', v: r.id, vt: 'str' }] }, 220, 520 + i * 40, clear.id));
  debug(f, 'cleared', 'cleared', 760, 540, true);
  return nodes;
}

function main() {
  const plant = JSON.parse(fs.readFileSync(PLANT_FILE, 'utf8'));
  const text = `${JSON.stringify(build(plant), null, 2)}\n`;
  if (process.argv.includes('--check')) {
    const current = fs.existsSync(OUT_FILE) ? fs.readFileSync(OUT_FILE, 'utf8') : '';
    if (current !== text) {
      console.error('flows/case-study.json is out of date with flows/plant.json: run node scripts/case-study-flow.js');
      process.exit(1);
    }
    console.log('flows/case-study.json matches flows/plant.json');
    return;
  }
  fs.writeFileSync(OUT_FILE, text);
  console.log(`case-study-flow: ${OUT_FILE} (${text.length} bytes)`);
}

if (require.main === module) main();

module.exports = { build, nid, idsIn, CASE_STUDY };
