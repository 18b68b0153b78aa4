'use strict';
// The plant document's JSON Schema (node-red-contrib-sugarshack/schema/plant.schema.json, generated
// from the core's types by scripts/build-wasm.sh) against the core itself: every plant document in
// the repository fits it; every document the core refuses for its shape (serde's reading: a wrong
// type, an unknown or missing key) the schema refuses at the same place; and over random changes
// to real documents, whatever the schema refuses the core refuses too, so the two cannot drift.
const assert = require('node:assert/strict');
const fs = require('fs');
const path = require('path');
const os = require('os');
const { execFileSync } = require('child_process');
const Ajv = require('ajv');
const helper = require('node-red-node-test-helper');
const { PALETTE, paletteNodes, startServer, stopServer } = require('./support');

const { validatePlant, PLANT_SCHEMA } = require(path.join(PALETTE, 'lib', 'plant', 'plant.js'));
const { plantReference } = require('../../scripts/docs/plant-reference');

helper.init(require.resolve('node-red'));

const ROOT = path.join(__dirname, '..', '..');
const SCHEMA = JSON.parse(fs.readFileSync(PLANT_SCHEMA, 'utf8'));
// Strict: a keyword ajv does not know is an error, but for the editors' markdown descriptions.
const ajv = new Ajv({ allErrors: true, strict: true, strictTypes: true, allowUnionTypes: true });
ajv.addKeyword('markdownDescription');
const fits = ajv.compile(SCHEMA);

/** Where the schema refuses a document: JSON pointers, an unknown key's own place included; [] when it fits. */
function refusedAt(doc) {
  if (fits(doc)) return [];
  return fits.errors.map((e) => (e.keyword === 'additionalProperties' ? `${e.instancePath}/${e.params.additionalProperty}` : e.instancePath));
}

/** The core's path of a problem (`operations[0].steps[1]`, `actuatorTypes.valve`) as a JSON pointer. */
function pointerOf(corePath) {
  return corePath === '' ? '' : `/${corePath.replace(/\[(\d+)\]/g, '.$1').split('.').join('/')}`;
}

/** Every plant document in the repository's JSON files: whole files, and plant config nodes in flows. */
function repositoryPlants() {
  const files = execFileSync('git', ['ls-files', '*.json'], { cwd: ROOT, encoding: 'utf8' }).split('\n')
    .filter((f) => f && !/(^|\/)(package(-lock)?\.json|locales\/.*)$/.test(f));
  const found = [];
  for (const file of files) {
    const text = fs.readFileSync(path.join(ROOT, file), 'utf8');
    // JSON with comments (tsconfig.json) holds no plant.
    if (!text.includes('actuatorTypes')) continue;
    const value = JSON.parse(text);
    if (value && value.actuatorTypes) found.push({ where: file, doc: value });
    for (const node of Array.isArray(value) ? value : []) {
      if (node && node.type === 'sugarshack-plant') {
        found.push({ where: `${file} (${node.id})`, doc: typeof node.plant === 'string' ? JSON.parse(node.plant) : node.plant });
      }
    }
  }
  return found;
}

const PLANT = JSON.parse(fs.readFileSync(path.join(ROOT, 'flows', 'plant.json'), 'utf8'));
const SMALL = JSON.parse(fs.readFileSync(path.join(ROOT, 'tests', 'integration', 'fixtures', 'plant-small.json'), 'utf8'));

