'use strict';
const { load } = require('../lib/wasm');
const { coreConfig } = require('../lib/config');
const { Persistence } = require('../lib/persistence');
const { InterlockRuntime } = require('../lib/runtime');
const { SugarshackError } = require('../lib/errors');
const { trackFlows, whenFlowsStarted } = require('../lib/flows');
const { issueLockouts } = require('../lib/operation-runner');

function resourcesOf(plant) {
  if (!plant) throw new SugarshackError('NO_PLANT', 'the plant chosen for this interlock does not exist; choose another or none');
  if (plant.state === 'failed') throw plant.failure;
  return plant.interlockResources();
}

module.exports = function (RED) {
  const { Interlock } = load();
  trackFlows(RED);

  function InterlockNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    node.name = props.name;
    // Bound to a plant, the interlock takes its resources and lockouts from the
    // plant document, and operation and routine nodes can run on it.
    const plant = props.plant ? RED.nodes.getNode(props.plant)?.runtime || null : null;
    let config = null;
    let configError = null;
    try {
      config = coreConfig(props);
      if (props.plant) config.resources = resourcesOf(plant);
    } catch (err) {
      configError = err;
    }
    const persistence = props.persist ? new Persistence(node.context().global, node.id, props.store) : null;
    node.runtime = new InterlockRuntime({ owner: node, Interlock, config, persistence, plant });
    node.runtime.start(configError).then(() => {
      // Lines restored faulted (an operation the restart interrupted, or a fault not yet
      // cleared) get their lockout commands again once the actuators nodes are up.
      if (!plant || node.runtime.state !== 'ready') return;
      const faulted = node.runtime.faultedResources();
      if (faulted.length === 0) return;
      whenFlowsStarted(RED, () => {
        if (node.runtime.state !== 'ready') return;
        issueLockouts(node, plant, node.runtime.faultResources(faulted, 'restored faulted: lockout sent again at start'));
      });
    });

    node.on('close', (removed, done) => {
      node.runtime.close().then(() => done(), (err) => {
        node.error(err);
        done();
      });
    });
  }

  RED.nodes.registerType('sugarshack-interlock', InterlockNode);
};
