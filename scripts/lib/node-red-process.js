'use strict';
// A throwaway Node-RED process for benchmarks and measurements: an aedes
// broker on a free port, and Node-RED in its own process and temporary user
// directory (optionally with this palette linked in), stopped and removed by
// `cleanup()`, also on SIGINT/SIGTERM.
const fs = require('fs');
const net = require('net');
const os = require('os');
const path = require('path');
const { spawn } = require('child_process');
const { Aedes } = require('aedes');

const ROOT = path.resolve(__dirname, '..', '..');
const PALETTE = path.join(ROOT, 'node-red-contrib-sugarshack');
const RED_JS = path.join(ROOT, 'node_modules', 'node-red', 'red.js');

const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

function freePort() {
  return new Promise((resolve, reject) => {
    const s = net.createServer();
    s.on('error', reject);
    s.listen(0, '127.0.0.1', () => {
      const { port } = s.address();
      s.close(() => resolve(port));
    });
  });
}

/** settings.js for a throwaway user dir; `context`: the default context store's module. */
function settingsFile(dir, { context = 'memory', extra = '' } = {}) {
  return `module.exports = {
  uiHost: '127.0.0.1',
  userDir: ${JSON.stringify(dir)},
  flowFile: 'flows.json',
  credentialSecret: false,
  contextStorage: { default: { module: '${context}' } },${extra}
  logging: { console: { level: 'info', metrics: false, audit: false } },
  telemetry: { enabled: false, updateNotification: false },
  diagnostics: { enabled: false, ui: false },
  externalModules: { autoInstall: false, palette: { allowInstall: false } },
  editorTheme: { projects: { enabled: false }, tours: false },
};
`;
}

class Session {
  constructor(tag) {
    this.tag = tag;
    this.broker = null;
    this.server = null;
    this.red = null;
    this.sim = null;
    this.dirs = [];
    this.cleaning = null;
    process.on('exit', () => {
      if (this.red && this.red.exitCode === null) this.red.kill('SIGKILL');
    });
    for (const signal of ['SIGINT', 'SIGTERM']) {
      process.on(signal, () => {
        console.error(`${tag}: ${signal}, stopping`);
        this.cleanup().finally(() => process.exit(130));
      });
    }
  }

  /** An aedes broker on a free 127.0.0.1 port; `onPublish(packet, client)` sees every publish. */
  async startBroker(onPublish) {
    const broker = await Aedes.createBroker();
    const server = net.createServer(broker.handle);
    await new Promise((resolve, reject) => {
      server.once('error', reject);
      server.listen(0, '127.0.0.1', resolve);
    });
    this.broker = broker;
    this.server = server;
    if (onPublish) broker.on('publish', onPublish);
    return server.address().port;
  }

  /** Starts Node-RED on `flow`; resolves once its flows run and its MQTT client is connected. */
  async startRed(label, flow, { withPalette = true } = {}) {
    const dir = fs.mkdtempSync(path.join(os.tmpdir(), `sugarshack-${this.tag}-${label}-`));
    this.dirs.push(dir);
    fs.writeFileSync(path.join(dir, 'settings.js'), settingsFile(dir));
    fs.writeFileSync(path.join(dir, 'flows.json'), JSON.stringify(flow, null, 2));
    if (withPalette) {
      fs.mkdirSync(path.join(dir, 'node_modules'));
      fs.symlinkSync(PALETTE, path.join(dir, 'node_modules', 'node-red-contrib-sugarshack'), 'dir');
    }
    const port = await freePort();
    const logFile = path.join(dir, 'node-red.log');
    const out = fs.openSync(logFile, 'a');
    const red = spawn(process.execPath, [RED_JS, '-u', dir, '-p', String(port), '-s', path.join(dir, 'settings.js'), '--no-telemetry'], {
      cwd: dir, stdio: ['ignore', out, out],
    });
    fs.closeSync(out);
    this.red = red;
    const text = () => fs.readFileSync(logFile, 'utf8');
    const deadline = Date.now() + 60000;
    for (;;) {
      const t = text();
      if (t.includes('Started flows') && t.includes('Connected to broker')) break;
      if (red.exitCode !== null || red.signalCode !== null) throw new Error(`Node-RED (${label}) exited during start-up:\n${t.slice(-3000)}`);
      if (Date.now() > deadline) throw new Error(`Node-RED (${label}) not started with a connected broker after 60 s:\n${t.slice(-3000)}`);
      await sleep(200);
    }
    return { red, dir, logFile, text, url: `http://127.0.0.1:${port}` };
  }

  async stopRed() {
    const { red } = this;
    if (!red || red.exitCode !== null || red.signalCode !== null) return;
    const exited = new Promise((resolve) => red.once('exit', resolve));
    red.kill('SIGTERM');
    const killer = setTimeout(() => red.kill('SIGKILL'), 10000);
    await exited;
    clearTimeout(killer);
    this.red = null;
  }

  cleanup() {
    if (this.cleaning) return this.cleaning;
    this.cleaning = (async () => {
      await this.stopRed().catch(() => {});
      if (this.sim) await Promise.race([this.sim.stop().catch(() => {}), sleep(5000)]);
      if (this.server) this.server.close();
      if (this.broker) await new Promise((resolve) => this.broker.close(resolve));
      for (const dir of this.dirs) fs.rmSync(dir, { recursive: true, force: true });
    })();
    return this.cleaning;
  }
}

module.exports = { Session, settingsFile, freePort, sleep, ROOT, PALETTE };