/** A sound document: panel and station, a valve, a pump, a line, an operation of both kinds of step, a routine. */
function sound() {
  return {
    $schema: './node_modules/node-red-contrib-sugarshack/schema/plant.schema.json',
    name: 'schema test',
    actuatorTypes: {
      valve: { signal: 'analog', unit: '%', min: 0, max: 100, tolerance: 3, noMotionMs: 4000, completionMs: 15000, staleMs: 5000, retries: 1, escalation: 'fail-fast' },
      pump: { signal: 'binary', noMotionMs: 4000, completionMs: 6000, staleMs: 5000, reports: 'periodic' },
    },
    devices: [
      { id: 'ctrl-1', kind: 'actuator-panel' },
      { id: 'station-2', kind: 'sensor-station', profile: 'sugarshack' },
      {
        id: 'relay', kind: 'actuator-panel', profile: 'custom',
        custom: {
          status: { topic: '{prefix}/availability', online: 'up', offline: 'down' },
          actuators: { pump: { state: '{prefix}/{entity}', value: 'state', map: { ON: 1, OFF: 0 }, command: '{prefix}/{entity}/set' } },
        },
      },
    ],
    actuators: [
      { id: 'V1', type: 'valve', device: 'ctrl-1', io: 1, idle: 0, lockout: 0, resource: 'YEL' },
      { id: 'P1', type: 'pump', device: 'ctrl-1', io: 1, idle: false, lockout: false, resource: 'YEL' },
      { id: 'P2', type: 'pump', device: 'relay', entity: 'p2', idle: false, lockout: false },
    ],
    sensors: [{ id: 'LT-2', device: 'station-2', name: 'volume', unit: 'L', updateMs: 1000, staleMs: 5000 }],
    resources: [{ id: 'YEL', lockout: { valves: { V1: 0 }, pumps: { P1: false } } }],
    operations: [{
      id: '10', description: 'fill', priority: 20, resources: ['YEL'], steps: [
        { command: { valves: { V1: 100 }, pump: { P1: true } }, timeoutMs: 20000 },
        { wait: '`LT-2` >= 100', sensors: ['LT-2'], timeoutMs: 60000 },
      ],
    }],
    routines: [{
      id: 'r', states: ['a', 'b'], initial: 'a', errorState: 'a', transitions: [
        { from: 'a', to: 'b', operation: '10', trigger: { msg: 'go' } },
        { from: 'b', to: 'a', operation: '10', trigger: { when: '`LT-2` < 10', sensors: ['LT-2'], everyMs: 1000 } },
      ],
    }],
    clockSkewMs: 5000,
    simulation: { tanks: [], transfers: [] },
  };
}

/** `sound()` changed by `change(doc)`. */
function changed(change) {
  const doc = sound();
  change(doc);
  return doc;
}

