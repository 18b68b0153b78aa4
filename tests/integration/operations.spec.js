'use strict';
// Routines running operations end to end: Node-RED with the routine nodes, the
// interlock bound to the plant, an actuators bus and the core mqtt in/out nodes,
// against a real Mosquitto and the plant simulator running the fixture plant
// (lines YEL, PUR and RED; ops 10 and 12 on YEL, 18 on YEL+RED, 51 on RED, 41
// and 42 on PUR+RED; routines truck, silo and washball, each started by a msg
// and moved on by a tank-level condition).
//
// The interlock's event log is replayed after each run: a grant never lands on
// a line another operation holds (or that is faulted), and the contention on
// YEL and on RED really happened (requests queued behind a holder, then granted).
//
// Run: npx mocha --timeout 30000 --exit tests/integration/operations.spec.js
// (OPS_LOG=1 prints the event trail and the timings of each run.)
const assert = require('node:assert/strict');
const path = require('path');
const helper = require('node-red-node-test-helper');
const { startMosquitto } = require('./support/mosquitto');
const { connectProbe } = require('./support/mqtt-probe');
const { startTestSimulator } = require('./support/simulator');
const { PLANT_FILE, PLANT } = require('./support/routines-flow');
const {
  TAB, sinkNode, startRealTimeServer, stopServer, settings, sleep, until,
} = require('../flow/support');

helper.init(require.resolve('node-red'));
const { PALETTE_AND_MQTT } = require('./support/mqtt-nodes');
const { mqttBroker } = require('./support/node-red');


// Simulated time runs 10x: a valve sweeps in 0.1 s, datapoints come at 10 Hz, a
// 1,000 L tank fills in 0.5 s; the fixture's thresholds (noMotionMs 1 s,
// completionMs 2 s, staleMs 1.5 s) are set for that.
const SIM_OPTIONS = { plant: PLANT_FILE, speed: 10, sweepS: 1, pumpDelayMs: 200 };
const DEVICES = PLANT.devices.map((d) => d.id);
const ACTUATORS = PLANT.actuators;
const YEL_ACTUATORS = ACTUATORS.filter((a) => a.resource === 'YEL');

// Per routine: its node, its initial state, and the msg that starts its cycle
// (the only transition out of the initial state; the next one is a condition).
const ROUTINES = Object.fromEntries(PLANT.routines.map((r) => {
  const start = r.transitions.find((t) => t.from === r.initial && t.trigger.msg);
  return [r.id, { ...r, node: `rt-${r.id}`, startMsg: start.trigger.msg }];
}));

const commandText = (a, value) => (a.type === 'pump' ? (value ? 'ON' : 'OFF') : String(value));

function flow(port) {
  return [
    TAB,
    // The plant before the interlock: the interlock reads its lines from it.
    { id: 'pl', type: 'sugarshack-plant', name: 'routines plant', plant: PLANT },
    { id: 'il', type: 'sugarshack-interlock', name: 'lines', plant: 'pl', resources: [], policy: 'greedy', persist: false },
    mqttBroker('br', port),
    // One mqtt in per device: panel batches and statuses, sensor datapoints.
    ...DEVICES.map((dev) => ({
      id: `in-${dev}`, z: 'f1', type: 'mqtt in', name: '', topic: `${dev}/#`, qos: '1', datatype: 'auto-detect', broker: 'br',
      nl: false, rap: true, rh: 0, inputs: 0, wires: [['bus']],
    })),
    { id: 'bus', z: 'f1', type: 'sugarshack-actuators', plant: 'pl', devices: '', wires: [['mout'], [], ['ev']] },
    { id: 'mout', z: 'f1', type: 'mqtt out', name: '', topic: '', qos: '', retain: '', broker: 'br', wires: [] },
    { id: 'ilev', z: 'f1', type: 'sugarshack-interlock-events', interlock: 'il', wires: [['events']] },
    ...Object.values(ROUTINES).map((r) => ({
      id: r.node, z: 'f1', type: 'sugarshack-routine', interlock: 'il', routine: r.id, store: 'default', wires: [['rt']],
    })),
    { id: 'clr', z: 'f1', type: 'sugarshack-clear', interlock: 'il', mode: 'list', resources: 'YEL', wires: [['cleared']] },
    { id: 'c1', z: 'f1', type: 'catch', scope: null, uncaught: false, wires: [['caught']] },
    ...['ev', 'events', 'rt', 'cleared', 'caught'].map(sinkNode),
  ];
}

