#!/usr/bin/env node
// Checks a plant document as a deploy would (the core's checks, the same as the
// plant node's check button and POST /sugarshack/plant/validate): every problem
// and warning with its path. Exits 1 when the document would be refused.
// usage: node scripts/check-plant.js <plant.json>   (npm start -- --plant <file> --check)
'use strict';
const fs = require('fs');
const path = require('path');
const { validatePlant } = require('../node-red-contrib-sugarshack/lib/plant/plant');

function report(file) {
  const name = path.basename(file);
  let text;
  try {
    text = fs.readFileSync(file, 'utf8');
  } catch (err) {
    return { ok: false, lines: [`check: cannot read ${file}: ${err.code === 'ENOENT' ? 'no such file' : err.message}`] };
  }
  const { valid, errors, warnings } = validatePlant(text);
  const item = (p) => `  ${p.path ? `${p.path}: ` : ''}${p.message}`;
  const lines = [];
  if (valid) {
    const plant = JSON.parse(text);
    const count = (list, one) => `${(list || []).length} ${one}${(list || []).length === 1 ? '' : 's'}`;
    lines.push(`check: ${name} is valid: ${count(plant.devices, 'device')}, ${count(plant.actuators, 'actuator')}, ${count(plant.sensors, 'sensor')}, ${count(plant.resources, 'line')}, ${count(plant.operations, 'operation')}, ${count(plant.routines, 'routine')}`);
  } else {
    lines.push(`check: ${name} would be refused at deploy, ${errors.length} problem${errors.length === 1 ? '' : 's'}:`, ...errors.map(item));
  }
  if (warnings.length) lines.push(`check: ${warnings.length} warning${warnings.length === 1 ? '' : 's'}:`, ...warnings.map(item));
  return { ok: valid, lines };
}

function main() {
  const file = process.argv[2];
  if (!file) {
    console.error('usage: check-plant.js <plant.json>');
    process.exit(2);
  }
  const { ok, lines } = report(file);
  (ok ? console.log : console.error)(lines.join('\n'));
  process.exit(ok ? 0 : 1);
}

if (require.main === module) main();

module.exports = { report };
