#!/usr/bin/env node
// Starter flows for a plant of your own (`npm start -- --plant my-plant.json`),
// made from its plant document as the case study's are from flows/plant.json:
// the field bus over MQTT, the interlock bound to the plant, a routine node per
// routine, a manual start per operation, simulator faults and clearing
// (scripts/case-study-flow.js), and the HMI at /dashboard (scripts/hmi-flow.js).
//
// usage: node scripts/starter-flows.js [--reset] [--broker URL] <plant.json> <flows.json>
//   Writes <flows.json> from the document when it does not exist (or --reset).
//   When it does, the flows are the user's: only their plant node follows the
//   document, when the document changed since the flows were made and the
//   plant node was not changed in the editor meanwhile; otherwise it says what
//   differs. --broker: the MQTT broker the flows use (default 127.0.0.1:1883).
'use strict';
const crypto = require('crypto');
const fs = require('fs');
const path = require('path');
const { isDeepStrictEqual } = require('util');
const { build, idsIn } = require('./case-study-flow');
const { hmi, HMI_INFO } = require('./hmi-flow');
const { pointBrokersAt } = require('./merge-flows');

const say = (text) => console.log(`start: ${text}`);

/** The mqtt in topics that carry every device's messages, by its profile (Tasmota: tele/ and stat/ before its topic). */
function deviceTopics(plant) {
  const topics = (plant.devices || []).flatMap((d) => {
    const prefix = d.prefix || d.id;
    if (d.profile === 'tasmota') return [`tele/${prefix}/#`, `stat/${prefix}/#`];
    if (d.profile === 'custom') return ['#'];
    return [`${prefix}/#`];
  });
  return topics.includes('#') ? ['#'] : [...new Set(topics)];
}

/** The simulator faults offered: the first valve of each line stuck, the first station dead, and clear. */
function faultsOf(plant) {
  const types = plant.actuatorTypes || {};
  const valves = (plant.actuators || []).filter((a) => (types[a.type] || {}).signal === 'analog');
  const lines = (plant.resources || []).map((r) => r.id);
  const stuck = lines.length
    ? lines.map((line) => [valves.find((v) => v.resource === line), line]).filter(([v]) => v)
    : valves.slice(0, 1).map((v) => [v, null]);
  const station = (plant.devices || []).find((d) => d.kind === 'sensor-station');
  return [
    ...stuck.map(([v, line]) => [`stuck ${v.id}${line ? ` (${line})` : ''}`, { fault: 'stuck', actuator: v.id }]),
    ...(station ? [[`${station.id} dead (sensors stale)`, { fault: 'dead', device: station.id }]] : []),
    ['clear simulator faults', { fault: 'clear' }],
  ];
}

/** The first operation whose steps command `actuator`. */
function operationMoving(plant, actuator) {
  const commands = (op) => (op.steps || []).some((s) => s.command && Object.values(s.command).some((group) => group && actuator in group));
  const op = (plant.operations || []).find(commands);
  return op ? op.id : null;
}

function optionsFor(plant, name) {
  const title = plant.name || name;
  const faults = faultsOf(plant);
  return {
    // Ids from the file's name, which names its run directory: they stay when the document changes.
    ns: `plant:${name}`,
    tabs: {
      plant: [title, `The plant ${title}: field bus, interlock, routines. Starter flows made from its plant document by npm start (scripts/starter-flows.js); yours to change.`],
      ops: ['Operations (manual)', 'Start any operation of the plant document by hand. An operation already running (for example under its routine) refuses a second start (C1).'],
      faults: ['Faults and clearing', 'Inject faults into the simulator, watch the line lock out, clear it.'],
    },
    opsComment: 'Start an operation by hand',
    faults,
    faultOp: faults[0][1].actuator ? operationMoving(plant, faults[0][1].actuator) : null,
    busTopics: deviceTopics(plant),
  };
}

/** The starter flows of `plant` (its file named `name`), on the broker at `brokerUrl`. */
function starterFlows(plant, name, brokerUrl = null) {
  const options = optionsFor(plant, name);
  const flows = build(plant, options);
  const nid = idsIn(options.ns);
  const prefix = crypto.createHash('sha1').update(`${options.ns}:hmi`).digest('hex').slice(0, 12);
  const dashboard = hmi({ prefix, interlock: nid('interlock'), plant: nid('plant'), tabLabel: 'HMI (dashboard)', info: HMI_INFO });
  return { flows: pointBrokersAt([...flows, ...dashboard], brokerUrl), plantId: nid('plant') };
}

const readJson = (file) => JSON.parse(fs.readFileSync(file, 'utf8'));
const write = (file, value) => fs.writeFileSync(file, `${JSON.stringify(value, null, 2)}\n`);

/**
 * Makes or keeps the flows of the plant in `plantFile` at `flowsFile`; the
 * document they were made from is kept beside them (`.plant-seeded.json`).
 */
function sync(plantFile, flowsFile, { reset = false, brokerUrl = null } = {}) {
  const plant = readJson(plantFile);
  const name = path.basename(plantFile, '.json');
  const seededFile = path.join(path.dirname(flowsFile), '.plant-seeded.json');
  const { flows, plantId } = starterFlows(plant, name, brokerUrl);
  if (reset || !fs.existsSync(flowsFile)) {
    write(flowsFile, flows);
    write(seededFile, plant);
    const count = (type) => flows.filter((n) => n.type === type).length;
    say(`flows: starter flows made from ${name}.json (${(plant.operations || []).length} operation(s), ${count('sugarshack-routine')} routine(s), the HMI) -> ${flowsFile}`);
    return;
  }
  const current = readJson(flowsFile);
  const node = current.find((n) => n.id === plantId);
  if (!node) {
    say(`flows: keeping ${flowsFile} (no plant node of its starter flows in it; the simulator plays ${name}.json)`);
    return;
  }
  const seeded = fs.existsSync(seededFile) ? readJson(seededFile) : null;
  if (isDeepStrictEqual(node.plant, plant)) {
    say(`flows: keeping ${flowsFile} (--reset-flows to make new ones from ${name}.json)`);
  } else if (seeded && isDeepStrictEqual(node.plant, seeded)) {
    node.plant = plant;
    write(flowsFile, current);
    write(seededFile, plant);
    say(`flows: ${name}.json changed since the flows were made: their plant node now holds it (new operations or routines get their nodes with --reset-flows)`);
  } else {
    say(`flows: the plant node in ${flowsFile} was changed in the editor and differs from ${name}.json: Node-RED runs the flows' copy, the simulator the file; --reset-flows makes new flows from the file`);
  }
}

function main() {
  const args = process.argv.slice(2);
  const options = { reset: false, brokerUrl: null };
  while (args[0] && args[0].startsWith('--')) {
    const flag = args.shift();
    if (flag === '--reset') options.reset = true;
    else if (flag === '--broker') options.brokerUrl = args.shift();
    else {
      console.error(`starter-flows: unknown option ${flag}`);
      process.exit(2);
    }
  }
  const [plantFile, flowsFile] = args;
  if (!plantFile || !flowsFile) {
    console.error('usage: starter-flows.js [--reset] [--broker URL] <plant.json> <flows.json>');
    process.exit(2);
  }
  sync(plantFile, flowsFile, options);
}

if (require.main === module) main();

module.exports = { starterFlows, sync, deviceTopics, faultsOf };
