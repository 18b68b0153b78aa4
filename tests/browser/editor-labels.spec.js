'use strict';
// The Node-RED editor in headless Chromium, with a deployed flow holding every
// node of the palette: node labels (with the interlock's and plant's plurals),
// port labels (the tooltip drawn on hovering a port, and every port's text),
// palette names, dialogs' placeholders, options and tips, and the plant's validation texts come
// out in English, read from the catalogs (nodes/locales/en-US/*.json).
const assert = require('node:assert/strict');
const { openEditor, trayOpened } = require('./editor');

const resources = (names) => names.map((name) => ({ name, lockout: { valves: { [`${name}-V1`]: 0 } } }));
const plantDocument = (actuators) => ({
  actuatorTypes: { valve: { signal: 'analog', unit: '%', min: 0, max: 100, tolerance: 3, noMotionMs: 4000, completionMs: 15000, staleMs: 5000, retries: 1 } },
  devices: [{ id: 'ctrl-1', kind: 'actuator-panel' }],
  actuators: actuators.map((id, i) => ({ id, type: 'valve', device: 'ctrl-1', io: i + 1, idle: 0, lockout: 0 })),
});
const node = (id, type, x, y, extra) => ({ id, type, z: 'f1', x, y, wires: [], ...extra });

const FLOW = [
  { id: 'f1', type: 'tab', label: 'labels' },
  { id: 'pl1', type: 'sugarshack-plant', name: '', plant: plantDocument(['V1']) },
  { id: 'pl2', type: 'sugarshack-plant', name: '', plant: plantDocument(['V1', 'V2']) },
  { id: 'il1', type: 'sugarshack-interlock', name: '', resources: resources(['YEL']), policy: 'greedy', persist: false },
  { id: 'il3', type: 'sugarshack-interlock', name: '', resources: resources(['YEL', 'GRN', 'RED']), policy: 'greedy', persist: false },
  { id: 'ilp', type: 'sugarshack-interlock', name: '', plant: 'pl2', resources: [], policy: 'greedy', persist: false },
  node('acq10', 'sugarshack-acquire', 120, 60, { interlock: 'il3', operation: '10', priority: 0, resources: 'YEL', timeout: 0, wires: [[]] }),
  node('acq', 'sugarshack-acquire', 120, 120, { interlock: 'il3', operation: '', priority: 0, resources: '', timeout: 0, wires: [[]] }),
  node('acqNamed', 'sugarshack-acquire', 120, 180, { name: 'fill the tank', interlock: 'il3', operation: '3', wires: [[]] }),
  node('rel7', 'sugarshack-release', 120, 240, { interlock: 'il3', operation: '7', wires: [[]] }),
  node('can', 'sugarshack-cancel', 120, 300, { interlock: 'il3', operation: '', wires: [[]] }),
  node('clrAll', 'sugarshack-clear', 120, 360, { interlock: 'il3', mode: 'all', resources: '', wires: [[], []] }),
  node('clrYel', 'sugarshack-clear', 120, 420, { interlock: 'il3', mode: 'resources', resources: 'YEL', wires: [[], []] }),
  node('clr', 'sugarshack-clear', 120, 480, { interlock: 'il3', mode: 'resources', resources: '', wires: [[], []] }),
  node('flt12', 'sugarshack-fault', 120, 540, { interlock: 'il3', mode: 'operation', operation: '12', after: 'send', wires: [[], []] }),
  node('flt', 'sugarshack-fault', 120, 600, { interlock: 'il3', mode: 'operation', operation: '', after: 'send', wires: [[], []] }),
  node('estop', 'sugarshack-fault', 120, 660, { interlock: 'il3', mode: 'resources', resources: 'YEL,RED', after: 'send', wires: [[], []] }),
  node('estop0', 'sugarshack-fault', 120, 720, { interlock: 'il3', mode: 'resources', resources: '', after: 'send', wires: [[], []] }),
  node('evt', 'sugarshack-interlock-events', 420, 60, { interlock: 'il1', wires: [[]] }),
  node('act1', 'sugarshack-actuators', 420, 120, { plant: 'pl2', devices: 'ctrl-1', wires: [[], [], []] }),
  node('act', 'sugarshack-actuators', 420, 180, { plant: 'pl2', devices: '', wires: [[], [], []] }),
  node('gc', 'sugarshack-group-command', 420, 240, { plant: 'pl2', timeout: 0, wires: [[]] }),
  node('op12', 'sugarshack-operation', 420, 300, { interlock: 'ilp', operation: '12', wires: [[]] }),
  node('op', 'sugarshack-operation', 420, 360, { interlock: 'ilp', operation: '', wires: [[]] }),
  node('wt', 'sugarshack-wait', 420, 420, { plant: 'pl2', condition: '', sensors: 'LT-3', timeout: 60, wires: [[]] }),
  node('rtTruck', 'sugarshack-routine', 420, 480, { interlock: 'ilp', routine: 'truck', wires: [[]] }),
  node('rt', 'sugarshack-routine', 420, 540, { interlock: 'ilp', routine: '', wires: [[]] }),
  node('pid', 'sugarshack-pid', 420, 600, { setpoint: 50, kp: 1, ti: 10, td: 0, outMin: 0, outMax: 100, ts: 1, wires: [[]] }),
  node('rcc', 'sugarshack-rcc', 420, 660, { controller: 2, thresholdsS: '1, 2', tsS: 0.5, wires: [[]] }),
  node('rccio', 'sugarshack-rcc-io', 420, 720, { controllers: 2, initialAction: 0, periodS: 0.5, wires: [[], []] }),
  node('jf', 'sugarshack-journal', 720, 60, { target: 'files', dir: '', filesMB: 1, wires: [[]] }),
  node('jh', 'sugarshack-journal', 720, 120, { target: 'http', host: 'questdb', port: 9, wires: [[]] }),
  node('jh0', 'sugarshack-journal', 720, 180, { target: 'http', host: '', port: 9, wires: [[]] }),
  node('st', 'sugarshack-state', 720, 240, { onChange: true, intervalS: 1, wires: [[]] }),
];

