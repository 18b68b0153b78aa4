'use strict';
// Docs as tests: every fenced block of the docs site's pages (README.md,
// CONTRIBUTING.md, docs/) says in its info string how it is tested, and is
// tested so (CONTRIBUTING.md, "Docs as tests"):
//   ```json plant            a whole plant document: the deploy's plant check finds no error
//   ```json simulation       { "simulation": ... } for the case-study plant: the simulator builds it
//   ```sh run [broker|stack] [until=WORD]
//   ```js run [broker|stack] run at the repository root; must succeed (with until=WORD: must
//                            print WORD, then is stopped). `broker`: an MQTT broker on a free
//                            port; `stack`: also the simulator on flows/plant.json and Node-RED
//                            with the case-study flows. The docs speak of npm start's ports:
//                            1880 and 1883 become the test's, `-h 127.0.0.1` gets `-p <port>`,
//                            and curl fails on an HTTP error.
//   ```sh by=PATH            run by the test at PATH, which must exist and read this page
//   ```sh skip: REASON       not run, for the reason given
//   ```text                  a picture or an output: nothing to run
const assert = require('node:assert/strict');
const fs = require('fs');
const path = require('path');
const { spawn } = require('child_process');
const { ROOT, sitePages, read, parse } = require('../../scripts/docs/markdown');
const { Session, sleep } = require('../../scripts/lib/node-red-process');
const { startSimulator, RESULT_TOPIC } = require('../../scripts/simulator');
const { buildModel } = require('../../scripts/simulator/plant');
const { validatePlant } = require('../../node-red-contrib-sugarshack/lib/plant');

const ENVS = ['broker', 'stack'];
const SNIPPET_MS = 60000;

const blocks = sitePages().flatMap((file) => parse(read(file)).fences.map((fence) => ({ ...fence, file, where: `${file}:${fence.line}` })));

/** Why a block's tags do not say how it is tested, or null. */
function untested({ lang, tags }) {
  const names = Object.keys(tags);
  const only = (...allowed) => names.every((n) => allowed.includes(n));
  if (tags.skip !== undefined) return tags.skip.length >= 10 ? null : 'a skip needs its reason: ```sh skip: why it cannot run';
  if (lang === 'text') return names.length ? '```text takes no tags' : null;
  if (tags.by) return only('by') ? null : '```by=PATH takes no other tag';
  if (lang === 'json') return (tags.plant || tags.simulation) && names.length === 1 ? null : '```json needs one tag: plant or simulation';
  if (['sh', 'js'].includes(lang) && tags.run) {
    if (!only('run', 'until', ...ENVS)) return `unknown tag among ${names.join(', ')}`;
    if (ENVS.filter((e) => tags[e]).length > 1) return 'one of broker and stack';
    return tags.until === true ? 'until needs a word: until=WORD' : null;
  }
  return 'no test tag: plant, simulation, run, by=PATH, skip: reason, or text (CONTRIBUTING.md, "Docs as tests")';
}

/** A snippet's text with npm start's ports replaced by the test's. */
function onPorts(text, ports) {
  let out = text;
  if (ports.red) out = out.replace(/127\.0\.0\.1:1880\b/g, `127.0.0.1:${ports.red}`);
  if (ports.mqtt) out = out.replace(/127\.0\.0\.1:1883\b/g, `127.0.0.1:${ports.mqtt}`).replace(/-h 127\.0\.0\.1(?=\s|$)/g, `-h 127.0.0.1 -p ${ports.mqtt}`);
  return out;
}

/** The command that runs a snippet at the repository root. */
function command(block, ports) {
  const body = onPorts(block.body, ports);
  if (block.lang === 'js') {
    const script = `(async () => {\n${body}\n})().then(() => process.exit(0), (err) => { console.error(err); process.exit(1); });`;
    return [process.execPath, ['-e', script]];
  }
  const curl = 'curl() { command curl --fail --silent --show-error "$@"; }\n';
  return ['bash', ['-euo', 'pipefail', '-c', curl + body]];
}

/**
 * Runs a snippet; resolves with its output. Without `until` it must exit 0;
 * with it, it must print the word, and then stop (with its children) on SIGTERM.
 */
