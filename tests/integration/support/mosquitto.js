'use strict';
// A private Mosquitto per test suite: its own config on a free loopback port,
// never the system service. restart() keeps the port, so clients configured
// with the URL reconnect to the new process (broker-restart tests).
//
//   const broker = await startMosquitto();   // { port, url, stop(), restart() }
const { spawn, execFileSync } = require('child_process');
const fs = require('fs');
const net = require('net');
const os = require('os');
const path = require('path');

function findMosquitto() {
  if (process.env.MOSQUITTO_BIN) return process.env.MOSQUITTO_BIN;
  if (fs.existsSync('/usr/sbin/mosquitto')) return '/usr/sbin/mosquitto';
  try {
    return execFileSync('sh', ['-c', 'command -v mosquitto'], { encoding: 'utf8' }).trim() || null;
  } catch {
    return null;
  }
}

function freePort() {
  return new Promise((resolve, reject) => {
    const srv = net.createServer();
    srv.unref();
    srv.on('error', reject);
    srv.listen(0, '127.0.0.1', () => {
      const { port } = srv.address();
      srv.close(() => resolve(port));
    });
  });
}

function canConnect(port) {
  return new Promise((resolve) => {
    const sock = net.connect({ port, host: '127.0.0.1' });
    sock.once('connect', () => {
      sock.destroy();
      resolve(true);
    });
    sock.once('error', () => resolve(false));
  });
}

const running = new Set();
// A test run that dies must not leave brokers behind.
process.on('exit', () => {
  for (const child of running) child.kill('SIGKILL');
});

// `config(port, dir)` gives a config of one's own (its listener on `port`, files under `dir`);
// `prepare(dir)` runs before the first start; `onLine(line, atMs)` sees each log line as it arrives.
async function startMosquitto({ port, timeoutMs = 5000, config, prepare, onLine } = {}) {
  const bin = findMosquitto();
  if (!bin) throw new Error('mosquitto not found (bash scripts/setup.sh installs it; or set MOSQUITTO_BIN)');
  port = port || (await freePort());
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'sugarshack-mosquitto-'));
  const conf = path.join(dir, 'mosquitto.conf');
  if (prepare) prepare(dir);
  fs.writeFileSync(conf, config ? config(port, dir) : [
    `listener ${port} 127.0.0.1`,
    'allow_anonymous true',
    'persistence false',
    'log_dest stderr',
    'log_type error',
    'log_type warning',
    'log_type notice',
    'log_type information', // "running" is at this level
    '',
  ].join('\n'));

  let child = null;
  let output = '';

  async function launch() {
    output = '';
    const proc = spawn(bin, ['-c', conf], { stdio: ['ignore', 'pipe', 'pipe'] });
    child = proc;
    running.add(proc);
    let partial = '';
    const take = (d) => {
      output += d;
      if (!onLine) return;
      const at = Date.now();
      const lines = (partial + d).split('\n');
      partial = lines.pop();
      for (const line of lines) onLine(line, at);
    };
    proc.stdout.on('data', take);
    proc.stderr.on('data', take);
    let exited = null;
    proc.once('exit', (code, signal) => {
      exited = { code, signal };
      running.delete(proc);
    });
    proc.once('error', (err) => {
      exited = { code: err.message };
      running.delete(proc);
    });
    const deadline = Date.now() + timeoutMs;
    while (Date.now() < deadline) {
      if (exited) throw new Error(`mosquitto exited (${exited.code ?? exited.signal}) on port ${port}: ${output.trim()}`);
      // "running" is logged once its listeners are open: a port that accepts
      // before that belongs to someone else.
      if (/mosquitto version \S+ running/.test(output) && (await canConnect(port)) && !exited) return;
      await new Promise((r) => setTimeout(r, 50));
    }
    proc.kill('SIGKILL');
    throw new Error(`mosquitto did not accept connections on port ${port} within ${timeoutMs} ms: ${output.trim()}`);
  }

  async function stop() {
    const proc = child;
    child = null;
    if (!proc || proc.exitCode !== null || proc.signalCode !== null) return;
    await new Promise((resolve) => {
      const force = setTimeout(() => proc.kill('SIGKILL'), 2000);
      proc.once('exit', () => {
        clearTimeout(force);
        resolve();
      });
      proc.kill('SIGTERM');
    });
  }

  try {
    await launch();
  } catch (err) {
    fs.rmSync(dir, { recursive: true, force: true });
    throw err;
  }
  return {
    port,
    url: `mqtt://127.0.0.1:${port}`,
    get output() { return output; },
    get pid() { return child && child.pid; },
    stop: async () => {
      await stop();
      fs.rmSync(dir, { recursive: true, force: true });
    },
    // Same port and config; retained messages are gone (persistence false).
    restart: async ({ downMs = 0 } = {}) => {
      await stop();
      if (downMs) await new Promise((r) => setTimeout(r, downMs));
      await launch();
    },
  };
}

module.exports = { startMosquitto, findMosquitto, freePort };
