'use strict';
// A real line-protocol server for the journal tests: Debian's victoria-metrics
// (installed by scripts/setup.sh), on a free loopback port with its own data
// directory. It can be killed and started again on the same port and data,
// and queried through its export API for the rows the journal wrote.
const fs = require('fs');
const os = require('os');
const path = require('path');
const { spawn, execFileSync } = require('child_process');
const { freePort } = require('./mosquitto');

function findVictoriaMetrics() {
  for (const candidate of ['victoria-metrics', '/usr/bin/victoria-metrics']) {
    try {
      execFileSync(candidate, ['-version'], { stdio: 'ignore' });
      return candidate;
    } catch { /* next */ }
  }
  return null;
}

async function get(url, init) {
  const res = await fetch(url, init);
  if (!res.ok) throw new Error(`${url}: ${res.status} ${await res.text()}`);
  return res.text();
}

async function startVictoriaMetrics() {
  const bin = findVictoriaMetrics();
  if (!bin) throw new Error('victoria-metrics not found: run scripts/setup.sh (apt-get install victoria-metrics)');
  const port = await freePort();
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'sugarshack-vm-'));
  const url = `http://127.0.0.1:${port}`;
  const vm = { port, url, proc: null, dir };

  vm.start = async () => {
    const logs = [];
    vm.proc = spawn(bin, [
      `-storageDataPath=${dir}`, `-httpListenAddr=127.0.0.1:${port}`, '-retentionPeriod=100y',
      '-search.latencyOffset=0s', '-search.disableCache', '-loggerLevel=ERROR',
    ], { stdio: ['ignore', 'pipe', 'pipe'] });
    vm.proc.stdout.on('data', (d) => logs.push(String(d)));
    vm.proc.stderr.on('data', (d) => logs.push(String(d)));
    for (let i = 0; i < 100; i++) {
      try {
        await get(`${url}/health`);
        return;
      } catch {
        if (vm.proc.exitCode !== null) break;
        await new Promise((r) => setTimeout(r, 100));
      }
    }
    throw new Error(`victoria-metrics did not start: ${logs.join('')}`);
  };

  /**
   * Kills the server and waits for it to exit. SIGTERM: VictoriaMetrics answers
   * a write before the rows are on its disk, so a SIGKILL loses its last
   * second or so of acknowledged rows, which no client can see or resend.
   */
  vm.kill = async (signal = 'SIGTERM') => {
    const { proc } = vm;
    if (!proc || proc.exitCode !== null) return;
    await new Promise((resolve) => {
      proc.once('exit', resolve);
      proc.kill(signal);
    });
    vm.proc = null;
  };

  vm.stop = async () => {
    await vm.kill();
    fs.rmSync(dir, { recursive: true, force: true });
  };

  /**
   * Every sample of the metrics matching `selector` ({__name__=...}): one
   * { metric, value, at } per sample, after making what was written searchable.
   */
  vm.export = async (selector) => {
    await get(`${url}/internal/force_flush`);
    const body = new URLSearchParams({ 'match[]': selector, start: '0' });
    const text = await get(`${url}/api/v1/export`, { method: 'POST', body });
    const out = [];
    for (const line of text.split('\n').filter(Boolean)) {
      const series = JSON.parse(line);
      series.values.forEach((value, i) => out.push({ metric: series.metric, value, at: series.timestamps[i] }));
    }
    return out;
  };

  await vm.start();
  return vm;
}

module.exports = { startVictoriaMetrics, findVictoriaMetrics };
