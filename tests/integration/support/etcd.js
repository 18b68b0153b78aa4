'use strict';
// A private three-member etcd cluster (Debian's etcd-server) on free loopback
// ports for a test suite, never the system service. Members can be killed
// (SIGKILL) and started again on their data directories, so a test can take
// one member away, then two (quorum lost), and bring them back.
//
//   const etcd = await startEtcd();       // { endpoints, members, kill(i), restart(i), stop() }
//   await etcd.kill(0); await etcd.kill(1); await etcd.restart(0); ...
const { spawn, execFileSync } = require('child_process');
const fs = require('fs');
const os = require('os');
const path = require('path');
const { freePort } = require('./mosquitto');

function findEtcd() {
  if (process.env.ETCD_BIN) return process.env.ETCD_BIN;
  for (const bin of ['/usr/bin/etcd', '/usr/local/bin/etcd']) if (fs.existsSync(bin)) return bin;
  try {
    return execFileSync('sh', ['-c', 'command -v etcd'], { encoding: 'utf8' }).trim() || null;
  } catch {
    return null;
  }
}

const running = new Set();
process.on('exit', () => {
  for (const child of running) child.kill('SIGKILL');
});

const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

/** Starts `size` members; resolves once every one answers its health endpoint. */
async function startEtcd({ size = 3, timeoutMs = 30000 } = {}) {
  const bin = findEtcd();
  if (!bin) throw new Error('etcd not found (bash scripts/setup.sh installs Debian\'s etcd-server; or set ETCD_BIN)');
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'sugarshack-etcd-'));
  const members = [];
  for (let i = 0; i < size; i++) {
    members.push({ name: `n${i + 1}`, client: await freePort(), peer: await freePort(), child: null, output: '' });
  }
  const initialCluster = members.map((m) => `${m.name}=http://127.0.0.1:${m.peer}`).join(',');

  function launch(m) {
    const args = [
      '--name', m.name,
      '--data-dir', path.join(dir, m.name),
      '--listen-client-urls', `http://127.0.0.1:${m.client}`,
      '--advertise-client-urls', `http://127.0.0.1:${m.client}`,
      '--listen-peer-urls', `http://127.0.0.1:${m.peer}`,
      '--initial-advertise-peer-urls', `http://127.0.0.1:${m.peer}`,
      '--initial-cluster', initialCluster,
      '--initial-cluster-token', path.basename(dir),
      '--initial-cluster-state', 'new',
      '--logger', 'zap',
      '--log-level', 'warn',
    ];
    m.output = '';
    const child = spawn(bin, args, { stdio: ['ignore', 'pipe', 'pipe'] });
    m.child = child;
    running.add(child);
    const keep = (d) => { m.output = (m.output + d).slice(-20000); };
    child.stdout.on('data', keep);
    child.stderr.on('data', keep);
    child.once('exit', () => running.delete(child));
  }

  const alive = (m) => Boolean(m.child && m.child.exitCode === null && m.child.signalCode === null);

  async function healthy(m) {
    try {
      const res = await fetch(`http://127.0.0.1:${m.client}/health`, { signal: AbortSignal.timeout(1000) });
      return res.ok && (await res.json()).health === 'true';
    } catch {
      return false;
    }
  }

  async function waitHealthy(list) {
    const deadline = Date.now() + timeoutMs;
    for (;;) {
      const states = await Promise.all(list.map(healthy));
      if (states.every(Boolean)) return;
      for (const m of list) if (!alive(m)) throw new Error(`etcd member ${m.name} exited: ${m.output.slice(-2000)}`);
      if (Date.now() > deadline) throw new Error(`etcd not healthy after ${timeoutMs} ms: ${list.map((m) => m.output.slice(-500)).join('\n')}`);
      await sleep(100);
    }
  }

  async function kill(i) {
    const m = members[i];
    if (!alive(m)) return;
    const exited = new Promise((resolve) => m.child.once('exit', resolve));
    m.child.kill('SIGKILL');
    await exited;
  }

  members.forEach(launch);
  try {
    await waitHealthy(members);
  } catch (err) {
    for (let i = 0; i < members.length; i++) await kill(i);
    fs.rmSync(dir, { recursive: true, force: true });
    throw err;
  }

  return {
    dir,
    members,
    endpoints: members.map((m) => `http://127.0.0.1:${m.client}`),
    alive: (i) => alive(members[i]),
    kill,
    /** Starts member `i` again on its data; resolves once the cluster has quorum and it answers healthy. */
    async restart(i) {
      if (!alive(members[i])) launch(members[i]);
      await waitHealthy(members.filter(alive));
    },
    healthy: (i) => healthy(members[i]),
    async stop() {
      for (let i = 0; i < members.length; i++) await kill(i);
      fs.rmSync(dir, { recursive: true, force: true });
    },
  };
}

module.exports = { startEtcd, findEtcd };
