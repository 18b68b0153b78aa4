'use strict';
// Every text key the nodes, their editor dialogs and lib/ use has its en-US text, in
// the catalog Node-RED loads for that node file (nodes/locales/en-US/<file>.json);
// lib/'s are under "sugarshack" in the interlock set's. No SugarshackError text is worded inline.
const assert = require('node:assert/strict');
const fs = require('fs');
const path = require('path');
const { PALETTE } = require('./support');

const NODES = path.join(PALETTE, 'nodes');
const catalogOf = (stem) => {
  const file = path.join(NODES, 'locales', 'en-US', `${stem}.json`);
  return fs.existsSync(file) ? JSON.parse(fs.readFileSync(file, 'utf8')) : {};
};
const textAt = (catalog, key) => key.split('.').reduce((v, part) => (v && typeof v === 'object' ? v[part] : undefined), catalog);
const stems = (ext) => fs.readdirSync(NODES).filter((f) => f.endsWith(ext)).map((f) => f.slice(0, -ext.length));
const readNode = (file) => fs.readFileSync(path.join(NODES, file), 'utf8');

// A dialog's keys: data-i18n="key" or "[attribute]key", and the node's own this._('key'[, subs]) (node._ in its dialog functions).
const DIALOG_KEY = /data-i18n="(?:\[[^\]]*\])?([^"]+)"|(?<![\w.$])(?:this|node)\._\('([^']+)'/g;
const dialogKeys = (source) => [...source.matchAll(DIALOG_KEY)].map((m) => m[1] || m[2]);

/** The scripts of a node's .html (its dialog template is not code). */
const scriptsOf = (html) => [...html.matchAll(/<script type="text\/javascript">([\s\S]*?)<\/script>/g)].map((m) => m[1]).join('\n');

/** The verbs whose types resources/editor.js's operationNode(verb) registers, by the .html that asks for them. */
const operationVerbs = () => stems('.html').flatMap((stem) => [...readNode(`${stem}.html`).matchAll(/sugarshackEditor\.operationNode\('([\w-]+)'\)/g)].map((m) => m[1]));

/** The keys operationNode reads for its type (`type + '.key'`), from resources/editor.js. */
function operationNodeKeys() {
  const editor = fs.readFileSync(path.join(PALETTE, 'resources', 'editor.js'), 'utf8');
  const body = editor.slice(editor.indexOf('function operationNode('));
  return [...new Set([...body.slice(0, body.indexOf('\n  }\n')).matchAll(/text\('([^']+)'\)|type \+ '\.([\w.]+)/g)].map((m) => m[1] || m[2]))];
}

describe('i18n catalogs', function () {
  it('hold every key a node file reads through RED._', function () {
    const missing = [];
    let keys = 0;
    for (const stem of stems('.js')) {
      const source = fs.readFileSync(path.join(NODES, `${stem}.js`), 'utf8');
      const type = /translator\(RED, '([^']+)'\)/.exec(source);
      if (!type) continue;
      for (const [, key] of source.matchAll(/\bt\('([\w.]+)'/g)) {
        keys++;
        if (typeof textAt(catalogOf(stem), `${type[1]}.${key}`) !== 'string') missing.push(`${stem}.js: ${type[1]}.${key}`);
      }
    }
    assert.ok(keys > 30, `${keys} keys`);
    assert.deepEqual(missing, []);
  });

  it('hold every label and palette name an editor dialog reads', function () {
    const missing = [];
    let keys = 0;
    for (const stem of stems('.html')) {
      const source = readNode(`${stem}.html`);
      // A node resources/editor.js registers with its dialog reads these for its type.
      const made = [...source.matchAll(/sugarshackEditor\.operationNode\('([\w-]+)'\)/g)]
        .flatMap(([, verb]) => operationNodeKeys().map((key) => `sugarshack-${verb}.${key}`));
      for (const key of [...made, ...dialogKeys(source)]) {
        if (key.startsWith('node-red:')) continue;
        keys++;
        if (typeof textAt(catalogOf(stem), key) !== 'string') missing.push(`${stem}.html: ${key}`);
      }
    }
    assert.ok(keys > 80, `${keys} keys`);
    assert.deepEqual(missing, []);
  });
});

