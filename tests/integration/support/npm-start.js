'use strict';
// `npm start` as a user runs it (scripts/start.sh: setup, the embedded broker,
// the simulators, Node-RED with the palette), in a run directory of its own and
// on free ports, and what the editor sees of it: the admin API, the inject
// buttons, the debug sidebar and the node statuses (its /comms websocket).
//
//   const stack = await startNpmStart({ args: ['--plant', file] });
//   await stack.click(injectId);
//   await stack.stop();
const fs = require('fs');
const os = require('os');
const path = require('path');
const { spawn } = require('child_process');
const WebSocket = require('ws');
const { freePort } = require('./mosquitto');
const { adminRequest } = require('./node-red');

const ROOT = path.resolve(__dirname, '..', '..', '..');
const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

/** Polls `predicate` (sync or async) every 200 ms until it gives a truthy value; throws naming `what` after `ms`. */
async function until(predicate, what, ms) {
  const deadline = Date.now() + ms;
  for (;;) {
    const value = await predicate();
    if (value) return value;
    if (Date.now() > deadline) throw new Error(`${what} did not happen within ${ms / 1000} s`);
    await sleep(200);
  }
}

function groupAlive(pid) {
  try {
    process.kill(-pid, 0);
    return true;
  } catch {
    return false;
  }
}

class NpmStart {
  constructor({ args, cwd, env }) {
    this.args = args;
    this.cwd = cwd;
    this.env = env;
    this.output = '';
    this.child = null;
    this.debug = []; // { id, name, msg (text), format }
    this.status = new Map(); // node id -> its last status
    this.ws = null;
  }

  async start(timeoutMs) {
    this.runDir = fs.mkdtempSync(path.join(os.tmpdir(), 'sugarshack-npm-start-'));
    this.port = await freePort();
    this.mqttPort = await freePort();
    // As `npm start -- <args>` typed in `cwd` (npm runs the script from the package root, INIT_CWD the directory it was called from).
    this.child = spawn('npm', ['--prefix', ROOT, 'start', '--', ...this.args], {
      cwd: this.cwd,
      env: {
        ...process.env, ...this.env, PORT: String(this.port), MQTT_PORT: String(this.mqttPort), SUGARSHACK_RUN_DIR: this.runDir,
      },
      detached: true, // its own process group: stop() ends the broker and simulators with it
      stdio: ['ignore', 'pipe', 'pipe'],
    });
    const take = (d) => { this.output += d; };
    this.child.stdout.on('data', take);
    this.child.stderr.on('data', take);
    this.exited = new Promise((resolve) => this.child.once('exit', resolve));
    await until(() => {
      if (this.child.exitCode !== null) throw new Error(`npm start exited (${this.child.exitCode}):\n${this.output.slice(-3000)}`);
      return /Started flows/.test(this.output) && /Connected to broker/.test(this.output);
    }, 'npm start: flows started, broker connected', timeoutMs);
    await this.listen();
    return this;
  }

  /** The editor's websocket: debug msgs and node statuses. */
  listen() {
    return new Promise((resolve, reject) => {
      const ws = new WebSocket(`ws://127.0.0.1:${this.port}/comms`);
      ws.on('open', () => {
        ws.send(JSON.stringify({ subscribe: 'debug' }));
        ws.send(JSON.stringify({ subscribe: 'status/#' }));
        resolve();
      });
      ws.on('error', reject);
      ws.on('message', (data) => {
        let parsed;
        try {
          parsed = JSON.parse(String(data));
        } catch {
          return;
        }
        for (const { topic, data: d } of Array.isArray(parsed) ? parsed : [parsed]) {
          if (topic === 'debug') this.debug.push(d);
          else if (topic && topic.startsWith('status/')) this.status.set(topic.slice(7), d);
        }
      });
      this.ws = ws;
    });
  }

  /** The debug msgs of node `id` from the `from`th msg on, each its msg as the sidebar gets it (objects parsed). */
  debugOf(id, from = 0) {
    return this.debug.slice(from).filter((d) => d.id === id).map((d) => (d.format === 'Object' || /^array/.test(d.format || '') ? JSON.parse(d.msg) : d.msg));
  }

  request(method, urlPath, body, headers = {}) {
    return adminRequest(this.port, method, urlPath, body, headers);
  }

  state() {
    return this.request('GET', '/sugarshack/state');
  }

  flows() {
    return this.request('GET', '/flows', undefined, { Accept: 'application/json' });
  }

  /** The editor's Deploy button (full): resolves once the runtime says the flows started again. */
  async deploy(flows) {
    const mark = this.output.length;
    await this.request('POST', '/flows', flows, { 'Node-RED-Deployment-Type': 'full' });
    await until(() => /Started flows/.test(this.output.slice(mark)), 'the flows to start after the deploy', 30000);
  }

  /** An inject node's button. */
  click(id) {
    return this.request('POST', `/inject/${id}`);
  }

  /** Node-RED's log lines since `mark` (a length of `output`) that report an error. */
  errorsSince(mark) {
    return this.output.slice(mark).split('\n').filter((l) => /\[error\]/.test(l));
  }

  async stop() {
    if (this.ws) this.ws.terminate();
    if (this.child && this.child.exitCode === null) {
      try {
        process.kill(-this.child.pid, 'SIGTERM');
      } catch { /* already gone */ }
      const killer = setTimeout(() => {
        try {
          process.kill(-this.child.pid, 'SIGKILL');
        } catch { /* gone */ }
      }, 10000);
      await this.exited;
      // The group (broker, simulators, Node-RED) ends after npm itself.
      for (let i = 0; i < 100 && groupAlive(this.child.pid); i++) await sleep(100);
      clearTimeout(killer);
    }
    if (this.runDir) fs.rmSync(this.runDir, { recursive: true, force: true, maxRetries: 5, retryDelay: 200 });
  }
}

/** `npm start -- <args>` called from `cwd` (the repository by default), once its flows run. */
async function startNpmStart({ args = [], cwd = ROOT, env = {}, timeoutMs = 300000 } = {}) {
  const stack = new NpmStart({ args, cwd, env });
  try {
    return await stack.start(timeoutMs);
  } catch (err) {
    await stack.stop();
    throw err;
  }
}

module.exports = { startNpmStart, until, sleep, ROOT };
