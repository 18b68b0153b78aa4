'use strict';
// The OPC UA server (node-red-contrib-sugarshack-opcua) against an independent
// client, Python's asyncua, in a real Node-RED process running the case-study
// plant (flows/case-study.json) on the simulator over a real Mosquitto, with
// adminAuth: ana may write, viewer may only read. Two servers serve the plant's
// interlock: one as a SCADA would reach it (Basic256Sha256 Sign and
// SignAndEncrypt only, anonymous off, the test client's certificate trusted by
// hand), one on loopback for trying it (None allowed, anonymous may read).
// Nothing waits on a fixed sleep: every wait polls for its condition with a bound.
//
// Run: npx mocha --timeout 30000 --exit tests/integration/opcua.spec.js
const assert = require('node:assert/strict');
const fs = require('fs');
const path = require('path');
const bcrypt = require(require.resolve('bcryptjs', { paths: [require.resolve('@node-red/editor-api')] }));
const { NodeRedProcess, waitFor } = require('./support/node-red');
const { startMosquitto, freePort } = require('./support/mosquitto');
const { startUaClient } = require('./support/opcua');
const { startSimulator } = require('../../scripts/simulator');
const { settingsFile } = require('../../scripts/lib/node-red-process');

const ROOT = path.resolve(__dirname, '..', '..');
const OPCUA_PACKAGE = path.join(ROOT, 'node-red-contrib-sugarshack-opcua');
const PASSWORD = 'maple-syrup-2026';
const NS_URI = 'https://github.com/sugarshack/sugarshack/UA/';
const TAB = '0pc0a0000000f001';
const SECURE = '0pc0a00000000101';
const TRYOUT = '0pc0a00000000102';
const PROBE_IL = '0pc0a00000000201';

/** The case-study flows on `mqttPort`, two OPC UA servers on the plant's interlock, and a probe of grant times. */
function flows(mqttPort, securePort, tryoutPort) {
  const caseStudy = JSON.parse(fs.readFileSync(path.join(ROOT, 'flows', 'case-study.json'), 'utf8'))
    .map((n) => (n.type === 'mqtt-broker' ? { ...n, port: String(mqttPort) } : n));
  const interlock = caseStudy.find((n) => n.type === 'sugarshack-interlock').id;
  const server = (id, name, port, extra) => ({
    id, type: 'sugarshack-opcua-server', z: TAB, name, interlock, host: '127.0.0.1', port,
    none: false, sign: true, encrypt: true, anonymous: false, trustClients: false, maxSessions: 20, actuatorLimit: 5000, conditionLimit: 500, ...extra,
  });
  return [
    ...caseStudy,
    { id: TAB, type: 'tab', label: 'OPC UA' },
    server(SECURE, 'scada', securePort, {}),
    server(TRYOUT, 'try it', tryoutPort, { none: true, anonymous: true, maxSessions: 40 }),
    // The interlock's grant time, asked over HTTP: acquire a line of a second interlock, release it, answer.
    { id: PROBE_IL, type: 'sugarshack-interlock', name: 'probe', resources: [{ name: 'PROBE' }], policy: 'greedy', queueBound: '1024', warnQueued: '', warnHeld: '', persist: false },
    { id: '0pc0a00000000202', type: 'http in', z: TAB, url: '/probe', method: 'post', wires: [['0pc0a00000000203']] },
    { id: '0pc0a00000000203', type: 'sugarshack-acquire', z: TAB, interlock: PROBE_IL, operation: 'probe', priority: '1', resources: 'PROBE', timeout: 0, wires: [['0pc0a00000000204']] },
    { id: '0pc0a00000000204', type: 'sugarshack-release', z: TAB, interlock: PROBE_IL, operation: 'probe', wires: [['0pc0a00000000205']] },
    { id: '0pc0a00000000205', type: 'http response', z: TAB, statusCode: '200', wires: [] },
  ];
}

