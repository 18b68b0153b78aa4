'use strict';
// An independent OPC UA client for the tests: Python's asyncua in its own
// process (opcua_client.py), asked over stdin/stdout. `scripts/setup.sh`
// installs asyncua; without it the suite fails saying so.
//
//   const ua = await startUaClient();
//   await ua.ask('connect', { name: 'ana', url, user: 'ana', password });
//   const nodes = await ua.ask('browse', { name: 'ana' });
//   await ua.stop();
const path = require('path');
const { spawn, execFileSync } = require('child_process');

const PYTHON = process.env.PYTHON || 'python3';

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
  child.stdout.on('data', (d) => {
    buffer += d;
    let nl;
    while ((nl = buffer.indexOf('\n')) >= 0) {
      const line = buffer.slice(0, nl);
      buffer = buffer.slice(nl + 1);
      const answer = JSON.parse(line);
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

module.exports = { startUaClient, asyncuaMissing };
