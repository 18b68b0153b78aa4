#!/usr/bin/env node
// The palette's examples that drive devices run on a plant of their own, the
// example rig (flows/example-rig.json): the case study's truck and silo lines,
// YEL and RED, on devices of their own (ESPHome under the topic prefix `rig/`),
// which npm start's simulator plays beside the case study. Not the case
// study's own plant: its routines keep all five lines busy, so an example's
// operation there would queue for minutes or be refused (its routine runs it),
// and an example's group command would move valves an operation holds.
//
// The rig's config nodes (plant, interlock, broker) are in every such example,
// the same, ids included, also where the example does not use them all: the
// first example imported brings them with their ids, and any imported after it
// reuses them (the editor's "Import copy" keeps a config node whose id exists
// and gives a new id to one that does not), so however many are imported, in
// whatever order, one interlock guards the rig's valves. This script writes
// them into each example from the one document.
// usage: node scripts/example-rig.js [--check]
//   --check: exit 1 if an example's rig nodes are not what the document gives.
'use strict';
const crypto = require('crypto');
const fs = require('fs');
const path = require('path');

const ROOT = path.resolve(__dirname, '..');
const RIG_FILE = path.join(ROOT, 'flows', 'example-rig.json');
const EXAMPLES = path.join(ROOT, 'node-red-contrib-sugarshack', 'examples');
const FILES = ['actuators-group-command', 'operation-subflow', 'operations-and-routines', 'subflows-op12', 'subflows-routine']
  .map((name) => path.join(EXAMPLES, `${name}.json`));
/** Where the rig's simulator takes faults (not under `rig/`, which the examples' field bus reads). */
const CONTROL_TOPIC = 'sim/rig/control';

const nid = (name) => crypto.createHash('sha1').update(`example-rig:${name}`).digest('hex').slice(0, 16);
const IDS = { plant: nid('plant'), interlock: nid('interlock'), broker: nid('broker') };

/** The rig's config nodes, by the property that names them. */
function configNodes(rig) {
  return {
    plant: { id: IDS.plant, type: 'sugarshack-plant', name: 'example rig (YEL, RED)', plant: rig },
    interlock: {
      id: IDS.interlock, type: 'sugarshack-interlock', name: 'example rig lines', plant: IDS.plant, resources: [],
      policy: 'greedy', queueBound: '1024', warnQueued: '120', warnHeld: '600', persist: true,
    },
    broker: {
      id: IDS.broker, type: 'mqtt-broker', name: 'local broker', broker: 'localhost', port: '1883', clientid: '',
      autoConnect: true, usetls: false, protocolVersion: '4', keepalive: '60', cleansession: true, autoUnsubscribe: true,
      birthTopic: '', closeTopic: '', willTopic: '', userProps: '', sessionExpiry: '',
    },
  };
}

/** The example with the rig's config nodes first, in place of what it had. */
function withRig(flow, rig) {
  const configs = configNodes(rig);
  return [configs.plant, configs.interlock, configs.broker, ...flow.filter((n) => !Object.values(IDS).includes(n.id))];
}

const readJson = (file) => JSON.parse(fs.readFileSync(file, 'utf8'));
const text = (flow) => `${JSON.stringify(flow, null, 2)}\n`;

function main() {
  const rig = readJson(RIG_FILE);
  const check = process.argv.includes('--check');
  let stale = 0;
  for (const file of FILES) {
    const current = fs.readFileSync(file, 'utf8');
    const want = text(withRig(JSON.parse(current), rig));
    if (current === want) continue;
    const name = path.relative(ROOT, file);
    if (check) {
      console.error(`example-rig: ${name} does not carry the rig of flows/example-rig.json: run node scripts/example-rig.js`);
      stale++;
    } else {
      fs.writeFileSync(file, want);
      console.log(`example-rig: wrote ${name}`);
    }
  }
  process.exit(stale ? 1 : 0);
}

if (require.main === module) main();

module.exports = { IDS, FILES, RIG_FILE, CONTROL_TOPIC, configNodes, withRig };
