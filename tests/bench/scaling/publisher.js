#!/usr/bin/env node
'use strict';
// A lean load generator in its own process: `panels` actuator panels of 17
// I/O (16 valves, 1 pump) each publishing one sugarshack batch
// (`<panel>/state`, {ts, valve, pump}) per second, spread evenly over the
// second in 10 ms slices. Batches, not one msg per entity: the cloud paper's
// panels publish batches, and at 95,000 I/O per-entity topics would make the
// publisher and broker the bottleneck, not Node-RED. Prints one JSON line per
// second on stdout: { sent } (msgs published so far).
//
// usage: node publisher.js <mqtt url> <panels>
const mqtt = require('mqtt');

const [url, panelsArg] = process.argv.slice(2);
const PANELS = Number(panelsArg);
if (!url || !(PANELS > 0)) {
  console.error('usage: node publisher.js <mqtt url> <panels>');
  process.exit(2);
}
const SLICE_MS = 10;
const SLICES = 1000 / SLICE_MS;
const client = mqtt.connect(url, { clientId: `scaling-pub-${process.pid}`, reconnectPeriod: 0 });
let sent = 0;
let slice = 0;
const position = (panel, io, t) => ((panel + io + t) % 20 === 0 ? 100 : 0);

client.on('connect', () => {
  const started = Date.now();
  setInterval(() => {
    const t = Math.floor((Date.now() - started) / 1000);
    const from = Math.floor((slice * PANELS) / SLICES);
    const to = Math.floor(((slice + 1) * PANELS) / SLICES);
    slice = (slice + 1) % SLICES;
    const ts = Date.now();
    for (let p = from; p < to; p++) {
      const valve = {};
      for (let io = 1; io <= 16; io++) valve[io] = position(p, io, t);
      client.publish(`ctrl-${p + 1}/state`, JSON.stringify({ ts, valve, pump: { 1: (p + t) % 2 === 0 } }), { qos: 0 });
      sent++;
    }
  }, SLICE_MS);
  setInterval(() => process.stdout.write(`${JSON.stringify({ sent })}\n`), 1000);
});
client.on('error', (err) => {
  console.error(`publisher: ${err.message}`);
  process.exit(1);
});
process.on('SIGTERM', () => client.end(true, () => process.exit(0)));
