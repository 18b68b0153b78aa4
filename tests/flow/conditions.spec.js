'use strict';
// Conditions are the core's (lib/operations/condition.js only reads sensors and asks it):
// the mistakes a deploy can see are refused there, with their path and in the
// words of the person who wrote them; what the core accepts, Node-RED's own
// JSONata reads and evaluates alike (random conditions of the language against
// random values); and every condition this repository ships is one.
const assert = require('node:assert/strict');
const fs = require('fs');
const path = require('path');
const helper = require('node-red-node-test-helper');
const { paletteNodes, TAB, sinkNode, collect, until, startServer, stopServer, runFor, PALETTE } = require('./support');
const { sensor: sensorOf, stopPanels, fakePlant, fakeValve } = require('./fake-panel');
const wasm = require(path.join(PALETTE, 'lib', 'wasm', 'index.js'));
const jsonata = require('@node-red/util/lib/jsonata');
const { mulberry32 } = require('../../scripts/simulator/random');

helper.init(require.resolve('node-red'));

const ROOT = path.join(__dirname, '..', '..');

function plantDocument(wait = '`LT-3` >= 100') {
  return {
    ...fakePlant([fakeValve('V101', 1, 'YEL')]),
    sensors: [
      { id: 'LT-3', device: 'station-3', name: 'volume' },
      { id: 'FT-3', device: 'station-3', name: 'flow' },
    ],
    resources: [{ id: 'YEL' }],
    operations: [{ id: '10', priority: 20, resources: ['YEL'], steps: [
      { command: { valves: { V101: 100 } }, timeoutMs: 3000 },
      { wait, sensors: ['LT-3'], timeoutMs: 600 },
    ] }],
    routines: [{ id: 'truck', states: ['empty', 'full'], initial: 'empty', transitions: [
      { from: 'empty', to: 'full', operation: '10', trigger: { when: '`LT-3` < 50', sensors: ['LT-3'], everyMs: 1000 } },
    ] }],
  };
}

// The mistakes of a newcomer: an id with a dash without backticks, a typo, and a condition that gives a number.
const MISTAKES = [
  ['LT-3 >= 50', "condition 'LT-3 >= 50': 'LT-3' reads as LT minus 3: write a sensor id that has a dash in backticks, `LT-3` (to subtract, put spaces around the minus)"],
  ['`LT3` >= 50', "condition '`LT3` >= 50': '`LT3`' is not a sensor of the plant; the sensors listed are LT-3 (did you mean `LT-3`?)"],
  ['`LT-3` - 50', "condition '`LT-3` - 50': the condition gives a number, not true or false: compare it, as in `LT-3` - 50 >= 50"],
];

/** The plant, its actuators node, a Catch into sink `caught`, sink `out`, and these wait nodes. */
function loadWaits(...waits) {
  return helper.load(paletteNodes, [
    TAB,
    { id: 'pl', type: 'sugarshack-plant', name: 'plant', plant: plantDocument() },
    { id: 'bus', z: 'f1', type: 'sugarshack-actuators', plant: 'pl', devices: '', wires: [[], [], []] },
    { id: 'c1', z: 'f1', type: 'catch', scope: null, uncaught: false, wires: [['caught']] },
    sinkNode('out'), sinkNode('caught'),
    ...waits,
  ]);
}