describe('the OPC UA server, with an independent client (asyncua), on the case-study plant', function () {
  this.timeout(120000);
  let broker; let sim; let red; let ua; let ns;
  let urls;
  let token;
  let clientCert;

  before(async function () {
    broker = await startMosquitto();
    sim = await startSimulator({ broker: broker.url, plant: path.join(ROOT, 'flows', 'plant.json'), seed: 7, reconnectMs: 200, log: () => {} });
    const [securePort, tryoutPort] = [await freePort(), await freePort()];
    urls = { secure: `opc.tcp://127.0.0.1:${securePort}`, tryout: `opc.tcp://127.0.0.1:${tryoutPort}` };
    red = new NodeRedProcess({ flows: flows(new URL(broker.url).port, securePort, tryoutPort), tag: 'opcua' });
    fs.symlinkSync(OPCUA_PACKAGE, path.join(red.dir, 'node_modules', 'node-red-contrib-sugarshack-opcua'), 'dir');
    const hash = bcrypt.hashSync(PASSWORD, 8);
    fs.writeFileSync(path.join(red.dir, 'settings.js'), settingsFile(red.dir, { context: 'localfilesystem', extra: `
  mqttReconnectTime: 300,
  adminAuth: { type: 'credentials', users: [
    { username: 'ana', password: ${JSON.stringify(hash)}, permissions: '*' },
    { username: 'viewer', password: ${JSON.stringify(hash)}, permissions: 'read' },
  ] },` }));
    ua = await startUaClient();
    // The test client's certificate, trusted by hand as an administrator would (pki/trusted/certs).
    clientCert = await ua.ask('cert', { dir: red.dir });
    const trusted = path.join(red.dir, 'sugarshack-opcua', 'pki', 'trusted', 'certs');
    fs.mkdirSync(trusted, { recursive: true });
    fs.copyFileSync(clientCert.cert, path.join(trusted, 'sugarshack-tests.der'));
    await red.start();
    token = await tokenOf('ana');
    try {
      await waitFor(() => (red.log().match(/OPC UA server on/g) || []).length >= 2, 'both OPC UA servers listening', 60000);
    } catch (err) {
      throw new Error(`${err.message}:\n${red.log().slice(-4000)}`);
    }
    await ua.ask('connect', { name: 'ana', url: urls.tryout, user: 'ana', password: PASSWORD });
    ns = await ua.ask('namespace', { name: 'ana', uri: NS_URI });
  });

  after(async function () {
    if (ua) await ua.stop();
    if (red) await red.finish(this.currentTest);
    if (sim) await sim.stop();
    if (broker) await broker.stop();
  });

  const id = (p) => `ns=${ns};s=${p}`;
  async function tokenOf(username) {
    const res = await fetch(`http://127.0.0.1:${red.port}/auth/token`, {
      method: 'POST', headers: { 'Content-Type': 'application/json' },
      body: JSON.stringify({ client_id: 'node-red-admin', grant_type: 'password', scope: '', username, password: PASSWORD }),
    });
    assert.equal(res.status, 200, `sign-in of ${username}`);
    return (await res.json()).access_token;
  }
  async function state() {
    const res = await fetch(`http://127.0.0.1:${red.port}/sugarshack/state`, { headers: { Authorization: `Bearer ${token}` } });
    assert.equal(res.status, 200);
    return res.json();
  }
  const readOne = async (nodeId, name = 'ana') => (await ua.ask('read', { name, nodeIds: [nodeId] }))[0];

  it('browses the plant: lines, queue, operations, routines, devices, actuators, sensors, alarms, methods', async function () {
    const nodes = await ua.ask('browse', { name: 'ana' });
    const paths = new Set(nodes.map((n) => n.path));
    for (const p of ['Plant', 'Plant/Lines/YEL/State', 'Plant/Lines/RED/ClearBlockers', 'Plant/Queue/Length', 'Plant/Operations/10/State',
      'Plant/Routines/truck/State', 'Plant/Devices/ctrl-1/Online', 'Plant/Devices/ctrl-1/Positions', 'Plant/Actuators/V101/Position',
      'Plant/Sensors/LT-3', 'Plant/Alarms/Count', 'Plant/EStop', 'Plant/Clear']) {
      assert.ok(paths.has(p), `${p} is in the address space (${nodes.length} nodes browsed)`);
    }
    const plant = JSON.parse(fs.readFileSync(path.join(ROOT, 'flows', 'plant.json'), 'utf8'));
    const actuators = nodes.filter((n) => /^Plant\/Actuators\/[^/]+$/.test(n.path));
    assert.equal(actuators.length, plant.actuators.length, 'an object per actuator');
    const sensor = nodes.find((n) => n.path === 'Plant/Sensors/LT-3');
    assert.equal(sensor.type, 'i=2368', 'a sensor is an AnalogItemType');
  });
});
