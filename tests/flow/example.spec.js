'use strict';
// Runs the shipped example flows (MQTT replaced by helper nodes fed as mqtt in
// delivers, the work of the contention example done on the manual clock) and
// checks what their comments tell the user to watch.
const assert = require('node:assert/strict');
const fs = require('fs');
const path = require('path');
const helper = require('node-red-node-test-helper');
const wasm = require('../../node-red-contrib-sugarshack/lib/wasm');
const {
  PALETTE, paletteNodes, subflowNodes, subflowCoreNodes, catchOnce, startServer, stopServer, linkNodes, until, settled, clock, runFor, runUntil,
} = require('./support');

helper.init(require.resolve('node-red'));

const coreNodesDir = path.dirname(require.resolve('@node-red/nodes/package.json'));
const coreNodes = ['common/20-inject.js', 'common/90-comment.js', 'function/89-delay.js', 'function/15-change.js', 'function/10-function.js']
  .map((f) => require(path.join(coreNodesDir, 'core', f)));
const EXAMPLES = path.join(PALETTE, 'examples');
const CONFIG_TYPES = { 'sugarshack-interlock': true, 'sugarshack-plant': true };
// Nodes of the palette that use no config node.
const STANDALONE_TYPES = { 'sugarshack-pid': true, 'sugarshack-rcc': true, 'sugarshack-rcc-io': true, 'sugarshack-state': true, 'sugarshack-journal': true };
const NODE_MODULES = [...paletteNodes, ...subflowNodes, ...new Set([...subflowCoreNodes, ...coreNodes]), catchOnce, linkNodes];

const readExample = (file) => JSON.parse(fs.readFileSync(path.join(EXAMPLES, file), 'utf8'));
const exampleFiles = () => fs.readdirSync(EXAMPLES).filter((f) => f.endsWith('.json')).sort();

/**
 * An example as the test helper runs it: debug and mqtt out nodes become helper
 * nodes, mqtt in nodes and Dashboard 2 widgets helper nodes keeping their wires,
 * the broker and the dashboard's config nodes go (the browser and palette
 * tests run the dashboard itself). `tweak(node)` may return a changed node.
 */
function helperFlow(file, tweak = (n) => n) {
  return readExample(file)
    .filter((n) => n.type !== 'mqtt-broker' && !(n.type.startsWith('ui-') && !n.z))
    .map((n) => {
      if (n.type === 'debug' || n.type === 'mqtt out') return { id: n.id, z: n.z, type: 'helper', name: n.name };
      if (n.type === 'mqtt in' || n.type.startsWith('ui-')) return { id: n.id, z: n.z, type: 'helper', name: n.name, wires: n.wires };
      return tweak(n);
    });
}

/** The contention example; its delay nodes (the work) become helper nodes that `doWork` drives on the manual clock. */
function contentionFlow(policy) {
  return helperFlow('interlock-yel-contention.json', (n) => {
    if (n.type === 'delay') return { id: n.id, z: n.z, type: 'helper', name: n.name, wires: n.wires, workMs: Number(n.timeout) * 1000 };
    if (n.type === 'sugarshack-interlock') return { ...n, policy };
    return n;
  });
}

/** Each work node sends its msg on (to its release node) once its delay has passed on the clock. */
function doWork(flow) {
  for (const w of flow.filter((n) => n.workMs)) {
    const node = helper.getNode(w.id);
    node.on('input', (msg) => clock().setTimeout(() => node.send(msg), w.workMs));
  }
}

/** The ids of an example's interlocks, whose saves `runFor`/`runUntil` wait for. */
const interlocksOf = (flow) => flow.filter((n) => n.type === 'sugarshack-interlock').map((n) => n.id);

/** Every plant and interlock of the flow has started (or failed), and what it did is saved. */
async function started(flow) {
  const configs = flow.filter((n) => n.type === 'sugarshack-plant' || n.type === 'sugarshack-interlock');
  await until(() => configs.every((n) => helper.getNode(n.id).runtime.state !== 'starting'), 'the plants and interlocks to start');
  await settled(helper, ...interlocksOf(flow));
}

const byName = (flow, type, name) => {
  const node = flow.find((n) => n.type === type && n.name === name);
  assert.ok(node, `a ${type} named '${name}'`);
  return node.id;
};
const acquireOf = (flow, op) => flow.find((n) => n.type === 'sugarshack-acquire' && n.operation === op).id;
const ofType = (flow, type) => flow.filter((n) => n.type === type);

/** Starts collecting what reaches each named helper node. */
function watch(flow, names) {
  const seen = {};
  for (const name of names) {
    seen[name] = [];
    helper.getNode(byName(flow, 'helper', name)).on('input', (m) => seen[name].push(m));
  }
  return seen;
}

function errorLogs() {
  const log = helper.log();
  return log.args.map((a) => a[0]).filter((e) => e && e.level === log.ERROR).map((e) => `${e.type} ${e.id}: ${e.msg}`);
}

/**
 * The field devices of an example's plant, without a broker, on the manual
 * clock, each speaking its profile through the core's device side (what the
 * simulator uses): each panel obeys the commands the actuators node publishes
 * (a valve reaches its target `delayMs` later) and reports its actuators; each
 * sensor reports the value set with `sensor(id, value)`. Everything is re-sent
 * every 200 ms, so nothing goes stale.
 */
