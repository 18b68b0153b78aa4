'use strict';
// An independent OPC UA client for the tests: Python's asyncua in its own
// process (opcua_client.py), asked over stdin/stdout. `scripts/setup.sh`
// installs asyncua; without it the suite fails saying so.
//
//   const ua = await startUaClient();
//   await ua.ask('connect', { name: 'ana', url, user: 'ana', password });
//   const nodes = await ua.ask('browse', { name: 'ana' });
//   await ua.stop();
//
// startOpcuaPlant() runs the case-study plant with two OPC UA servers for a
// suite (or a benchmark): Mosquitto, the simulator, Node-RED with adminAuth
// (ana may write, viewer may only read) and the OPC UA package, and this client.
const fs = require('fs');
const path = require('path');
const { spawn, execFileSync } = require('child_process');
const { NodeRedProcess, waitFor } = require('./node-red');
const { startMosquitto, freePort } = require('./mosquitto');
const { startSimulator } = require('../../../scripts/simulator');
const { settingsFile } = require('../../../scripts/lib/node-red-process');

const PYTHON = process.env.PYTHON || 'python3';
const ROOT = path.resolve(__dirname, '..', '..', '..');
const OPCUA_PACKAGE = path.join(ROOT, 'node-red-contrib-sugarshack-opcua');
const PASSWORD = 'maple-syrup-2026';
const NS_URI = 'https://github.com/sugarshack/sugarshack/UA/';
const TAB = '0pc0a0000000f001';
const PROBE_IL = '0pc0a00000000201';

function asyncuaMissing() {
  try {
    execFileSync(PYTHON, ['-c', 'import asyncua'], { stdio: 'ignore' });
    return null;
  } catch {
    return `Python's asyncua is not installed (bash scripts/setup.sh installs it: ${PYTHON} -m pip install asyncua)`;
  }
}

function startUaClient() {
  const missing = asyncuaMissing();
  if (missing) return Promise.reject(new Error(missing));
  const child = spawn(PYTHON, [path.join(__dirname, 'opcua_client.py')], { stdio: ['pipe', 'pipe', 'pipe'] });
  const waiting = new Map();
  let nextId = 1;
  let buffer = '';
  let stderr = '';
  let ready;
  const started = new Promise((resolve, reject) => {
    ready = resolve;
    child.once('exit', (code) => reject(new Error(`the asyncua client exited (${code}): ${stderr.slice(-2000)}`)));
  });
  child.stderr.on('data', (d) => { stderr = (stderr + d).slice(-20000); });
  // It died: what it was asked fails with its last words (the exit handler), not the test process.
  child.stdin.on('error', () => {});
  child.stdout.on('data', (d) => {
    buffer += d;
    let nl;
    while ((nl = buffer.indexOf('\n')) >= 0) {
      const line = buffer.slice(0, nl);
      buffer = buffer.slice(nl + 1);
      let answer;
      try {
        answer = JSON.parse(line);
      } catch {
        stderr += `\nnot JSON from the client: ${line.slice(0, 300)}`;
        continue;
      }
      if (answer.ready) {
        ready();
        continue;
      }
      const w = waiting.get(answer.id);
      waiting.delete(answer.id);
      if (!w) continue;
      if (answer.error) w.reject(Object.assign(new Error(`${w.op}: ${answer.error}`), { status: answer.status }));
      else w.resolve(answer.result);
    }
  });
  child.on('exit', (code) => {
    for (const w of waiting.values()) w.reject(new Error(`the asyncua client exited (${code}) during ${w.op}: ${stderr.slice(-2000)}`));
    waiting.clear();
  });
  const client = {
    /** One request (see opcua_client.py); rejects with the client's error (and `status`, its OPC UA status name). */
    ask(op, args = {}) {
      const id = nextId++;
      return new Promise((resolve, reject) => {
        waiting.set(id, { resolve, reject, op });
        child.stdin.write(`${JSON.stringify({ id, op, args })}\n`);
      });
    },
    stderr: () => stderr,
    async stop() {
      if (child.exitCode !== null) return;
      const exited = new Promise((resolve) => child.once('exit', resolve));
      child.stdin.end();
      const force = setTimeout(() => child.kill('SIGKILL'), 5000);
      await exited;
      clearTimeout(force);
    },
  };
  return started.then(() => client);
}


/**
 * The case-study flows on `mqttPort`, two OPC UA servers on the plant's
 * interlock (`secure`: Basic256Sha256 only, anonymous off, as a SCADA reaches
 * it; `tryout`: on loopback with None and anonymous reading, for trying it),
 * and POST /probe, which acquires and releases a line of a second interlock:
 * the interlock's grant time as seen from outside.
 */
