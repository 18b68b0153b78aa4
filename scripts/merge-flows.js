#!/usr/bin/env node
// usage: node merge-flows.js [--broker mqtt://host:port] <out.json> <flow.json>...
// Concatenates Node-RED flow exports into one flow file. Nodes whose id was
// already seen are dropped (with a warning); nodes whose tab (`z`) is not in
// any input get a generated tab so the merged file deploys as is. With
// --broker, every mqtt-broker node on the default local broker
// (localhost or 127.0.0.1, port 1883) is pointed at that one instead.
'use strict';
const fs = require('fs');
const path = require('path');

const LOCAL = new Set(['localhost', '127.0.0.1']);

/** `flow` with its mqtt-broker nodes on the default local broker pointed at `url` (unchanged when null). */
function pointBrokersAt(flow, url) {
  if (!url) return flow;
  const { hostname, port } = new URL(url);
  return flow.map((n) => (n.type === 'mqtt-broker' && LOCAL.has(n.broker) && String(n.port || '1883') === '1883'
    ? { ...n, broker: hostname, port: port || '1883' }
    : n));
}

/** The nodes of `files` in order, each id once, with a tab for every `z` no file defines. */
function merge(files) {
  const merged = [];
  const seen = new Set();
  for (const file of files) {
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
  return [...tabs, ...merged];
}

function main() {
  const args = process.argv.slice(2);
  let broker = null;
  if (args[0] === '--broker') {
    broker = args[1];
    args.splice(0, 2);
  }
  const [out, ...inputs] = args;
  if (!out || inputs.length === 0) {
    console.error('usage: merge-flows.js [--broker mqtt://host:port] <out.json> <flow.json>...');
    process.exit(2);
  }
  const flow = pointBrokersAt(merge(inputs), broker);
  fs.writeFileSync(out, `${JSON.stringify(flow, null, 4)}\n`);
  console.log(`merge-flows: ${flow.length} nodes from ${inputs.length} file(s) -> ${out}`);
}

if (require.main === module) main();

module.exports = { merge, pointBrokersAt };