function fakeField(flow, { delayMs = 20 } = {}) {
  const plant = flow.find((n) => n.type === 'sugarshack-plant').plant;
  const side = new (wasm.load().DeviceSide)(plant);
  const bus = () => helper.getNode(flow.find((n) => n.type === 'sugarshack-actuators').id);
  const give = (messages) => {
    for (const m of messages) bus()?.receive({ topic: m.topic, payload: m.payload, retain: m.retain, qos: 0 });
  };
  const positions = plant.actuators.map((a) => (a.type === 'pump' ? 0 : a.idle));
  const values = (plant.sensors || []).map(() => undefined);
  const handles = (list, keep) => list.map((x, i) => (keep(x, i) ? i : -1)).filter((i) => i >= 0);
  const report = (device) => {
    const mine = handles(plant.actuators, (a) => a.device === device);
    if (mine.length) give(side.actuatorMessages(side.device(device), mine, mine.map((i) => positions[i]), clock().now()));
    const sensed = handles(plant.sensors || [], (s, i) => s.device === device && values[i] !== undefined);
    if (sensed.length) give(side.sensorMessages(side.device(device), sensed, sensed.map((i) => values[i]), clock().now()));
  };
  const timers = new Set();
  const commands = helper.getNode(byName(flow, 'helper', 'device commands'));
  commands.on('input', (msg) => {
    const read = side.parseCommand(msg.topic, Buffer.from(String(msg.payload)));
    if (!read || read.kind !== 'set') return; // another topic, or a retained lockout being cleared
    const t = clock().setTimeout(() => {
      timers.delete(t);
      positions[read.actuator] = read.value;
      report(plant.actuators[read.actuator].device);
    }, delayMs);
    timers.add(t);
  });
  const devices = plant.devices.map((d) => d.id);
  for (const d of devices) give([side.status(side.device(d), true)]);
  const tick = () => {
    for (const d of devices) report(d);
  };
  tick();
  const interval = clock().setInterval(tick, 200);
  return {
    sensor(id, value) {
      const i = plant.sensors.findIndex((s) => s.id === id);
      values[i] = value;
      report(plant.sensors[i].device);
    },
    stop() {
      clock().clearInterval(interval);
      for (const t of timers) clock().clearTimeout(t);
      side.free();
    },
  };
}

/** The last status a node set (the status spy is shared by every node). */
const statusOf = (id) => helper.getNode(id).status.getCalls().filter((c) => c.thisValue.id === id).map((c) => c.args[0]).at(-1);

const commandsOf = (msgs) => msgs.map((m) => [m.topic, m.payload]);

/** The command topics of a rig panel's line lockout, sorted: its ten valves from `first` on, and its pump. */
const lockoutTopics = (panel, first, pump) => [
  ...Array.from({ length: 10 }, (_, i) => `rig/${panel}/valve/v${first + i}/position/command`), `rig/${panel}/switch/${pump}/command`].sort();

/**
 * Op 12 of the examples that run it (unload truck: YEL's two valves open, the
 * pump runs, then the idle step closes all), from its inject with LT-3 empty:
 * returns the msg it comes back with, once its commands are checked.
 */
async function unloadTruck({ flow, seen, field }, runTill) {
  field.sensor('LT-3', 0);
  const sent = seen['device commands'].length;
  helper.getNode(byName(flow, 'inject', 'unload truck (op 12)')).receive({});
  await runTill(() => seen['op 12 returned'].length === 1, 'op 12 to return to its caller');
  const back = seen['op 12 returned'][0];
  assert.equal(back.payload.pumps.P1, false, 'the msg has been through the idle step');
  assert.deepEqual(back.interlock.resources, ['YEL']);
  assert.equal(back.interlock.operation, '12');
  assert.deepEqual(commandsOf(seen['device commands'].slice(sent)).filter(([, p]) => p !== ''), [
    ['rig/ctrl-1/valve/v103/position/command', '100'], ['rig/ctrl-1/valve/v104/position/command', '100'],
    ['rig/ctrl-1/switch/p1/command', 'ON'],
    ['rig/ctrl-1/switch/p1/command', 'OFF'],
    ['rig/ctrl-1/valve/v103/position/command', '0'], ['rig/ctrl-1/valve/v104/position/command', '0'], ['rig/ctrl-1/switch/p1/command', 'OFF'],
  ]);
  return back;
}

/**
 * The hooks and start of a describe block that runs example `file` against a
 * fake field, each test in its own user directory (the interlock's state):
 * `start(tweak)` loads it (each node through `tweak`), waits for its plants and
 * interlocks, and watches the helper nodes named in `watched`; `run(ms)` and
 * `runTill(predicate, what)` move the manual clock, the interlocks (`ids`)
 * saving as it goes.
 */
function exampleRun(file, watched) {
  let field = null;
  const ids = interlocksOf(helperFlow(file));
  beforeEach(startServer);
  afterEach(async function () {
    field?.stop();
    field = null;
    await stopServer();
  });
  return {
    async start(tweak) {
      const flow = helperFlow(file, tweak);
      await helper.load(NODE_MODULES, flow);
      await started(flow);
      const seen = watch(flow, watched);
      field = fakeField(flow);
      return { flow, seen, field };
    },
    ids,
    run: (ms) => runFor(helper, ms, { ids }),
    runTill: (predicate, what) => runUntil(helper, predicate, what, { ids }),
  };
}

