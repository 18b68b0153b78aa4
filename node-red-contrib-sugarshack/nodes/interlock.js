'use strict';
const { load } = require('../lib/wasm');
const { coreConfig } = require('../lib/config');
const { Persistence } = require('../lib/persistence');
const { InterlockRuntime } = require('../lib/runtime');
const { SugarshackError } = require('../lib/errors');

function resourcesOf(plant) {
  if (!plant) throw new SugarshackError('NO_PLANT', 'the plant chosen for this interlock does not exist; choose another or none');
  if (plant.state === 'failed') throw plant.failure;
  return plant.interlockResources();
}

module.exports = function (RED) {
  const { Interlock } = load();

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
    node.runtime.start(configError);

    node.on('close', (removed, done) => {
      node.runtime.close().then(() => done(), (err) => {
        node.error(err);
        done();
      });
    });
  }

  RED.nodes.registerType('sugarshack-interlock', InterlockNode);
};
