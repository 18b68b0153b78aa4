#!/usr/bin/env node
// usage: node merge-flows.js <out.json> <flow.json>...
// Concatenates Node-RED flow exports into one flow file. Nodes whose id was
// already seen are dropped (with a warning); nodes whose tab (`z`) is not in
// any input get a generated tab so the merged file deploys as is.
'use strict';
const fs = require('fs');
const path = require('path');

const [out, ...inputs] = process.argv.slice(2);
if (!out || inputs.length === 0) {
  console.error('usage: merge-flows.js <out.json> <flow.json>...');
  process.exit(2);
}
const merged = [];
const seen = new Set();
for (const file of inputs) {
  const data = JSON.parse(fs.readFileSync(file, 'utf8'));
  for (const node of Array.isArray(data) ? data : data.flows || []) {
    if (seen.has(node.id)) {
      console.warn(`merge-flows: ${path.basename(file)}: duplicate id ${node.id} (${node.type}) skipped`);
      continue;
    }
    seen.add(node.id);
    merged.push(node);
  }
}
const containers = new Set(merged.filter((n) => n.type === 'tab' || n.type === 'subflow').map((n) => n.id));
const missing = [...new Set(merged.map((n) => n.z).filter((z) => z && !containers.has(z)))];
const tabs = missing.map((id, i) => ({ id, type: 'tab', label: `Flow ${i + 1}`, disabled: false, info: '' }));
fs.writeFileSync(out, `${JSON.stringify([...tabs, ...merged], null, 4)}\n`);
console.log(`merge-flows: ${merged.length + tabs.length} nodes from ${inputs.length} file(s) -> ${out}`);