// Every label the editor draws for the flow above, in English, as it read when the texts were inline.
const LABELS = {
  pl1: 'plant (1 actuator)',
  pl2: 'plant (2 actuators)',
  il1: 'interlock (1 resource)',
  il3: 'interlock (3 resources)',
  ilp: 'interlock (from plant)',
  acq10: 'acquire 10',
  acq: 'acquire',
  acqNamed: 'fill the tank',
  rel7: 'release 7',
  can: 'cancel',
  clrAll: 'clear all faulted',
  clrYel: 'clear YEL',
  clr: 'clear',
  flt12: 'fault 12',
  flt: 'fault',
  estop: 'e-stop YEL,RED',
  estop0: 'e-stop',
  evt: 'interlock events',
  act1: 'actuators ctrl-1',
  act: 'actuators',
  gc: 'group command',
  op12: 'operation 12',
  op: 'operation',
  wt: 'condition wait',
  rtTruck: 'routine truck',
  rt: 'routine',
  pid: 'pid sp 50',
  rcc: 'rcc C2',
  rccio: 'rcc i/o (2)',
  jf: 'journal (local files)',
  jh: 'journal → questdb',
  jh0: 'journal → ?',
  st: 'plant state',
};

// Port labels by type: [inputs], [outputs] (null: the port has none).
const PORTS = {
  'sugarshack-acquire': [[null], ['granted']],
  'sugarshack-release': [[null], [null]],
  'sugarshack-cancel': [[null], [null]],
  'sugarshack-clear': [[null], ['cleared', 'refused (reasons)']],
  'sugarshack-fault': [[null], ['msg', 'lockout commands']],
  'sugarshack-interlock-events': [[], ['event records']],
  'sugarshack-actuators': [['device feedback (mqtt in) and group commands'], ['MQTT commands (to mqtt out)', 'completed group commands', 'events and metrics']],
  'sugarshack-group-command': [['group command'], ['completed']],
  'sugarshack-operation': [['start, or hold · restart · stop · abort · reset'], ['completed']],
  'sugarshack-wait': [['msg to hold'], ['condition met']],
  'sugarshack-routine': [['trigger (msg.topic), or hold · restart · stop · abort · reset'], ['state events']],
  'sugarshack-pid': [['measurement, set point, mode, tunings, limits, or the rcc node\'s msg'], ['output (msg.payload) with msg.pid']],
  'sugarshack-rcc': [['I/O state { procVar, lastAction, agesMs }'], ['measurement with msg.rcc, to a pid node']],
  'sugarshack-rcc-io': [['measurement (topic "measurement") or a controller\'s write'], ['state { procVar, lastAction, agesMs }, every period', 'action, to the actuator']],
  'sugarshack-journal': [['operator note'], ['the msg, with msg.journal']],
  'sugarshack-state': [[null], ['the plant state']],
};