describe('conditions at deploy', function () {
  beforeEach(startServer);
  afterEach(async function () {
    stopPanels();
    await stopServer();
  });

  const validate = (plant) => helper.request().post('/sugarshack/plant/validate').send({ plant });

  it('the plant check refuses each condition mistake, naming the step, the condition and the fix', async function () {
    await helper.load(paletteNodes, [TAB, { id: 'pl', type: 'sugarshack-plant', name: 'plant', plant: plantDocument() }]);
    let res = await validate(plantDocument());
    assert.deepEqual(res.body, { valid: true, errors: [], warnings: [] });
    for (const [wait, message] of MISTAKES) {
      res = await validate(plantDocument(wait));
      assert.deepEqual(res.body.errors, [{ path: 'operations[0] (10).steps[1]', message }], wait);
    }
    const doc = plantDocument();
    doc.routines[0].transitions[0].trigger.when = 'LT-3 < 50';
    res = await validate(doc);
    assert.deepEqual(res.body.errors.map((e) => e.path), ['routines[0] (truck).transitions[0]']);
    assert.match(res.body.errors[0].message, /^condition 'LT-3 < 50': 'LT-3' reads as LT minus 3/);
    const unread = plantDocument();
    unread.operations[0].steps[1].sensors = ['LT-3', 'FT-3'];
    res = await validate(unread);
    assert.deepEqual(res.body.warnings, [{
      path: 'operations[0] (10).steps[1]',
      message: "lists sensor 'FT-3', which the condition does not read: the condition holds only while it is fresh too",
    }]);
  });

  it('a deploy with a condition that could never hold is refused before anything runs', async function () {
    await helper.load(paletteNodes, [
      TAB,
      { id: 'pl', type: 'sugarshack-plant', name: 'plant', plant: plantDocument('LT-3 >= 50') },
      { id: 'il', type: 'sugarshack-interlock', name: 'lines', plant: 'pl', resources: [], policy: 'greedy' },
      { id: 'op', z: 'f1', type: 'sugarshack-operation', interlock: 'il', operation: '10', wires: [[]] },
    ]);
    const logged = helper.getNode('pl').error.getCalls().map((c) => String(c.args[0]));
    assert.ok(logged.some((m) => m.includes(`operations[0] (10).steps[1]: ${MISTAKES[0][1]}`)), logged.join('\n'));
  });

  it("a wait node's own condition is read at deploy: a mistake is a red status and every msg is refused with it", async function () {
    const waitNode = (id, condition, sensors = 'LT-3') => ({ id, z: 'f1', type: 'sugarshack-wait', plant: 'pl', condition, sensors, timeout: 5, wires: [['out']] });
    await loadWaits(...MISTAKES.map(([condition], i) => waitNode(`w${i}`, condition)), waitNode('wUnknown', '`LT-3` > 1', 'LT-9'));
    const caught = collect(helper, 'caught');
    for (const [i, [, message]] of MISTAKES.entries()) {
      const node = helper.getNode(`w${i}`);
      const status = node.status.getCalls().map((c) => c.args[0]).at(-1);
      assert.equal(status.fill, 'red', `w${i}`);
      node.receive({ topic: 'go' });
      await until(() => caught.length === i + 1, `the refusal of w${i}`);
      assert.equal(caught[i].error.code, 'INVALID_CONDITION');
      assert.equal(caught[i].error.message, `SugarshackError: ${message}`);
    }
    helper.getNode('wUnknown').receive({});
    await until(() => caught.length === MISTAKES.length + 1, 'the unknown sensor');
    assert.equal(caught.at(-1).error.code, 'UNKNOWN_SENSOR');
  });

  it('arithmetic that meets no number does not hold, and the timeout says where', async function () {
    await loadWaits({ id: 'w', z: 'f1', type: 'sugarshack-wait', plant: 'pl', condition: '100 / `LT-3` * 2 > 1', sensors: 'LT-3', timeout: 1, wires: [['out']] });
    const [out, caught] = [collect(helper, 'out'), collect(helper, 'caught')];
    sensorOf(helper, 0);
    helper.getNode('w').receive({ topic: 'a' });
    await runFor(helper, 1000, { ids: ['pl'] });
    await until(() => caught.length === 1, 'the timeout');
    assert.equal(caught[0].error.code, 'CONDITION_TIMEOUT');
    assert.match(caught[0].error.message, /last check: '100 \/ `LT-3`' gives no finite number with these values/);
    sensorOf(helper, 50);
    helper.getNode('w').receive({ topic: 'b' });
    await until(() => out.length === 1, 'the condition holding');
    assert.deepEqual(out[0].condition.values, { 'LT-3': 50 });
  });
});

describe('conditions across a rebuilt core', function () {
  beforeEach(startServer);
  afterEach(stopServer);

  it('a msg waiting when the plant\'s core is rebuilt (after a trap) goes on once the new core sees the condition hold', async function () {
    await loadWaits({ id: 'w', z: 'f1', type: 'sugarshack-wait', plant: 'pl', condition: '`LT-3` >= 100', sensors: 'LT-3', timeout: 5, wires: [['out']] });
    const [out, caught] = [collect(helper, 'out'), collect(helper, 'caught')];
    sensorOf(helper, 10);
    helper.getNode('w').receive({ topic: 'a' });
    await runFor(helper, 100, { ids: ['pl'] });
    const runtime = helper.getNode('pl').runtime;
    const before = runtime.t;
    runtime.rebuild();
    assert.notEqual(runtime.t, before, 'a new core');
    sensorOf(helper, 150);
    await until(() => out.length === 1, 'the msg going on');
    assert.deepEqual(out[0].condition.values, { 'LT-3': 150 });
    assert.equal(caught.length, 0);
  });
});

// ---- the core against Node-RED's JSONata ---------------------------------------------

/** A seeded generator: the same cases on every run. */
function random(seed) {
  const next = mulberry32(seed);
  const int = (n) => Math.floor(next() * n);
  return { next, int, pick: (list) => list[int(list.length)] };
}

const SENSORS = ['LT-1', 'level', 'tank 2', 'B_2'];
const written = (name) => (/^[A-Za-z_][A-Za-z0-9_]*$/.test(name) ? name : `\`${name}\``);

