// @ts-check
'use strict';
const { plantDocument, servePlantValidation } = require('../lib/plant/plant');
const { PlantRuntime } = require('../lib/plant/plant-runtime');
const { serveStats } = require('../lib/host/stats');
const { paletteOf, settingsKey, runtimeOfConfigNode } = require('../lib/host/lifecycle');
const { useRED } = require('../lib/host/i18n');
const { messageBufferMax } = require('../lib/interlock/config');

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  paletteOf(RED);
  serveStats(RED);
  servePlantValidation(RED);

  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */

  function PlantNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    node.name = props.name;
    /** @type {{ plant: object | null, error: Error | null }} */
    const settings = { plant: null, error: null };
    try {
      settings.plant = plantDocument(props.plant);
    } catch (err) {
      settings.error = err;
    }
    const key = settingsKey({ plant: settings.plant, error: settings.error ? settings.error.message : null });
    node.runtime = runtimeOfConfigNode(RED, node, key, settings, () => new PlantRuntime({ id: node.id, settings, RED }));
    // The publishes it keeps while they cannot go out keep within Node-RED's buffer bound, read as the delay node reads it.
    node.runtime.bus.bufferMax = messageBufferMax(RED);
  }

  RED.nodes.registerType('sugarshack-plant', PlantNode);
};
