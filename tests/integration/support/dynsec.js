'use strict';
// A private Mosquitto with its dynamic-security plugin (Debian's
// mosquitto_dynamic_security.so): no anonymous clients, an admin account that
// may disable and enable the others at run time, one account per name given,
// every topic open to them, and `log_type all`, so each PUBLISH the broker
// receives is logged with the client id that sent it (`onPublish`).
//
//   const broker = await startDynsecMosquitto({ accounts: ['nr-a', 'nr-b', 'sim'], onPublish });
//   broker.urlOf('sim')   // mqtt://sim:<password>@127.0.0.1:<port>
const fs = require('fs');
const path = require('path');
const { execFileSync } = require('child_process');
const mqtt = require('mqtt');
const { startMosquitto } = require('./mosquitto');

const PLUGIN = process.env.MOSQUITTO_DYNSEC || '/usr/lib/x86_64-linux-gnu/mosquitto_dynamic_security.so';
const ADMIN = { username: 'admin', password: 'admin-secret' };
const PUBLISH = /Received PUBLISH from (\S+) \(d\d, q\d, r\d, m\d+, '([^']*)'/;

async function control(url, commands) {
  const client = await mqtt.connectAsync(url, { username: ADMIN.username, password: ADMIN.password, reconnectPeriod: 0 });
  try {
    const answered = new Promise((resolve) => client.once('message', (topic, payload) => resolve(JSON.parse(String(payload)))));
    await client.subscribeAsync('$CONTROL/dynamic-security/v1/response');
    await client.publishAsync('$CONTROL/dynamic-security/v1', JSON.stringify({ commands }));
    const answer = await answered;
    const failed = answer.responses.filter((r) => r.error);
    if (failed.length) throw new Error(`dynamic security refused: ${JSON.stringify(failed)}`);
  } finally {
    await client.endAsync(true);
  }
}

async function startDynsecMosquitto({ accounts, onPublish = () => {} }) {
  if (!fs.existsSync(PLUGIN)) throw new Error(`${PLUGIN} not found (Debian's mosquitto package ships it; or set MOSQUITTO_DYNSEC)`);
  const broker = await startMosquitto({
    prepare: (dir) => {
      const file = path.join(dir, 'dynsec.json');
      execFileSync('mosquitto_ctrl', ['dynsec', 'init', file, ADMIN.username, ADMIN.password], { stdio: 'ignore' });
      // Started as root, Mosquitto runs as its own user, and the plugin rewrites its file on every change.
      fs.chmodSync(dir, 0o777);
      fs.chmodSync(file, 0o666);
    },
    config: (port, dir) => [
      `listener ${port} 127.0.0.1`,
      'allow_anonymous false',
      `plugin ${PLUGIN}`,
      `plugin_opt_config_file ${path.join(dir, 'dynsec.json')}`,
      'persistence false',
      'log_dest stderr',
      'log_type all',
      '',
    ].join('\n'),
    onLine: (line, at) => {
      const m = PUBLISH.exec(line);
      if (m) onPublish({ client: m[1], topic: m[2], at });
    },
  });
  const password = (name) => `${name}-secret`;
  const adminUrl = `mqtt://127.0.0.1:${broker.port}`;
  await control(adminUrl, [
    ...['publishClientSend', 'publishClientReceive', 'subscribe', 'unsubscribe'].map((acltype) => ({ command: 'setDefaultACLAccess', acls: [{ acltype, allow: true }] })),
    ...accounts.map((username) => ({ command: 'createClient', username, password: password(username) })),
  ]);
  return {
    ...broker,
    admin: ADMIN,
    account: (name) => ({ username: name, password: password(name) }),
    urlOf: (name) => `mqtt://${name}:${password(name)}@127.0.0.1:${broker.port}`,
    control: (commands) => control(adminUrl, commands),
  };
}

module.exports = { startDynsecMosquitto };
