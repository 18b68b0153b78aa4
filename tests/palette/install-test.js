#!/usr/bin/env node
// Palette install test: starts Node-RED on a user dir in which the packed
// palette is already installed, checks that every node set loaded, deploys each
// example flow and checks the runtime log. Prints PASS/FAIL lines; exits 1 on failure.
//
// usage: node install-test.js --red <node-red/red.js> --userdir <dir>
//          [--node <node binary>] [--pkg <palette package.json>]
//          [--examples <dir>] [--label <text>] [--types a,b,c]
//          [--subflows no] [--config-nodes no] [--expect-log <text>]
// --subflows no / --config-nodes no: the package has none (the OPC UA package);
// --expect-log: a line its examples must log (within 90 s of their deploy).
// Expected type names may also come from SUGARSHACK_EXPECTED_TYPES (comma-separated).
// Subflow modules (a set whose file has its subflow in subflows/<set>.json) are
// checked to be registered as their meta.type. It also runs the checks of
// `node-red-dev validate` that need no network (its name, catalogue and npm
// checks do), against the Node-RED and Node.js it runs on.
'use strict';
const fs = require('fs');
const path = require('path');
const net = require('net');
const { spawn } = require('child_process');
const semver = require('semver');

const args = {};
for (let i = 2; i < process.argv.length; i += 2) args[process.argv[i].replace(/^--/, '')] = process.argv[i + 1];
const root = path.resolve(__dirname, '../..');
const pkgFile = path.resolve(args.pkg || path.join(root, 'node-red-contrib-sugarshack/package.json'));
const examplesDir = path.resolve(args.examples || path.join(path.dirname(pkgFile), 'examples'));
const label = args.label || 'node-red';
const nodeBin = args.node || process.execPath;
const expectedTypes = (args.types || process.env.SUGARSHACK_EXPECTED_TYPES || '')
  .split(',').map((s) => s.trim()).filter(Boolean);
if (!args.red || !args.userdir) {
  console.error('usage: install-test.js --red <red.js> --userdir <dir> [--node <bin>] [--types a,b]');
  process.exit(2);
}

let failures = 0;
const pass = (msg) => console.log(`  PASS [${label}] ${msg}`);
const fail = (msg) => { failures++; console.log(`  FAIL [${label}] ${msg}`); };
const check = (ok, msg, detail) => (ok ? pass(msg) : fail(detail ? `${msg}: ${detail}` : msg));
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
// Node-RED 5 reports a load error as an object (possibly `{}`); the log has the text.
const errText = (e) => (typeof e === 'object' ? e.message || e.code || `${JSON.stringify(e)} (see log)` : e);
const indent = (lines) => `\n      ${lines.join('\n      ')}`;

function freePort() {
  return new Promise((resolve, reject) => {
    const srv = net.createServer().once('error', reject);
    srv.listen(0, '127.0.0.1', () => { const { port } = srv.address(); srv.close(() => resolve(port)); });
  });
}

// Exported example flows often omit their tab; add one for every undefined `z`.
function withTabs(flow) {
  const defined = new Set(flow.filter((n) => n.type === 'tab' || n.type === 'subflow').map((n) => n.id));
  const missing = [...new Set(flow.map((n) => n.z).filter((z) => z && !defined.has(z)))];
  return [...missing.map((id) => ({ id, type: 'tab', label: `tab ${id}` })), ...flow];
}

/** The package's subflow modules: sets whose file has its subflow beside it in subflows/<set>.json. */
function subflowModules(pkg) {
  const dir = path.dirname(pkgFile);
  return Object.entries((pkg['node-red'] && pkg['node-red'].nodes) || {}).flatMap(([set, file]) => {
    const json = path.join(dir, path.dirname(file), 'subflows', `${set}.json`);
    if (!fs.existsSync(json)) return [];
    try {
      return [{ set, def: JSON.parse(fs.readFileSync(json, 'utf8')) }];
    } catch (e) {
      return [{ set, error: e.message }];
    }
  });
}

