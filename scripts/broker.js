#!/usr/bin/env node
'use strict';
// Embedded MQTT broker (aedes) for `npm start`: TCP on 127.0.0.1:${MQTT_PORT:-1883}.
// In-memory retained messages and sessions; a restart forgets them.
// env: MQTT_PORT (default 1883), MQTT_HOST (default 127.0.0.1), MQTT_QUIET=1 (no per-client lines)
const net = require('net');
const { Aedes } = require('aedes');

const port = Number(process.env.MQTT_PORT || 1883);
const host = process.env.MQTT_HOST || '127.0.0.1';
const quiet = process.env.MQTT_QUIET === '1';
const log = (msg) => console.log(`${new Date().toISOString().slice(11, 23)} broker: ${msg}`);

async function main() {
  const aedes = await Aedes.createBroker();
  const server = net.createServer(aedes.handle);

  if (!quiet) {
    aedes.on('client', (client) => log(`client connected: ${client.id}`));
    aedes.on('clientDisconnect', (client) => log(`client disconnected: ${client.id}`));
  }
  aedes.on('clientError', (client, err) => log(`client ${client && client.id} error: ${err.message}`));
  aedes.on('connectionError', (client, err) => log(`connection error: ${err.message}`));

  server.on('error', (err) => {
    console.error(`broker: cannot listen on ${host}:${port}: ${err.message}`);
    process.exit(1);
  });
  server.listen(port, host, () => log(`listening on mqtt://${host}:${port}`));

  const shutdown = () => {
    log('stopping');
    server.close();
    aedes.close(() => process.exit(0));
    setTimeout(() => process.exit(0), 2000).unref();
  };
  process.on('SIGINT', shutdown);
  process.on('SIGTERM', shutdown);
}

main().catch((err) => {
  console.error(`broker: ${err.message}`);
  process.exit(1);
});
