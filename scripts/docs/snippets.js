'use strict';
// Docs as tests: the tags a fenced block of the docs carries, and how a block
// tagged `run` is run (tests/docs/snippets.spec.js runs them all; a page's own
// test may run its blocks with these too). See CONTRIBUTING.md, "Docs as tests".
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
const { spawn } = require('child_process');
const { ROOT, sitePages, read, parse } = require('./markdown');

/** Every fenced block of the site's pages, with its file and `where` (file:line). */
function docBlocks(files = sitePages()) {
  return files.flatMap((file) => parse(read(file)).fences.map((fence) => ({ ...fence, file, where: `${file}:${fence.line}` })));
}

const ENVS = ['broker', 'stack'];
const SNIPPET_MS = 60000;

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

module.exports = { ENVS, SNIPPET_MS, docBlocks, untested, onPorts, run };