/**
 * Replays the interlock's events in order, tracking the holder of every line
 * (an operation, or "faulted"). Returns the problems found (a grant on a line
 * held or faulted, a release or fault by an operation that did not hold the
 * line, a clear of a line not faulted, a request queued while all its lines
 * were free), every wait (a request queued, with who held what it needed, then
 * its grant and waitedMs), and the holders and waiters left at the end.
 */
function replay(records) {
  const holder = new Map();
  const queued = new Map();
  const waits = [];
  const problems = [];
  const at = (e) => `#${e.index} ${e.kind} ${e.operation || ''} [${e.resources.join(',')}]`;
  records.forEach((record, index) => {
    const e = { ...record, index };
    const { kind, operation, resources } = e;
    switch (kind) {
      case 'queued': {
        const heldBy = {};
        for (const r of resources) if (holder.has(r)) heldBy[r] = holder.get(r);
        // Greedy: a request waits only when one of its lines is taken.
        if (Object.keys(heldBy).length === 0) problems.push(`${at(e)}: queued while all its lines were free`);
        queued.set(operation, { operation, resources, heldBy, queuedAtMs: e.atMs });
        break;
      }
      case 'granted': {
        for (const r of resources) {
          if (holder.has(r)) problems.push(`${at(e)}: granted ${r} while ${holder.get(r)} had it`);
        }
        for (const r of resources) holder.set(r, operation);
        const q = queued.get(operation);
        if (q) {
          waits.push({ ...q, waitedMs: e.waitedMs, grantedAtMs: e.atMs });
          queued.delete(operation);
        } else if (e.waitedMs > 0) {
          problems.push(`${at(e)}: granted after ${e.waitedMs} ms without having been queued`);
        }
        break;
      }
      case 'released':
        for (const r of resources) {
          if (holder.get(r) !== operation) problems.push(`${at(e)}: released ${r}, held by ${holder.get(r) || 'nobody'}`);
          holder.delete(r);
        }
        break;
      case 'faulted':
        for (const r of resources) {
          if (holder.get(r) !== operation) problems.push(`${at(e)}: faulted on ${r}, held by ${holder.get(r) || 'nobody'}`);
          holder.set(r, `faulted (op ${operation})`);
        }
        break;
      case 'resource-faulted':
      case 'interrupted':
        for (const r of resources) holder.set(r, `faulted (${kind})`);
        break;
      case 'cleared':
        for (const r of resources) {
          if (!String(holder.get(r)).startsWith('faulted')) problems.push(`${at(e)}: cleared ${r}, which was not faulted`);
          holder.delete(r);
        }
        break;
      case 'dropped':
      case 'cancelled':
        queued.delete(operation);
        break;
      default:
        break;
    }
  });
  return { problems, waits, holder, queued };
}

/** Checks a routine's events: every move follows one of its transitions, from the state it was in. */
function checkRoutineTrail(routine, trail) {
  let state = routine.initial;
  let pending = null;
  trail.forEach((p, i) => {
    const where = `routine ${routine.id} event #${i} (${p.event} ${p.operation || ''} ${p.from}->${p.to})`;
    if (p.event === 'dispatched') {
      assert.equal(pending, null, `${where}: dispatched while ${pending} was pending`);
      assert.equal(p.from, state, `${where}: dispatched from ${p.from} while in ${state}`);
      assert.ok(routine.transitions.some((t) => t.from === p.from && t.to === p.to && t.operation === p.operation),
        `${where}: no such transition`);
      pending = p;
    } else if (p.event === 'completed') {
      assert.ok(pending && pending.operation === p.operation && pending.from === p.from && pending.to === p.to,
        `${where}: does not match the dispatch ${JSON.stringify(pending)}`);
      assert.equal(p.state, p.to, `${where}: now in ${p.state}`);
      state = p.to;
      pending = null;
    } else if (p.event === 'faulted') {
      assert.ok(pending && pending.operation === p.operation, `${where}: does not match the dispatch`);
      assert.equal(p.to, routine.errorState, `${where}: not to the error state`);
      state = p.to;
      pending = null;
    } else if (p.event === 'reset') {
      assert.equal(pending, null, `${where}: reset while pending`);
      assert.equal(p.from, state);
      assert.equal(p.to, routine.initial);
      state = p.to;
    } else {
      assert.fail(`${where}: unexpected event`);
    }
  });
  return { state, pending };
}

