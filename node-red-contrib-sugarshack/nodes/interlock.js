'use strict';
const { load } = require('../lib/wasm');
const { coreConfig } = require('../lib/config');
const { Persistence } = require('../lib/persistence');
const { InterlockRuntime } = require('../lib/runtime');

module.exports = function (RED) {
  const { Interlock } = load();

  function InterlockNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    node.name = props.name;
    let config = null;
    let configError = null;
    try {
      config = coreConfig(props);
    } catch (err) {
      configError = err;
    }
    const persistence = props.persist ? new Persistence(node.context().global, node.id, props.store) : null;
    node.runtime = new InterlockRuntime({ owner: node, Interlock, config, persistence });
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