describe('examples', function () {
  beforeEach(startServer);
  afterEach(stopServer);

  it('every example flow uses only configured nodes, and together they use every node type', function () {
    const pkg = JSON.parse(fs.readFileSync(path.join(PALETTE, 'package.json'), 'utf8'));
    const used = new Set();
    const ids = new Map();
    for (const file of exampleFiles()) {
      const flow = readExample(file);
      // Each node of the palette names its config node (interlock or plant) through the property of that name.
      const configs = new Map(flow.filter((n) => CONFIG_TYPES[n.type]).map((n) => [n.id, n.type]));
      for (const n of flow) {
        used.add(n.type);
        assert.match(n.id, /^[0-9a-f]{16}$/, `${file}: node id ${n.id} is 16 hex digits, as Node-RED exports them`);
        // The only ids two examples share are the example rig's config nodes, the same in each (an import of both reuses them).
        if (ids.has(n.id)) assert.deepEqual(n, ids.get(n.id).node, `${file}: node id ${n.id} is also used in ${ids.get(n.id).file} for another node`);
        else ids.set(n.id, { file, node: n });
        if (n.type.startsWith('sugarshack-') && !CONFIG_TYPES[n.type] && !STANDALONE_TYPES[n.type]) {
          const property = n.interlock !== undefined ? 'interlock' : 'plant';
          assert.equal(configs.get(n[property]), `sugarshack-${property}`, `${file}: ${n.type} ${n.id} has its ${property} in the file`);
        }
        if (n.type === 'sugarshack-interlock' && n.plant) {
          assert.equal(configs.get(n.plant), 'sugarshack-plant', `${file}: interlock ${n.id} has its plant in the file`);
        }
        for (const [key, value] of Object.entries(n)) {
          if (key === 'broker' && n.type !== 'mqtt-broker') assert.ok(flow.some((c) => c.id === value && c.type === 'mqtt-broker'), `${file}: ${n.id} has its broker in the file`);
        }
        if (n.type === 'link call') {
          for (const target of n.links) assert.ok(flow.some((c) => c.id === target && c.type === 'link in'), `${file}: link call ${n.id} calls a link in of the file`);
        }
        if (n.type === 'catch' && Array.isArray(n.scope)) {
          for (const target of n.scope) assert.ok(flow.some((c) => c.id === target), `${file}: catch ${n.id} watches a node of the file`);
        }
        if (n.z) assert.ok(flow.some((c) => c.id === n.z && (c.type === 'tab' || c.type === 'subflow')), `${file}: ${n.id} is on a tab or in a subflow of the file`);
        if (n.type.startsWith('subflow:')) assert.ok(flow.some((c) => c.id === n.type.slice(8) && c.type === 'subflow'), `${file}: ${n.id} is an instance of a subflow of the file`);
      }
    }
    const types = Object.keys(pkg['node-red'].nodes).map((set) => `sugarshack-${set}`);
    for (const type of types) assert.ok(used.has(type), `${type} appears in an example`);
  });

  it('the examples that drive devices carry the example rig\'s plant, interlock and broker nodes, as scripts/example-rig.js writes them from flows/example-rig.json', function () {
    const { FILES, IDS, RIG_FILE, withRig } = require('../../scripts/example-rig.js');
    const rig = JSON.parse(fs.readFileSync(RIG_FILE, 'utf8'));
    for (const file of FILES) {
      const flow = readExample(path.basename(file));
      assert.deepEqual(flow, withRig(flow, rig), `${path.basename(file)}: run node scripts/example-rig.js`);
      assert.deepEqual(flow.slice(0, 3).map((n) => n.id), [IDS.plant, IDS.interlock, IDS.broker]);
    }
    // No other example binds to the rig's devices, and none to the case study's but the HMI (with npm start's ids);
    // modbus-pid-loop's plant is its own Modbus I/O module (the simulator's flow loop), shared with no other plant.
    const ownPlant = { 'modbus-pid-loop.json': readExample('modbus-pid-loop.json').filter((n) => n.type === 'sugarshack-plant' && n.plant.simulation && n.plant.simulation.loop).map((n) => n.id) };
    const caseStudy = JSON.parse(fs.readFileSync(path.join(__dirname, '..', '..', 'flows', 'case-study.json'), 'utf8'));
    const casePlant = caseStudy.find((n) => n.type === 'sugarshack-plant').id;
    for (const file of exampleFiles()) {
      const plants = readExample(file).filter((n) => n.type === 'sugarshack-plant').map((n) => n.id);
      const expected = FILES.some((f) => path.basename(f) === file) ? [IDS.plant] : file === 'hmi-dashboard.json' ? [casePlant] : ownPlant[file] || [];
      assert.deepEqual(plants, expected, file);
    }
  });

  it('the HMI example and flows/hmi.json are what scripts/hmi-flow.js makes of scripts/hmi/*.vue (one source, no hand copy)', function () {
    const { npmStart, example } = require('../../scripts/hmi-flow.js');
    assert.deepEqual(readExample('hmi-dashboard.json'), example());
    assert.deepEqual(JSON.parse(fs.readFileSync(path.join(__dirname, '..', '..', 'flows', 'hmi.json'), 'utf8')), npmStart());
    // The panels are the same subflows in both, the palette's own nodes inside, no private internals.
    const panels = (flow) => flow.filter((n) => n.type === 'subflow').map((n) => n.name);
    assert.deepEqual(panels(example()), ['sugarshack lines panel', 'sugarshack alarms panel']);
    const inside = example().filter((n) => n.z && example().some((sf) => sf.type === 'subflow' && sf.id === n.z)).map((n) => n.type);
    assert.deepEqual([...new Set(inside)].sort(), ['catch', 'change', 'sugarshack-state', 'switch', 'ui-template']);
  });

  for (const file of exampleFiles()) {
    it(`${file} deploys without an error, every plant document valid`, async function () {
      const flow = helperFlow(file);
      await helper.load(NODE_MODULES, flow);
      await started(flow);
      assert.deepEqual(errorLogs(), []);
      for (const p of ofType(flow, 'sugarshack-plant')) assert.equal(helper.getNode(p.id).runtime.state, 'ready', `plant ${p.name}`);
      for (const il of ofType(flow, 'sugarshack-interlock')) assert.equal(helper.getNode(il.id).runtime.state, 'ready', `interlock ${il.name}`);
    });
  }
});

