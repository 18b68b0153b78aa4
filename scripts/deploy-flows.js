#!/usr/bin/env node
// Writes the Node-RED flows of the container recipe (deploy/node-red/flows.json
// and flows_cred.json) from flows/case-study.json: the same plant, its broker
// and a journal to the database, every address and secret a `${ENV}` reference
// that Node-RED fills in from the container's environment when it starts; and
// QuestDB's statements for the journal's tables (deploy/questdb/schema.sql)
// from the journal's schema (lib/journal/schema.js).
// usage: node scripts/deploy-flows.js [--check]
//   --check: exit 1 if the committed files are not what their sources give.
'use strict';
const crypto = require('crypto');
const fs = require('fs');
const path = require('path');

const ROOT = path.resolve(__dirname, '..');
const SOURCE = path.join(ROOT, 'flows', 'case-study.json');
const OUT = {
  flows: path.join(ROOT, 'deploy', 'node-red', 'flows.json'),
  credentials: path.join(ROOT, 'deploy', 'node-red', 'flows_cred.json'),
  schema: path.join(ROOT, 'deploy', 'questdb', 'schema.sql'),
};

/** deploy/questdb/schema.sql: one statement per line, as deploy/questdb/schema.sh reads them. */
function schemaSql() {
  const { questdbStatements } = require('../node-red-contrib-sugarshack/lib/journal/schema');
  return `-- Written by scripts/deploy-flows.js from lib/journal/schema.js; run by schema.sh, one statement per line.\n${questdbStatements().join('\n')}\n`;
}

const nid = (name) => crypto.createHash('sha1').update(`deploy:${name}`).digest('hex').slice(0, 16);

/** Node-RED replaces a property whose whole value is `${NAME}` (credentials too). */
const env = (name) => `\${${name}}`;

function build(caseStudy) {
  const flows = caseStudy.map((n) => ({ ...n }));
  const credentials = {};
  for (const broker of flows.filter((n) => n.type === 'mqtt-broker')) {
    Object.assign(broker, { broker: env('MQTT_HOST'), port: env('MQTT_PORT') });
    credentials[broker.id] = { user: env('MQTT_USER'), password: env('MQTT_PASSWORD') };
  }
  const tab = nid('tab:journal');
  const journal = nid('journal');
  flows.push(
    { id: tab, type: 'tab', label: 'Journal', disabled: false, info: 'Every datapoint, event, operator action and timing figure to the database (QuestDB over HTTP line protocol), tagged with this plant\'s id. Set by the container\'s environment: SUGARSHACK_PLANT_ID, SUGARSHACK_DB_*.' },
    {
      id: journal, type: 'sugarshack-journal', z: tab, name: 'journal → database', target: 'http',
      plantId: env('SUGARSHACK_PLANT_ID'), host: env('SUGARSHACK_DB_HOST'), port: env('SUGARSHACK_DB_PORT'),
      tls: env('SUGARSHACK_DB_TLS'), bufferMB: env('SUGARSHACK_JOURNAL_BUFFER_MB'), flushS: 1, dir: '', filesMB: 512,
      x: 420, y: 100, wires: [[nid('debug:journal')]],
    },
    {
      id: nid('inject:note'), type: 'inject', z: tab, name: 'operator note', props: [{ p: 'payload' }, { p: 'who', v: 'operator', vt: 'str' }, { p: 'why', v: 'start of shift', vt: 'str' }, { p: 'topic', vt: 'str' }],
      repeat: '', crontab: '', once: false, onceDelay: 0.1, topic: 'plant', payload: '', payloadType: 'str', x: 180, y: 100, wires: [[journal]],
    },
    {
      id: nid('debug:journal'), type: 'debug', z: tab, name: 'journal metrics', active: false, tosidebar: true, console: false, tostatus: false,
      complete: 'journal', targetType: 'msg', statusVal: '', statusType: 'auto', x: 660, y: 100, wires: [],
    },
  );
  credentials[journal] = { username: env('SUGARSHACK_DB_USER'), password: env('SUGARSHACK_DB_PASSWORD'), token: env('SUGARSHACK_DB_TOKEN') };
  return { flows, credentials };
}

function main() {
  const built = build(JSON.parse(fs.readFileSync(SOURCE, 'utf8')));
  const texts = { flows: `${JSON.stringify(built.flows, null, 2)}\n`, credentials: `${JSON.stringify(built.credentials, null, 2)}\n`, schema: schemaSql() };
  if (process.argv.includes('--check')) {
    const stale = Object.keys(OUT).filter((k) => !fs.existsSync(OUT[k]) || fs.readFileSync(OUT[k], 'utf8') !== texts[k]);
    if (stale.length) {
      console.error(`${stale.map((k) => path.relative(ROOT, OUT[k])).join(', ')} out of date with flows/case-study.json or the journal's schema: run node scripts/deploy-flows.js`);
      process.exit(1);
    }
    console.log('deploy/node-red flows match flows/case-study.json, deploy/questdb/schema.sql the journal\'s schema');
    return;
  }
  for (const k of Object.keys(OUT)) fs.writeFileSync(OUT[k], texts[k]);
  console.log(`deploy-flows: ${built.flows.length} nodes -> ${path.relative(ROOT, OUT.flows)}, credentials -> ${path.relative(ROOT, OUT.credentials)}, tables -> ${path.relative(ROOT, OUT.schema)}`);
}

if (require.main === module) main();

module.exports = { build, schemaSql, OUT };
