// @ts-check
'use strict';
const { coreConfig, messageBufferMax } = require('../lib/interlock/config');
const { EngineRuntime } = require('../lib/interlock/engine-runtime');
const { SugarshackError } = require('../lib/host/errors');
const { paletteOf, settingsKey, runtimeOfConfigNode } = require('../lib/host/lifecycle');
const { useRED } = require('../lib/host/i18n');

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  paletteOf(RED);

  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */

  function InterlockNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    node.name = props.name;
    // Bound to a plant, the interlock takes its resources and lockouts from the
    // plant document, and operation and routine nodes can run on it.
    const plantNode = props.plant ? RED.nodes.getNode(props.plant) : null;
    const plant = plantNode ? plantNode.runtime || null : null;
    const persist = props.persist === true || props.persist === 'true';
    /** @type {{ config: object | null, persist: boolean, plantBound: boolean, plantId: string | null, legacyStore: string | undefined, error: Error | null }} */
    const settings = {
      config: null, persist, plantBound: Boolean(props.plant), plantId: props.plant || null, legacyStore: props.store && props.store !== 'default' ? props.store : undefined, error: null,
    };
    try {
      settings.config = coreConfig(props, messageBufferMax(RED));
      if (props.plant && !plant) throw SugarshackError.of('NO_PLANT', 'noSuchPlant');
    } catch (err) {
      settings.error = err;
    }
    // A deploy that keeps these hands the running interlock over; one that changes them drains first.
    const key = settingsKey({
      config: settings.plantBound ? { ...settings.config, resources: null } : settings.config,
      persist,
      plant: plant ? plant.targetKey : null,
      error: settings.error ? settings.error.message : null,
    });
    // The interlock runs on one engine, its plant's runs and routines beside it.
    node.runtime = runtimeOfConfigNode(RED, node, key, settings, () => new EngineRuntime({ RED, id: node.id, settings, plant }));
  }

  RED.nodes.registerType('sugarshack-interlock', InterlockNode);
};

