'use strict';
// The HMI of npm start (flows/case-study.json + flows/hmi.json, the case-study
// plant simulated) in a real headless Chromium: the dashboard shows the five
// lines and their holders, E-STOP on YEL faults it on the page and sends its
// lockout, CLEAR is refused while a YEL device is offline (reason shown) and
// accepted once it is back, a forced CLEAR with a reason is recorded as forced,
// an alarm's acknowledgement survives a reload and shows who acknowledged
// (the dashboard user, from a Dashboard 2 plugin as FlowFuse's user add-on
// supplies it); HOLD on a running operation shows it held and RESTART resumes it; the page speaks the plant document's words: operations by their
// descriptions, sensor values with their units, every line drawn through its
// valves and pumps, each with its commanded and reported position; the editor's interlock sidebar tab shows the same lines, the
// timing page draws the paper's figures from GET /sugarshack/stats, and the
// palette's HMI example, deployed alone, draws its lines.
// Screenshots go to tests/browser/screenshots-out/.
const assert = require('node:assert/strict');
const fs = require('fs');
const os = require('os');
const path = require('path');
const puppeteer = require('puppeteer-core');
const { NodeRedProcess } = require('../integration/support/node-red');
const { startMosquitto } = require('../integration/support/mosquitto');
const { startSimulator } = require('../../scripts/simulator');

const ROOT = path.resolve(__dirname, '..', '..');
const PLANT = JSON.parse(fs.readFileSync(path.join(ROOT, 'flows', 'plant.json'), 'utf8'));
const SHOTS = path.join(__dirname, 'screenshots-out');
const CHROMIUM = process.env.CHROMIUM_BIN || '/usr/bin/chromium';
const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

const onBroker = (flow, mqttPort) => flow.map((n) => (n.type === 'mqtt-broker' ? { ...n, broker: '127.0.0.1', port: String(mqttPort) } : n));

/** The flows npm start deploys, on the test's broker. */
function npmStartFlows(mqttPort) {
  const read = (f) => JSON.parse(fs.readFileSync(path.join(ROOT, 'flows', f), 'utf8'));
  return onBroker([...read('case-study.json'), ...read('hmi.json')], mqttPort);
}

const DASHBOARD_USER = 'operator-ana';

/**
 * A Dashboard 2 plugin that signs every dashboard msg as DASHBOARD_USER, the
 * way FlowFuse's user add-on puts the signed-in user in msg._client.user.
 */
function installDashboardUser(dir) {
  const pkg = path.join(dir, 'node_modules', 'sugarshack-test-dashboard-user');
  fs.mkdirSync(pkg);
  fs.writeFileSync(path.join(pkg, 'package.json'), JSON.stringify({
    name: 'sugarshack-test-dashboard-user', version: '1.0.0', keywords: ['node-red'], 'node-red': { plugins: { user: 'plugin.js' } },
  }));
  fs.writeFileSync(path.join(pkg, 'plugin.js'), `module.exports = (RED) => RED.plugins.registerPlugin('sugarshack-test-dashboard-user', {
  type: 'node-red-dashboard-2',
  hooks: { onAddConnectionCredentials: (conn, msg) => { msg._client = { ...msg._client, user: { username: ${JSON.stringify(DASHBOARD_USER)} } }; return msg; } },
});\n`);
}