// ---- Texts built in JS: every one a catalog key, every key used, placeholders matching.

const LIB = path.join(PALETTE, 'lib');
// The mechanism itself (it builds the "errors.<key>" of SugarshackError.of).
const MECHANISM = new Set(['i18n.js', 'errors.js']);
const SHARED_CATALOG = catalogOf('interlock');

/** Source files whose texts are checked: lib/*.js and lib's folders, nodes/*.js, and the editor's: the scripts of nodes/*.html and resources/*.js. */
function sources() {
  const libFiles = (dir) => fs.readdirSync(path.join(LIB, dir)).filter((f) => f.endsWith('.js') && !MECHANISM.has(f))
    .map((f) => ({ file: path.posix.join('lib', dir, f), full: path.join(LIB, dir, f) }));
  return [
    ...libFiles(''),
    ...fs.readdirSync(LIB, { withFileTypes: true }).filter((d) => d.isDirectory()).flatMap((d) => libFiles(d.name)),
    ...stems('.js').map((s) => ({ file: `nodes/${s}.js`, full: path.join(NODES, `${s}.js`) })),
    ...fs.readdirSync(path.join(PALETTE, 'resources')).filter((f) => f.endsWith('.js'))
      .map((f) => ({ file: `resources/${f}`, full: path.join(PALETTE, 'resources', f) })),
  ].map(({ file, full }) => ({ file, source: fs.readFileSync(full, 'utf8') })).concat(editorScripts());
}

/** The scripts of nodes/*.html, as sources. */
function editorScripts() {
  return stems('.html').map((stem) => ({ file: `nodes/${stem}.html`, source: scriptsOf(readNode(`${stem}.html`)) }));
}

/** The arguments of the call whose "(" is at `open`, as source text, split at top-level commas. */
/**
 * Walks from the bracket at `open` to the one closing it, strings skipped, and
 * returns its index; `atComma(i)` is told each comma at the first level.
 */
function walkBrackets(source, open, atComma = () => {}) {
  let depth = 0;
  for (let i = open; i < source.length; i++) {
    const c = source[i];
    if (c === "'" || c === '"' || c === '`') {
      for (i++; i < source.length && source[i] !== c; i++) if (source[i] === '\\') i++;
    } else if ('([{'.includes(c)) depth++;
    else if (')]}'.includes(c) && --depth === 0) return i;
    else if (c === ',' && depth === 1) atComma(i);
  }
  throw new Error(`unclosed bracket at ${open}`);
}

/** The arguments of the call whose parenthesis is at `open`, as source text. */
function callArgs(source, open) {
  const cuts = [open];
  walkBrackets(source, open, (i) => cuts.push(i));
  cuts.push(closing(source, open));
  return cuts.slice(1).map((cut, k) => source.slice(cuts[k] + 1, cut).trim()).filter((arg) => arg !== '');
}

/** The names an object literal `{ a, b: x }` gives; null when the argument is not one. */
function subsNames(arg) {
  if (arg === undefined) return [];
  if (!arg.startsWith('{')) return null;
  const inner = callArgs(`(${arg.slice(1, -1)})`, 0);
  const names = inner.map((part) => /^(\w+)\s*(:|$)/.exec(part));
  return names.every(Boolean) ? names.map((m) => m[1]) : null;
}

const placeholders = (text) => [...text.matchAll(/__(\w+?)__/g)].map((m) => m[1]).sort();

const PACKAGE_NAME = JSON.parse(fs.readFileSync(path.join(PALETTE, 'package.json'), 'utf8')).name;

/**
 * Whose catalog a file's t() reads: a node file's translator(RED, '<type>'), or an editor
 * script's `var NS = '<module>/<set>:<prefix>.'` (RED._ by namespace). Null when it has neither.
 */