/**
 * The checks of `node-red-dev validate` that run offline (P01, P03-P07, N02, D01-D02),
 * with P06 and P07 against the Node-RED and Node.js under test instead of npm's dist-tags.
 */
async function validateOffline(pkg, sets, types, base, nrVersion, nodeVersion) {
  const v = (msg) => `node-red-dev ${msg}`;
  check(Boolean(pkg.license), v(`P01 license declared (${pkg.license})`));
  check(Boolean(pkg.repository || pkg.bugs), v('P03 repository or bugs link'));
  check(/^(@[a-z\d][\w-.]+\/)?[a-z\d][\w-.]*$/.test(pkg.name) && !/^(node-red|nodered)(?!-contrib-)/i.test(pkg.name), v(`P04 valid name ${pkg.name}`));
  check((pkg.keywords || []).includes('node-red'), v('P05 keyword node-red'));
  const nrRange = pkg['node-red'] && pkg['node-red'].version;
  check(Boolean(nrRange) && semver.satisfies(semver.coerce(nrVersion), nrRange), v(`P06 node-red.version ${nrRange} admits Node-RED ${nrVersion}`));
  const nodeRange = pkg.engines && pkg.engines.node;
  check(Boolean(nodeRange) && semver.satisfies(semver.coerce(nodeVersion), nodeRange), v(`P07 engines.node ${nodeRange} admits Node.js ${nodeVersion}`));
  const deps = Object.keys(pkg.dependencies || {});
  check(deps.length <= 6, v(`D01 at most 6 dependencies (${deps.length})`));
  // N02: every node type that is not a config node appears in an example; config types are read from each set's editor HTML.
  const configTypes = new Set();
  for (const s of sets) {
    const res = await fetch(`${base}/nodes/${s.id}`, { headers: { Accept: 'text/html' } });
    const html = res.ok ? await res.text() : '';
    for (const m of html.matchAll(/registerType\(\s*['"]([^'"]+)['"]\s*,\s*\{([\s\S]*?)\}\s*\)\s*;/g)) {
      if (/category\s*:\s*['"]config['"]/.test(m[2])) configTypes.add(m[1]);
    }
  }
  const used = new Set();
  for (const file of fs.existsSync(examplesDir) ? fs.readdirSync(examplesDir).filter((f) => f.endsWith('.json')) : []) {
    try {
      for (const n of JSON.parse(fs.readFileSync(path.join(examplesDir, file), 'utf8'))) used.add(n.type);
    } catch { /* reported when the example is deployed */ }
  }
  const missing = types.filter((t) => !configTypes.has(t) && !used.has(t));
  const configExpected = args['config-nodes'] !== 'no';
  check((configTypes.size > 0 || !configExpected) && missing.length === 0, v(`N02 an example for every node (config nodes ${[...configTypes].join(', ') || 'none'} aside)`), `none for ${missing.join(', ')}`);
  check(new Set(types).size === types.length, v('N01 (offline part) no node type registered twice'));
}

async function main() {
  const pkg = JSON.parse(fs.readFileSync(pkgFile, 'utf8'));
  const moduleName = pkg.name;
  const setNames = Object.keys((pkg['node-red'] && pkg['node-red'].nodes) || {});
  const settingsFile = path.join(args.userdir, 'settings.js');
  fs.writeFileSync(settingsFile, `module.exports = {
  uiHost: '127.0.0.1',
  flowFile: 'flows.json',
  credentialSecret: false,
  logging: { console: { level: 'info', metrics: false, audit: false } },
};\n`);

  const port = await freePort();
  const base = `http://127.0.0.1:${port}`;
  let log = '';
  const child = spawn(nodeBin, [args.red, '-u', args.userdir, '-p', String(port), '-s', settingsFile],
    { stdio: ['ignore', 'pipe', 'pipe'] });
  child.stdout.on('data', (d) => { log += d; });
  child.stderr.on('data', (d) => { log += d; });
  let exited = null;
  child.on('exit', (code, sig) => { exited = sig || code; });
  const kill = () => { if (exited === null) child.kill('SIGTERM'); };
  process.on('exit', kill);
  for (const s of ['SIGINT', 'SIGTERM']) process.on(s, () => { kill(); process.exit(130); });

  try {
    let nodes = null;
    for (let t = Date.now(); Date.now() - t < 60000 && exited === null;) {
      try {
        const res = await fetch(`${base}/nodes`, { headers: { Accept: 'application/json' } });
        if (res.ok) { nodes = await res.json(); break; }
      } catch { /* not listening yet */ }
      await sleep(250);
    }
    if (!nodes) {
      fail(`Node-RED admin API did not come up (exit: ${exited})`);
      return;
    }
    const nrVersion = (log.match(/Node-RED version: (v\S+)/) || [])[1] || '?';
    const nodeVersion = (log.match(/Node\.js\s+version: (v\S+)/) || [])[1] || '?';
    pass(`Node-RED ${nrVersion} on Node.js ${nodeVersion} up on ${base}`);

    const sets = nodes.filter((s) => s.module === moduleName);
    check(sets.length > 0, `module ${moduleName} is loaded`, 'not in GET /nodes');
    for (const s of sets) {
      check(!s.err && s.enabled !== false, `node set ${s.id} enabled without error`,
        `enabled=${s.enabled} err=${errText(s.err)}`);
    }
    const loadedSets = new Set(sets.map((s) => s.name));
    for (const name of setNames) check(loadedSets.has(name), `node set ${moduleName}/${name} registered`, 'missing');
    const types = sets.flatMap((s) => s.types || []);
    check(types.length > 0, `registers node types: ${types.join(', ') || '(none)'}`);
    for (const t of expectedTypes) check(types.includes(t), `type ${t} registered`, 'missing');
    const subflows = subflowModules(pkg);
    if (args.subflows !== 'no') check(subflows.length > 0, `package has subflow modules: ${subflows.map((s) => s.set).join(', ') || '(none)'}`);
    for (const { set, def, error } of subflows) {
      if (error) { fail(`subflow module ${set} parses: ${error}`); continue; }
      const type = def.meta && def.meta.type;
      check(types.includes(type), `subflow module ${set} registered as node type ${type}`, 'missing');
      const loaded = sets.find((s) => s.name === set);
      check(Boolean(loaded && (loaded.types || []).includes(type)), `subflow module ${set}: type ${type} belongs to its node set`);
      for (const key of ['module', 'version', 'license']) {
        check(def.meta[key] === pkg[key === 'module' ? 'name' : key], `subflow module ${set}: meta.${key} is the package's`, `${def.meta[key]}`);
      }
      const functions = (def.flow || []).filter((n) => n.type === 'function');
      check(functions.length === 0, `subflow module ${set} has no function node inside`, functions.map((n) => n.id).join(', '));
      const bare = (def.env || []).filter((e) => !e.ui || !e.ui.label);
      check(bare.length === 0, `subflow module ${set}: every property has a labelled form field`, bare.map((e) => e.name).join(', '));
      const inner = new Set((def.flow || []).map((n) => n.type));
      const unknown = [...inner].filter((t) => !nodes.some((s) => (s.types || []).includes(t)));
      check(unknown.length === 0, `subflow module ${set}: every node type inside is installed`, unknown.join(', '));
    }
    // Users without Dashboard 2 load the palette as before: only its HMI example uses dashboard nodes.
    const declared = Object.keys({ ...pkg.dependencies, ...pkg.peerDependencies, ...pkg.optionalDependencies });
    const dashboardInside = subflows.flatMap(({ def }) => ((def && def.flow) || []).filter((n) => /^ui[-_]/.test(n.type)).map((n) => n.type));
    check(!declared.some((d) => d.includes('dashboard')) && dashboardInside.length === 0,
      'the palette\'s node sets need no dashboard (no dependency on it, no dashboard node in a subflow module)', `${declared.join(', ')} ${dashboardInside.join(', ')}`);
    await validateOffline(pkg, sets, types, base, nrVersion, nodeVersion);

    // The plant document's schema ships with the palette (installed beside the OPC UA package too):
    // where VS Code users point "$schema", and served to the plant dialog.
    const schemaFile = path.join(args.userdir, 'node_modules', 'node-red-contrib-sugarshack', 'schema', 'plant.schema.json');
    check(fs.existsSync(schemaFile), 'the palette ships the plant document\'s JSON Schema (node_modules/node-red-contrib-sugarshack/schema/plant.schema.json)');
    const served = await fetch(`${base}/sugarshack/plant/schema`);
    const schema = served.ok ? await served.json() : null;
    check(Boolean(schema && schema.title && schema.definitions && schema.definitions.Actuator),
      'GET /sugarshack/plant/schema serves it to the plant dialog', `HTTP ${served.status}`);

    const examples = fs.existsSync(examplesDir)
      ? fs.readdirSync(examplesDir).filter((f) => f.endsWith('.json')).sort() : [];
    if (examples.length === 0) console.log(`  note [${label}] no example flows in ${examplesDir}`);
    for (const file of examples) {
      let flow;
      try {
        flow = withTabs(JSON.parse(fs.readFileSync(path.join(examplesDir, file), 'utf8')));
      } catch (e) { fail(`example ${file} parses: ${e.message}`); continue; }
      const mark = log.length;
      const res = await fetch(`${base}/flows`, {
        method: 'POST',
        headers: { 'Content-Type': 'application/json', 'Node-RED-Deployment-Type': 'full' },
        body: JSON.stringify(flow),
      });
      check(res.status === 200 || res.status === 204, `example ${file} deploys`, `HTTP ${res.status} ${await res.text()}`);
      // Wait for the runtime to restart the flows, then give the nodes a second to run.
      for (let t = Date.now(); Date.now() - t < 10000 && !/Updated flows[\s\S]*Started flows|missing types/.test(log.slice(mark));) await sleep(100);
      await sleep(1000);
      const bad = log.slice(mark).split('\n').filter((l) => /\[error\]|\bError\b|missing types/.test(l));
      check(bad.length === 0, `example ${file} runs without errors in the log`, indent(bad));
      const deployed = await (await fetch(`${base}/flows`, { headers: { Accept: 'application/json' } })).json();
      const ids = new Set((Array.isArray(deployed) ? deployed : deployed.flows || []).map((n) => n.id));
      const lost = flow.filter((n) => !ids.has(n.id)).map((n) => n.id);
      check(lost.length === 0, `example ${file}: GET /flows returns all ${flow.length} nodes`, `missing ${lost.join(', ')}`);
    }

    if (args['expect-log']) {
      for (let t = Date.now(); Date.now() - t < 90000 && !log.includes(args['expect-log']) && exited === null;) await sleep(250);
      check(log.includes(args['expect-log']), `the examples log "${args['expect-log']}"`);
    }
    // Load-time problems (e.g. a node file throwing on require) show up as warnings naming the module.
    const bad = log.split('\n').filter((l) => /\[error\]/.test(l) || (l.includes(moduleName) && /Error/.test(l)));
    check(bad.length === 0, 'Node-RED log has no [error] lines or module load errors', indent(bad));
  } finally {
    kill();
    if (exited === null) await Promise.race([new Promise((r) => child.once('exit', r)), sleep(5000)]);
    if (exited === null) child.kill('SIGKILL');
    if (failures > 0) console.log(`---- Node-RED log (${label}) ----\n${log}---- end of log ----`);
  }
}

main().then(
  () => {
    console.log(failures ? `FAIL [${label}] ${failures} check(s) failed` : `PASS [${label}] palette install test`);
    process.exit(failures ? 1 : 0);
  },
  (e) => { console.log(`FAIL [${label}] ${e.stack || e}`); process.exit(1); },
);
