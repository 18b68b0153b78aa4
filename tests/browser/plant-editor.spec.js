'use strict';
// The plant document in the real Node-RED editor (headless Chromium): the plant dialog's Monaco
// editor reads the plant document's JSON Schema (generated from the core's types): typing inside
// "actuators" proposes an actuator's keys, hovering a key shows its description, a wrong type is
// marked as it is typed, also in a document that names its "$schema" for VS Code; the problem list
// stays within the dialog however long it is. The operation, routine and condition wait nodes offer
// the plant's operations, routines and sensors, and still take an id typed.
const assert = require('node:assert/strict');
const fs = require('fs');
const path = require('path');
const { openEditor, trayOpened } = require('./editor');

const PALETTE = path.join(__dirname, '..', '..', 'node-red-contrib-sugarshack');
const SCHEMA = JSON.parse(fs.readFileSync(path.join(PALETTE, 'schema', 'plant.schema.json'), 'utf8'));
const catalog = (stem) => JSON.parse(fs.readFileSync(path.join(PALETTE, 'nodes', 'locales', 'en-US', `${stem}.json`), 'utf8'));

const PLANT = {
  actuatorTypes: { valve: { signal: 'analog', unit: '%', noMotionMs: 4000, completionMs: 15000, staleMs: 5000 } },
  devices: [{ id: 'ctrl-1', kind: 'actuator-panel' }, { id: 'station-3', kind: 'sensor-station' }],
  actuators: [{ id: 'V1', type: 'valve', device: 'ctrl-1', io: 1, idle: 0, lockout: 0, resource: 'YEL' }],
  sensors: [{ id: 'LT-3', device: 'station-3', name: 'volume', unit: 'L' }, { id: 'FT-3', device: 'station-3', name: 'flow' }],
  resources: [{ id: 'YEL' }],
  operations: [
    { id: '10', description: 'fill the tank', priority: 1, resources: ['YEL'], steps: [{ command: { valves: { V1: 100 } }, timeoutMs: 20000 }] },
    { id: '12', priority: 2, resources: ['YEL'], steps: [{ wait: '`LT-3` > 100', sensors: ['LT-3'], timeoutMs: 60000 }] },
  ],
  routines: [{ id: 'truck', states: ['idle', 'busy'], initial: 'idle', transitions: [{ from: 'idle', to: 'busy', operation: '10', trigger: { msg: 'go' } }] }],
};

const node = (id, type, y, extra) => ({ id, type, z: 'f1', x: 150, y, wires: [[]], ...extra });
const FLOW = [
  { id: 'f1', type: 'tab', label: 'plant editor' },
  { id: 'pl', type: 'sugarshack-plant', name: '', plant: PLANT },
  { id: 'il', type: 'sugarshack-interlock', name: '', plant: 'pl', resources: [], policy: 'greedy', persist: false },
  node('op', 'sugarshack-operation', 60, { interlock: 'il', operation: '12' }),
  node('rt', 'sugarshack-routine', 120, { interlock: 'il', routine: '' }),
  node('wt', 'sugarshack-wait', 180, { plant: 'pl', condition: '`LT-3` > 100', sensors: 'LT-3', timeout: 60 }),
];