/** A random condition of the language: text, with needless parentheses and spaces now and then. */
function randomCondition(r, depth = 0) {
  const space = () => r.pick(['', ' ', ' ', '  ']);
  const wrap = (text) => (r.next() < 0.15 ? `(${text})` : text);
  const number = (d) => {
    if (d > 3 || r.next() < 0.35) {
      return r.next() < 0.5 ? written(r.pick(SENSORS)) : String(r.pick([0, 1, 2, 3, 10, 0.5, 1e308, 12000, r.int(1000)]));
    }
    switch (r.int(5)) {
      case 0: return `-(${number(d + 1)})`;
      case 1: return `(${number(d + 1)} ${r.pick(['+', '-', '*', '/', '%'])} ${number(d + 1)})`;
      case 2: return `$${r.pick(['abs', 'floor', 'ceil'])}(${number(d + 1)})`;
      case 3: return `$${r.pick(['min', 'max'])}([${Array.from({ length: 1 + r.int(3) }, () => number(d + 1)).join(', ')}])`;
      default: {
        // Glued to a name, '-' would be refused as an id with a dash (JSONata reads LT-1 as LT minus 1).
        const op = r.pick(['+', '-', '*', '/', '%']);
        const gap = op === '-' ? ' ' : space();
        return wrap(`${number(d + 1)}${gap}${op}${gap}${number(d + 1)}`);
      }
    }
  };
  if (depth > 2 || r.next() < 0.4) {
    if (r.next() < 0.1) return r.pick(['true', 'false']);
    return wrap(`${number(0)}${space()}${r.pick(['<', '<=', '>', '>=', '=', '!='])}${space()}${number(0)}`);
  }
  switch (r.int(4)) {
    case 0: return `$not(${randomCondition(r, depth + 1)})`;
    case 1: return `(${randomCondition(r, depth + 1)}) ${r.pick(['=', '!='])} (${randomCondition(r, depth + 1)})`;
    default: return wrap(`${randomCondition(r, depth + 1)} ${r.pick(['and', 'or'])} ${randomCondition(r, depth + 1)}`);
  }
}

/** JSONata's answer: true, false, or 'error'. */
async function jsonataSays(text, input) {
  try {
    return await jsonata(text).evaluate(input);
  } catch {
    return 'error';
  }
}

describe('conditions: the core agrees with JSONata', function () {
  this.timeout(60000);
  let t;
  let sensors;
  before(function () {
    const { Tracker } = wasm.load();
    t = new Tracker({
      actuatorTypes: {},
      devices: [{ id: 's', kind: 'sensor-station' }],
      sensors: SENSORS.map((id, i) => ({ id, device: 's', name: `n${i}` })),
    }, 0);
    sensors = Uint32Array.from(SENSORS, (id) => t.sensor(id));
  });
  after(() => t.free());

  /** The core's answer for `text` over `values`: true, false, 'error' (no number), or null when refused. */
  function coreSays(text, values) {
    let handle;
    try {
      handle = t.condition(text, SENSORS);
    } catch (err) {
      assert.equal(err.code, 'INVALID_CONDITION', `${text}: ${err.message}`);
      return null;
    }
    values.forEach((value, i) => t.recordSensor(sensors[i], value, undefined, 0));
    const check = t.checkCondition(handle, sensors, 0);
    assert.ok(check.values, `${text}: every sensor fresh (${check.reason})`);
    // Not met: its values (false), or arithmetic that gave no number (JSONata's error).
    return check.met || (/gives no finite number/.test(check.reason) ? 'error' : false);
  }

  const randomValues = (r) => SENSORS.map(() => r.pick([0, -0, 1, 2, -3, 0.5, 12000, 1e308, -1e308, r.next() * 2000 - 1000]));
  const inputOf = (values) => Object.fromEntries(SENSORS.map((id, i) => [id, values[i]]));

  it('gives what JSONata gives on 2000 random conditions of the language and random values', async function () {
    const r = random(26);
    let held = 0;
    let errors = 0;
    for (let i = 0; i < 2000; i++) {
      const text = randomCondition(r);
      const values = randomValues(r);
      const core = coreSays(text, values);
      assert.notEqual(core, null, `the core refused a condition of its own language: ${text}`);
      const reference = await jsonataSays(text, inputOf(values));
      assert.equal(core, reference, `${text} with ${JSON.stringify(values)}`);
      if (core === true) held++;
      if (core === 'error') errors++;
    }
    assert.ok(held > 300 && errors > 10, `${held} held, ${errors} met no number: both sides of each rule were tried`);
  });

  it('whatever text of JSONata tokens the core reads, JSONata reads and evaluates alike', async function () {
    const r = random(2026);
    const TOKENS = ['`LT-1`', 'level', 'B_2', '`tank 2`', '1', '0', '2.5', '-', '+', '*', '/', '%', '=', '!=', '<', '<=', '>', '>=',
      'and', 'or', '(', ')', '$not(', '$abs(', '$max([', '])', ',', 'true', 'false'];
    let read = 0;
    for (let i = 0; i < 40000; i++) {
      const text = Array.from({ length: 1 + r.int(7) }, () => r.pick(TOKENS)).join(r.pick([' ', ' ', '']));
      const values = randomValues(r);
      const core = coreSays(text, values);
      if (core === null) continue;
      read++;
      assert.equal(core, await jsonataSays(text, inputOf(values)), `${text} with ${JSON.stringify(values)}`);
    }
    assert.ok(read > 300, `${read} texts read`);
  });

  it('refuses what JSONata reads another way or cannot give true or false for', async function () {
    for (const text of ['LT-1 >= 50', '`LT1` >= 50', '`LT-1`', '1 < `LT-1` < 5', '`LT-1` > 1 = 1', '"LT-1" > 1']) {
      assert.equal(coreSays(text, [60, 1, 1, 1]), null, text);
      const reference = await jsonataSays(text, inputOf([60, 1, 1, 1]));
      assert.notEqual(reference, true, `${text}: JSONata gives ${reference}, never the intended true`);
    }
  });
});