// Documents the core refuses for their shape, each with what is wrong, as a user would write it.
const WRONG_SHAPES = {
  'an unknown top-level key': (d) => { d.actuatorType = {}; },
  'no devices': (d) => { delete d.devices; },
  'actuatorTypes as a list': (d) => { d.actuatorTypes = [d.actuatorTypes.valve]; },
  '$schema as a number': (d) => { d.$schema = 7; },
  'a signal that is not analog or binary': (d) => { d.actuatorTypes.valve.signal = 'digital'; },
  'an escalation that does not exist': (d) => { d.actuatorTypes.valve.escalation = 'retry'; },
  'reports that do not exist': (d) => { d.actuatorTypes.pump.reports = 'sometimes'; },
  'a negative duration': (d) => { d.actuatorTypes.valve.noMotionMs = -1; },
  'a duration as text': (d) => { d.actuatorTypes.valve.staleMs = '5 s'; },
  'a missing duration': (d) => { delete d.actuatorTypes.pump.completionMs; },
  'negative retries': (d) => { d.actuatorTypes.valve.retries = -1; },
  'retries with a fraction': (d) => { d.actuatorTypes.valve.retries = 1.5; },
  'min as text': (d) => { d.actuatorTypes.valve.min = 'zero'; },
  'a device kind that does not exist': (d) => { d.devices[0].kind = 'panel'; },
  'a profile that does not exist': (d) => { d.devices[0].profile = 'esp-home'; },
  'a device without a kind': (d) => { delete d.devices[1].kind; },
  'an unknown key in a custom actuator': (d) => { d.devices[2].custom.actuators.pump.topic = 'x'; },
  'a custom status without its offline payload': (d) => { delete d.devices[2].custom.status.offline; },
  'a custom map to words': (d) => { d.devices[2].custom.actuators.pump.map.ON = 'on'; },
  'a custom map as null': (d) => { d.devices[2].custom.actuators.pump.map = null; },
  'an actuator with an unknown key': (d) => { d.actuators[0].position = 0; },
  'an io as text': (d) => { d.actuators[0].io = 'one'; },
  'a negative io': (d) => { d.actuators[0].io = -1; },
  'an io beyond 32 bits': (d) => { d.actuators[0].io = 2 ** 32; },
  'a component that does not exist': (d) => { d.actuators[2].component = 'relay'; },
  'a lockout as a word': (d) => { d.actuators[0].lockout = 'closed'; },
  'a lockout as null': (d) => { d.actuators[1].lockout = null; },
  'an idle state as a list': (d) => { d.actuators[0].idle = [0]; },
  'an actuator without a lockout': (d) => { delete d.actuators[0].lockout; },
  'a sensor without a name': (d) => { delete d.sensors[0].name; },
  'a negative updateMs': (d) => { d.sensors[0].updateMs = -5; },
  'a resource lockout that is not a group command': (d) => { d.resources[0].lockout = 5; },
  'a group of a lockout that is not an object': (d) => { d.resources[0].lockout.valves = 0; },
  'a target as a word': (d) => { d.operations[0].steps[0].command.valves.V1 = 'open'; },
  'a target as null': (d) => { d.operations[0].steps[0].command.pump.P1 = null; },
  'a priority as a word': (d) => { d.operations[0].priority = 'high'; },
  'a priority with a fraction': (d) => { d.operations[0].priority = 2.5; },
  'a priority beyond 32 bits': (d) => { d.operations[0].priority = 2 ** 31; },
  'resources as a string': (d) => { d.operations[0].resources = 'YEL'; },
  'an operation without steps': (d) => { delete d.operations[0].steps; },
  'a step with both command and wait': (d) => { d.operations[0].steps[0].wait = 'true'; },
  'a step with neither command nor wait': (d) => { d.operations[0].steps[0] = { timeoutMs: 1000 }; },
  'a command step with sensors': (d) => { d.operations[0].steps[0].sensors = ['LT-2']; },
  'a command step without its timeout': (d) => { delete d.operations[0].steps[0].timeoutMs; },
  'a command as null': (d) => { d.operations[0].steps[0].command = null; },
  'a wait without its sensors': (d) => { delete d.operations[0].steps[1].sensors; },
  'a wait as null': (d) => { d.operations[0].steps[1].wait = null; },
  'a wait as a number': (d) => { d.operations[0].steps[1].wait = 100; },
  'a step with an unknown key': (d) => { d.operations[0].steps[1].timeout = 60; },
  'a routine without an initial state': (d) => { delete d.routines[0].initial; },
  'a trigger with both msg and when': (d) => { d.routines[0].transitions[0].trigger.when = 'true'; },
  'a msg trigger with everyMs': (d) => { d.routines[0].transitions[0].trigger.everyMs = 1000; },
  'a msg trigger with sensors': (d) => { d.routines[0].transitions[0].trigger.sensors = []; },
  'a when trigger without everyMs': (d) => { delete d.routines[0].transitions[1].trigger.everyMs; },
  'an empty trigger': (d) => { d.routines[0].transitions[0].trigger = {}; },
  'a transition with an unknown key': (d) => { d.routines[0].transitions[0].when = 'x'; },
  'clockSkewMs as null': (d) => { d.clockSkewMs = null; },
  'a simulation section that is not an object': (d) => { d.simulation = 42; },
  'a simulation tank with its capacity as text': (d) => { d.simulation.tanks = [{ id: 'T', station: 'station-2', datapoint: 'volume', capacityL: 'big' }]; },
  'a simulation tank with an unknown key': (d) => { d.simulation.tanks = [{ id: 'T', capacityL: 100, volume: 5 }]; },
};

