'use strict';
// pymodbus's own server (PyPI `pymodbus`, installed by scripts/setup.sh) playing
// an I/O module with a valve and a pump on it: io_module.py beside this file.
// Its valve moves only as advance(ms) tells it, on the test's clock.
//
//   const io = await startIoModule({ units: [1, 2] });   // a free port, Modbus TCP
//   await io.advance(100); (await io.get(1)).holding[0]; io.kill(); await io.restart();
const { spawn, execFile, execFileSync } = require('child_process');
const path = require('path');
const readline = require('readline');
const { freePort } = require('../mosquitto');

const SCRIPT = path.join(__dirname, 'io_module.py');
const PYTHON = process.env.PYTHON || 'python3';

/** The pymodbus version on this machine, or null when it is missing. */
function pymodbusVersion() {
  try {
    return execFileSync(PYTHON, ['-c', 'import pymodbus; print(pymodbus.__version__)'], { encoding: 'utf8' }).trim();
  } catch {
    return null;
  }
}

class IoModule {
  constructor({ port, units, framing, serial }) {
    this.port = port;
    this.units = units;
    this.framing = framing;
    this.serial = serial;
    this.child = null;
    this.waiting = new Map();
    this.nextId = 1;
    this.stderr = '';
  }

  /** Starts the server; resolves once it listens (or its serial port is open). */
  start() {
    const args = [SCRIPT, '--port', String(this.port), '--units', this.units.join(','), '--framing', this.framing];
    if (this.serial) args.push('--serial', this.serial);
    const child = spawn(PYTHON, args, { stdio: ['pipe', 'pipe', 'pipe'] });
    this.child = child;
    child.stderr.on('data', (d) => { this.stderr = (this.stderr + d).slice(-4000); });
    const lines = readline.createInterface({ input: child.stdout });
    return new Promise((resolve, reject) => {
      const failed = (code) => reject(new Error(`io_module.py exited (${code}) before it was ready: ${this.stderr}`));
      child.once('exit', failed);
      lines.on('line', (line) => {
        const answer = JSON.parse(line);
        if (answer.ready) {
          child.off('exit', failed);
          resolve(this);
          return;
        }
        const waiter = this.waiting.get(answer.id);
        this.waiting.delete(answer.id);
        if (waiter) waiter(answer);
      });
    });
  }

  ask(request) {
    const id = this.nextId++;
    return new Promise((resolve, reject) => {
      if (!this.child || this.child.exitCode !== null || this.child.signalCode) {
        reject(new Error('io_module.py is not running'));
        return;
      }
      this.waiting.set(id, resolve);
      this.child.stdin.write(`${JSON.stringify({ ...request, id })}\n`);
    });
  }

  /** Moves its valves toward their commands by `ms` of travel (4 s closed to open). */
  advance(ms) {
    return this.ask({ cmd: 'advance', ms });
  }

  /** Unit `unit`'s valve stops following its command. */
  stick(unit) {
    return this.ask({ cmd: 'stick', unit });
  }

  /** Unit `unit` never answers again. */
  mute(unit) {
    return this.ask({ cmd: 'mute', unit });
  }

  /** `{ holding, input, coil, discrete, writes: [[fc, address, values]] }` of unit `unit`. */
  get(unit) {
    return this.ask({ cmd: 'get', unit });
  }

  /** SIGSTOP: its sockets stay open and the kernel takes the bytes, but nothing answers. */
  freeze() {
    this.frozen = true;
    this.child.kill('SIGSTOP');
  }

  thaw() {
    this.frozen = false;
    this.child.kill('SIGCONT');
  }

  /** Running and answering (not killed, not frozen). */
  get running() {
    return Boolean(this.child && this.child.exitCode === null && !this.child.signalCode && !this.frozen);
  }

  /** SIGKILL: the process dies, its sockets close with it. Resolves once it is gone. */
  kill() {
    const { child } = this;
    this.frozen = false;
    if (!child || child.exitCode !== null || child.signalCode) return Promise.resolve();
    return new Promise((resolve) => {
      child.once('exit', () => resolve());
      child.kill('SIGKILL');
    });
  }

  /** A new process on the same port: a module that rebooted, its registers at their power-on values. */
  async restart() {
    await this.kill();
    return this.start();
  }

  stop() {
    return this.kill();
  }
}

/** Starts an I/O module on a free port; `framing`: 'socket' (Modbus TCP) or 'rtu' (RTU frames over TCP). */
async function startIoModule({ units = [1], framing = 'socket', serial = null } = {}) {
  const port = serial ? 0 : await freePort();
  return new IoModule({ port, units, framing, serial }).start();
}


/**
 * pymodbus's client (support/modbus/client.py) against `port`: resolves with
 * one answer per request ([method, address, countOrValue, unit]).
 */
function pymodbusClient(port, requests) {
  return new Promise((resolve, reject) => {
    execFile(PYTHON, [path.join(__dirname, 'client.py'), JSON.stringify({ port, requests })], { encoding: 'utf8', timeout: 20000 }, (err, out, errText) => {
      if (err) reject(new Error(`client.py: ${err.message} ${errText}`));
      else resolve(out.trim().split('\n').map((line) => JSON.parse(line)));
    });
  });
}

module.exports = { startIoModule, pymodbusVersion, pymodbusClient };