describe('example: interlock-yel-contention', function () {
  beforeEach(startServer);
  afterEach(stopServer);

  for (const [policy, order] of [['greedy', ['10', '51', '12', '18']], ['no-overtaking', ['10', '18', '12', '51']]]) {
    it(`"start all" grants in the order the comment describes (${policy})`, async function () {
      const flow = contentionFlow(policy);
      await helper.load(NODE_MODULES, flow);
      doWork(flow);
      const seen = watch(flow, ['granted', 'returned', 'refusals']);
      helper.getNode(byName(flow, 'inject', 'start all')).receive({});
      const took = await runUntil(helper, () => seen.returned.length === 4, 'all four operations to return', { ids: interlocksOf(flow), step: 100 });
      assert.deepEqual(seen.granted.map((m) => m.interlock.operation), order);
      // Greedy: 10 and 51 at once, 12 once 10 is done (5 s), 18 once 12 is (10 s), done at 14 s.
      // No overtaking: 51 may not take RED ahead of 18; 18 once 10 is done (5 s), then 12 and 51 (9 s), done at 17 s.
      assert.deepEqual(seen.granted.map((m) => m.interlock.waitedMs), policy === 'greedy' ? [0, 0, 5000, 10000] : [0, 5000, 9000, 9000]);
      assert.equal(took, policy === 'greedy' ? 14000 : 17000);
      assert.deepEqual(seen.refusals, []);
    });
  }

  it('fault op 12 locks YEL out, refuses its release, and clear resumes the queue', async function () {
    const flow = contentionFlow('greedy');
    await helper.load(NODE_MODULES, flow);
    doWork(flow);
    const run = (ms) => runFor(helper, ms, { ids: interlocksOf(flow), step: 100 });
    const seen = watch(flow, ['granted', 'returned', 'refusals', 'lockout commands', 'cleared']);
    helper.getNode(byName(flow, 'inject', 'start op 12 (unload truck)')).receive({});
    await until(() => seen.granted.length === 1, 'op 12 granted');
    helper.getNode(byName(flow, 'inject', 'fault op 12')).receive({});
    await until(() => seen['lockout commands'].length === 1, 'the YEL lockout');
    const lockout = seen['lockout commands'][0];
    assert.equal(lockout.topic, 'lockout/YEL');
    assert.deepEqual(lockout.payload, { valves: { V10: 0, V11: 0, V12: 0, V13: 0 }, pumps: { P1: false } });
    assert.equal(lockout.note, 'pump P1 ran dry');
    await run(4900);
    assert.deepEqual(seen.refusals, [], 'op 12 works on for its 5 s');
    await run(100);
    await until(() => seen.refusals.length === 1, 'the refused release of 12');
    assert.equal(seen.refusals[0].error.code, 'NOT_HOLDING');

    helper.getNode(acquireOf(flow, '10')).receive({ payload: 'load truck' });
    helper.getNode(byName(flow, 'inject', 'start op 51 (drain silo)')).receive({});
    await until(() => seen.granted.length === 2, 'op 51 granted on RED');
    assert.equal(seen.granted[1].interlock.operation, '51');
    await run(1000);
    helper.getNode(byName(flow, 'inject', 'clear all faulted')).receive({});
    await until(() => seen.granted.length === 3, 'op 10 granted after the clear');
    assert.deepEqual(seen.cleared[0].cleared, ['YEL']);
    assert.equal(seen.granted[2].interlock.operation, '10');
    assert.equal(seen.granted[2].interlock.waitedMs, 1000, 'op 10 waited on the faulted line until the clear');
  });
});

describe('example: operation-subflow', function () {
  const { start: startExample, run, runTill } = exampleRun('operation-subflow.json', ['op 12 returned', 'device commands',
    'command errors', 'faulted', 'lockout done', 'refused calls', 'cleared', 'interlock events']);
  /** The example with `waitS` as the condition's timeout. */
  const start = ({ waitS } = {}) => startExample((n) => (n.type === 'sugarshack-wait' && waitS ? { ...n, timeout: waitS } : n));

  it('op 12 runs from its link call: acquire, commands through the shared block, condition, back to idle, release, return', async function () {
    const { flow, seen, field } = await start();
    await unloadTruck({ flow, seen, field }, runTill);
    // Interlock events are published once per turn of the event loop: the release may follow the msg.
    const kinds = () => seen['interlock events'].map((m) => m.payload.kind).filter((k) => k === 'granted' || k === 'released');
    await runTill(() => kinds().length === 2, 'the granted and released events');
    assert.deepEqual(kinds(), ['granted', 'released']);
    for (const name of ['command errors', 'faulted', 'refused calls']) assert.deepEqual(seen[name], [], name);

    // C1: while op 12 holds YEL, a second call is refused at the acquire node, not faulted.
    field.sensor('LT-3', 5000);
    helper.getNode(byName(flow, 'inject', 'unload truck (op 12)')).receive({});
    await runTill(() => seen['interlock events'].filter((m) => m.payload.kind === 'granted').length === 2, 'the second grant');
    helper.getNode(byName(flow, 'inject', 'unload truck (op 12)')).receive({});
    await runTill(() => seen['refused calls'].length === 1, 'the refused second call');
    assert.equal(seen['refused calls'][0].error.code, 'ALREADY_HOLDING');
    assert.deepEqual(seen.faulted, []);
    field.sensor('LT-3', 0);
    await runTill(() => seen['op 12 returned'].length === 2, 'the first call to return');
    await run(100);
    assert.equal(seen['op 12 returned'].length, 2, 'the refused call does not return');

    // e-stop RED: RED's lockout, retained, derived from the plant's RED actuators.
    helper.getNode(byName(flow, 'inject', 'e-stop RED')).receive({});
    await runTill(() => seen['lockout done'].length === 1, 'the RED lockout to complete');
    assert.equal(seen['lockout done'][0].topic, 'lockout/RED');
    const retained = seen['device commands'].filter((m) => m.retain && m.payload !== '');
    assert.deepEqual(retained.map((m) => m.topic).sort(), lockoutTopics('ctrl-5', 501, 'p3'));
  });

  it('a condition that does not hold in time faults op 12 through the Catch: YEL locks out, blocks op 12 until cleared', async function () {
    const { flow, seen, field } = await start({ waitS: 0.3 });
    field.sensor('LT-3', 5000);
    helper.getNode(byName(flow, 'inject', 'unload truck (op 12)')).receive({});
    await runTill(() => seen.faulted.length === 1, 'the fault');
    assert.equal(seen.faulted[0].error.code, 'CONDITION_TIMEOUT');
    assert.match(seen.faulted[0].error.message, /`LT-3` < 50 did not hold within 0.3 s/);
    await runTill(() => seen['lockout done'].length === 1, 'the YEL lockout to complete');
    const lockout = seen['lockout done'][0];
    assert.equal(lockout.topic, 'lockout/YEL');
    assert.equal(lockout.command.faultLockoutMs, 20, 'from the fault to every YEL actuator at its lockout state');
    const retained = seen['device commands'].filter((m) => m.retain && m.payload !== '');
    assert.deepEqual(retained.map((m) => [m.topic, m.payload]).sort(), lockoutTopics('ctrl-1', 101, 'p1').map((t) => [t, t.endsWith('p1/command') ? 'OFF' : '0']));

    // YEL stays faulted: the next call waits at the acquire node until a person clears it.
    field.sensor('LT-3', 0);
    helper.getNode(byName(flow, 'inject', 'unload truck (op 12)')).receive({});
    await run(200);
    assert.equal(seen['op 12 returned'].length, 0, 'op 12 waits on the faulted line');
    helper.getNode(byName(flow, 'inject', 'clear all faulted')).receive({});
    await runTill(() => seen['op 12 returned'].length === 1, 'op 12 after the clear');
    assert.deepEqual(seen.cleared[0].cleared, ['YEL']);
    assert.equal(seen['op 12 returned'][0].interlock.waitedMs, 200, 'from the call to the clear');
    assert.deepEqual(seen['command errors'], []);
  });
});