function tCatalog(file, source) {
  const type = /translator\(RED, '([^']+)'\)/.exec(source);
  // A node type's texts are in its catalog (locales/en-US/pid.json for sugarshack-pid), wherever in lib/ they are read.
  if (type) return { stem: type[1].replace(/^sugarshack-/, ''), prefix: type[1] };
  const ns = /var NS = '([^':]+)\/([\w-]+):([\w.-]+)\.';/.exec(source);
  if (!ns) return null;
  assert.equal(ns[1], PACKAGE_NAME, `${file}: the namespace names another module`);
  return { stem: ns[2], prefix: ns[3] };
}

/** Every text lookup in the sources: { at, keys (full catalog keys), subs, stem (whose catalog), catalog }. */
function lookups() {
  // The texts the core's engine names (its catalogTexts()) are looked up like the JS's.
  const { texts, labels } = require(path.join(LIB, 'wasm', 'index.js')).load().catalogTexts();
  const found = texts.map(({ key, params }) => ({ at: `core: ${key}`, keys: [`sugarshack.${key}`], subs: params, stem: 'interlock', catalog: SHARED_CATALOG }))
    .concat(labels.map((label) => ({ at: `core: label ${label}`, keys: [`sugarshack.labels.${label}`], subs: [], stem: 'interlock', catalog: SHARED_CATALOG })));
  for (const { file, source } of sources()) {
    const own = tCatalog(file, source);
    // A bare text() is lib/host/i18n.js's only where the file takes it from there (journal/bus.js has a text() of its own).
    const importsText = /const \{[^}]*\btext\b[^}]*\} = require\('(?:\.\.?\/)+(?:host\/)?i18n'\)/.test(source);
    const calls = /(?<![\w.$]|function )(t|text|i18n\.text|i18n\.typeText|SugarshackError\.of|this\._|node\._)\(/g;
    for (const m of source.matchAll(calls)) {
      if (m[1] === 'text' && !importsText) continue;
      const args = callArgs(source, m.index + m[0].length - 1);
      const [keyArg, subsArg] = m[1] === 'SugarshackError.of' || m[1] === 'i18n.typeText' ? args.slice(1) : args;
      // The key, or each key a conditional may pick: a catalog key has a dot (SugarshackError.of's names the entry under errors).
      const keyForm = { 'SugarshackError.of': /'(\w+)'/g, 'this._': /'([\w-]+(?:\.\w+)+)'/g, 'node._': /'([\w-]+(?:\.\w+)+)'/g }[m[1]] || /'(\w+(?:\.\w+)+)'/g;
      const keys = [...keyArg.matchAll(keyForm)].map((k) => k[1]);
      const at = `${file}: ${m[0]}${args.join(', ')})`;
      const subs = subsNames(subsArg);
      // A count picks "<key>_plural" where there is one (i18next v3 form, which Node-RED migrates for i18next v4).
      const withPlurals = (catalog, full) => (subs || []).includes('count')
        ? full.flatMap((k) => (typeof textAt(catalog, `${k}_plural`) === 'string' ? [k, `${k}_plural`] : [k])) : full;
      if (m[1] === 'this._' || m[1] === 'node._') {
        // A node definition's own lookup: a full key in its set's catalog; operationNode's is its type's, for each verb.
        const typed = /^type \+ '\.([\w.]+)'$/.exec(keyArg);
        const owners = typed ? operationVerbs().map((verb) => ({ stem: verb, key: `sugarshack-${verb}.${typed[1]}` }))
          : [{ stem: path.basename(file, '.html'), key: keys[0] }];
        assert.ok(typed || file.endsWith('.html'), `${at}: this._() outside a node's .html or operationNode`);
        for (const { stem, key } of owners) {
          const catalog = catalogOf(stem);
          found.push({ at, keys: key ? withPlurals(catalog, [key]) : [], subs, stem, catalog });
        }
      } else if (m[1] === 'i18n.typeText') {
        // A node type's text read outside its node file: i18n.typeText('sugarshack-<type>', '<key>', subs).
        const type = /^'sugarshack-([\w-]+)'$/.exec(args[0]);
        assert.ok(type, `${at}: the type is not a literal`);
        const catalog = catalogOf(type[1]);
        found.push({ at, keys: withPlurals(catalog, keys.map((k) => `sugarshack-${type[1]}.${k}`)), subs, stem: type[1], catalog });
      } else if (m[1] === 't') {
        assert.ok(own, `${at}: t() in a file without translator(RED, '<type>') or var NS`);
        const catalog = catalogOf(own.stem);
        found.push({ at, keys: withPlurals(catalog, keys.map((k) => `${own.prefix}.${k}`)), subs, stem: own.stem, catalog });
      } else {
        const prefix = m[1] === 'SugarshackError.of' ? 'sugarshack.errors.' : 'sugarshack.';
        found.push({ at, keys: keys.map((k) => prefix + k), subs, stem: 'interlock', catalog: SHARED_CATALOG });
      }
    }
  }
  return found;
}

