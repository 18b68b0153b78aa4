'use strict';
// The routines plant (tests/integration/fixtures/plant-routines.json: lines YEL,
// PUR and RED, operations 10, 12, 18, 51, 41 and 42, three routines) as a flow
// for a real Node-RED process, driven and watched over MQTT:
//   test/op/<id>           starts operation <id>
//   test/estop/<line>      faults a line (its lockouts go to the devices)
//   test/clear/<line>      clears it
//   test/routine/<id>      sends the routine a trigger (the payload is the topic)
//   test/events            every interlock event (published once saved)
//   test/done              msg.operation of each operation that returned
//   test/errors            msg.error of everything a Catch node sees
const path = require('path');
const { mqttBroker } = require('./node-red');
const { loadPlant } = require('../../../scripts/simulator/plant');

const PLANT_FILE = path.join(__dirname, '..', 'fixtures', 'plant-routines.json');
const PLANT = loadPlant(PLANT_FILE);
const LINES = PLANT.resources.map((r) => r.id);
const OPERATIONS = PLANT.operations.map((o) => ({ id: o.id, lines: o.resources }));
const ROUTINES = PLANT.routines.map((r) => ({ id: r.id, start: r.transitions.find((t) => t.from === r.initial && t.trigger.msg).trigger.msg }));

function flow(port, label = 'routines') {
  const nodes = [
    { id: 'tab', type: 'tab', label },
    mqttBroker('br', port),
    { id: 'pl', type: 'sugarshack-plant', name: 'routines plant', plant: PLANT },
    { id: 'il', type: 'sugarshack-interlock', name: 'lines', plant: 'pl', resources: [], policy: 'greedy', queueBound: '', warnQueued: '', warnHeld: '', persist: true },
    { id: 'bus', z: 'tab', type: 'sugarshack-actuators', plant: 'pl', devices: '', broker: 'br', wires: [['mout'], [], []] },
    { id: 'mout', z: 'tab', type: 'mqtt out', topic: '', qos: '1', retain: '', broker: 'br', wires: [] },
    { id: 'ilev', z: 'tab', type: 'sugarshack-interlock-events', interlock: 'il', wires: [['evout']] },
    { id: 'evout', z: 'tab', type: 'mqtt out', topic: 'test/events', qos: '1', retain: 'false', broker: 'br', wires: [] },
    // An operation's msg when it returns, and every error a Catch node sees.
    {
      id: 'opdone', z: 'tab', type: 'change', rules: [{ t: 'set', p: 'payload', pt: 'msg', to: 'operation', tot: 'msg' }], wires: [['doneout']],
    },
    { id: 'doneout', z: 'tab', type: 'mqtt out', topic: 'test/done', qos: '1', retain: 'false', broker: 'br', wires: [] },
    { id: 'catchall', z: 'tab', type: 'catch', scope: null, uncaught: false, wires: [['errsummary']] },
    {
      id: 'errsummary', z: 'tab', type: 'change', rules: [{ t: 'set', p: 'payload', pt: 'msg', to: 'error', tot: 'msg' }], wires: [['errout']],
    },
    { id: 'errout', z: 'tab', type: 'mqtt out', topic: 'test/errors', qos: '1', retain: 'false', broker: 'br', wires: [] },
  ];
  const mqttIn = (id, topic, wire) => ({
    id, z: 'tab', type: 'mqtt in', topic, qos: '1', datatype: 'utf8', broker: 'br', nl: false, rap: true, rh: 0, inputs: 0, wires: [[wire]],
  });
  for (const dev of PLANT.devices.map((d) => d.id)) {
    nodes.push({ ...mqttIn(`in-${dev}`, `${dev}/#`, 'bus'), datatype: 'auto-detect' });
  }
  for (const op of OPERATIONS) {
    nodes.push(mqttIn(`in-op-${op.id}`, `test/op/${op.id}`, `op-${op.id}`));
    nodes.push({ id: `op-${op.id}`, z: 'tab', type: 'sugarshack-operation', interlock: 'il', operation: op.id, wires: [['opdone']] });
  }
  for (const line of LINES) {
    nodes.push(mqttIn(`in-estop-${line}`, `test/estop/${line}`, `estop-${line}`));
    nodes.push({ id: `estop-${line}`, z: 'tab', type: 'sugarshack-fault', interlock: 'il', mode: 'resources', operation: '', resources: line, wires: [[], ['bus']] });
    nodes.push(mqttIn(`in-clear-${line}`, `test/clear/${line}`, `clear-${line}`));
    nodes.push({ id: `clear-${line}`, z: 'tab', type: 'sugarshack-clear', interlock: 'il', mode: 'list', resources: line, wires: [[]] });
  }
  for (const r of ROUTINES) {
    nodes.push(mqttIn(`in-rt-${r.id}`, `test/routine/${r.id}`, `topic-${r.id}`));
    nodes.push({
      id: `topic-${r.id}`, z: 'tab', type: 'change', rules: [{ t: 'set', p: 'topic', pt: 'msg', to: 'payload', tot: 'msg' }], wires: [[`rt-${r.id}`]],
    });
    nodes.push({ id: `rt-${r.id}`, z: 'tab', type: 'sugarshack-routine', interlock: 'il', routine: r.id, wires: [[]] });
  }
  return nodes;
}

/** Whether every actuator of `line` was sent its lockout among `commands` (probe msgs on +/+/+/command) since `since`. */
function lockoutSeen(commands, line, since) {
  return PLANT.actuators.filter((a) => a.resource === line).every((a) => {
    const want = a.type === 'pump' ? (a.lockout ? 'ON' : 'OFF') : String(a.lockout);
    return commands.some((m) => m.at >= since && m.topic === `${a.device}/${a.type}/${a.io}/command` && m.text === want);
  });
}

/**
 * One random piece of work over MQTT: an operation started (45 %), a line
 * e-stopped (15 %) or cleared (15 %, noted in `clearsSent`), a routine
 * triggered (15 %), a valve stuck in the simulator (10 %).
 */
async function randomStep({ probe, sim, rnd, clearsSent }) {
  const pick = (list) => list[Math.floor(rnd() * list.length)];
  const r = rnd();
  if (r < 0.45) await probe.publish(`test/op/${pick(OPERATIONS).id}`, 'go');
  else if (r < 0.6) await probe.publish(`test/estop/${pick(LINES)}`, 'e-stop');
  else if (r < 0.75) {
    const line = pick(LINES);
    clearsSent[line] = Date.now();
    await probe.publish(`test/clear/${line}`, 'operator');
  } else if (r < 0.9) {
    const routine = pick(ROUTINES);
    await probe.publish(`test/routine/${routine.id}`, routine.start);
  } else {
    await sim.inject({ fault: 'stuck', device: 'ctrl-1', valve: 1 + Math.floor(rnd() * 5) });
  }
}

module.exports = {
  PLANT_FILE, PLANT, LINES, OPERATIONS, ROUTINES, flow, lockoutSeen, randomStep,
};
