'use strict';
// Connects a node to the runtime of its config node (an interlock or a plant).
const { SugarshackError } = require('./errors');
const { errorStatus } = require('./status');

// What a node says when its config node is unset: [code, message].
const MISSING = {
  interlock: ['NO_INTERLOCK', 'no interlock is configured for this node'],
  plant: ['NO_PLANT', 'no plant is configured for this node'],
};

/**
 * Returns the runtime of config node `configId`, registering `node` for status
 * updates and withdrawing its waiting msgs on close; null (with a red status) when unset.
 */
function bindRuntime(RED, node, configId, kind, { showCounts = true } = {}) {
  const configNode = configId ? RED.nodes.getNode(configId) : null;
  const runtime = configNode && configNode.runtime;
  if (!runtime) {
    node.status(errorStatus(MISSING[kind][0]));
    return null;
  }
  // Nodes with a status of their own (operation, routine, wait) do not show the runtime's counts.
  if (showCounts) runtime.addUser(node);
  node.on('close', (removed, done) => {
    runtime.dropNode(node);
    runtime.removeUser(node);
    done();
  });
  return runtime;
}

function bindInterlock(RED, node, configId, options) {
  return bindRuntime(RED, node, configId, 'interlock', options);
}

function bindPlant(RED, node, configId, options) {
  return bindRuntime(RED, node, configId, 'plant', options);
}

/** The input handler every node of a runtime shares: `work(runtime, msg, send, done)` does the node's part. */
function onInput(node, runtime, work, kind = 'interlock') {
  node.on('input', (msg, send, done) => {
    if (!runtime) {
      const [code, message] = MISSING[kind];
      done(new SugarshackError(code, message));
      return;
    }
    runtime.submit(node, done, (rt) => work(rt, msg, send, done));
  });
}

module.exports = { bindInterlock, bindPlant, onInput };
