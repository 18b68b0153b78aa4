#!/usr/bin/env node
// usage: node scripts/profile-flows.js <flows.json> <plant.json> <profile>
// Gives the plant node that holds the plant document of <plant.json> (found by
// its document's name) that document with every device speaking <profile>,
// as the simulator's --profile makes its devices speak it (withProfile), so
// `PROFILE=modbus npm start` runs the case-study flows over Modbus.
'use strict';
const fs = require('fs');
const { loadPlant, withProfile } = require('./simulator/plant');

const [flowsFile, plantFile, profile] = process.argv.slice(2);
if (!flowsFile || !plantFile || !profile) {
  console.error('usage: profile-flows.js <flows.json> <plant.json> <profile>');
  process.exit(2);
}
const plant = loadPlant(plantFile);
const flows = JSON.parse(fs.readFileSync(flowsFile, 'utf8'));
const nodes = flows.filter((n) => n.type === 'sugarshack-plant' && n.plant && n.plant.name === plant.name);
for (const node of nodes) node.plant = withProfile(plant, profile);
fs.writeFileSync(flowsFile, `${JSON.stringify(flows, null, 4)}\n`);
console.log(`profile-flows: ${nodes.length} plant node(s) of '${plant.name}' speak ${profile}`);
