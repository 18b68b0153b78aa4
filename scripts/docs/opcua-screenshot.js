#!/usr/bin/env node
'use strict';
// Makes docs/opcua-client.png, the screenshot in docs/how-to/opcua.md: the
// case-study plant on the simulator with an OPC UA server (the test's
// startOpcuaPlant), BLU stopped by EStop as ana, and FreeOpcUa's client GUI
// (a client none of us wrote) browsing it, drawn offscreen.
//
//   python3 -m pip install opcua-client      # the GUI, on asyncua and PyQt5
//   node scripts/docs/opcua-screenshot.js    # PYTHON=... for another interpreter
const fs = require('fs');
const os = require('os');
const path = require('path');
const { execFileSync } = require('child_process');
const { startOpcuaPlant, PASSWORD, NS_URI, ROOT } = require('../../tests/integration/support/opcua');

const OUT = path.join(ROOT, 'docs', 'opcua-client.png');

async function main() {
  const plant = await startOpcuaPlant({ tag: 'opcua-screenshot', servers: ['tryout'] });
  const config = fs.mkdtempSync(path.join(os.tmpdir(), 'sugarshack-uagui-'));
  try {
    const { ua, urls } = plant;
    await ua.ask('connect', { name: 'ana', url: urls.tryout, user: 'ana', password: PASSWORD });
    const ns = await ua.ask('namespace', { name: 'ana', uri: NS_URI });
    const lines = { type: 'StringArray', value: ['BLU'] };
    const answer = await ua.ask('call', { name: 'ana', objectId: `ns=${ns};s=Plant`, methodId: `ns=${ns};s=EStop`, args: [lines, { type: 'String', value: 'sap leak at the evaporator' }] });
    if (answer.status !== 'Good') throw new Error(`EStop: ${JSON.stringify(answer)}`);
    execFileSync(process.env.PYTHON || 'python3', [path.join(__dirname, 'opcua_screenshot.py'), urls.tryout, NS_URI, OUT], {
      stdio: ['ignore', 'ignore', 'inherit'], timeout: 120000, env: { ...process.env, XDG_CONFIG_HOME: config, QT_QPA_PLATFORM: 'offscreen' },
    });
    console.log(`opcua-screenshot: ${path.relative(ROOT, OUT)} (${fs.statSync(OUT).size} bytes)`);
  } finally {
    fs.rmSync(config, { recursive: true, force: true });
    await plant.stop();
  }
}

main().catch((err) => {
  console.error(`opcua-screenshot: ${err.stack || err}`);
  process.exit(1);
});