function opcuaFlows(mqttPort, securePort, tryoutPort, { plantFlows = null, servers = ['secure', 'tryout'] } = {}) {
  const base = (plantFlows || JSON.parse(fs.readFileSync(path.join(ROOT, 'flows', 'case-study.json'), 'utf8')))
    .map((n) => (n.type === 'mqtt-broker' ? { ...n, port: String(mqttPort) } : n));
  const interlock = base.find((n) => n.type === 'sugarshack-interlock').id;
  const server = (id, name, port, extra) => ({
    id, type: 'sugarshack-opcua-server', z: TAB, name, interlock, host: '127.0.0.1', port,
    none: false, sign: true, encrypt: true, anonymous: false, trustClients: false, maxSessions: 20, actuatorLimit: 5000, conditionLimit: 500, ...extra,
  });
  return [
    ...base,
    { id: TAB, type: 'tab', label: 'OPC UA' },
    ...(servers.includes('secure') ? [server('0pc0a00000000101', 'scada', securePort, {})] : []),
    ...(servers.includes('tryout') ? [server('0pc0a00000000102', 'try it', tryoutPort, { none: true, anonymous: true, maxSessions: 40 })] : []),
    { id: PROBE_IL, type: 'sugarshack-interlock', name: 'probe', resources: [{ name: 'PROBE' }], policy: 'greedy', queueBound: '1024', warnQueued: '', warnHeld: '', persist: false },
    { id: '0pc0a00000000202', type: 'http in', z: TAB, url: '/probe', method: 'post', wires: [['0pc0a00000000203']] },
    { id: '0pc0a00000000203', type: 'sugarshack-acquire', z: TAB, interlock: PROBE_IL, operation: 'probe', priority: '1', resources: 'PROBE', timeout: 0, wires: [['0pc0a00000000204']] },
    { id: '0pc0a00000000204', type: 'sugarshack-release', z: TAB, interlock: PROBE_IL, operation: 'probe', wires: [['0pc0a00000000205']] },
    { id: '0pc0a00000000205', type: 'http response', z: TAB, statusCode: '200', wires: [] },
  ];
}

/**
 * Mosquitto, the simulator on the case-study plant (`speed` times the wall
 * clock; none when `simPlant` is null), Node-RED with adminAuth and the OPC
 * UA package (unless not `installed`) on opcuaFlows() (`servers`: which of
 * the two; `preamble`: code for the top of settings.js), and
 * the asyncua client with a certificate trusted by hand (pki/trusted/certs),
 * as an administrator trusts a SCADA's. Resolves once both servers listen.
 */
async function startOpcuaPlant({
  tag = 'opcua', speed = 4, plantFlows = null, simPlant = path.join(ROOT, 'flows', 'plant.json'), servers = ['secure', 'tryout'], installed = true, preamble = '',
  startTimeoutMs = 90000,
} = {}) {
  const broker = await startMosquitto();
  const sim = simPlant ? await startSimulator({ broker: broker.url, plant: simPlant, seed: 7, reconnectMs: 200, speed, log: () => {} }) : null;
  const [securePort, tryoutPort] = [await freePort(), await freePort()];
  const urls = { secure: `opc.tcp://127.0.0.1:${securePort}`, tryout: `opc.tcp://127.0.0.1:${tryoutPort}` };
  const red = new NodeRedProcess({ flows: opcuaFlows(new URL(broker.url).port, securePort, tryoutPort, { plantFlows, servers }), tag });
  if (installed) fs.symlinkSync(OPCUA_PACKAGE, path.join(red.dir, 'node_modules', 'node-red-contrib-sugarshack-opcua'), 'dir');
  // Node-RED's own bcrypt, as its `node-red admin hash-pw` uses.
  const bcrypt = require(require.resolve('bcryptjs', { paths: [require.resolve('@node-red/editor-api')] }));
  const hash = bcrypt.hashSync(PASSWORD, 8);
  fs.writeFileSync(path.join(red.dir, 'settings.js'), preamble + settingsFile(red.dir, { context: 'localfilesystem', extra: `
  mqttReconnectTime: 300,
  adminAuth: { type: 'credentials', users: [
    { username: 'ana', password: ${JSON.stringify(hash)}, permissions: '*' },
    { username: 'viewer', password: ${JSON.stringify(hash)}, permissions: 'read' },
  ] },` }));
  const ua = await startUaClient();
  const clientCert = await ua.ask('cert', { dir: red.dir });
  const trusted = path.join(red.dir, 'sugarshack-opcua', 'pki', 'trusted', 'certs');
  fs.mkdirSync(trusted, { recursive: true });
  fs.copyFileSync(clientCert.cert, path.join(trusted, 'sugarshack-tests.der'));
  const stop = async (test) => {
    await ua.stop();
    await red.finish(test);
    if (sim) await sim.stop();
    await broker.stop();
  };
  try {
    await red.start({ timeoutMs: startTimeoutMs });
    await waitFor(() => (red.log().match(/OPC UA server on/g) || []).length >= servers.length, 'the OPC UA servers listening', startTimeoutMs);
  } catch (err) {
    const log = red.log().slice(-4000);
    await stop();
    throw new Error(`${err.message}:\n${log}`);
  }
  return { broker, sim, red, ua, urls, clientCert, stop };
}

module.exports = { startUaClient, asyncuaMissing, startOpcuaPlant, opcuaFlows, PASSWORD, NS_URI, ROOT };