describe('example: operations-and-routines', function () {
  const FILE = 'operations-and-routines.json';
  const { start, runTill } = exampleRun(FILE, ['operation returned', 'routine events', 'errors', 'interlock events', 'device commands']);

  const inject = (flow, name) => helper.getNode(byName(flow, 'inject', name)).receive({});

  it('the interlock takes YEL and RED with their lockouts from the plant; operations, wait and routine start idle', async function () {
    const flow = helperFlow(FILE);
    await helper.load(NODE_MODULES, flow);
    await started(flow);
    assert.deepEqual(errorLogs(), []);
    const il = helper.getNode(ofType(flow, 'sugarshack-interlock')[0].id).runtime;
    assert.deepEqual(il.config.resources.map((r) => r.name), ['YEL', 'RED']);
    assert.deepEqual(il.config.resources[1].lockout.pumps, { P3: false });
    const plant = ofType(flow, 'sugarshack-plant')[0].plant;
    for (const op of ofType(flow, 'sugarshack-operation')) assert.ok(plant.operations.some((o) => o.id === op.operation));
    assert.equal(ofType(flow, 'sugarshack-routine')[0].routine, plant.routines[0].id);
    const statuses = (type) => ofType(flow, type).map((n) => statusOf(n.id));
    for (const s of statuses('sugarshack-operation')) assert.deepEqual(s, { fill: 'grey', shape: 'ring', text: 'idle' });
    assert.deepEqual(statuses('sugarshack-routine'), [{ fill: 'green', shape: 'dot', text: 'empty' }]);
  });

  it('op 18 from its inject; a second start is refused (C1); drain silo waits for LT-2, then queues behind op 18 on RED', async function () {
    const { flow, seen, field } = await start();
    field.sensor('LT-7', 1000);
    field.sensor('LT-2', 20000);
    inject(flow, 'start op 18 (flit downstock)');
    await runTill(() => seen['device commands'].some((m) => m.topic === 'rig/ctrl-5/switch/p3/command' && m.payload === 'ON'), 'P3 on');
    inject(flow, 'start op 18 (flit downstock)');
    await runTill(() => seen.errors.length === 1, 'the refused second start');
    assert.equal(seen.errors[0].error.code, 'OPERATION_RUNNING');
    inject(flow, 'drain silo when LT-2 ≥ 15000 L');
    await runTill(() => seen['interlock events'].some((m) => m.payload.kind === 'queued' && m.payload.operation === '51'), 'op 51 queued');
    field.sensor('LT-7', 200);
    await runTill(() => seen['operation returned'].length === 2, 'op 18, then op 51');
    const [op18, op51] = seen['operation returned'].map((m) => m.operation);
    assert.equal(op18.id, '18');
    assert.equal(op51.id, '51');
    // Op 18 ran 80 ms (two commands, its wait already met, a command, back to idle): op 51 queued for RED from 20 ms on.
    assert.equal(op18.runMs, 80);
    assert.equal(op51.queuedMs, 60, 'op 51 waited for RED');
    assert.deepEqual(op18.steps.map((s) => s.kind), ['command', 'command', 'wait', 'command', 'returnToIdle']);
    assert.deepEqual(seen['operation returned'][1].condition.values, { 'LT-2': 20000 });
    assert.equal(seen.errors.length, 1);
  });

  it('the truck routine: load runs op 10 to loaded, unload runs op 12 back to empty, one pending operation at a time', async function () {
    const { flow, seen, field } = await start();
    field.sensor('LT-2', 20000);
    field.sensor('LT-3', 0);
    inject(flow, 'reset');
    await runTill(() => seen['routine events'].length === 1, 'the reset');
    assert.equal(seen['routine events'][0].payload.to, 'empty');
    inject(flow, 'load');
    await runTill(() => seen['routine events'].length === 2, 'the dispatch of op 10');
    assert.deepEqual(
      (({ event, operation, from, to, state, pending }) => ({ event, operation, from, to, state, pending }))(seen['routine events'][1].payload),
      { event: 'dispatched', operation: '10', from: 'empty', to: 'loaded', state: 'empty', pending: '10' },
    );
    inject(flow, 'unload');
    await runTill(() => seen.errors.length === 1, 'the trigger refused while op 10 is pending');
    assert.equal(seen.errors[0].error.code, 'ROUTINE_BUSY');
    field.sensor('LT-3', 7000);
    await runTill(() => seen['routine events'].length === 3, 'op 10 to complete');
    assert.equal(seen['routine events'][2].payload.event, 'completed');
    assert.equal(seen['routine events'][2].payload.state, 'loaded');
    inject(flow, 'unload');
    await runTill(() => seen['routine events'].length === 4, 'the dispatch of op 12');
    field.sensor('LT-3', 0);
    await runTill(() => seen['routine events'].length === 5, 'op 12 to complete');
    assert.deepEqual(seen['routine events'].map((m) => [m.payload.event, m.payload.state]), [
      ['reset', 'empty'], ['dispatched', 'empty'], ['completed', 'loaded'], ['dispatched', 'loaded'], ['completed', 'empty'],
    ]);
    inject(flow, 'unload');
    await runTill(() => seen.errors.length === 2, 'no unload from empty');
    assert.equal(seen.errors[1].error.code, 'NO_TRANSITION');
  });
});

