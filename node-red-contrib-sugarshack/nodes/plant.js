// @ts-check
'use strict';
const { plantDocument, servePlantValidation } = require('../lib/plant');
const { PlantRuntime } = require('../lib/plant-runtime');
const { serveStats } = require('../lib/stats');
const { paletteOf, settingsKey, runtimeOfConfigNode } = require('../lib/lifecycle');
const { useRED } = require('../lib/i18n');

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
  }

  RED.nodes.registerType('sugarshack-plant', PlantNode);
};
