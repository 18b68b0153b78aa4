'use strict';
// A real Node-RED process for tests that must treat it as a plant would: kill
// it with SIGKILL mid-run (a power cut), restart it on the same user directory,
// feed it hostile MQTT msgs and check it is still alive. The palette is linked
// into the user directory; the context store is `localfilesystem` with Node-RED's
// default cache, as users have it.
//
//   const red = new NodeRedProcess({ flows });
//   await red.start();          // resolves once the flows run and MQTT is connected
//   await red.kill();           // SIGKILL
//   await red.start();          // same user directory
//   const state = await red.get('/sugarshack/state');
//   await red.stop(); red.remove();
const fs = require('fs');
const http = require('http');
const os = require('os');
const path = require('path');
const { spawn } = require('child_process');
const { freePort } = require('./mosquitto');
const { settingsFile } = require('../../../scripts/lib/node-red-process');

const ROOT = path.resolve(__dirname, '..', '..', '..');
const PALETTE = path.join(ROOT, 'node-red-contrib-sugarshack');
const RED_JS = path.join(ROOT, 'node_modules', 'node-red', 'red.js');

const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

const running = new Set();
process.on('exit', () => {
  for (const child of running) child.kill('SIGKILL');
});

// What npm start and most users have: on disk, with the store's default cache.
const settingsOf = (dir, extra = '') => settingsFile(dir, { context: 'localfilesystem', extra: `\n  mqttReconnectTime: 300,${extra}` });

/** An mqtt-broker config node for a flow, on a local broker's port. */
function mqttBroker(id, port) {
  return {
    id, type: 'mqtt-broker', name: 'mosquitto', broker: '127.0.0.1', port: String(port), clientid: '',
    autoConnect: true, usetls: false, protocolVersion: '4', keepalive: '5', cleansession: true, autoUnsubscribe: true,
  };
}

class NodeRedProcess {
  /** `settings`: more of settings.js (text inside its object); `env`: the process's environment on top of this one's. */
  constructor({ flows, tag = 'red', settings = '', env = {} }) {
    this.dir = fs.mkdtempSync(path.join(os.tmpdir(), `sugarshack-${tag}-`));
    this.logFile = path.join(this.dir, 'node-red.log');
    this.env = env;
    fs.writeFileSync(path.join(this.dir, 'settings.js'), settingsOf(this.dir, settings));
    fs.writeFileSync(path.join(this.dir, 'flows.json'), JSON.stringify(flows, null, 2));
    fs.mkdirSync(path.join(this.dir, 'node_modules'));
    fs.symlinkSync(PALETTE, path.join(this.dir, 'node_modules', 'node-red-contrib-sugarshack'), 'dir');
    this.child = null;
    this.port = null;
    this.starts = 0;
  }

  log() {
    return fs.existsSync(this.logFile) ? fs.readFileSync(this.logFile, 'utf8') : '';
  }

  /** The log written since the last start. */
  logOfThisRun() {
    return this.log().slice(this.logStart || 0);
  }

  get alive() {
    return Boolean(this.child && this.child.exitCode === null && this.child.signalCode === null);
  }

  /** Running and not stopped by SIGSTOP: it can answer. */
  get answering() {
    return this.alive && !this.paused;
  }

  /**
   * Starts Node-RED; resolves once its flows run (`started` is the log's line for it,
   * in the runtime's language) and its MQTT client is connected.
   */
  async start({ timeoutMs = 60000, waitForBroker = true, started = 'Started flows' } = {}) {
    this.port = this.port || await freePort();
    this.logStart = this.log().length;
    const out = fs.openSync(this.logFile, 'a');
    const child = spawn(process.execPath, [RED_JS, '-u', this.dir, '-p', String(this.port), '-s', path.join(this.dir, 'settings.js')], {
      cwd: this.dir, stdio: ['ignore', out, out], env: { ...process.env, ...this.env },
    });
    fs.closeSync(out);
    this.child = child;
    running.add(child);
    child.once('exit', () => running.delete(child));
    this.starts += 1;
    const deadline = Date.now() + timeoutMs;
    for (;;) {
      const text = this.logOfThisRun();
      if (text.includes(started) && (!waitForBroker || text.includes('Connected to broker'))) return;
      if (!this.alive) throw new Error(`Node-RED exited during start-up:\n${text.slice(-3000)}`);
      if (Date.now() > deadline) throw new Error(`Node-RED not started after ${timeoutMs} ms:\n${text.slice(-3000)}`);
      await sleep(50);
    }
  }

