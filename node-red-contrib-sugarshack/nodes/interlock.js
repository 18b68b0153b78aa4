// @ts-check
'use strict';
const { coreConfig, messageBufferMax } = require('../lib/config');
const { InterlockRuntime } = require('../lib/interlock-runtime');
const { EngineRuntime } = require('../lib/interlock/engine-runtime');
const { clusterOf } = require('../lib/cluster');
const { SugarshackError } = require('../lib/errors');
const { paletteOf, settingsKey, runtimeOfConfigNode } = require('../lib/lifecycle');
const { useRED } = require('../lib/i18n');

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
    // Alone, the interlock runs on one engine; bound to a plant (its runs and routines) or in a hot-standby cluster, on the interlock runtime.
    const Runtime = props.plant || inCluster(RED) ? InterlockRuntime : EngineRuntime;
    node.runtime = runtimeOfConfigNode(RED, node, key, settings, () => new Runtime({ RED, id: node.id, settings, plant }));
  }

  RED.nodes.registerType('sugarshack-interlock', InterlockNode);
};

/** Whether this instance is one of a hot-standby cluster (a misconfigured one counts: the interlock runtime refuses then). */
function inCluster(RED) {
  try {
    return Boolean(clusterOf(RED));
  } catch {
    return true;
  }
}