describe('the HMI at /dashboard in headless Chromium', function () {
  this.timeout(180000);
  let broker; let sim; let red; let browser; let page; let profile;

  before(async function () {
    fs.mkdirSync(SHOTS, { recursive: true });
    broker = await startMosquitto();
    const port = Number(new URL(broker.url).port);
    sim = await startSimulator({ broker: broker.url, plant: path.join(ROOT, 'flows', 'plant.json'), seed: 7, sweepS: 1, pumpDelayMs: 200, reconnectMs: 200, log: () => {} });
    red = new NodeRedProcess({ flows: npmStartFlows(port), tag: 'hmi' });
    fs.mkdirSync(path.join(red.dir, 'node_modules', '@flowfuse'));
    fs.symlinkSync(path.join(ROOT, 'node_modules', '@flowfuse', 'node-red-dashboard'), path.join(red.dir, 'node_modules', '@flowfuse', 'node-red-dashboard'), 'dir');
    installDashboardUser(red.dir);
    await red.start();
    profile = fs.mkdtempSync(path.join(os.tmpdir(), 'sugarshack-chromium-'));
    browser = await puppeteer.launch({
      executablePath: CHROMIUM,
      headless: true,
      args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run', '--disable-background-networking',
        '--disable-component-update', '--disable-sync', `--user-data-dir=${profile}`],
    });
    page = await browser.newPage();
    await page.setViewport({ width: 1400, height: 1000 });
  });

  after(async function () {
    if (browser) await browser.close();
    if (red) await red.finish(this.currentTest);
    if (sim) await sim.stop();
    if (broker) await broker.stop();
    if (profile) fs.rmSync(profile, { recursive: true, force: true });
  });

  const shot = (name) => page.screenshot({ path: path.join(SHOTS, `${name}.png`), fullPage: true });
  const lineRow = (name) => `tr[data-line="${name}"]`;
  // A line's button, found and clicked in one step: rows above it change height as their lines change state.
  const press = (line, button) => page.$eval(`${lineRow(line)} .ss-${button}`, (el) => el.click());
  const textOf = (selector) => page.$eval(selector, (el) => el.innerText).catch(() => '');
  async function waitText(selector, re, what, timeoutMs = 30000) {
    const deadline = Date.now() + timeoutMs;
    let last = '';
    while (Date.now() < deadline) {
      last = await textOf(selector);
      if (re.test(last)) return last;
      await sleep(200);
    }
    await shot(`failed-${what.replace(/\W+/g, '-')}`);
    throw new Error(`${what}: '${selector}' reads '${last}', wanted ${re}`);
  }
  const lockoutsSent = [];

  it('shows the five lines and their holders within seconds, each operation by its name in the plant document', async function () {
    const started = Date.now();
    await page.goto(`http://127.0.0.1:${red.port}/dashboard/plant`, { waitUntil: 'domcontentloaded' });
    for (const line of ['YEL', 'GRN', 'BLU', 'PUR', 'RED']) await waitText(lineRow(line), new RegExp(`${line}\\s+(free|held|faulted)`), `line ${line}`, 20000);
    assert.ok(Date.now() - started < 20000);
    // The routines start operations at once: wait for a holder on the page, then read it against the document.
    const named = (id) => `${PLANT.operations.find((o) => o.id === id).description} (${id})`;
    const deadline = Date.now() + 30000;
    let checked = 0;
    while (checked === 0 && Date.now() < deadline) {
      const state = await red.get('/sugarshack/state');
      for (const l of state.interlocks[0].lines.filter((x) => x.holder)) {
        const row = await textOf(lineRow(l.name));
        if (!row.includes(`prio ${l.holder.priority}`)) continue; // the page is a moment behind
        assert.ok(row.includes(named(l.holder.operation)), `${l.name} shows its holder by name: ${row}`);
        assert.doesNotMatch(row, /\bop \d+/, 'no bare operation numbers');
        checked++;
      }
      if (checked === 0) await sleep(500);
    }
    assert.ok(checked > 0, 'a held line was seen on the page');
    await shot('1-plant');
  });

  it('draws each line with the valves and pumps it runs through, each with its commanded and reported position', async function () {
    const lineOf = (line) => PLANT.actuators.filter((a) => a.resource === line).map((a) => a.id);
    for (const line of ['YEL', 'GRN', 'BLU', 'PUR', 'RED']) {
      const drawn = await page.$$eval(`tr[data-diagram="${line}"] [data-actuator]`, (els) => els.map((el) => el.dataset.actuator));
      assert.deepEqual(drawn, lineOf(line), `line ${line} is drawn through its actuators, in the document's order`);
    }
    const labels = await page.$$eval('tr.ss-diagram [data-actuator] .ss-act-pos', (els) => els.map((el) => el.textContent));
    for (const label of labels) assert.match(label, /^(–|\d+|on|off) \/ (–|\d+|on|off)( %)?$/, 'commanded / reported, valves in %');
    // An actuator an operation opened: its label says so, and its symbol is filled once feedback shows it open.
    const deadline = Date.now() + 60000;
    let opened = null;
    while (!opened && Date.now() < deadline) {
      opened = await page.$$eval('tr.ss-diagram [data-actuator][data-commanded="100"][data-open="true"]', (els) => els.map((el) => ({
        id: el.dataset.actuator, reported: Number(el.dataset.reported), label: el.querySelector('.ss-act-pos').textContent, fill: getComputedStyle(el.querySelector('polygon, circle')).fill,
      }))[0] || null);
      if (!opened) await sleep(500);
    }
    assert.ok(opened, 'an open actuator on some line');
    assert.match(opened.label, new RegExp(`^100 / ${Math.round(opened.reported)} %$`), `${opened.id}: ${opened.label}`);
    assert.equal(opened.fill, 'rgb(46, 125, 50)', 'drawn filled: open');
    await shot('1b-lines-drawn');
  });

  it('shows the sensors with their units from the plant document', async function () {
    const units = Object.fromEntries(PLANT.sensors.map((s) => [s.id, s.unit]));
    await waitText('.ss-sensors tr[data-sensor="LT-2"] .ss-value', /^\d+(\.\d)? L$/, 'LT-2 in litres');
    const shown = await page.$$eval('.ss-sensors tr[data-sensor]', (rows) => rows.map((r) => [r.dataset.sensor, r.querySelector('.ss-value').textContent.trim()]));
    assert.ok(shown.length > 0);
    for (const [sensor, text] of shown) {
      if (text !== '-') assert.ok(text.endsWith(` ${units[sensor]}`), `${sensor}: ${text} ends with its unit ${units[sensor]}`);
    }
  });

  it('HOLD on a running operation shows it held, keeping its line, with RESTART in place of HOLD; RESTART resumes it', async function () {
    const runOn = (op) => `.ss-run[data-operation="${op}"]`;
    const runOf = async (op) => ((await red.get('/sugarshack/state')).interlocks[0].runs || []).find((r) => r.operation === op);
    // The routines run operations by themselves: the first one the page shows running is held, found and
    // clicked in one step (the next one, if it ended before the click arrived).
    const deadline = Date.now() + 90000;
    let op = null;
    while (!op && Date.now() < deadline) {
      const clicked = await page.evaluate(() => {
        const button = document.querySelector('.ss-run[data-state="running"] .ss-hold');
        if (!button) return null;
        button.click();
        return button.closest('.ss-run').dataset.operation;
      });
      if (!clicked) {
        await sleep(200);
        continue;
      }
      const until = Date.now() + 15000;
      let run = await runOf(clicked);
      while (run && run.state !== 'held' && Date.now() < until) {
        await sleep(200);
        run = await runOf(clicked);
      }
      if (run && run.state === 'held') op = clicked;
    }
    assert.ok(op, 'an operation held from the page');
    const held = await waitText(runOn(op), /\bheld\b/, `operation ${op} shown held`, 20000);
    assert.ok(held.includes(PLANT.operations.find((o) => o.id === op).description), `by its name: ${held}`);
    // The state's text and its buttons may come in separate pushes: wait for the button, not the text.
    await page.waitForSelector(`${runOn(op)} .ss-restart`, { timeout: 10000 }).catch(() => null);
    assert.ok(await page.$(`${runOn(op)} .ss-restart`), `RESTART offered: ${JSON.stringify(await runOf(op))}`);
    assert.equal(await page.$(`${runOn(op)} .ss-hold`), null, 'HOLD not offered while held');
    const lines = (await red.get('/sugarshack/state')).interlocks[0].lines;
    assert.ok(lines.some((l) => l.holder && l.holder.operation === op), `a held operation keeps its lines: ${JSON.stringify(lines.map((l) => [l.name, l.holder]))}`);
    await shot('1c-operation-held');
    await page.$eval(`${runOn(op)} .ss-restart`, (el) => el.click());
    const resumed = async () => {
      const run = await runOf(op);
      return !run || ['restarting', 'running'].includes(run.state) || run.state === 'complete';
    };
    const until = Date.now() + 30000;
    while (!(await resumed()) && Date.now() < until) await sleep(200);
    assert.ok(await resumed(), `operation ${op} restarted: ${JSON.stringify(await runOf(op))}`);
    await waitText('.ss-lines', new RegExp(`^(?![\\s\\S]*${op}\\): held)`), `operation ${op} no longer shown held`, 20000);
  });

  it('E-STOP on YEL turns YEL faulted on the page and sends its lockout', async function () {
    const mqtt = require('mqtt');
    const client = mqtt.connect(broker.url);
    await new Promise((resolve) => client.on('connect', resolve));
    client.subscribe('ctrl-1/#');
    client.on('message', (topic, payload) => { if (/command/.test(topic)) lockoutsSent.push([topic, String(payload)]); });
    await press('YEL', 'estop');
    await waitText(lineRow('YEL'), /faulted/, 'YEL faulted');
    await waitText('.ss-alarms', /e-stop YEL/, 'the alarm of the e-stop');
    const deadline = Date.now() + 15000;
    while (Date.now() < deadline && lockoutsSent.length === 0) await sleep(100);
    client.end(true);
    assert.ok(lockoutsSent.length > 0, 'lockout commands published to ctrl-1');
    await shot('2-yel-faulted');
  });

  it('the editor\'s interlock sidebar tab shows the same state as the dashboard', async function () {
    const editor = await browser.newPage();
    await editor.setViewport({ width: 1400, height: 1000 });
    try {
      await editor.goto(`http://127.0.0.1:${red.port}/`, { waitUntil: 'domcontentloaded' });
      // Loaded: the toolbar is up and the loading bar gone (the editor picks its own sidebar tab until then).
      await editor.waitForFunction(() => window.RED && window.sugarshackSidebar && $('.red-ui-header-toolbar').is(':visible')
        && !$('#red-ui-loading-progress').is(':visible'), { timeout: 60000 });
      // What View > Interlock does (the tab sits in the sidebar's overflow menu at this width).
      await editor.evaluate(() => RED.sidebar.show('sugarshack-interlock'));
      await editor.waitForFunction(() => $('.sugarshack-sidebar').is(':visible'), { timeout: 5000 });
      const sbRow = (line) => `.sugarshack-sidebar tr[data-line="${line}"]`;
      await editor.waitForSelector(`${sbRow('YEL')}[data-state="faulted"]`, { timeout: 15000 });
      const sidebarYel = await editor.$eval(sbRow('YEL'), (el) => el.innerText);
      const dashboardYel = await textOf(lineRow('YEL'));
      await editor.screenshot({ path: path.join(SHOTS, '2b-editor-sidebar.png') });
      assert.ok(await editor.$eval('.sugarshack-sidebar', (el) => el.checkVisibility()), 'the tab is on screen');
      assert.match(sidebarYel, /YEL\s+faulted\s+manual/);
      assert.match(dashboardYel, /YEL\s+faulted\s+manual/);
      // The same note on both: the operator's reason from the dashboard's E-STOP.
      assert.ok(sidebarYel.includes('E-STOP YEL from the dashboard') && dashboardYel.includes('E-STOP YEL from the dashboard'), `${sidebarYel} | ${dashboardYel}`);
      const names = await editor.$$eval('.sugarshack-sidebar tr.ss-sb-line', (rows) => rows.map((r) => r.dataset.line));
      assert.deepEqual(names, ['YEL', 'GRN', 'BLU', 'PUR', 'RED']);
      assert.match(await editor.$eval('.sugarshack-sidebar .ss-sb-queue', (el) => el.innerText), /^queue: /);
      await editor.waitForSelector('.sugarshack-sidebar .ss-sb-alarm[data-alarm="line-faulted:YEL"]', { timeout: 5000 });
      assert.match(await editor.$eval('.sugarshack-sidebar .ss-sb-alarm[data-alarm="line-faulted:YEL"]', (el) => el.innerText), /YEL faulted, manual/);
      assert.match(await editor.$eval('.sugarshack-sidebar .ss-sb-routines', (el) => el.innerText), /truck/);
    } finally {
      await editor.close();
    }
  });

  it('CLEAR is refused while a YEL device is offline, the reason shown, then accepted', async function () {
    await sim.inject({ fault: 'dead', device: 'ctrl-1' });
    await waitText(lineRow('YEL'), /device ctrl-1 offline/, 'the reason not to clear', 30000);
    await press('YEL', 'clear');
    await waitText(`${lineRow('YEL')} .ss-refused`, /refused: device ctrl-1 offline/, 'the refusal');
    await shot('3-clear-refused');
    assert.match(await textOf(lineRow('YEL')), /faulted/);
    await sim.inject({ fault: 'revive', device: 'ctrl-1' });
    // Still faulted, no longer "not clearable" (an empty text, a row not drawn yet, matches neither).
    await waitText(lineRow('YEL'), /^(?![\s\S]*not clearable)[\s\S]*YEL\s+faulted/, 'YEL clearable again', 60000);
    await page.type('.ss-reason', 'ctrl-1 restarted, valves checked');
    await press('YEL', 'clear');
    await waitText(lineRow('YEL'), /YEL\s+(free|held)/, 'YEL cleared', 30000);
    await waitText('.ss-alarms', new RegExp(`cleared YEL by ${DASHBOARD_USER}: ctrl-1 restarted, valves checked`), 'the clear in the event list, with who and why');
    await shot('4-cleared');
  });

  // BLU: free early on (only a late step of the evaporator's cycle takes it), so the routines keep
  // running operations for the timing page.
  it('CLEAR with force and a reason goes through over a refusal and is recorded as forced, with that reason', async function () {
    await press('BLU', 'estop');
    await waitText(lineRow('BLU'), /BLU\s+faulted/, 'BLU faulted');
    await sim.inject({ fault: 'dead', device: 'ctrl-3' });
    await waitText(lineRow('BLU'), /device ctrl-3 offline/, 'the reason not to clear BLU', 30000);
    await page.type('.ss-reason', 'ctrl-3 being replaced; BLU valves closed by hand');
    // Set where it is at that moment: the dashboard re-renders as the plant changes.
    await page.$eval('.ss-force', (el) => { if (!el.checked) el.click(); });
    await press('BLU', 'clear');
    await waitText(lineRow('BLU'), /BLU\s+(free|held)/, 'BLU cleared over its reasons', 30000);
    const forced = await waitText('.ss-event.ss-forced', /FORCED/, 'the forced clear marked in the event list');
    assert.match(forced, new RegExp(`cleared BLU by ${DASHBOARD_USER} \\(forced\\): ctrl-3 being replaced; BLU valves closed by hand`));
    assert.equal(await page.$eval('.ss-force', (el) => el.checked), false, 'force is for one clear only');
    const cleared = (await red.get('/sugarshack/state')).interlocks[0].recentEvents.filter((e) => e.kind === 'cleared').at(-1);
    assert.deepEqual([cleared.resources, cleared.by, cleared.forced, cleared.reason], [['BLU'], DASHBOARD_USER, true, 'ctrl-3 being replaced; BLU valves closed by hand']);
    await shot('5-forced-clear');
    await sim.inject({ fault: 'revive', device: 'ctrl-3' });
  });

  it('an alarm acknowledged on the page stays acknowledged after a reload, showing who acknowledged it and when', async function () {
    const alarm = (id) => `.ss-alarm[data-alarm="${id}"]`;
    // Found and clicked in one step: new alarms arrive at the top and move the rest down.
    const ack = (id) => page.$eval(`${alarm(id)} .ss-ack`, (button) => button.click());
    // YEL's alarm returned to normal with its clear; acknowledged, it leaves the list.
    await waitText(alarm('line-faulted:YEL'), /returned to normal · unacknowledged/, 'YEL back to normal, not yet acknowledged');
    await ack('line-faulted:YEL');
    await waitText('.ss-alarms', /^(?![\s\S]*YEL faulted)/, 'the acknowledged, normal alarm leaves the list');
    // An active one stays, acknowledged.
    await page.type('.ss-reason', 'dye test on BLU');
    await press('BLU', 'estop');
    await waitText(alarm('line-faulted:BLU'), /BLU faulted, manual: dye test on BLU[\s\S]*active · unacknowledged/, 'the BLU alarm');
    await ack('line-faulted:BLU');
    const acked = new RegExp(`active · acknowledged by ${DASHBOARD_USER} at \\d`);
    await waitText(alarm('line-faulted:BLU'), acked, 'the acknowledgement with who');
    await page.reload({ waitUntil: 'domcontentloaded' });
    await waitText(alarm('line-faulted:BLU'), acked, 'the acknowledgement after a reload', 20000);
    await sleep(500); // the navigation drawer slides away after a load
    const blu = (await red.get('/sugarshack/state')).interlocks[0].alarms.find((a) => a.id === 'line-faulted:BLU');
    assert.equal(blu.state, 'active-acknowledged');
    assert.equal(blu.acked.by, DASHBOARD_USER);
    await shot('6-alarm-acknowledged-after-reload');
  });

  it('the timing page draws the paper\'s Figs. 11-15 with data from the timing figures', async function () {
    await page.goto(`http://127.0.0.1:${red.port}/dashboard/timing`, { waitUntil: 'domcontentloaded' });
    const figures = ['fig11', 'fig12', 'fig13', 'fig14', 'fig15'];
    // The case-study devices speak stock ESPHome, whose states carry no device time: no time of flight (Fig. 11).
    const withData = ['fig12', 'fig13', 'fig14', 'fig15'];
    const deadline = Date.now() + 60000;
    let counts = {};
    while (Date.now() < deadline) {
      counts = await page.$$eval('.ss-fig', (els) => Object.fromEntries(els.map((el) => [el.dataset.fig, Number(el.dataset.series)]))).catch(() => ({}));
      if (withData.every((f) => counts[f] > 0)) break;
      await sleep(500);
    }
    await shot('7-timing');
    assert.deepEqual(Object.keys(counts).sort(), figures, 'five figures on the page');
    for (const f of withData) assert.ok(counts[f] > 0, `${f} has data: ${JSON.stringify(counts)}`);
    // Fig. 11: a bar per device with a time-of-flight series, or why there is none.
    const stats = await red.get('/sugarshack/stats');
    const devices = Object.keys(stats).filter((n) => n.startsWith('tof/') && stats[n].n > 0).length;
    assert.ok(counts.fig11 <= devices && (devices === 0) === (counts.fig11 === 0), `fig11 shows ${counts.fig11} of ${devices} devices`);
    if (devices === 0) assert.match(await page.$eval('.ss-fig[data-fig="fig11"]', (el) => el.textContent), /no device feedback has carried a timestamp/);
    // Read after the page: an operation may have finished in between and added a series.
    assert.ok(counts.fig15 <= Object.keys(stats).filter((n) => /^operation\/(run|queued)\//.test(n)).length, 'a bar per operation series');
    const fig14 = await page.$eval('.ss-fig[data-fig="fig14"]', (el) => el.textContent);
    assert.match(fig14, /all lockouts \(n [1-9]/);
  });

  it('the palette\'s HMI example, deployed alone on a Node-RED, draws its own lines from its panel subflows', async function () {
    const example = JSON.parse(fs.readFileSync(path.join(ROOT, 'node-red-contrib-sugarshack', 'examples', 'hmi-dashboard.json'), 'utf8'));
    await red.deploy(onBroker(example, Number(new URL(broker.url).port))); // rejects unless 2xx
    const own = example.find((n) => n.type === 'sugarshack-interlock').id;
    await page.goto(`http://127.0.0.1:${red.port}/dashboard/plant`, { waitUntil: 'domcontentloaded' });
    for (const line of ['YEL', 'GRN', 'BLU', 'PUR', 'RED']) await waitText(lineRow(line), new RegExp(`${line}\\s+(free|held|faulted)`), `the example's line ${line}`, 30000);
    const state = await red.get('/sugarshack/state');
    assert.deepEqual(state.interlocks.map((il) => il.id), [own], 'only the example\'s interlock runs');
    assert.ok(await page.$('.ss-alarms'), 'its alarms panel is drawn');
    await shot('8-example-alone');
  });
});
