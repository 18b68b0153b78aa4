'use strict';
// A field device without a broker, on the manual clock: an actuator panel that
// reaches each command its actuators node publishes `delayMs` of clock time
// later and then reports its state batch, and sensor datapoints stamped with
// the clock. It follows the helper nodes by id, so it goes on across deploys.
const { hooks } = require('@node-red/util');
const { clock } = require('./support');

let panels = 0;
const active = new Set(); // hook labels of the panels not stopped yet

/**
 * Panel `device` of plant document `doc`: every actuator starts at its idle
 * state; commands are read from what reaches helper node `mqtt`, feedback goes
 * to actuators node `bus`. Actuators listed in `stuck` ("valve/3") never move.
 * It stops with `stop()` or `stopPanels()`, or by itself once its test's clock is gone.
 */
function fakePanel(helper, doc, { device = 'ctrl-1', bus = 'bus', mqtt = 'mqtt', delayMs = 20, stuck = new Set() } = {}) {
  const positions = {};
  for (const a of doc.actuators.filter((x) => x.device === device)) {
    positions[a.type] = positions[a.type] || {};
    positions[a.type][a.io] = a.idle;
  }
  const report = () => helper.getNode(bus)?.receive({ topic: `${device}/state`, payload: { ts: clock().now(), ...positions } });
  const commands = [];
  const label = `onReceive.sugarshack-panel-${++panels}`;
  const ownClock = clock();
  const stop = () => {
    active.delete(label);
    hooks.remove(label);
  };
  active.add(label);
  hooks.add(label, (event) => {
    if (clock() !== ownClock) { // its test is over
      stop();
      return;
    }
    if (event.destination.id !== mqtt) return;
    const msg = event.msg;
    const [name, type, io] = String(msg.topic).split('/');
    if (name !== device || msg.payload === '') return; // another device, or a retained lockout being cleared
    commands.push({ atMs: clock().now(), topic: msg.topic, payload: msg.payload, retain: msg.retain });
    if (stuck.has(`${type}/${io}`)) return;
    const value = type === 'pump' ? msg.payload === 'ON' : Number(msg.payload);
    clock().setTimeout(() => {
      positions[type][io] = value;
      report();
    }, delayMs);
  });
  report();
  return { report, positions, commands, stop };
}

/** Stops every panel (an afterEach hook): no hook of a test is left to the next one. */
function stopPanels() {
  for (const label of [...active]) {
    active.delete(label);
    hooks.remove(label);
  }
}

/** One datapoint of sensor `name` of `station`, stamped with the clock, given to actuators node `bus`. */
function sensor(helper, value, { station = 'station-3', name = 'volume', bus = 'bus' } = {}) {
  helper.getNode(bus).receive({ topic: `${station}/sensor/${name}/state`, payload: { ts: clock().now(), value } });
}

/**
 * The start of a plant document the fake devices answer for: a valve type and a
 * pump type with short timings, panel ctrl-1 and station-3, and `actuators`.
 */
function fakePlant(actuators) {
  return {
    actuatorTypes: {
      valve: { signal: 'analog', min: 0, max: 100, tolerance: 3, noMotionMs: 400, completionMs: 2000, staleMs: 60000 },
      pump: { signal: 'binary', noMotionMs: 400, completionMs: 2000, staleMs: 60000 },
    },
    devices: [{ id: 'ctrl-1', kind: 'actuator-panel' }, { id: 'station-3', kind: 'sensor-station' }],
    actuators,
  };
}

/** A valve of panel ctrl-1 on `line`, idle and locked out closed. */
const fakeValve = (id, io, line) => ({ id, type: 'valve', device: 'ctrl-1', io, idle: 0, lockout: 0, resource: line });
/** Pump P1 of panel ctrl-1 on `line`, idle and locked out off. */
const fakePump = (line) => ({ id: 'P1', type: 'pump', device: 'ctrl-1', io: 1, idle: false, lockout: false, resource: line });

/** Op 10 of the tests' plants: it loads a truck on YEL (valves open, pump on, wait for LT-3, pump off); `extra` adds to it. */
function loadTruck(extra = {}) {
  return {
    id: '10', description: 'load truck', priority: 20, resources: ['YEL'], ...extra, steps: [
      { command: { valves: { V101: 100, V102: 100 } }, timeoutMs: 3000 },
      { command: { pumps: { P1: true } }, timeoutMs: 3000 },
      { wait: '`LT-3` >= 100', sensors: ['LT-3'], timeoutMs: 600 },
      { command: { pumps: { P1: false } }, timeoutMs: 3000 },
    ],
  };
}

/** Op 12 of the tests' plants: it unloads a truck on YEL. */
const unloadTruck = () => ({ id: '12', description: 'unload truck', priority: 22, resources: ['YEL'], steps: [{ command: { valves: { V101: 50 } }, timeoutMs: 3000 }] });

/**
 * The plant node of document `doc`, interlock `il` bound to it, its actuators
 * node (commands to helper `mqtt`, events to `ev`), the interlock's events
 * node (to `events`) and a Catch node (to `caught`).
 */
function boundPlant(doc, { persist = false } = {}) {
  return [
    { id: 'pl', type: 'sugarshack-plant', name: 'plant', plant: doc },
    { id: 'il', type: 'sugarshack-interlock', name: 'lines', plant: 'pl', resources: [], policy: 'greedy', persist },
    { id: 'bus', z: 'f1', type: 'sugarshack-actuators', plant: 'pl', devices: '', wires: [['mqtt'], [], ['ev']] },
    { id: 'ilev', z: 'f1', type: 'sugarshack-interlock-events', interlock: 'il', wires: [['events']] },
    { id: 'c1', z: 'f1', type: 'catch', scope: null, uncaught: false, wires: [['caught']] },
  ];
}

/** The truck routine of the tests' plants: empty, full and its error state fault; op 10 loads it on 'load', then `rest`. */
function truckRoutine(...rest) {
  return {
    id: 'truck', states: ['empty', 'full', 'fault'], initial: 'empty', errorState: 'fault',
    transitions: [{ from: 'empty', to: 'full', operation: '10', trigger: { msg: 'load' } }, ...rest],
  };
}

module.exports = { fakePanel, sensor, stopPanels, fakePlant, fakeValve, fakePump, truckRoutine, loadTruck, unloadTruck, boundPlant };