describe('routines running operations on Mosquitto with the plant simulator', function () {
  this.timeout(60000);
  let broker;
  let sim;
  let probes;
  let seen; // sink name -> [{ at, msg }]
  let budget; // routine id -> cycles it may still start on its own

  const records = () => seen.events.map((x) => x.msg.payload);
  const trail = (id) => seen.rt.map((x) => x.msg.payload).filter((p) => p.routine === id);
  const completedOps = (id, sinceMs = 0) => seen.rt.filter((x) => x.at >= sinceMs && x.msg.payload.routine === id
    && x.msg.payload.event === 'completed');
  const errorLogs = () => helper.log().getCalls().map((c) => c.args[0]).filter((l) => l && l.level === helper.log().ERROR);

  function startCycle(id) {
    const r = ROUTINES[id];
    helper.getNode(r.node).receive({ topic: r.startMsg });
  }

  /** Routine idle in its initial state with nothing pending (its last event says so). */
  function atRest(id) {
    const last = trail(id).at(-1);
    return !last || (['completed', 'reset'].includes(last.event) && last.state === ROUTINES[id].initial && !last.pending);
  }

  function dump() {
    const lines = records().map((e) => `${e.atMs % 100000} ${e.kind} ${e.operation || ''} [${e.resources}] ${e.waitedMs ?? ''}`);
    const rts = seen.rt.map((x) => `${x.at % 100000} ${x.msg.payload.routine} ${x.msg.payload.event} ${x.msg.payload.operation || ''} -> ${x.msg.payload.state}`);
    return `interlock events:\n  ${lines.join('\n  ')}\nroutine events:\n  ${rts.join('\n  ')}\nsim log tail:\n  ${sim.logs.slice(-30).join('\n  ')}`;
  }

  async function start() {
    broker = await startMosquitto();
    sim = await startTestSimulator(broker.url, SIM_OPTIONS);
    probes = [];
    await new Promise((resolve) => startRealTimeServer(resolve));
    settings({ mqttReconnectTime: 300 });
    await helper.load(PALETTE_AND_MQTT, flow(broker.port));
    seen = {};
    for (const id of ['ev', 'events', 'rt', 'cleared', 'caught']) {
      const got = [];
      helper.getNode(id).on('input', (msg) => got.push({ at: Date.now(), msg }));
      seen[id] = got;
    }
    budget = {};
    // A routine back in its initial state starts its next cycle while it has some left.
    helper.getNode('rt').on('input', (msg) => {
      const p = msg.payload;
      if (p.event === 'completed' && p.state === ROUTINES[p.routine].initial && budget[p.routine] > 0) {
        budget[p.routine]--;
        startCycle(p.routine);
      }
    });
    // Ready once every panel has reported and every tank level is fresh.
    const plant = helper.getNode('pl').runtime;
    const sensors = Uint32Array.from(PLANT.sensors, (s) => plant.t.sensor(s.id));
    // Checked as any condition over them is: its values are null while one is not fresh.
    const everyOne = plant.t.condition('true', PLANT.sensors.map((s) => s.id));
    const fresh = () => plant.t.checkCondition(everyOne, sensors, Date.now()).values !== null;
    const reported = (id) => seen.ev.some((x) => x.msg.topic === `actuator/changed/${id}`);
    await until(() => fresh() && ['V101', 'P1', 'V401', 'V501', 'P3'].every(reported), 'the first panel batches and sensor values', 8000);
  }

  /** Retained messages on the broker under `filter`, as a fresh subscriber gets them: topic -> text. */
  async function retainedOn(filter) {
    const probe = await connectProbe(broker.url, [filter]);
    probes.push(probe);
    await sleep(300);
    return new Map(probe.messages.filter((m) => m.retain).map((m) => [m.topic, m.text]));
  }

  function assertAllIdle() {
    for (const a of ACTUATORS) {
      const panel = sim.devices[a.device];
      if (a.type === 'valve') assert.equal(panel.valves[a.io].position, a.idle, `${a.id} (${a.device} valve ${a.io}) at ${panel.valves[a.io].position} %`);
      else assert.equal(panel.pump.running, a.idle, `${a.id} (${a.device} pump) running`);
    }
  }

  function report(title) {
    if (!process.env.OPS_LOG) return;
    const ops = seen.rt.map((x) => x.msg.payload).filter((p) => p.event === 'completed');
    const byOp = {};
    for (const p of ops) (byOp[p.operation] ||= []).push(`${p.queuedMs}+${p.runMs}`);
    console.log(`      ${title}: queued+run ms per operation: ${JSON.stringify(byOp)}`);
    const kinds = {};
    for (const x of seen.ev) kinds[x.msg.payload.kind] = (kinds[x.msg.payload.kind] || 0) + 1;
    console.log(`      actuator events: ${JSON.stringify(kinds)}`);
    console.log(`      ${dump().split('sim log tail')[0].replace(/\n/g, '\n      ')}`);
  }

  afterEach(async function () {
    if (this.currentTest.state === 'failed' && seen && sim) console.log(dump());
    await stopServer().catch(() => {});
    for (const p of probes || []) await p.end().catch(() => {});
    if (sim) await sim.stop().catch(() => {});
    if (broker) await broker.stop();
    broker = null;
    sim = null;
    probes = null;
  });

  it('runs three routines through their operations with contention on YEL and RED; no line ever has two holders', async function () {
    await start();
    const cycles = { truck: 3, washball: 3, silo: 2 };
    const began = Date.now();
    // Washball takes PUR+RED (41), the truck YEL (10); then flit downstock (18)
    // needs YEL and RED, both held: it waits for both.
    budget.washball = cycles.washball - 1;
    startCycle('washball');
    await until(() => records().some((e) => e.kind === 'granted' && e.operation === '41'), 'op 41 granted');
    budget.truck = cycles.truck - 1;
    startCycle('truck');
    await until(() => records().some((e) => e.kind === 'granted' && e.operation === '10'), 'op 10 granted');
    budget.silo = cycles.silo - 1;
    startCycle('silo');

    const total = (id) => 2 * cycles[id];
    await until(() => Object.keys(cycles).every((id) => completedOps(id).length === total(id) && atRest(id)),
      () => `every routine through its cycles (completed: ${Object.keys(cycles).map((id) => `${id} ${completedOps(id).length}/${total(id)}`).join(', ')})`,
      40000);
    const elapsedMs = Date.now() - began;
    await sleep(300); // nothing more may happen: every routine rests in its initial state

    assert.deepEqual(seen.caught.map((x) => x.msg.error && x.msg.error.message), [], 'no error reached the Catch node');
    assert.deepEqual(errorLogs().map((l) => `${l.type}: ${l.msg}`), [], 'no node logged an error');
    assert.deepEqual(seen.ev.filter((x) => x.msg.payload.kind === 'fault').map((x) => x.msg.topic), [], 'no actuator fault');

    // The interlock's log: never two holders of a line; everything released at the end.
    const log = records();
    const { problems, waits, holder, queued } = replay(log);
    assert.deepEqual(problems, [], dump());
    assert.deepEqual([...holder], [], 'nothing held at the end');
    assert.deepEqual([...queued], [], 'nothing waiting at the end');
    assert.equal(log.filter((e) => e.kind === 'granted').length, 2 * (cycles.truck + cycles.washball + cycles.silo));
    assert.equal(log.filter((e) => e.kind === 'released').length, 2 * (cycles.truck + cycles.washball + cycles.silo));
    assert.deepEqual(log.filter((e) => !['queued', 'granted', 'released'].includes(e.kind)).map((e) => e.kind), []);

    // The contention happened: requests queued behind another operation holding
    // YEL, and RED, then granted after a wait.
    const contended = (line) => waits.filter((w) => w.resources.includes(line) && w.heldBy[line] && w.heldBy[line] !== w.operation && w.waitedMs > 0);
    assert.ok(contended('YEL').length >= 1, `an operation waited on YEL: ${JSON.stringify(waits)}`);
    assert.ok(contended('RED').length >= 1, `an operation waited on RED: ${JSON.stringify(waits)}`);
    // 18 asked while 10 held YEL and 41 held RED (the start above).
    const first18 = waits.find((w) => w.operation === '18');
    assert.deepEqual(first18 && first18.heldBy, { YEL: '10', RED: '41' });
    for (const w of waits) {
      assert.ok(w.waitedMs >= w.grantedAtMs - w.queuedAtMs - 1, `waitedMs of ${JSON.stringify(w)}`);
    }
    // The routines' own figures agree: the ops that waited report queuedMs > 0.
    const queuedOps = seen.rt.map((x) => x.msg.payload).filter((p) => p.event === 'completed' && p.queuedMs > 0).map((p) => p.operation);
    assert.ok(queuedOps.includes('18'), `routine queuedMs: ${queuedOps}`);

    // Each routine went through its states in the order its transitions define.
    for (const [id, n] of Object.entries(cycles)) {
      const r = ROUTINES[id];
      const got = trail(id);
      const end = checkRoutineTrail(r, got);
      assert.deepEqual(end, { state: r.initial, pending: null });
      const expected = [];
      for (let i = 0; i < n; i++) {
        for (const t of r.transitions) {
          expected.push(['dispatched', t.operation, t.from, t.to], ['completed', t.operation, t.from, t.to]);
        }
      }
      assert.deepEqual(got.map((p) => [p.event, p.operation, p.from, p.to]), expected, `routine ${id}`);
      assert.ok(completedOps(id).length >= 2);
      for (const p of got.filter((x) => x.event === 'completed')) {
        assert.ok(p.runMs > 0 && p.queuedMs >= 0, `timings of ${JSON.stringify(p)}`);
      }
    }

    // Every operation returned what it commanded to idle: the simulator's true
    // positions, and the tanks where the last operations left them.
    assertAllIdle();
    const tanks = sim.hydraulics.snapshot().tanks;
    assert.equal(tanks['T-truck'], 0);
    assert.equal(tanks['T-washball'], 0);
    assert.ok(tanks['T-s7'] >= 950, `T-s7 at ${tanks['T-s7']}`);
    report(`run of ${elapsedMs} ms`);
  });

  it('a stuck valve faults op 10: the truck routine goes to its error state, YEL locks out, the other lines go on; clear, reset and it resumes', async function () {
    await start();
    // The washball routine cycles on PUR and RED throughout; the truck does one cycle.
    budget.washball = Infinity;
    startCycle('washball');
    startCycle('truck');
    await until(() => completedOps('truck').length === 2 && atRest('truck'), 'the first truck cycle', 10000);

    // V101 (ctrl-1 valve 1), which op 10 opens first, stops moving.
    await sim.inject({ fault: 'stuck', device: 'ctrl-1', valve: 1 });
    startCycle('truck');
    await until(() => trail('truck').some((p) => p.event === 'faulted'), 'the truck routine faulting', 10000);
    const faultAt = Date.now();
    const faulted = trail('truck').find((p) => p.event === 'faulted');
    assert.equal(faulted.operation, '10');
    assert.equal(faulted.from, 'empty');
    assert.equal(faulted.to, 'fault');
    assert.equal(faulted.state, 'fault');
    assert.equal(faulted.error.code, 'COMMAND_FAILED');
    assert.match(faulted.error.message, /operation '10' faulted at step 1 \(command\)/);
    assert.match(faulted.error.message, /valve V101 did not move within 1 s of its command \(after 1 retry\)/);
    assert.match(faulted.error.message, /YEL locked out until cleared/);
    // The error reached the Catch node, with the routine's event msg.
    await until(() => seen.caught.length === 1, 'the Catch node');
    assert.equal(seen.caught[0].msg.payload.event, 'faulted');
    assert.equal(seen.caught[0].msg.error.code, 'COMMAND_FAILED');
    assert.ok(seen.caught[0].msg.error.message.endsWith(faulted.error.message), seen.caught[0].msg.error.message);
    // The interlock latched YEL under op 10.
    await until(() => records().some((e) => e.kind === 'faulted'), 'the interlock fault event');
    const faultRecord = records().find((e) => e.kind === 'faulted');
    assert.deepEqual([faultRecord.operation, faultRecord.resources], ['10', ['YEL']]);

    // YEL's lockout went out retained: every YEL actuator to its lockout state;
    // the simulator carried it out (V102, which had opened, closed; P1 off).
    await until(() => sim.devices['ctrl-1'].valves[2].position === 0, 'V102 closed by the lockout', 3000);
    const retained = await retainedOn('ctrl-1/+/+/command');
    for (const a of YEL_ACTUATORS) {
      assert.equal(retained.get(`ctrl-1/${a.type}/${a.io}/command`), commandText(a, a.lockout), `retained lockout of ${a.id}: ${JSON.stringify([...retained])}`);
    }
    assert.equal(sim.devices['ctrl-1'].pump.running, false);
    assert.equal(sim.devices['ctrl-1'].valves[1].position, 0, 'V101 never moved');

    // Meanwhile the washball routine (PUR, RED) keeps completing operations.
    await until(() => completedOps('washball', faultAt).length >= 2, 'two washball operations after the fault', 10000);
    assert.equal(trail('truck').at(-1).event, 'faulted', 'the truck routine waits in its error state');

    // Recovery: the valve is fixed, a person clears YEL, the routine is reset and runs again.
    await sim.inject({ fault: 'clear', device: 'ctrl-1' });
    helper.getNode('clr').receive({ topic: 'clear YEL' });
    await until(() => seen.cleared.length === 1, 'the clear');
    assert.deepEqual(seen.cleared[0].msg.cleared, ['YEL']);
    await until(() => records().some((e) => e.kind === 'cleared' && e.resources.includes('YEL')), 'the cleared event');
    helper.getNode(ROUTINES.truck.node).receive({ topic: 'reset' });
    await until(() => trail('truck').at(-1).event === 'reset', 'the reset');
    assert.deepEqual(
      (({ from, to, state }) => ({ from, to, state }))(trail('truck').at(-1)),
      { from: 'fault', to: 'empty', state: 'empty' },
    );
    const resumedAt = Date.now();
    startCycle('truck');
    await until(() => completedOps('truck', resumedAt).length === 2 && atRest('truck'), 'the truck cycle after the reset', 10000);
    assert.deepEqual(completedOps('truck', resumedAt).map((x) => x.msg.payload.operation), ['10', '12']);

    // Stop the washball routine after its current cycle and let everything come to rest.
    budget.washball = 0;
    await until(() => atRest('washball') && atRest('truck') && atRest('silo'), 'every routine at rest', 10000);
    await sleep(300);

    const { problems, holder, queued } = replay(records());
    assert.deepEqual(problems, [], dump());
    assert.deepEqual([...holder], []);
    assert.deepEqual([...queued], []);
    // No grant on YEL between its fault and its clear (the replay treats a faulted line as held).
    const kinds = records().map((e) => `${e.kind} ${e.operation || ''}`.trim());
    const yel = records().filter((e) => e.resources.includes('YEL')).map((e) => `${e.kind} ${e.operation || ''}`.trim());
    assert.deepEqual(yel.slice(yel.indexOf('faulted 10'), yel.indexOf('faulted 10') + 3), ['faulted 10', 'cleared', 'granted 10'], kinds.join(', '));
    for (const [id, r] of Object.entries(ROUTINES)) checkRoutineTrail(r, trail(id));
    assert.equal(seen.caught.length, 1, 'only the fault reached the Catch node');
    assert.ok(completedOps('washball').length >= 4);

    // The resumed run cleared the retained lockouts of what it commanded again; the rest stay.
    const after = await retainedOn('ctrl-1/+/+/command');
    for (const id of ['V101', 'V102', 'V103', 'V104', 'P1']) {
      const a = ACTUATORS.find((x) => x.id === id);
      assert.equal(after.get(`ctrl-1/${a.type}/${a.io}/command`), undefined, `${id} still has a retained command: ${JSON.stringify([...after])}`);
    }
    assert.equal(after.get('ctrl-1/valve/5/command'), '0', 'V105, not commanded since, keeps its lockout');
    assertAllIdle();
    report('fault run');
  });
});