function run(block, ports) {
  const [cmd, args] = command(block, ports);
  const child = spawn(cmd, args, { cwd: ROOT, detached: true, stdio: ['ignore', 'pipe', 'pipe'] });
  let output = '';
  child.stdout.on('data', (d) => { output += d; });
  child.stderr.on('data', (d) => { output += d; });
  const signal = (name) => { try { process.kill(-child.pid, name); } catch { /* already gone */ } };
  return new Promise((resolve, reject) => {
    let stopping = false;
    let poll = null;
    let timer = null;
    const finish = (why) => {
      clearTimeout(timer);
      clearInterval(poll);
      if (why) reject(new Error(`${block.where}: ${why}:\n${output}`));
      else resolve(output);
    };
    const giveUp = (ms, why) => {
      clearTimeout(timer);
      timer = setTimeout(() => { signal('SIGKILL'); finish(why); }, ms);
    };
    giveUp(SNIPPET_MS, `still running after ${SNIPPET_MS} ms`);
    child.once('exit', (code, sig) => {
      if (stopping) finish();
      else if (block.tags.until) finish(`ended (${code ?? sig}) before printing "${block.tags.until}"`);
      else finish(code === 0 ? null : `exited ${code ?? sig}`);
    });
    if (block.tags.until) {
      poll = setInterval(() => {
        if (!output.includes(block.tags.until)) return;
        clearInterval(poll);
        stopping = true;
        signal('SIGTERM');
        giveUp(10000, 'did not stop within 10 s of SIGTERM');
      }, 100);
    }
  });
}

describe('docs as tests: the fenced blocks of the docs', function () {
  it('finds the docs\' blocks', function () {
    assert.ok(blocks.length >= 10, `only ${blocks.length} fenced blocks found`);
  });

  it('every block says how it is tested', function () {
    const bad = blocks.map((b) => [b, untested(b)]).filter(([, why]) => why).map(([b, why]) => `${b.where}: \`\`\`${b.info}: ${why}`);
    assert.deepEqual(bad, []);
  });

  for (const block of blocks.filter((b) => b.lang === 'json' && b.tags.plant)) {
    it(`${block.where}: the plant document passes the plant check`, function () {
      const { errors } = validatePlant(block.body);
      assert.deepEqual(errors, []);
    });
  }

  for (const block of blocks.filter((b) => b.lang === 'json' && b.tags.simulation)) {
    it(`${block.where}: the simulator builds this simulation section for the case-study plant`, function () {
      const { simulation } = JSON.parse(block.body);
      assert.ok(simulation, 'the block is { "simulation": ... }');
      const plant = JSON.parse(read('flows/plant.json'));
      const model = buildModel({ ...plant, simulation });
      assert.ok(model);
    });
  }

  for (const block of blocks.filter((b) => b.tags.by)) {
    it(`${block.where}: ${block.tags.by} runs it`, function () {
      const test = path.join(ROOT, block.tags.by);
      assert.ok(fs.existsSync(test), `${block.tags.by} does not exist`);
      assert.ok(fs.readFileSync(test, 'utf8').includes(block.file), `${block.tags.by} does not read ${block.file}`);
    });
  }

  for (const block of blocks.filter((b) => b.tags.run && !ENVS.some((e) => b.tags[e]))) {
    it(`${block.where}: runs`, async function () {
      this.timeout(SNIPPET_MS + 15000);
      await run(block, {});
    });
  }

  describe('with a broker', function () {
    const mine = blocks.filter((b) => b.tags.run && b.tags.broker);
    let session;
    before(async function () {
      if (!mine.length) this.skip();
      session = new Session('docs-broker');
      await session.startBroker();
    });
    after(() => session && session.cleanup());
    for (const block of mine) {
      it(`${block.where}: runs`, async function () {
        this.timeout(SNIPPET_MS + 15000);
        await run(block, { mqtt: session.server.address().port });
      });
    }
  });

  describe('on a stack: broker, simulator and Node-RED with the case-study flows', function () {
    const mine = blocks.filter((b) => b.tags.run && b.tags.stack);
    let session; let red; const results = [];
    before(async function () {
      if (!mine.length) this.skip();
      this.timeout(120000);
      session = new Session('docs-stack');
      const mqtt = await session.startBroker((packet) => {
        if (packet.topic === RESULT_TOPIC) results.push(JSON.parse(packet.payload.toString()));
      });
      session.sim = await startSimulator({ broker: `mqtt://127.0.0.1:${mqtt}`, plant: path.join(ROOT, 'flows', 'plant.json'), log: () => {} });
      const flows = JSON.parse(read('flows/case-study.json'))
        .map((n) => (n.type === 'mqtt-broker' ? { ...n, broker: '127.0.0.1', port: String(mqtt) } : n));
      red = await session.startRed('docs', flows);
      red.ports = { mqtt, red: Number(new URL(red.url).port) };
    });
    after(() => session && session.cleanup());
    for (const block of mine) {
      it(`${block.where}: runs`, async function () {
        this.timeout(SNIPPET_MS + 15000);
        results.length = 0;
        await run(block, red.ports);
        // A fault sent to the simulator is answered on sim/control/result; none may be refused.
        await sleep(200);
        assert.deepEqual(results.filter((r) => !r.ok), []);
      });
    }
  });
});

module.exports = { untested, onPorts };