  /** SIGSTOP (a process paused, as by a long GC or a hung VM) or SIGCONT. */
  signal(name) {
    if (!this.alive) return;
    this.child.kill(name);
    this.paused = name === 'SIGSTOP';
  }

  /** A power cut: SIGKILL, no chance to save anything. */
  async kill() {
    const { child } = this;
    if (!this.alive) return;
    const exited = new Promise((resolve) => child.once('exit', resolve));
    child.kill('SIGKILL');
    await exited;
  }

  async stop() {
    const { child } = this;
    if (!this.alive) return;
    const exited = new Promise((resolve) => child.once('exit', resolve));
    child.kill('SIGTERM');
    const force = setTimeout(() => child.kill('SIGKILL'), 10000);
    await exited;
    clearTimeout(force);
  }

  remove() {
    fs.rmSync(this.dir, { recursive: true, force: true });
  }

  /** A suite's end: stopped, the tail of its log printed when `test` (the last one run) failed, its directory removed. */
  async finish(test) {
    await this.stop();
    if (test && test.state === 'failed') console.log(this.log().slice(-4000));
    this.remove();
  }

  /** GET on the admin API; resolves with the parsed JSON body. */
  get(urlPath) {
    return this.request('GET', urlPath);
  }

  /** A deploy as the editor's Deploy button makes it: POST /flows, type full, flows or nodes. */
  deploy(flows, type = 'full') {
    return this.request('POST', '/flows', flows, { 'Node-RED-Deployment-Type': type });
  }

  request(method, urlPath, body, headers = {}) {
    return adminRequest(this.port, method, urlPath, body, headers);
  }

  /** The interlock's lines as `GET /sugarshack/state` gives them: { name: 'free' | 'held:<op>' | 'faulted:<cause>' }. */
  async lines(interlockId) {
    const state = await this.get('/sugarshack/state');
    const il = state.interlocks.find((i) => i.id === interlockId);
    if (!il || !il.lines) throw new Error(`interlock ${interlockId} is not running: ${JSON.stringify(il)}`);
    return Object.fromEntries(il.lines.map((l) => [l.name, lineState(l.state)]));
  }
}

/** A request to Node-RED on `port`: resolves with the body (parsed when JSON), rejects on a status outside 2xx. */
function adminRequest(port, method, urlPath, body, headers = {}) {
  const text = body === undefined ? null : JSON.stringify(body);
  return new Promise((resolve, reject) => {
    const req = http.request({
      host: '127.0.0.1',
      port,
      path: urlPath,
      method,
      timeout: 10000,
      headers: text === null ? headers : { ...headers, 'Content-Type': 'application/json', 'Content-Length': Buffer.byteLength(text) },
    }, (res) => {
      let answer = '';
      res.on('data', (d) => { answer += d; });
      res.on('end', () => {
        if (res.statusCode < 200 || res.statusCode > 299) reject(new Error(`${method} ${urlPath}: ${res.statusCode} ${answer.slice(0, 200)}`));
        else resolve(answer && /json/.test(res.headers['content-type'] || '') ? JSON.parse(answer) : answer || null);
      });
    });
    req.on('error', reject);
    req.on('timeout', () => req.destroy(new Error(`${method} ${urlPath}: no answer in 10 s`)));
    if (text !== null) req.write(text);
    req.end();
  });
}

function lineState(s) {
  if (s.state === 'held') return `held:${s.operation}`;
  if (s.state === 'faulted') return `faulted:${s.cause}`;
  return s.state;
}

/** Polls `predicate` (sync or async) every 10 ms until it holds; throws naming `what` after `ms`. */
async function waitFor(predicate, what, ms = 8000) {
  const deadline = Date.now() + ms;
  while (!(await predicate())) {
    if (Date.now() > deadline) throw new Error(`timed out waiting for ${what}`);
    await sleep(10);
  }
}

/**
 * Like waitFor, for a long run on a machine of unknown speed: it fails only when
 * `progress()` stays the same for `stallMs` (slow is fine, stuck is not).
 */
async function waitWhileMoving(predicate, progress, what, stallMs = 15000) {
  let last = await progress();
  let deadline = Date.now() + stallMs;
  while (!(await predicate())) {
    const now = await progress();
    if (now !== last) [last, deadline] = [now, Date.now() + stallMs];
    if (Date.now() > deadline) throw new Error(`timed out waiting for ${what}: no progress for ${stallMs / 1000} s (at ${last})`);
    await sleep(10);
  }
}

module.exports = { NodeRedProcess, mqttBroker, adminRequest, lineState, sleep, waitFor, waitWhileMoving };
