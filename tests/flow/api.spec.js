'use strict';
// The palette's API for other packages (lib/api.js, handed over as the Node-RED
// plugin sugarshack-api): an interlock and its plant read by handle, changes
// heard by exception (a plant change names what the core touched, and nothing
// comes while nothing changes), and a person's e-stop, clear, acknowledge and
// shelves through the same paths as the admin endpoints, attributed. A plant
// and its interlock in the test helper's Node-RED, a fake panel, the manual clock.
const assert = require('node:assert/strict');
const path = require('path');
const helper = require('node-red-node-test-helper');
const { PALETTE, paletteNodes, TAB, sinkNode, serverPerTest, clock, runFor, runUntil } = require('./support');
const { fakePanel, stopPanels, fakePlant, fakeValve, fakePump } = require('./fake-panel');
const { paletteApi, VERSION } = require('../../node-red-contrib-sugarshack/lib/api');
const { paletteOf } = require('../../node-red-contrib-sugarshack/lib/host/lifecycle');
const wasm = require('../../node-red-contrib-sugarshack/lib/wasm');

helper.init(require.resolve('node-red'));

// A node module that registers nothing: it keeps the RED that node modules are given.
let RED = null;
const keepRED = (red) => { RED = red; };

const DOC = {
  ...fakePlant([fakeValve('V101', 1, 'YEL'), fakeValve('V102', 2, 'YEL'), fakeValve('V501', 5, 'RED'), fakePump('YEL')]),
  sensors: [{ id: 'LT-3', device: 'station-3', name: 'volume', unit: 'L', min: 0, max: 12000 }],
  resources: [{ id: 'YEL' }, { id: 'RED' }],
};

async function start() {
  await helper.load([...paletteNodes, keepRED], [
    TAB,
    { id: 'pl', type: 'sugarshack-plant', name: 'plant', plant: DOC },
    { id: 'il', type: 'sugarshack-interlock', name: 'lines', plant: 'pl', resources: [], policy: 'greedy', persist: false },
    { id: 'bus', z: 'f1', type: 'sugarshack-actuators', plant: 'pl', devices: '', wires: [['mqtt'], [], []] },
    sinkNode('mqtt'),
  ]);
  const api = paletteApi(RED);
  await runUntil(helper, () => api.interlock('il') !== null, 'the interlock running');
  return api;
}

