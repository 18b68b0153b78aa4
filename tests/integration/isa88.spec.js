'use strict';
// An operator's hold, restart and abort (ISA-88) on the real stack: Mosquitto,
// the simulator playing the case-study plant (flows/plant.json, ESPHome
// devices, at 10x) and a Node-RED process running the case-study flows
// without their routines (so nothing starts an operation but this test). The
// commands go in as the editor's buttons send them: an inject with
// msg.topic `hold`, `restart` or `abort` into an operation node.
//
// - op 10 (load truck, YEL) held in its wait: the document's hold command (P1
//   off, V101 closed) reaches the devices, the truck stops filling, nothing
//   else is commanded while it is held, and YEL stays held by op 10; restarted,
//   V101 and P1 are put back and op 10 completes as it would have;
// - op 21 (evap push conc, GRN) aborted while it runs: GRN's lockout goes out
//   at once, without waiting for its step; op 21 waits for a reset, attributed,
//   and GRN stays faulted after it (a person clears the line);
// - op 12 (unload truck, YEL) held, then, once that is on disk, Node-RED killed
//   with SIGKILL: it comes back held (YEL held by op 12, nothing commanded),
//   and a restart finishes the unload.
//
// Run: npx mocha --timeout 30000 --exit tests/integration/isa88.spec.js
const assert = require('node:assert/strict');
const fs = require('fs');
const path = require('path');
const { startMosquitto } = require('./support/mosquitto');
const { connectProbe } = require('./support/mqtt-probe');
const { startTestSimulator } = require('./support/simulator');
const { NodeRedProcess, sleep, waitFor } = require('./support/node-red');
const { build, nid } = require('../../scripts/case-study-flow');
const { docBlocks, run } = require('../../scripts/docs/snippets');

// The state API page's own command holds op 10: its snippet needs op 10 running, which this test sees to.
const HOLD_SNIPPET = docBlocks(['docs/reference/state-api.md'])
  .find((b) => b.tags.by === 'tests/integration/isa88.spec.js' && b.body.includes('"command":"hold"'));

const ROOT = path.resolve(__dirname, '..', '..');
const PLANT_FILE = path.join(ROOT, 'flows', 'plant.json');
const PLANT = JSON.parse(fs.readFileSync(PLANT_FILE, 'utf8'));
const ACTUATORS = Object.fromEntries(PLANT.actuators.map((a) => [a.id, a]));
const OPERATIONS = Object.fromEntries(PLANT.operations.map((o) => [o.id, o]));
// A command to an actuator as the ESPHome profile publishes it, and its text.
const commandTopic = (a) => (a.type === 'pump' ? `${a.device}/switch/${a.id.toLowerCase()}/command` : `${a.device}/valve/${a.id.toLowerCase()}/position/command`);
const commandText = (a, value) => (a.type === 'pump' ? (value ? 'ON' : 'OFF') : String(value));
const COMMAND_TOPICS = ['+/switch/+/command', '+/valve/+/position/command'];
const ofLine = (line) => PLANT.actuators.filter((a) => a.resource === line);
const TEST_DONE = 'test/done';

/** The buttons this test clicks: the walkthrough's own (`hold op 10`, ...) and one per command it adds. */
const ADDED = [['abort', '21'], ['reset', '21'], ['hold', '12'], ['restart', '12']];
const buttonId = (command, op) => nid(`test:${command}:${op}`);

/** The case-study flows on `port`, without the routines, with a button per ADDED command and op 10's result out to MQTT. */
function flows(port) {
  const all = build(PLANT);
  const routines = new Set(all.filter((n) => n.type === 'sugarshack-routine').map((n) => n.id));
  const nodes = all
    .filter((n) => !routines.has(n.id) && !(n.wires || []).some((w) => w.some((id) => routines.has(id))))
    .map((n) => (n.type === 'mqtt-broker' ? { ...n, port: String(port) } : n));
  const faultOp = nodes.find((n) => n.id === nid('fault-op:10'));
  faultOp.wires = [[...faultOp.wires[0], 'test-result']];
  const z = faultOp.z;
  nodes.push(
    { id: 'test-result', z, type: 'change', rules: [{ t: 'set', p: 'payload', pt: 'msg', to: 'operation', tot: 'msg' }], wires: [['test-done']] },
    { id: 'test-done', z, type: 'mqtt out', topic: TEST_DONE, qos: '1', retain: 'false', broker: nid('broker'), wires: [] },
    ...ADDED.map(([command, op]) => ({
      id: buttonId(command, op), z, type: 'inject', name: `${command} op ${op}`,
      props: [{ p: 'payload' }, { p: 'topic', vt: 'str' }, { p: 'by', v: 'ana', vt: 'str' }, { p: 'reason', v: 'the ISA-88 test', vt: 'str' }],
      topic: command, payload: '', payloadType: 'str', repeat: '', once: false, wires: [[nid(`operation:${op}`)]],
    })),
  );
  return nodes;
}