// ---- every condition shipped -------------------------------------------------------

/** Files that hold conditions: flows, examples, fixtures, docs and node help. */
function shippedFiles() {
  const out = [];
  const walk = (dir) => {
    for (const entry of fs.readdirSync(dir, { withFileTypes: true })) {
      if (['node_modules', 'target', '.git', 'wasm'].includes(entry.name)) continue;
      const file = path.join(dir, entry.name);
      if (entry.isDirectory()) walk(file);
      else if (/\.(json|md|html)$/.test(entry.name)) out.push(file);
    }
  };
  for (const dir of ['flows', 'docs', 'tests', 'scripts', path.join('node-red-contrib-sugarshack', 'examples'), path.join('node-red-contrib-sugarshack', 'nodes')]) {
    if (fs.existsSync(path.join(ROOT, dir))) walk(path.join(ROOT, dir));
  }
  for (const file of ['README.md', 'CONTRIBUTING.md', path.join('node-red-contrib-sugarshack', 'README.md')]) {
    if (fs.existsSync(path.join(ROOT, file))) out.push(path.join(ROOT, file));
  }
  return out;
}

/** (condition, sensors) pairs: steps and triggers of plant documents, wait nodes and condition steps. */
function conditionsIn(file) {
  const text = fs.readFileSync(file, 'utf8');
  const found = [];
  const names = (sensors) => (Array.isArray(sensors) ? sensors : String(sensors).split(',').map((s) => s.trim()).filter(Boolean));
  if (file.endsWith('.json')) {
    let doc;
    try {
      doc = JSON.parse(text);
    } catch {
      return found;
    }
    const walk = (value) => {
      if (!value || typeof value !== 'object') return;
      if (Array.isArray(value)) return value.forEach(walk);
      const condition = value.wait ?? value.when ?? (/^sugarshack-(wait|condition-step)$/.test(value.type) ? value.condition : undefined);
      if (typeof condition === 'string' && value.sensors !== undefined) found.push([condition, names(value.sensors)]);
      Object.values(value).forEach(walk);
    };
    walk(doc);
  } else {
    const unescape = (s) => s.replace(/&lt;/g, '<').replace(/&gt;/g, '>').replace(/&amp;/g, '&').replace(/\\"/g, '"');
    for (const m of text.matchAll(/"(?:wait|when)":\s*"((?:[^"\\]|\\.)*)",\s*"sensors":\s*\[([^\]]*)\]/g)) {
      found.push([unescape(m[1]), [...m[2].matchAll(/"([^"]+)"/g)].map((n) => n[1])]);
    }
  }
  return found;
}

describe('conditions: every one this repository ships', function () {
  it('is read by the core: in plant documents, wait nodes, condition steps, docs and help', function () {
    const { Tracker } = wasm.load();
    let count = 0;
    const refused = [];
    for (const file of shippedFiles()) {
      for (const [condition, sensors] of conditionsIn(file)) {
        if (/\$\{|__/.test(condition) || sensors.length === 0 && !/^(true|false)$/.test(condition)) continue; // a template, not a condition
        count++;
        const t = new Tracker({
          actuatorTypes: {},
          devices: [{ id: 's', kind: 'sensor-station' }],
          sensors: [...new Set(sensors)].map((id, i) => ({ id, device: 's', name: `n${i}` })),
        }, 0);
        try {
          t.condition(condition, sensors);
        } catch (err) {
          refused.push(`${path.relative(ROOT, file)}: ${err.message}`);
        } finally {
          t.free();
        }
      }
    }
    assert.deepEqual(refused, []);
    assert.ok(count > 100, `${count} conditions found`);
  });
});