describe('the palette API for other packages (lib/api.js)', function () {
  serverPerTest();
  afterEach(stopPanels);

  it('is handed over as the plugin sugarshack-api', async function () {
    await start();
    const registered = {};
    require(path.join(PALETTE, 'plugins', 'api.js'))({ ...RED, plugins: { registerPlugin: (id, def) => { registered[id] = def; } } });
    assert.equal(registered['sugarshack-api'].version, VERSION);
    assert.equal(typeof registered['sugarshack-api'].api.estop, 'function');
  });

  it('reads the interlock and its plant by handle, and hears of changes by exception', async function () {
    const api = await start();
    assert.deepEqual(api.interlock('il').lines.map((l) => l.name), ['YEL', 'RED']);
    assert.equal(api.interlock('nope'), null);
    const plant = api.plant('il');
    assert.deepEqual(plant.actuators.map((a) => a.id), ['V101', 'V102', 'V501', 'P1']);
    assert.deepEqual(plant.devices, ['ctrl-1', 'station-3']);
    assert.deepEqual(plant.sensors.map((s) => [s.handle, s.id, s.min, s.max]), [[0, 'LT-3', 0, 12000]]);
    const heard = [];
    const ids = [];
    const stop = [api.onPlantChange('il', (c) => heard.push(c)), api.onChange((changed) => ids.push(...changed))];
    fakePanel(helper, DOC);
    await runUntil(helper, () => heard.some((c) => c.actuators.size > 0), 'the first feedback heard');
    const v101 = plant.actuators.find((a) => a.id === 'V101').handle;
    assert.deepEqual(api.actuators('il', [v101]), [{ target: null, position: 0, phase: 'idle' }]);
    assert.deepEqual(api.devices('il', [0]), [{ online: true, stale: [] }]);
    // Nothing changes, nothing is heard (the plant's own timers run meanwhile).
    await runFor(helper, 200);
    heard.length = 0;
    await runFor(helper, 1000);
    assert.deepEqual(heard, [], 'no change, no notice');
    const answer = await api.estop('il', ['YEL'], { by: 'ann', reason: 'smoke' }, 'not used');
    assert.deepEqual(answer, { stopped: ['YEL'], by: 'ann' });
    await runUntil(helper, () => heard.some((c) => c.devices.has(0)), 'the lockout\'s publish heard as its device');
    assert.equal(api.actuators('il', [v101])[0].target, 0, 'the lockout is its target');
    assert.ok(ids.includes('il'), 'the interlock named as changed');
    const line = api.interlock('il').lines.find((l) => l.name === 'YEL');
    assert.deepEqual([line.state.state, line.fault.note], ['faulted', 'smoke']);
    assert.equal(api.interlock('il').recentEvents.find((e) => e.kind === 'resource-faulted').by, 'ann');
    stop.forEach((off) => off());
  });

  it('its reads made from inside a msg\'s read of the plant (a feedback payload\'s getter) throw INVALID_INPUT, nothing rebuilt; after it they answer', async function () {
    const api = await start();
    const generation = wasm.currentGeneration();
    const reads = {
      interlock: () => api.interlock('il'),
      plant: () => api.plant('il'),
      actuators: () => api.actuators('il', [0]),
      devices: () => api.devices('il', [0]),
      sensors: () => api.sensors('il'),
    };
    const thrown = {};
    const payload = {
      ts: clock().now(),
      get value() {
        for (const [name, read] of Object.entries(reads)) {
          try {
            read();
          } catch (err) {
            thrown[name] = `${err.code}: ${err.message}`;
          }
        }
        return 7;
      },
    };
    helper.getNode('bus').receive({ topic: 'station-3/sensor/volume/state', payload });
    await runFor(helper, 100);
    for (const name of Object.keys(reads)) assert.match(thrown[name] ?? 'nothing thrown', /^INVALID_INPUT: .*while the core was still reading another msg/, name);
    assert.equal(wasm.currentGeneration(), generation, 'no rebuild');
    assert.equal(api.sensors('il')[0].value, 7, 'the feedback applied');
    for (const read of Object.values(reads)) assert.ok(read() !== null);
  });

  it('clears by the core\'s rule: refused with every reason in the core\'s words, then forced, as the given person', async function () {
    const api = await start();
    fakePanel(helper, DOC);
    await runFor(helper, 50);
    await api.estop('il', ['YEL'], { by: 'ann' }, 'stopped by a test');
    await runFor(helper, 50);
    helper.getNode('bus').receive({ topic: 'ctrl-1/status', payload: 'offline' }); // its last will
    await runFor(helper, 50);
    const refused = await api.clear('il', ['YEL'], { by: 'bo', reason: 'looks fine' }).then(() => null, (err) => err);
    assert.equal(refused && refused.code, 'CLEAR_REFUSED');
    const [yel] = refused.lines;
    assert.ok(yel.texts.some((t) => t.includes('ctrl-1') && t.includes('offline')), JSON.stringify(yel));
    const blockers = api.interlock('il').lines.find((l) => l.name === 'YEL').clearBlockers;
    assert.ok(blockers.length > 0 && blockers.every((b) => typeof b.text === 'string' && b.text !== ''), 'the state gives each reason in words');
    assert.deepEqual(await api.clear('il', ['YEL'], { by: 'bo', reason: 'valve checked by hand', force: true }), { cleared: ['YEL'], by: 'bo' });
    const clearEvent = () => api.interlock('il').recentEvents.find((e) => e.kind === 'cleared');
    await runUntil(helper, () => clearEvent() !== undefined, 'the clear recorded');
    const cleared = clearEvent();
    assert.deepEqual([cleared.by, cleared.reason, cleared.forced], ['bo', 'valve checked by hand', true]);
    await assert.rejects(api.clear('nope', null, {}), (err) => err.code === 'NO_INTERLOCK');
    // On a hot standby the refusal names the instance that acts (tests/integration/standby.spec.js runs a real one).
    const runtime = paletteOf(RED).runtimes.get('il');
    const [life, cluster] = [runtime.life, runtime.cluster];
    runtime.step('stand-down');
    runtime.cluster = { leader: { instance: 'edge-b' } };
    try {
      await assert.rejects(api.clear('il', ['YEL'], {}), (err) => err.code === 'NO_INTERLOCK' && err.message === "interlock 'il' is on standby here: instance edge-b acts");
    } finally {
      Object.assign(runtime, { life, cluster });
    }
  });

  it('acknowledges and shelves alarms as the given person; a one-shot shelf ends with its condition', async function () {
    const api = await start();
    fakePanel(helper, DOC);
    await api.estop('il', ['RED'], { by: 'ann' }, 'stopped by a test');
    const id = api.alarmId('line-faulted', 'RED');
    await runUntil(helper, () => (api.interlock('il').alarms || []).some((a) => a.id === id), 'the RED alarm');
    const acked = await api.acknowledge('il', [id], { by: 'bo', reason: 'on it' });
    assert.deepEqual(acked.changes.map((c) => [c.action, c.by, c.reason]), [['acknowledge', 'bo', 'on it']]);
    await api.shelve('il', id, { untilMs: clock().now() + api.maxShelveMs, oneShot: true }, { by: 'bo' });
    const alarm = () => api.interlock('il').alarms.find((a) => a.id === id);
    assert.deepEqual([alarm().shelved.by, alarm().shelved.oneShot], ['bo', true]);
    await runUntil(helper, () => api.interlock('il').lines.find((l) => l.name === 'RED').clearBlockers.length === 0, 'RED isolated');
    await api.clear('il', ['RED'], { by: 'bo' });
    await runUntil(helper, () => alarm() === undefined, 'the alarm gone: back to normal, acknowledged, its one-shot shelf over');
    assert.equal(api.alarmSeverities['line-faulted'], 800);
  });

  it('signs nobody in without adminAuth', async function () {
    const api = await start();
    assert.equal(await api.signIn('ann', 'secret'), null);
  });
});