// Documents both read: optional keys given as null or left out, fractions of a millisecond.
const RIGHT_SHAPES = {
  'as it is': () => {},
  'optional keys as null': (d) => {
    Object.assign(d.actuatorTypes.valve, { unit: null, reports: null });
    Object.assign(d.actuators[0], { resource: 'YEL', tolerance: null });
    Object.assign(d.sensors[0], { unit: null, staleMs: null, updateMs: null });
    Object.assign(d.devices[0], { prefix: null, reports: null, custom: null });
    d.resources[0].lockout = null;
    d.routines[0].errorState = null;
    d.name = null;
    d.$schema = null;
  },
  'no optional lists': (d) => { for (const key of ['actuators', 'sensors', 'resources', 'operations', 'routines']) delete d[key]; },
  'fractions of a millisecond': (d) => { d.operations[0].steps[1].timeoutMs = 60000.5; d.clockSkewMs = 0.25; },
  'an empty simulation section': (d) => { d.simulation = {}; },
  'a simulation tank on a station\'s datapoint': (d) => { d.simulation.tanks = [{ id: 'T', station: 'station-2', datapoint: 'volume', capacityL: 100 }]; },
  'an ESPHome device with its entities': (d) => {
    d.devices[0].profile = 'esphome';
    for (const a of d.actuators.filter((x) => x.device === 'ctrl-1')) { delete a.io; a.entity = a.id.toLowerCase(); }
    d.actuators[0].component = 'valve';
  },
};

describe('the plant document\'s JSON Schema', function () {
  it('is draft 7, titled, with a description on every key an editor proposes', function () {
    assert.equal(SCHEMA.$schema, 'http://json-schema.org/draft-07/schema#');
    assert.equal(SCHEMA.title, 'sugarshack plant document');
    assert.deepEqual(SCHEMA.required, ['actuatorTypes', 'devices']);
    assert.match(SCHEMA.definitions.Actuator.properties.lockout.description, /safe state/);
    assert.deepEqual(SCHEMA.definitions.Signal.oneOf.map((v) => v.const), ['analog', 'binary']);
  });

  it('fits every plant document in the repository, which the core reads too', function () {
    const plants = repositoryPlants();
    const where = plants.map((p) => p.where);
    assert.ok(where.includes('flows/plant.json') && where.includes('tests/integration/fixtures/plant-small.json'), where.join(', '));
    assert.ok(where.some((w) => w.startsWith('node-red-contrib-sugarshack/examples/')), where.join(', '));
    assert.ok(plants.length >= 10, `${plants.length} plant documents`);
    const unfit = plants.filter((p) => !fits(p.doc)).map((p) => `${p.where}: ${ajv.errorsText(fits.errors)}`);
    assert.deepEqual(unfit, []);
    const unread = plants.map((p) => ({ where: p.where, answer: validatePlant(p.doc) })).filter((p) => !p.answer.valid);
    assert.deepEqual(unread.map((p) => `${p.where}: ${JSON.stringify(p.answer.errors[0])}`), []);
  });

  it('refuses what the core refuses for its shape, at the place the core names', function () {
    assert.deepEqual(refusedAt(sound()), []);
    assert.equal(validatePlant(sound()).valid, true, JSON.stringify(validatePlant(sound()).errors));
    const disagreements = [];
    for (const [what, change] of Object.entries(WRONG_SHAPES)) {
      const doc = changed(change);
      const core = validatePlant(doc);
      const schema = refusedAt(doc);
      if (core.valid || core.errors.length !== 1) disagreements.push(`${what}: the core ${core.valid ? 'reads it' : `finds ${core.errors.length} problems`}`);
      else if (schema.length === 0) disagreements.push(`${what}: the schema takes it; the core says ${JSON.stringify(core.errors[0])}`);
      else {
        const at = pointerOf(core.errors[0].path);
        if (!schema.some((p) => p === at || p.startsWith(`${at}/`))) disagreements.push(`${what}: the core refuses at ${at}, the schema at ${schema.join(', ')}`);
      }
    }
    assert.deepEqual(disagreements, []);
  });

  it('takes what the core reads', function () {
    const disagreements = [];
    for (const [what, change] of Object.entries(RIGHT_SHAPES)) {
      const doc = changed(change);
      const core = validatePlant(doc);
      if (!core.valid) disagreements.push(`${what}: the core refuses it: ${JSON.stringify(core.errors)}`);
      if (!fits(doc)) disagreements.push(`${what}: the schema refuses it: ${ajv.errorsText(fits.errors)}`);
    }
    assert.deepEqual(disagreements, []);
  });

  it('over random changes to real documents, refuses nothing the core reads', function () {
    // A small seeded generator (xorshift32): the same changes every run.
    let seed = 0x2f6b1a35;
    const random = () => {
      seed ^= seed << 13; seed ^= seed >>> 17; seed ^= seed << 5;
      return (seed >>> 0) / 2 ** 32;
    };
    const pick = (list) => list[Math.floor(random() * list.length)];
    const VALUES = ['', 'x', 'valve', 'on-change', -1, 0, 1, 2.5, 1e9, 2 ** 32, true, false, null, [], ['LT-2'], {}, { valves: { V1: 0 } }];
    /** Every [parent, key] of a document, to change one of them. */
    const places = (value, out = []) => {
      if (value && typeof value === 'object') {
        for (const key of Object.keys(value)) {
          out.push([value, key]);
          places(value[key], out);
        }
      }
      return out;
    };
    let schemaRefused = 0;
    let coreRefused = 0;
    const stricter = [];
    for (let i = 0; i < 600; i++) {
      const doc = structuredClone(pick([sound(), SMALL, PLANT]));
      const [parent, key] = pick(places(doc));
      const how = random();
      if (how < 0.6) parent[key] = structuredClone(pick(VALUES));
      else if (how < 0.8 && !Array.isArray(parent)) delete parent[key];
      else if (!Array.isArray(parent)) parent[`${key}X`] = structuredClone(pick(VALUES));
      const refused = !fits(doc);
      const core = validatePlant(doc);
      if (refused) schemaRefused++;
      if (!core.valid) coreRefused++;
      if (refused && core.valid) stricter.push(`${JSON.stringify(parent).slice(0, 200)}: ${ajv.errorsText(fits.errors)}`);
    }
    assert.deepEqual(stricter.slice(0, 5), []);
    // The changes reach both sides: most are refused, and the core refuses more (it also checks meaning).
    assert.ok(schemaRefused > 200 && coreRefused > schemaRefused, `schema ${schemaRefused}, core ${coreRefused} of 600`);
  });
});