const PALETTE_LABELS = {
  'sugarshack-acquire': 'acquire',
  'sugarshack-actuators': 'actuators',
  'sugarshack-cancel': 'cancel',
  'sugarshack-clear': 'clear',
  'sugarshack-fault': 'fault',
  'sugarshack-group-command': 'group command',
  'sugarshack-interlock': 'interlock',
  'sugarshack-interlock-events': 'interlock events',
  'sugarshack-journal': 'journal',
  'sugarshack-operation': 'operation',
  'sugarshack-pid': 'pid',
  'sugarshack-plant': 'plant',
  'sugarshack-rcc': 'rcc',
  'sugarshack-rcc-io': 'rcc i/o',
  'sugarshack-release': 'release',
  'sugarshack-routine': 'routine',
  'sugarshack-state': 'plant state',
  'sugarshack-wait': 'condition wait',
};

describe('the editor\'s labels in headless Chromium', function () {
  this.timeout(180000);
  let editor; let page;

  before(async function () {
    editor = await openEditor({ flows: FLOW, tag: 'editor-labels', readyNode: 'acq10' });
    page = editor.page;
  });

  after(async function () {
    if (editor) await editor.close(this.currentTest);
  });

  it('labels every node and config node as before, with the plural of the interlock\'s resources and the plant\'s actuators', async function () {
    const labels = await page.evaluate((ids) => Object.fromEntries(ids.map((id) => [id, RED.utils.getNodeLabel(RED.nodes.node(id))])), Object.keys(LABELS));
    assert.deepEqual(labels, LABELS);
    // As drawn on the workspace.
    const drawn = await page.$eval('[id="acq10"] .red-ui-flow-node-label', (el) => el.textContent);
    assert.equal(drawn, 'acquire 10');
  });

  it('gives every port its label, and shows it as the tooltip on hovering the port', async function () {
    const ports = await page.evaluate((types) => {
      const label = (n, labels, i) => {
        if (typeof labels === 'string') return labels;
        if (typeof labels === 'function') return labels.call(n, i);
        return Array.isArray(labels) ? labels[i] : labels;
      };
      const out = {};
      for (const type of types) {
        const n = RED.nodes.filterNodes({ type })[0];
        const def = RED.nodes.getType(type);
        const inputs = Array.from({ length: def.inputs || 0 }, (_, i) => label(n, def.inputLabels, i) ?? null);
        const outputs = Array.from({ length: n.outputs }, (_, i) => label(n, def.outputLabels, i) ?? null);
        out[type] = [inputs, outputs];
      }
      return out;
    }, Object.keys(PORTS));
    assert.deepEqual(ports, PORTS);

    const port = await page.$('[id="act1"] .red-ui-flow-port-output:nth-of-type(1) .red-ui-flow-port, [id="act1"] .red-ui-flow-port-output .red-ui-flow-port');
    assert.ok(port, 'the actuators node draws its output ports');
    await port.hover();
    await page.waitForSelector('.red-ui-flow-port-tooltip', { timeout: 5000 });
    const tooltip = await page.$eval('.red-ui-flow-port-tooltip', (el) => el.textContent);
    assert.equal(tooltip, 'MQTT commands (to mqtt out)');
  });

  it('names every type in the palette', async function () {
    const names = await page.evaluate((types) => Object.fromEntries(types.map((type) => {
      const def = RED.nodes.getType(type);
      return [type, typeof def.paletteLabel === 'function' ? def.paletteLabel.call(def) : def.paletteLabel];
    })), Object.keys(PALETTE_LABELS));
    assert.deepEqual(names, PALETTE_LABELS);
  });

  it('fills a dialog\'s placeholders, options and tips, and checks a plant document\'s shape in English', async function () {
    await page.evaluate(() => RED.editor.edit(RED.nodes.node('acq10')));
    await page.waitForSelector('#node-input-operation + .red-ui-typedInput-container', { visible: true, timeout: 10000 });
    const placeholders = await page.evaluate(() => ['operation', 'priority', 'resources', 'timeout']
      .map((f) => $(`#node-input-${f}`).attr('placeholder')));
    const dialog = await page.evaluate(() => $('#dialog-form').text().replace(/\s+/g, ' ').trim());
    await page.evaluate(() => RED.tray.close());
    assert.deepEqual(placeholders, ['id, e.g. 12 (or msg.operation)', '0', 'YEL,RED (or msg.resources)', '0']);
    assert.match(dialog, /^Interlock .* Operation Priority higher = more urgent Resources YELGRNRED Timeout s \(0 = wait forever\) Name$/);

    // A tip with markup, from the catalog.
    await page.evaluate(() => RED.editor.editConfig('', 'sugarshack-interlock', 'il1'));
    await page.waitForSelector('#node-config-input-policy', { visible: true, timeout: 10000 });
    const interlock = await page.evaluate(() => ({
      policies: $('#node-config-input-policy option').toArray().map((o) => o.textContent),
      tip: $('#node-config-dialog-edit-form .form-tips').last().html(),
    }));
    await page.evaluate(() => RED.tray.close());
    assert.deepEqual(interlock.policies, ['greedy: grant every waiter that fits', 'no overtaking: never starve a waiter']);
    assert.equal(interlock.tip, 'Persisted, the state is written to <code>sugarshack/</code> in the Node-RED user directory '
      + 'before any grant, lockout or clear leaves the node, whatever context store is configured.');

    const checks = await page.evaluate(() => {
      const plant = RED.nodes.getType('sugarshack-plant').defaults.plant;
      const n = RED.nodes.node('pl1');
      let notJson = null;
      try { JSON.parse('{'); } catch (e) { notJson = e.message; }
      return {
        starterName: plant.value.name,
        notJson: [plant.validate.call(n, '{'), notJson],
        answers: ['[]', '{}', '{"actuatorTypes":{}}', '{"actuatorTypes":{},"devices":[],"actuators":1}', '{"actuatorTypes":{},"devices":[]}']
          .map((text) => plant.validate.call(n, text)),
        // A blank Smith setting takes the core's default; a wrong one is marked.
        pid: ['alpha', 'horizon', 'maxSamples'].map((field) => {
          const { validate } = RED.nodes.getType('sugarshack-pid').defaults[field];
          return ['', '0', '-1'].map((v) => validate.call({ smith: 'adaptive' }, v));
        }),
      };
    });
    assert.deepEqual(checks.pid, [[true, false, false], [true, true, false], [true, false, false]]);
    assert.equal(checks.starterName, 'sugar shack');
    assert.equal(checks.notJson[0], `the plant document is not valid JSON: ${checks.notJson[1]}`);
    assert.deepEqual(checks.answers, [
      'the plant document must be a JSON object',
      'the plant document needs "actuatorTypes"',
      'the plant document needs a "devices" list',
      '"actuators" must be a list',
      true,
    ]);
  });

  it('shows the runtime\'s check of a plant document in the dialog, with the plural of the problems', async function () {
    await page.evaluate(() => RED.editor.editConfig('', 'sugarshack-plant', 'pl1'));
    await page.waitForFunction(() => RED.nodes.node('pl1').editor && $('#sugarshack-plant-check').is(':visible'), { timeout: 10000 });
    const checked = async (doc) => {
      await page.evaluate((text) => {
        $('#sugarshack-plant-problem').empty();
        RED.nodes.node('pl1').editor.setValue(text);
        $('#sugarshack-plant-check').trigger('click');
      }, JSON.stringify(doc));
      await page.waitForFunction(() => $('#sugarshack-plant-problem').text() !== '', { timeout: 10000 });
      return page.$eval('#sugarshack-plant-problem', (el) => el.innerText);
    };
    const fine = await checked(plantDocument(['V1']));
    const twoUnknownTypes = plantDocument(['V1', 'V2']);
    twoUnknownTypes.actuators.forEach((a) => { a.type = 'nope'; });
    const wrong = await checked(twoUnknownTypes);
    await page.evaluate(() => RED.tray.close());
    assert.equal(fine, 'no problems found');
    const [, count] = /^(\d+) problems \(a deploy refuses the document\):\n/.exec(wrong) || [];
    assert.ok(Number(count) >= 2, wrong);
  });

  it('reads the labels from the catalog of the editor\'s language', async function () {
    // A German catalog for two sets, as the editor holds catalogs once Node-RED has served them ("_plural" is "_other" by then).
    const german = await page.evaluate(async () => {
      i18next.addResourceBundle('de', 'node-red-contrib-sugarshack/acquire', { 'sugarshack-acquire': {
        nodeLabel: { operation: 'belegen __operation__' }, outputLabels: { granted: 'zugeteilt' } } }, true, true);
      i18next.addResourceBundle('de', 'node-red-contrib-sugarshack/interlock', { 'sugarshack-interlock': {
        nodeLabel: { resources: 'Verriegelung (__count__ Ressource)', resources_other: 'Verriegelung (__count__ Ressourcen)' } } }, true, true);
      await i18next.changeLanguage('de');
      const def = RED.nodes.getType('sugarshack-acquire');
      const read = {
        acq10: RED.utils.getNodeLabel(RED.nodes.node('acq10')),
        granted: def.outputLabels.call(RED.nodes.node('acq10'), 0),
        il1: RED.utils.getNodeLabel(RED.nodes.node('il1')),
        il3: RED.utils.getNodeLabel(RED.nodes.node('il3')),
        // Not in the German catalog: en-US.
        acq: RED.utils.getNodeLabel(RED.nodes.node('acq')),
      };
      await i18next.changeLanguage('en-US');
      return read;
    });
    assert.deepEqual(german, {
      acq10: 'belegen 10', granted: 'zugeteilt', il1: 'Verriegelung (1 Ressource)', il3: 'Verriegelung (3 Ressourcen)', acq: 'acquire',
    });
  });

  it('offers the release, cancel, fault and clear values from msg, flow, global, env or JSONata, and saves where each comes from', async function () {
    // Each node of a flow saved before the sources (no *Type): its dialog opens on the literal, and the picker still marks its lines.
    const fields = [['rel7', 'operation', '7'], ['can', 'operation', ''], ['flt12', 'operation', '12'], ['estop', 'resources', 'YEL,RED'], ['clrYel', 'resources', 'YEL']];
    for (const [id, field, literal] of fields) {
      await page.evaluate((n) => RED.editor.edit(RED.nodes.node(n)), id);
      const input = `#node-input-${field}`;
      await page.waitForSelector(`${input} + .red-ui-typedInput-container`, { visible: true, timeout: 10000 });
      await trayOpened(page);
      const opened = await page.evaluate((sel) => [$(sel).typedInput('type'), $(sel).typedInput('value')], input);
      assert.deepEqual(opened, ['str', literal], id);
      if (field === 'resources') {
        const marked = await page.evaluate(() => $('.form-row:visible button.selected').toArray().map((b) => b.textContent));
        assert.deepEqual(marked, literal.split(','), `${id}: the picker marks the literal lines`);
      }
      await page.$eval(`${input} + .red-ui-typedInput-container .red-ui-typedInput-type-select`, (el) => el.click());
      await page.waitForFunction(() => $('.red-ui-typedInput-options:visible').length === 1, { timeout: 10000 });
      const offered = await page.$$eval('.red-ui-typedInput-options a', (els) => els.filter((e) => e.offsetParent).map((e) => e.innerText.trim()));
      await page.keyboard.press('Escape');
      assert.deepEqual(offered, ['string', 'msg.', 'flow.', 'global.', 'env variable', 'expression'], id);
      await page.evaluate((sel) => {
        $(sel).typedInput('type', 'jsonata');
        $(sel).typedInput('value', 'payload.x');
        $('#node-dialog-ok').trigger('click');
      }, input);
      await page.waitForFunction(() => !$('#node-dialog-ok').is(':visible'), { timeout: 10000 });
      const saved = await page.evaluate((n, f) => [RED.nodes.node(n)[f], RED.nodes.node(n)[`${f}Type`]], id, field);
      assert.deepEqual(saved, ['payload.x', 'jsonata'], id);
    }
  });
});