describe('example: subflows-op12', function () {
  const { start: startExample, runTill, ids } = exampleRun('subflows-op12.json', ['op 12 returned', 'device commands', 'faulted',
    'step errors', 'lockout done', 'panel', 'not understood', 'clear refused', 'state']);
  /** The example with `waitS` as the condition step's timeout. */
  const start = ({ waitS } = {}) => startExample((n) => (n.type === 'sugarshack-condition-step' && waitS ? { ...n, timeout: waitS } : n));

  it('op 12 from the singular operation node: its steps through the group command entry and a condition step, then return', async function () {
    const loaded = await start();
    const back = await unloadTruck(loaded, runTill);
    assert.equal(back.interlock.priority, 22);
    assert.equal(typeof back.condition.waitedMs, 'number', 'the condition step held');
    for (const name of ['faulted', 'step errors', 'lockout done']) assert.deepEqual(loaded.seen[name], [], name);
  });

  it('a condition step that does not hold in time reports which condition failed, to the Catch of the steps', async function () {
    const { flow, seen, field } = await start({ waitS: 0.3 });
    field.sensor('LT-3', 5000);
    helper.getNode(byName(flow, 'inject', 'unload truck (op 12)')).receive({});
    await runTill(() => seen['step errors'].length === 1, 'the condition failure');
    assert.equal(seen['step errors'][0].error.code, 'CONDITION_TIMEOUT');
    assert.match(seen['step errors'][0].error.message, /`LT-3` < 50 did not hold within 0.3 s/);
    assert.equal(seen['step errors'][0].error.source.type, 'sugarshack-wait');
  });

  it('the operator panel: e-stop locks RED out through the group command entry, clear clears it, anything else comes out of output 4', async function () {
    const { flow, seen } = await start();
    const panel = helper.getNode(byName(flow, 'sugarshack-operator-panel', 'RED panel'));
    helper.getNode(byName(flow, 'inject', 'e-stop RED')).receive({});
    await runTill(() => seen['lockout done'].length === 1, 'the RED lockout to complete');
    assert.equal(seen['lockout done'][0].topic, 'lockout/RED');
    assert.equal(seen.panel.length, 1);
    assert.deepEqual(helper.getNode(ids[0]).runtime.core.counts(), { holding: 0, queued: 0, faulted: 1 });
    helper.getNode(byName(flow, 'inject', 'clear RED')).receive({});
    await runTill(() => seen.panel.length === 2, 'the clear');
    assert.deepEqual(seen.panel[1].cleared, ['RED']);
    assert.deepEqual(helper.getNode(ids[0]).runtime.core.counts(), { holding: 0, queued: 0, faulted: 0 });
    panel.receive({ payload: 'reset' });
    await runTill(() => seen['not understood'].length === 1, 'the msg not understood');
    assert.equal(seen['not understood'][0].payload, 'reset');
    assert.equal(seen.panel.length, 2);
  });

  it('the operator panel refuses a clear while a RED device is offline, every reason listed, then clears; the state node shows it all', async function () {
    const { flow, seen } = await start();
    const panel = helper.getNode(byName(flow, 'sugarshack-operator-panel', 'RED panel'));
    const bus = helper.getNode(flow.find((n) => n.type === 'sugarshack-actuators').id);
    const plantId = flow.find((n) => n.type === 'sugarshack-plant').id;
    // What the state node sends, read straight from the runtimes while waiting.
    const state = () => ({ interlocks: [helper.getNode(ids[0]).runtime.describe()], plants: [helper.getNode(plantId).runtime.describe()] });
    panel.receive({ payload: 'e-stop', by: 'ana', reason: 'leak at the RED pump' });
    await runTill(() => seen['lockout done'].length === 1, 'the RED lockout to complete');
    let red = state().interlocks[0].lines.find((l) => l.name === 'RED');
    assert.equal(red.fault.cause, 'manual');
    assert.equal(red.fault.note, 'leak at the RED pump');
    assert.deepEqual(red.clearBlockers, []);
    bus.receive({ topic: 'rig/ctrl-5/status', payload: 'offline', retain: true });
    await runTill(() => state().plants[0].devices.find((d) => d.device === 'rig-ctrl-5').state === 'offline', 'rig-ctrl-5 offline');
    red = state().interlocks[0].lines.find((l) => l.name === 'RED');
    assert.deepEqual(red.clearBlockers, [{ kind: 'deviceOffline', device: 'rig-ctrl-5', text: 'device rig-ctrl-5 offline' }]);
    panel.receive({ payload: 'clear', by: 'ana' });
    await runTill(() => seen['clear refused'].length === 1, 'the refusal');
    const refused = seen['clear refused'][0].refused;
    assert.equal(refused.code, 'CLEAR_REFUSED');
    assert.deepEqual(refused.lines, [{ line: 'RED', reasons: [{ kind: 'deviceOffline', device: 'rig-ctrl-5' }], texts: ['device rig-ctrl-5 offline'] }]);
    assert.match(refused.message, /device rig-ctrl-5 offline/);
    assert.equal(state().interlocks[0].lines.find((l) => l.name === 'RED').state.state, 'faulted', 'refused whole');
    bus.receive({ topic: 'rig/ctrl-5/status', payload: 'online', retain: true });
    await runTill(() => state().interlocks[0].lines.find((l) => l.name === 'RED').clearBlockers.length === 0, 'RED isolated again on fresh feedback');
    panel.receive({ payload: 'clear', by: 'ana', reason: 'pump fixed' });
    await runTill(() => seen.panel.length === 2, 'the clear');
    assert.deepEqual(seen.panel[1].cleared, ['RED']);
    assert.deepEqual(seen.panel[1].clearedBy, { by: 'ana', reason: 'pump fixed', forced: false });
    helper.getNode(byName(flow, 'inject', 'plant state')).receive({});
    await runTill(() => seen.state.length === 1, 'the state msg');
    const after = seen.state[0];
    assert.equal(after.trigger, 'request');
    assert.deepEqual(after.payload.interlocks[0].lines.find((l) => l.name === 'RED'), {
      name: 'RED', state: { state: 'free' }, holder: null, fault: null, waiting: [], clearBlockers: [],
    });
    assert.ok(after.payload.plants[0].sensors.some((s) => s.sensor === 'LT-3'), 'sensors listed');
    assert.deepEqual(after.payload.plants[0].devices.map((d) => [d.device, d.state]), [['rig-ctrl-1', 'online'], ['rig-ctrl-5', 'online'], ['rig-station-2', 'online'], ['rig-station-3', 'online'], ['rig-station-7', 'online']]);
  });

  it('the editor\'s POST /sugarshack/estop and /sugarshack/clear: lockout sent, clear refused with its reasons, then cleared, each recorded by "unknown" without adminAuth', async function () {
    const { flow, seen } = await start();
    const bus = helper.getNode(flow.find((n) => n.type === 'sugarshack-actuators').id);
    const runtime = helper.getNode(ids[0]).runtime;
    const records = [];
    runtime.events.add({ send: (msg) => records.push(msg.payload) });
    const post = (url, body) => helper.request().post(url).send(body);
    const red = () => runtime.describe().lines.find((l) => l.name === 'RED');
    const sent = seen['device commands'].length;

    let res = await post('/sugarshack/estop', { interlock: ids[0], lines: ['RED'], reason: 'leak under P5' });
    assert.equal(res.status, 200, res.text);
    assert.deepEqual(res.body, { stopped: ['RED'], by: 'unknown' });
    assert.equal(red().fault.note, 'leak under P5');
    await runTill(() => red().clearBlockers.length === 0 && runtime.plant.describe().lockoutsPending.length === 0, 'RED locked out');
    assert.ok(commandsOf(seen['device commands'].slice(sent)).some(([topic]) => topic.startsWith('rig/ctrl-5/')), 'the lockout went to rig-ctrl-5');

    bus.receive({ topic: 'rig/ctrl-5/status', payload: 'offline', retain: true });
    await runTill(() => red().clearBlockers.length === 1, 'rig-ctrl-5 offline');
    res = await post('/sugarshack/clear', { interlock: ids[0], lines: ['RED'] });
    assert.equal(res.status, 409);
    assert.equal(res.body.code, 'CLEAR_REFUSED');
    assert.deepEqual(res.body.lines, [{ line: 'RED', reasons: [{ kind: 'deviceOffline', device: 'rig-ctrl-5' }], texts: ['device rig-ctrl-5 offline'] }]);
    assert.equal(red().state.state, 'faulted');

    bus.receive({ topic: 'rig/ctrl-5/status', payload: 'online', retain: true });
    await runTill(() => red().clearBlockers.length === 0, 'RED isolated again on fresh feedback');
    res = await post('/sugarshack/clear', { interlock: ids[0], lines: ['RED'], reason: 'pipe fixed' });
    assert.equal(res.status, 200, res.text);
    assert.deepEqual(res.body, { cleared: ['RED'], by: 'unknown' });
    await runTill(() => records.some((r) => r.kind === 'cleared'), 'the cleared event');
    const faulted = records.find((r) => r.kind === 'resource-faulted');
    const cleared = records.find((r) => r.kind === 'cleared');
    assert.equal(faulted.by, 'unknown');
    assert.equal(faulted.reason, 'leak under P5');
    assert.equal(cleared.by, 'unknown');
    assert.equal(cleared.reason, 'pipe fixed');
    assert.equal(cleared.forced, undefined, 'not forced');

    // Not faulted any more, a line that does not exist, an interlock that does not, no lines to stop.
    res = await post('/sugarshack/clear', { interlock: ids[0], lines: ['RED'] });
    assert.equal(res.status, 409);
    assert.equal(res.body.code, 'NOT_FAULTED');
    assert.match(res.body.message, /line 'RED' is not faulted/);
    res = await post('/sugarshack/clear', { interlock: ids[0], lines: ['PINK'] });
    assert.equal(res.status, 409);
    assert.match(res.body.code, /UNKNOWN_RESOURCE|INVALID_RESOURCES/);
    res = await post('/sugarshack/estop', { interlock: 'nope', lines: ['RED'] });
    assert.equal(res.status, 404);
    assert.equal(res.body.code, 'NO_INTERLOCK');
    res = await post('/sugarshack/estop', { interlock: ids[0], lines: [] });
    assert.equal(res.status, 409);
    assert.equal(res.body.code, 'INVALID_RESOURCES');
    res = await post('/sugarshack/estop', { interlock: ids[0], lines: 'RED' });
    assert.equal(res.status, 409, 'lines must be a list');
    assert.deepEqual(runtime.core.counts(), { holding: 0, queued: 0, faulted: 0 }, 'none of the bad requests changed anything');
  });

  it('alarms: an e-stop and an offline device raise them; acknowledged by POST and by the state node as who asked, shelved until a time, kept over a restart', async function () {
    const { flow, seen } = await start();
    const panel = helper.getNode(byName(flow, 'sugarshack-operator-panel', 'RED panel'));
    const bus = helper.getNode(flow.find((n) => n.type === 'sugarshack-actuators').id);
    const runtime = () => helper.getNode(ids[0]).runtime;
    const alarm = (id) => runtime().describe().alarms.find((a) => a.id === id);
    const post = (url, body) => helper.request().post(url).send(body);
    panel.receive({ payload: 'e-stop', by: 'ana', reason: 'leak at the RED pump' });
    await runTill(() => seen['lockout done'].length === 1, 'the RED lockout to complete');
    assert.equal(alarm('line-faulted:RED').state, 'active-unacknowledged');
    assert.match(alarm('line-faulted:RED').text, /RED faulted, manual: leak at the RED pump/);
    assert.equal(runtime().describe().recentEvents.at(-1).summary, 'e-stop RED by ana: leak at the RED pump');
    bus.receive({ topic: 'rig/ctrl-5/status', payload: 'offline', retain: true });
    await runTill(() => alarm('device-offline:rig-ctrl-5'), 'the device-offline alarm');
    assert.equal(alarm('device-offline:rig-ctrl-5').text, 'device rig-ctrl-5 offline', 'worded by the core');

    // The editor acknowledges one; without adminAuth it is "unknown" who did. The journal gets it as an operator action.
    const ackedAt = clock().now();
    const { journal } = require(path.join(PALETTE, 'lib', 'journal', 'bus.js'));
    const journaled = [];
    const action = journal.action;
    journal.action = (...args) => journaled.push(args);
    let res;
    try {
      res = await post('/sugarshack/alarms/ack', { interlock: ids[0], ids: ['line-faulted:RED'], reason: 'seen' });
    } finally {
      journal.action = action;
    }
    assert.deepEqual(journaled.map(([kind, who, target]) => [kind, who.reason, target]), [['alarm-ack', 'seen', ['line-faulted:RED']]]);
    assert.equal(res.status, 200, res.text);
    assert.deepEqual(res.body.changes.map((c) => [c.id, c.from, c.to, c.by]), [['line-faulted:RED', 'active-unacknowledged', 'active-acknowledged', 'unknown']]);
    assert.deepEqual(alarm('line-faulted:RED').acked, { by: 'unknown', atMs: ackedAt, reason: 'seen' });
    res = await post('/sugarshack/alarms/ack', { interlock: ids[0], ids: ['line-faulted:PINK'] });
    assert.equal(res.status, 409);
    assert.equal(res.body.code, 'UNKNOWN_ALARM');
    res = await post('/sugarshack/alarms/shelve', { interlock: ids[0], id: 'device-offline:rig-ctrl-5' });
    assert.equal(res.status, 409);
    assert.equal(res.body.code, 'INVALID_SHELF');
    res = await post('/sugarshack/alarms/shelve', { interlock: ids[0], id: 'device-offline:rig-ctrl-5', forMs: NaN });
    assert.equal(res.status, 409, 'NaN is no duration');

    // The dashboard shelves through the state node, as its signed-in user.
    const state = helper.getNode(byName(flow, 'sugarshack-state', 'plant state'));
    state.receive({ topic: 'shelve', id: 'device-offline:rig-ctrl-5', forMs: 2000, reason: 'rig-ctrl-5 on the bench', _client: { user: { username: 'bo' } } });
    await runTill(() => seen.state.length === 1, 'the answer of the state node');
    assert.equal(seen.state[0].alarmChanges[0].action, 'shelve');
    const shelved = seen.state[0].payload.interlocks[0].alarms.find((a) => a.id === 'device-offline:rig-ctrl-5');
    assert.equal(shelved.shelved.by, 'bo');
    assert.equal(shelved.shelved.reason, 'rig-ctrl-5 on the bench');
    assert.equal(shelved.shelved.untilMs, shelved.shelved.atMs + 2000);
    await runTill(() => !alarm('device-offline:rig-ctrl-5').shelved, 'the shelf to run out', { maxMs: 3000 });
    assert.equal(alarm('device-offline:rig-ctrl-5').state, 'active-unacknowledged', 'back from the shelf in its true state');

    // Acknowledged by the state node: the device comes back online, the alarm leaves the list.
    state.receive({ topic: 'ack', id: 'device-offline:rig-ctrl-5', by: 'cy' });
    await runTill(() => seen.state.length === 2, 'the ack');
    assert.equal(alarm('device-offline:rig-ctrl-5').acked.by, 'cy');
    bus.receive({ topic: 'rig/ctrl-5/status', payload: 'online', retain: true });
    await runTill(() => !alarm('device-offline:rig-ctrl-5'), 'the acknowledged alarm to go once normal');
    const refusals = [];
    state.on('call:error', (call) => refusals.push(call.args[0]));
    state.receive({ topic: 'ack', id: 'device-offline:rig-ctrl-5' });
    await runTill(() => refusals.length === 1, 'the refusal of an alarm not listed');
    assert.equal(refusals[0].code, 'UNKNOWN_ALARM');
    assert.equal(seen.state.length, 2, 'nothing sent for it');

    // The acknowledgement is saved with the interlock's state: a restart keeps it.
    await settled(helper, ids[0]);
    const saved = JSON.parse(fs.readFileSync(runtime().store.where, 'utf8'));
    assert.deepEqual(saved.state.alarms.alarms.map((a) => [a.id, a.state, a.acked && a.acked.by]), [['line-faulted:RED', 'active-acknowledged', 'unknown']]);
    await helper.unload();
    await helper.load(NODE_MODULES, flow);
    await started(flow);
    await runTill(() => runtime().state === 'ready' && alarm('line-faulted:RED'), 'the interlock back');
    assert.equal(alarm('line-faulted:RED').state, 'active-acknowledged');
    assert.deepEqual(alarm('line-faulted:RED').acked, { by: 'unknown', atMs: ackedAt, reason: 'seen' });
  });

  it('a forced clear goes through over the reasons and says so', async function () {
    const { flow, seen } = await start();
    const panel = helper.getNode(byName(flow, 'sugarshack-operator-panel', 'RED panel'));
    const bus = helper.getNode(flow.find((n) => n.type === 'sugarshack-actuators').id);
    panel.receive({ payload: 'e-stop' });
    await runTill(() => seen['lockout done'].length === 1, 'the RED lockout to complete');
    bus.receive({ topic: 'rig/ctrl-5/status', payload: 'offline', retain: true });
    panel.receive({ payload: 'clear', force: true, by: 'ana', reason: 'rig-ctrl-5 is being replaced; valves closed by hand' });
    await runTill(() => seen.panel.length === 2, 'the forced clear');
    assert.deepEqual(seen.panel[1].clearedBy, { by: 'ana', reason: 'rig-ctrl-5 is being replaced; valves closed by hand', forced: true });
    assert.deepEqual(seen['clear refused'], []);
  });
});