describe('GET /sugarshack/plant/schema', function () {
  beforeEach(startServer);
  afterEach(stopServer);

  it('serves the schema the package ships, for the plant dialog\'s editor', async function () {
    await helper.load(paletteNodes, []);
    const res = await helper.request().get('/sugarshack/plant/schema');
    assert.equal(res.status, 200, res.text);
    assert.match(res.headers['content-type'], /^application\/schema\+json/);
    assert.deepEqual(JSON.parse(res.text), SCHEMA);
  });
});

describe('the plant document\'s reference (scripts/docs/plant-reference.js)', function () {
  it('writes every key of the schema with its meaning, each part a section its links reach', function () {
    const out = path.join(fs.mkdtempSync(path.join(os.tmpdir(), 'sugarshack-reference-')), 'docs', 'plant.md');
    execFileSync(process.execPath, [path.join(ROOT, 'scripts', 'docs', 'plant-reference.js'), out], { encoding: 'utf8' });
    const markdown = fs.readFileSync(out, 'utf8');
    fs.rmSync(path.dirname(path.dirname(out)), { recursive: true });
    assert.equal(markdown, plantReference(SCHEMA));

    const missing = [];
    const parts = [['The document', SCHEMA], ...Object.entries(SCHEMA.definitions)];
    for (const [name, schema] of parts) {
      if (!markdown.includes(`\n## ${name}\n`)) missing.push(`section ${name}`);
      for (const form of schema.anyOf || [schema]) {
        for (const [key, value] of Object.entries(form.properties || {})) {
          const row = markdown.split('\n').find((line) => line.replace(/^ +/, '').startsWith(`| \`${key}\` |`) && line.includes(value.markdownDescription));
          if (!row) missing.push(`${name}.${key}`);
        }
      }
    }
    assert.deepEqual(missing, []);
    const headings = new Set([...markdown.matchAll(/^## (.+)$/gm)].map((m) => m[1].toLowerCase()));
    const links = [...markdown.matchAll(/\]\(#([\w-]+)\)/g)].map((m) => m[1]);
    assert.ok(links.length > 20, `${links.length} links`);
    assert.deepEqual(links.filter((a) => !headings.has(a)), []);
  });
});