describe('ISA-88 hold, restart and abort on the real stack (Mosquitto, simulator, Node-RED)', function () {
  this.timeout(240000);
  let broker; let sim; let probe; let red;

  before(async function () {
    broker = await startMosquitto();
    [sim, probe] = await Promise.all([
      startTestSimulator(broker.url, { plant: PLANT_FILE, speed: 10, sweepS: 4, pumpDelayMs: 200 }),
      connectProbe(broker.url, [...COMMAND_TOPICS, TEST_DONE]),
    ]);
    red = new NodeRedProcess({ flows: flows(new URL(broker.url).port), tag: 'isa88' });
    await red.start();
  });

  // Node-RED first (the tail of its log when a test failed), then what it talks to.
  after(async function () {
    await red?.finish(this.currentTest);
    await Promise.all([probe?.end(), sim?.stop()]);
    await broker?.stop();
  });

  const click = async (id) => {
    const res = await fetch(`http://127.0.0.1:${red.port}/inject/${id}`, { method: 'POST' });
    assert.equal(res.status, 200, `the button ${id}`);
  };
  const walkthroughButton = (name) => build(PLANT).find((n) => n.type === 'inject' && n.name === name).id;
  const state = () => red.get('/sugarshack/state');
  const pick = ({ state, operation }) => ({ state, operation });
  const line = async (name) => (await state()).interlocks[0].lines.find((l) => l.name === name).state;
  // The run of `op` the state API lists (the plant's runs, or its interlock's).
  const runOf = async (op) => {
    const s = await state();
    const runs = [...(s.runs || []), ...s.interlocks.flatMap((i) => i.runs || [])];
    return runs.find((r) => r.operation === op || r.id === op) || null;
  };
  const runIs = (op, wanted) => async () => ((await runOf(op)) || {}).state === wanted;
  const pick2 = ({ by, reason, commands }) => ({ by, reason, commands });
  // Whether the interlock's state file holds a run of `op` saved held (its hold command confirmed).
  const savedHeld = (op) => {
    const dir = path.join(red.dir, 'sugarshack');
    const file = fs.readdirSync(dir).find((f) => /^interlock-.*\.json$/.test(f));
    const has = (v) => v !== null && typeof v === 'object' && ((v.operation === op && v.held === true) || Object.values(v).some(has));
    return Boolean(file) && has(JSON.parse(fs.readFileSync(path.join(dir, file), 'utf8')));
  };
  const volume = (tank) => sim.hydraulics.tanks.get(tank).volumeL;
  const panel = (a) => sim.devices[a.device];
  const pumpRunning = (id) => panel(ACTUATORS[id]).pumps[ACTUATORS[id].io].running;
  const valveAt = (id) => panel(ACTUATORS[id]).valves[ACTUATORS[id].io].position;
  const commandsSince = (since) => COMMAND_TOPICS.flatMap((t) => probe.on(t)).filter((m) => m.at >= since);
  const sent = (since, id, value) => commandsSince(since).some((m) => m.topic === commandTopic(ACTUATORS[id]) && m.text === commandText(ACTUATORS[id], value));
  const holdCommand = (op) => Object.values(OPERATIONS[op].hold.command).flatMap((group) => Object.entries(group));

  it('holds op 10 (load truck) mid-step: its hold command reaches the devices, nothing else is commanded, YEL stays held; restarted, it completes as it would have', async function () {
    assert.deepEqual(holdCommand('10'), [['P1', false], ['V101', 0]], 'the case study holds a fill by stopping its pump and closing its feed valve');
    await click(walkthroughButton('run op 10 now'));
    // Mid-step: the pump runs and the truck is filling, far from its 6000 L.
    await waitFor(() => pumpRunning('P1') && volume('T-truck') > 1000, 'op 10 filling the truck', 60000);
    assert.ok(volume('T-truck') < 4000, `the truck is still filling (${volume('T-truck')} L)`);

    const heldAt = Date.now();
    const answer = JSON.parse(await run(HOLD_SNIPPET, { red: red.port }));
    assert.equal(answer.operation, '10');
    await waitFor(runIs('10', 'held'), 'op 10 held', 30000);
    for (const [id, value] of holdCommand('10')) assert.ok(sent(heldAt, id, value), `the hold sent ${id} ${commandText(ACTUATORS[id], value)}`);
    await waitFor(() => !pumpRunning('P1') && valveAt('V101') < 3, 'P1 stopped and V101 closed at the devices', 10000);
    const commandedByHold = commandsSince(heldAt).map((m) => m.topic);
    assert.deepEqual([...new Set(commandedByHold)].sort(), holdCommand('10').map(([id]) => commandTopic(ACTUATORS[id])).sort(), 'the hold commanded only its hold command');

    // Held: nothing is commanded, the truck does not fill, YEL stays held by op 10.
    const quietFrom = Date.now();
    const level = volume('T-truck');
    await sleep(3000);
    assert.deepEqual(commandsSince(quietFrom).map((m) => `${m.topic} ${m.text}`), [], 'nothing commanded while held');
    assert.ok(Math.abs(volume('T-truck') - level) < 1, `the truck stopped filling (${level} L, then ${volume('T-truck')} L)`);
    assert.deepEqual(pick(await line('YEL')), { state: 'held', operation: '10' }, 'YEL held by op 10');
    assert.equal((await runOf('10')).state, 'held');

    const restartedAt = Date.now();
    const done = probe.waitFor(TEST_DONE, () => true, 120000);
    await click(walkthroughButton('restart op 10'));
    // What the hold changed goes back where op 10 had it, then the fill goes on.
    await waitFor(() => sent(restartedAt, 'V101', 100) && sent(restartedAt, 'P1', true), 'V101 opened and P1 started again', 30000);
    await waitFor(() => pumpRunning('P1') && volume('T-truck') > level + 100, 'the truck filling again', 30000);
    const result = (await done).json;
    assert.equal(result.id, '10');
    assert.ok(!result.error && !result.fault, `op 10 completed: ${JSON.stringify(result)}`);
    assert.ok(result.heldMs >= 3000, `its time held (${result.heldMs} ms) is counted apart, not against its wait's timeout`);
    assert.ok(volume('T-truck') >= 6000 - 100, `the truck is loaded (${volume('T-truck')} L)`);
    await waitFor(async () => (await line('YEL')).state === 'free', 'YEL released', 10000);
    assert.ok(!pumpRunning('P1') && valveAt('V101') < 3 && valveAt('V102') < 3, 'op 10 left its actuators idle');
  });

  it('aborts op 21 (evap push conc) while it runs: GRN\'s lockout goes out at once', async function () {
    await click(nid('inject:operation:21'));
    await waitFor(() => pumpRunning('P2'), 'op 21 pumping', 60000);
    const abortedAt = Date.now();
    await click(buttonId('abort', '21'));
    // Every GRN actuator sent its lockout state, well within a step (a valve is given 40 s).
    await waitFor(() => ofLine('GRN').every((a) => sent(abortedAt, a.id, a.lockout)), 'GRN\'s lockout sent', 5000);
    const tookMs = Date.now() - abortedAt;
    assert.ok(tookMs < 2000, `GRN's lockout went out ${tookMs} ms after the abort`);
    const aborted = async () => (await state()).interlocks[0].aborted.find((a) => a.operation === '21');
    await waitFor(aborted, 'op 21 listed aborted', 10000);
    assert.deepEqual(pick2(await aborted()), { by: 'ana', reason: 'the ISA-88 test', commands: ['reset'] }, 'the abort is attributed, and waits for a reset');
    assert.equal((await line('GRN')).state, 'faulted', 'an abort locks its lines out, as a fault does');
    await waitFor(() => !pumpRunning('P2'), 'P2 stopped at the device', 10000);
    await click(buttonId('reset', '21'));
    await waitFor(async () => !(await aborted()), 'op 21 reset', 10000);
    assert.equal((await line('GRN')).state, 'faulted', 'a reset is the operation\'s: its lines wait for a person\'s clear');
  });

  it('a SIGKILL while op 12 (unload truck) is held comes back held: YEL held by op 12, nothing commanded; a restart finishes the unload', async function () {
    await click(nid('inject:operation:12'));
    await waitFor(() => pumpRunning('P1') && volume('T-truck') < 5000, 'op 12 unloading the truck', 60000);
    await click(buttonId('hold', '12'));
    await waitFor(runIs('12', 'held'), 'op 12 held', 30000);
    await waitFor(() => !pumpRunning('P1') && valveAt('V103') < 3, 'P1 stopped and V103 closed', 10000);
    const level = volume('T-truck');
    // Killed once the held state is on disk (killed before, it comes back holding and sends its hold command again).
    await waitFor(() => savedHeld('12'), 'op 12 saved held', 10000);
    await red.kill();
    const restartedAt = Date.now();
    await red.start();
    assert.equal((await runOf('12') || {}).state, 'held', 'op 12 comes back held');
    assert.deepEqual(pick(await line('YEL')), { state: 'held', operation: '12' }, 'YEL held by op 12');
    await sleep(3000);
    const yel = new Set(ofLine('YEL').map(commandTopic));
    assert.deepEqual(commandsSince(restartedAt).filter((m) => yel.has(m.topic)).map((m) => `${m.topic} ${m.text}`), [], 'nothing on YEL commanded after the restart');
    assert.ok(!pumpRunning('P1') && Math.abs(volume('T-truck') - level) < 1, 'the truck stayed as it was held');

    await click(buttonId('restart', '12'));
    await waitFor(async () => (await line('YEL')).state === 'free', 'op 12 done and YEL released', 120000);
    // Its wait ends on LT-3 < 50 as the sensor reads it (with the simulator's noise).
    assert.ok(volume('T-truck') < 100, `the truck is unloaded (${volume('T-truck')} L)`);
  });
});
