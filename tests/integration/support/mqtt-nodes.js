'use strict';
// The palette's nodes with Node-RED's own MQTT nodes, for test-helper flows
// that talk to a real broker.
const path = require('path');
const { paletteNodes, stopServer } = require('../../flow/support');

const coreNodesDir = path.dirname(require.resolve('@node-red/nodes/package.json'));
const mqttNodes = require(path.join(coreNodesDir, 'core/network/10-mqtt.js'));

/**
 * An actuators node on plant 'pl' publishing through mqtt out node 'mout' (its
 * return to 'ret', its events to 'ev'), and a group command node to 'out'; with
 * `broker`, the actuators node watches that broker's connection.
 */
function busNodes({ broker } = {}) {
  return [
    { id: 'bus', z: 'f1', type: 'sugarshack-actuators', plant: 'pl', devices: '', broker, wires: [['mout'], ['ret'], ['ev']] },
    { id: 'mout', z: 'f1', type: 'mqtt out', name: '', topic: '', qos: '', retain: '', broker: 'br', wires: [] },
    { id: 'gc', z: 'f1', type: 'sugarshack-group-command', plant: 'pl', timeout: 0, wires: [['out']] },
  ];
}

/** The events of actuator `id` of `kind` among the msgs the 'ev' sink got. */
const actuatorEvents = (seen, kind, id) => seen.ev.filter((m) => m.topic === `actuator/${kind}/${id}`).map((m) => m.payload);

/** Ends a test: its flows, then the probe, the simulator and the broker it started. */
async function stopAll({ probe, sim, broker }) {
  await stopServer().catch(() => {});
  if (probe) await probe.end().catch(() => {});
  if (sim) await sim.stop().catch(() => {});
  if (broker) await broker.stop();
}

module.exports = { PALETTE_AND_MQTT: [...paletteNodes, mqttNodes], busNodes, actuatorEvents, stopAll };