describe('the plant document in the editor (headless Chromium)', function () {
  this.timeout(180000);
  let editor; let page;

  before(async function () {
    editor = await openEditor({ flows: FLOW, tag: 'plant-editor', readyNode: 'op' });
    page = editor.page;
  });

  after(async function () {
    if (editor) await editor.close(this.currentTest);
  });

  afterEach(async function () {
    await page.evaluate(() => { if (RED.tray) RED.tray.close(); });
    await page.waitForFunction(() => !$('.red-ui-tray').length, { timeout: 10000 });
  });

  /** Opens the plant dialog once its editor checks against the schema (a wrong type is marked). */
  async function openPlant() {
    await page.evaluate(() => RED.editor.editConfig('', 'sugarshack-plant', 'pl'));
    await trayOpened(page);
    await page.waitForFunction(() => RED.nodes.node('pl').editor && (monaco.languages.json.jsonDefaults.diagnosticsOptions.schemas || [])
      .some((s) => s.uri === 'sugarshack:/plant.schema.json' && s.schema), { timeout: 20000 });
    await page.evaluate((text) => RED.nodes.node('pl').editor.setValue(text), JSON.stringify({ ...PLANT, clockSkewMs: 'soon' }));
    await markersWhen((messages) => messages.length > 0);
  }

  /** Puts `text` in the plant dialog's editor and its cursor at the `n`th character after the first `marker`. */
  async function typeAt(text, marker, n) {
    await page.evaluate((value, at, offset) => {
      const ed = RED.nodes.node('pl').editor;
      ed.setValue(value);
      ed.focus();
      ed.setPosition(ed.getModel().getPositionAt(value.indexOf(at) + offset));
    }, text, marker, n);
    await page.waitForFunction(() => RED.nodes.node('pl').editor.hasTextFocus(), { timeout: 10000 });
  }

  /** The editor's markers, once `wanted(messages)` holds: [{ message, line }]. */
  async function markersWhen(wanted) {
    const handle = await page.waitForFunction(`(() => {
      const model = RED.nodes.node('pl').editor.getModel();
      const markers = monaco.editor.getModelMarkers({ resource: model.uri }).map((m) => ({ message: m.message, line: m.startLineNumber }));
      return (${wanted})(markers.map((m) => m.message)) && markers;
    })()`, { timeout: 15000 });
    return handle.jsonValue();
  }

  it('proposes an actuator\'s keys as you type inside "actuators", and marks a wrong type as you type it', async function () {
    await openPlant();
    // A new actuator, empty, last in the list: the cursor inside its braces.
    const text = JSON.stringify({ ...PLANT, actuators: [...PLANT.actuators, {}] }, null, 2);
    await typeAt(text, '{}', 1);
    await page.keyboard.type('"');
    const opened = await page.evaluate(() => { const ed = RED.nodes.node('pl').editor; return ed.getModel().getLineContent(ed.getPosition().lineNumber).trim(); });
    assert.match(opened, /^\{""?\}$/, 'the quote went into the new actuator');
    await page.waitForSelector('.suggest-widget.visible .monaco-list-row', { timeout: 15000 });
    const proposed = await page.$$eval('.suggest-widget.visible .monaco-list-row .label-name', (els) => els.map((e) => e.textContent.trim()));
    assert.deepEqual([...proposed].sort(), Object.keys(SCHEMA.definitions.Actuator.properties).sort());

    await page.keyboard.press('Escape');
    await page.keyboard.type('io": "one"');
    const line = await page.evaluate(() => RED.nodes.node('pl').editor.getPosition().lineNumber);
    const typed = await page.evaluate((n) => RED.nodes.node('pl').editor.getModel().getLineContent(n).trim(), line);
    assert.equal(typed, '{"io": "one"}');
    // Waits for this text's markers: until Monaco validates it again, the markers are the last text's.
    const markers = await markersWhen((messages) => messages.some((m) => m === 'Incorrect type. Expected one of integer, null.'));
    assert.deepEqual(markers.filter((m) => /Incorrect type/.test(m.message)), [{ message: 'Incorrect type. Expected one of integer, null.', line }]);
    // Drawn inline, under the value.
    await page.waitForSelector('#node-config-input-plant-editor .squiggly-warning, #node-config-input-plant-editor .squiggly-error', { timeout: 10000 });

    // Put right, the marker goes; what the new actuator still lacks stays marked.
    for (let i = 0; i < '"one"'.length; i++) await page.keyboard.press('Backspace');
    await page.keyboard.type('1');
    const fixed = await markersWhen((messages) => !messages.some((m) => /Incorrect type/.test(m)));
    assert.ok(fixed.some((m) => /Missing property "lockout"/.test(m.message)), JSON.stringify(fixed));
  });

  it('shows a key\'s description on hover, as the core\'s doc comment words it', async function () {
    await openPlant();
    await typeAt(JSON.stringify(PLANT, null, 2), '"lockout"', 3);
    await page.evaluate(() => RED.nodes.node('pl').editor.trigger('test', 'editor.action.showHover', {}));
    // Not Monaco's "Loading..." while its JSON worker starts: the description itself.
    await page.waitForFunction(() => /safe state/.test($('.monaco-hover-content').text()), { timeout: 15000 });
    const hover = await page.$eval('.monaco-hover-content', (el) => el.innerText.trim());
    // Markdown: its `code` is drawn as code.
    assert.equal(hover, SCHEMA.definitions.Actuator.properties.lockout.markdownDescription.replace(/`/g, ''));
    assert.match(hover, /safe state/);
  });

  it('gives the same help to a document that names its "$schema" for VS Code', async function () {
    await openPlant();
    const doc = { $schema: '../node_modules/node-red-contrib-sugarshack/schema/plant.schema.json', ...PLANT };
    doc.operations = [{ ...PLANT.operations[0], priority: 'high' }, PLANT.operations[1]];
    await typeAt(JSON.stringify(doc, null, 2), '"high"', 0);
    const markers = await markersWhen((messages) => messages.includes('Incorrect type. Expected "integer".'));
    const line = await page.evaluate(() => RED.nodes.node('pl').editor.getPosition().lineNumber);
    assert.deepEqual(markers, [{ message: 'Incorrect type. Expected "integer".', line }]);
  });

  it('keeps a long problem list within the dialog, scrolling', async function () {
    await openPlant();
    const many = { ...PLANT, actuators: Array.from({ length: 60 }, (_, i) => ({ id: `V${i + 1}`, type: 'nope', device: 'ctrl-1', io: i + 1, lockout: 0 })) };
    await page.evaluate((text) => {
      RED.nodes.node('pl').editor.setValue(text);
      $('#sugarshack-plant-check').trigger('click');
    }, JSON.stringify(many, null, 2));
    await page.waitForFunction(() => $('#sugarshack-plant-problem li').length >= 60, { timeout: 15000 });
    const box = await page.evaluate(() => {
      const list = document.getElementById('sugarshack-plant-problem');
      const rect = (el) => el.getBoundingClientRect();
      return {
        listBottom: rect(list).bottom,
        trayBottom: rect(document.querySelector('.red-ui-tray-body-wrapper') || document.querySelector('.red-ui-tray-body')).bottom,
        scrolls: list.scrollHeight > list.clientHeight,
        editorHeight: rect(document.getElementById('node-config-input-plant-editor')).height,
        header: list.innerText.split('\n')[0],
      };
    });
    assert.match(box.header, /^\d+ problems \(a deploy refuses the document\):$/);
    assert.ok(box.listBottom <= box.trayBottom, `the list ends at ${box.listBottom}, below the dialog at ${box.trayBottom}`);
    assert.ok(box.scrolls, 'the list scrolls');
    assert.ok(box.editorHeight >= 200, `the editor keeps ${box.editorHeight} px`);
  });

  /** The items of the typedInput option menu shown for `input`, once its trigger is clicked. */
  async function optionsOf(input) {
    const trigger = `${input} + .red-ui-typedInput-container .red-ui-typedInput-option-trigger`;
    await page.waitForSelector(trigger, { visible: true, timeout: 10000 });
    // Clicked where it is at that moment: the tray may still be sliding in.
    await page.$eval(trigger, (el) => el.click());
    await page.waitForFunction(() => $('.red-ui-typedInput-options:visible').length === 1, { timeout: 10000 });
    return page.$$eval('.red-ui-typedInput-options a', (els) => els.filter((e) => e.offsetParent).map((e) => e.innerText.trim()));
  }

  async function done() {
    // Clicked in the page, not at its place on screen: the tray may still be sliding in, with its
    // OK button outside the window or under the search box (seen as the test's flaky timeout).
    await page.$eval('#node-dialog-ok', (ok) => ok.click());
    await page.waitForFunction(() => !$('.red-ui-tray').length, { timeout: 10000 });
  }

  it('lists the plant\'s operations in the operation node, and takes an id typed', async function () {
    await page.evaluate(() => RED.editor.edit(RED.nodes.node('op')));
    await page.waitForSelector('#node-input-operation + .red-ui-typedInput-container', { visible: true, timeout: 10000 });
    assert.deepEqual(await page.evaluate(() => [$('#node-input-operation').typedInput('type'), $('#node-input-operation').val()]), ['plant', '12']);
    assert.deepEqual(await optionsOf('#node-input-operation'), ['10: fill the tank', '12']);
    await page.evaluate(() => $('.red-ui-typedInput-options:visible a').filter((i, a) => a.innerText.trim() === '10: fill the tank').trigger('click'));
    await done();
    assert.equal(await page.evaluate(() => RED.nodes.node('op').operation), '10');

    // An id the plant does not have yet: typed.
    await page.evaluate(() => RED.editor.edit(RED.nodes.node('op')));
    await page.waitForSelector('#node-input-operation + .red-ui-typedInput-container .red-ui-typedInput-type-select', { visible: true, timeout: 10000 });
    await trayOpened(page);
    await page.$eval('#node-input-operation + .red-ui-typedInput-container .red-ui-typedInput-type-select', (el) => el.click());
    // The value menu may still be fading out: wait for the type menu itself.
    await page.waitForFunction(() => $('.red-ui-typedInput-options:visible').length === 1
      && $('.red-ui-typedInput-options:visible a').filter((i, a) => a.innerText.trim() === 'string').length === 1, { timeout: 10000 });
    const types = await page.$$eval('.red-ui-typedInput-options a', (els) => els.filter((e) => e.offsetParent).map((e) => e.innerText.trim()));
    // Listed, typed, or read for each msg as Node-RED's own nodes read a value.
    assert.deepEqual(types, [catalog('operation')['sugarshack-operation'].label.fromPlant, 'string', 'msg.', 'flow.', 'global.', 'env variable', 'expression']);
    await page.evaluate(() => $('.red-ui-typedInput-options:visible a').filter((i, a) => a.innerText.trim() === 'string').trigger('click'));
    await page.click('#node-input-operation + .red-ui-typedInput-container input.red-ui-typedInput-input', { clickCount: 3 });
    await page.keyboard.type('30');
    await done();
    assert.equal(await page.evaluate(() => RED.nodes.node('op').operation), '30');
    await page.evaluate(() => RED.editor.edit(RED.nodes.node('op')));
    await page.waitForSelector('#node-input-operation + .red-ui-typedInput-container', { visible: true, timeout: 10000 });
    assert.deepEqual(await page.evaluate(() => [$('#node-input-operation').typedInput('type'), $('#node-input-operation').val()]), ['str', '30']);

    // Read from each msg: the type is kept beside the value, and opens as it was saved.
    await page.evaluate(() => { $('#node-input-operation').typedInput('type', 'msg'); $('#node-input-operation').typedInput('value', 'topic'); });
    await done();
    assert.deepEqual(await page.evaluate(() => [RED.nodes.node('op').operationType, RED.nodes.node('op').operation]), ['msg', 'topic']);
    await page.evaluate(() => RED.editor.edit(RED.nodes.node('op')));
    await page.waitForSelector('#node-input-operation + .red-ui-typedInput-container', { visible: true, timeout: 10000 });
    assert.deepEqual(await page.evaluate(() => [$('#node-input-operation').typedInput('type'), $('#node-input-operation').val()]), ['msg', 'topic']);
    await done();
  });

  it('lists the plant\'s routines in the routine node, its first for a new one', async function () {
    await page.evaluate(() => RED.editor.edit(RED.nodes.node('rt')));
    await page.waitForSelector('#node-input-routine + .red-ui-typedInput-container', { visible: true, timeout: 10000 });
    assert.deepEqual(await optionsOf('#node-input-routine'), ['truck']);
    await page.keyboard.press('Escape');
    await done();
    assert.equal(await page.evaluate(() => RED.nodes.node('rt').routine), 'truck');
  });

  it('offers the plant\'s sensors to the condition wait node, kept in step with its list', async function () {
    await page.evaluate(() => RED.editor.edit(RED.nodes.node('wt')));
    await page.waitForSelector('#sugarshack-wait-picker button', { visible: true, timeout: 10000 });
    const buttons = () => page.$$eval('#sugarshack-wait-picker button', (els) => els.map((b) => [b.textContent, b.classList.contains('selected')]));
    assert.deepEqual(await buttons(), [['LT-3', true], ['FT-3', false]]);
    await page.evaluate(() => $('#sugarshack-wait-picker button').filter((i, b) => b.textContent === 'FT-3').trigger('click'));
    assert.deepEqual(await buttons(), [['LT-3', true], ['FT-3', true]]);
    await done();
    assert.equal(await page.evaluate(() => RED.nodes.node('wt').sensors), 'LT-3,FT-3');
  });
});