function leaves(object, prefix = '') {
  return Object.entries(object).flatMap(([k, v]) => (v && typeof v === 'object' ? leaves(v, `${prefix}${k}.`) : [`${prefix}${k}`]));
}

describe('texts built in JS', function () {
  it('no SugarshackError is worded inline: its text is a catalog key (SugarshackError.of, or t() in a node file)', function () {
    const inline = [];
    let calls = 0;
    for (const { file, source } of sources()) {
      for (const m of source.matchAll(/new SugarshackError\(/g)) {
        calls++;
        const [, message] = callArgs(source, m.index + m[0].length - 1);
        // Texts the core worded (e.message), a catalog text (t(...)), or a variable passing one on.
        if (/^['"`]/.test(message) || /['"`]\s*\+|\+\s*['"`]/.test(message)) inline.push(`${file}: ${source.slice(m.index, m.index + 120)}`);
      }
    }
    assert.ok(calls > 10, `${calls} SugarshackError constructions`);
    assert.deepEqual(inline, []);
  });

  it('every key a lookup reads is in the en-US catalog, with the placeholders the call fills', function () {
    const problems = [];
    const all = lookups();
    assert.ok(all.length > 100, `${all.length} lookups`);
    for (const { at, keys, subs, catalog } of all) {
      if (keys.length === 0) problems.push(`${at}: no literal key`);
      if (subs === null) problems.push(`${at}: placeholders not given as an object literal`);
      const used = new Set();
      for (const key of keys) {
        const text = textAt(catalog, key);
        if (typeof text !== 'string') {
          problems.push(`${at}: ${key} missing`);
          continue;
        }
        const wanted = placeholders(text);
        wanted.forEach((p) => used.add(p));
        const missing = wanted.filter((p) => !(subs || []).includes(p));
        if (missing.length) problems.push(`${at}: ${key} needs ${missing.join(', ')}`);
      }
      const extra = (subs || []).filter((s) => !used.has(s));
      if (extra.length) problems.push(`${at}: gives ${extra.join(', ')}, which no text of ${keys.join(' | ')} reads`);
    }
    assert.deepEqual(problems, []);
  });

  it('every catalog key is read by some code or editor dialog', function () {
    const OPERATION_NODE_KEYS = operationNodeKeys();
    assert.ok(OPERATION_NODE_KEYS.includes('paletteLabel') && OPERATION_NODE_KEYS.includes('placeholder.operation'),
      `operationNode's keys read from resources/editor.js: ${OPERATION_NODE_KEYS}`);
    const read = new Set(lookups().flatMap(({ stem, keys }) => keys.map((k) => `${stem}|${k}`)));
    const readKey = (stem, key) => read.has(`${stem}|${key}`);
    const unused = [];
    for (const file of fs.readdirSync(path.join(NODES, 'locales', 'en-US')).filter((f) => f.endsWith('.json'))) {
      const stem = file.slice(0, -5);
      const html = fs.existsSync(path.join(NODES, `${stem}.html`)) ? readNode(`${stem}.html`) : '';
      // The dialog's data-i18n keys (its this._ calls are lookups, with their plurals).
      const inDialog = new Set(dialogKeys(html.replace(/<script type="text\/javascript">[\s\S]*?<\/script>/g, '')));
      // A dialog built by resources/editor.js's operationNode(verb) reads the keys it names there.
      if (/sugarshackEditor\.operationNode\(/.test(html)) OPERATION_NODE_KEYS.forEach((key) => inDialog.add(`sugarshack-${stem}.${key}`));
      for (const key of leaves(catalogOf(stem))) {
        if (!readKey(stem, key) && !inDialog.has(key)) unused.push(`${file}: ${key}`);
      }
    }
    assert.deepEqual(unused, []);
  });
});

// ---- The editor's node and port labels: catalog texts, not English worded inline.

/** Index of the bracket closing the one at `open` (strings skipped). */
function closing(source, open) {
  return walkBrackets(source, open);
}

const LABEL_PROPERTY = /(?<![\w$])(label|paletteLabel|inputLabels|outputLabels)\s*:\s*/g;

/**
 * The string literals with a letter in them that a label, paletteLabel, inputLabels or outputLabels
 * of `source` gives: past its lookups (this._, node._, t, RED._), and the values it compares with
 * (this.mode === 'all', typeof x === 'object'). A node's own name or ids are properties, not literals.
 */
function inlineLabelTexts(source) {
  const found = [];
  for (const m of source.matchAll(LABEL_PROPERTY)) {
    let at = m.index + m[0].length;
    if (source.startsWith('function', at)) at = source.indexOf('{', at);
    const rest = source.slice(at);
    let value = '([{'.includes(rest[0]) ? rest.slice(0, closing(rest, 0) + 1)
      : /^(?:'(?:[^'\\]|\\.)*'|"(?:[^"\\]|\\.)*"|[^,\n}'"])*/.exec(rest)[0];
    for (let call; (call = /(?<![\w.$])(this\._|node\._|t|RED\._)\(/.exec(value));) {
      const open = call.index + call[0].length - 1;
      value = value.slice(0, call.index) + value.slice(closing(value, open) + 1);
    }
    value = value.replace(/(===?|!==?)\s*(['"])[^'"]*\2|(['"])[^'"]*\3\s*(===?|!==?)/g, '');
    for (const literal of value.matchAll(/'(?:[^'\\]|\\.)*'|"(?:[^"\\]|\\.)*"|`(?:[^`\\]|\\.)*`/g)) {
      if (/[a-z]/i.test(literal[0])) found.push(`${m[1]}: ${literal[0]}`);
    }
  }
  return found;
}

describe('the editor\'s labels', function () {
  it('a node\'s label, palette name and port labels are read from its catalog, not worded inline', function () {
    // The check itself: it finds the forms the labels had, and passes lookups, names, ids and comparisons.
    assert.deepEqual(inlineLabelTexts(`{
      outputLabels: ['granted'],
      inputLabels: 'the rcc node\\'s msg',
      label: function () { if (this.mode === 'all') return 'clear all faulted'; return this.name || 'rcc C' + this.controller; },
    }`), ["outputLabels: 'granted'", "inputLabels: 'the rcc node\\'s msg'", "label: 'clear all faulted'", "label: 'rcc C'"]);
    assert.deepEqual(inlineLabelTexts(`{
      outputLabels: function (i) { return [this._('x.outputLabels.a'), this._('x.outputLabels.b')][i]; },
      label: function () {
        var plant = this.plant && typeof this.plant === 'object' ? this.plant : {};
        if (this.mode === 'all') return this._('x.nodeLabel.all');
        return this.name || plant.name || (this.target === 'http' ? this._('x.nodeLabel.db', { host: this.host || '?' }) : this.id);
      },
    }`), []);

    const inline = [];
    let labels = 0;
    const editorSources = [...editorScripts(), ...sources().filter(({ file }) => file.startsWith('resources/'))];
    for (const { file, source } of editorSources) {
      labels += [...source.matchAll(LABEL_PROPERTY)].length;
      inline.push(...inlineLabelTexts(source).map((text) => `${file}: ${text}`));
    }
    assert.ok(labels > 50, `${labels} label properties`);
    assert.deepEqual(inline, []);
  });
});

// ---- A runtime in another language: the texts change, the codes do not.

describe('texts in the runtime language', function () {
  const helper = require('node-red-node-test-helper');
  const { TAB, interlockConfig, acquire, sinkNode, collect, until, paletteNodes, startServer, stopServer } = require('./support');
  const { SHARED_NAMESPACE } = require(path.join(PALETTE, 'lib', 'host', 'i18n.js'));
  helper.init(require.resolve('node-red'));

  // A "de" catalog as Node-RED would hold it: by namespace, then the key.
  const GERMAN = {
    [SHARED_NAMESPACE]: {
      sugarshack: {
        errors: { priorityNotInteger: '__from__ muss eine ganze Zahl sein, nicht __got__' },
        labels: { configuredPriority: 'die eingestellte Priorität' },
      },
    },
    'sugarshack-fault': { errors: { stopped: '__lines__ ausgefallen (Not-Aus)' } },
  };
  // RED._ as Node-RED's: "ns:key" reads that namespace, a bare key the node set's own; the key when there is no text.
  const germanRED = (key, subs = {}) => {
    const [ns, bare] = key.includes(':') ? key.split(':') : [null, key];
    const text = ns ? textAt(GERMAN[ns] || {}, bare) : textAt(GERMAN, bare);
    return typeof text === 'string' ? text.replace(/__(\w+?)__/g, (w, n) => (n in subs ? String(subs[n]) : w)) : bare;
  };
  const inGerman = paletteNodes.map((init) => (RED) => {
    RED._ = germanRED;
    return init(RED);
  });

  beforeEach(startServer);
  afterEach(stopServer);

  /** Loads acquire 'a', whose priority 'urgent' is refused, with `extra` nodes and a Catch node; resolves with what it caught once 'a' was refused. */
  async function refusedAcquire(nodeSet, extra = []) {
    await helper.load(nodeSet, [
      TAB, interlockConfig(),
      acquire('a', '10', 'urgent', 'YEL', 'out'),
      ...extra,
      { id: 'c1', z: 'f1', type: 'catch', scope: null, uncaught: false, wires: [['caught']] },
      sinkNode('out'), sinkNode('caught'),
    ]);
    const caught = collect(helper, 'caught');
    helper.getNode('a').receive({});
    await until(() => caught.length === 1, 'the refused acquire');
    return caught;
  }

  it('a Catch node gets a lib/ error and a node error in the catalog language, with their codes', async function () {
    const caught = await refusedAcquire(inGerman, [
      { id: 'f', z: 'f1', type: 'sugarshack-fault', interlock: 'il', mode: 'resources', resources: 'GRN', after: 'fail', wires: [['out'], []] },
    ]);
    assert.equal(caught[0].error.code, 'INVALID_PRIORITY');
    assert.equal(caught[0].error.message, 'SugarshackError: die eingestellte Priorität muss eine ganze Zahl sein, nicht "urgent"');

    helper.getNode('f').receive({ resources: 'GRN' });
    await until(() => caught.length === 2, 'the failed fault msg');
    assert.equal(caught[1].error.code, 'FAULTED');
    assert.equal(caught[1].error.message, 'SugarshackError: GRN ausgefallen (Not-Aus)');
  });

  it('without a catalog for the language a text stays in English', async function () {
    const caught = await refusedAcquire(paletteNodes);
    assert.equal(caught[0].error.message, 'SugarshackError: the configured priority must be a whole number, like 5 (higher is more urgent); got "urgent"');
  });
});
