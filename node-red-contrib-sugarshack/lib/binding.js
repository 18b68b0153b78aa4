'use strict';
// Connects a node to the interlock runtime of its config node.
const { InterlockError } = require('./errors');
const { errorStatus } = require('./status');

/**
 * Returns the runtime for `configId`, registering `node` for status updates and
 * withdrawing its waiting requests on close; null (with a red status) when unset.
 */
function bindInterlock(RED, node, configId) {
  const configNode = configId ? RED.nodes.getNode(configId) : null;
  const runtime = configNode && configNode.runtime;
  if (!runtime) {
    node.status(errorStatus('NO_INTERLOCK'));
    return null;
  }
  runtime.addUser(node);
  node.on('close', (removed, done) => {
    runtime.dropNode(node);
    runtime.removeUser(node);
    done();
  });
  return runtime;
}

/** The input handler every interlock node shares: `work(runtime)` does the node's part. */
function onInput(node, runtime, work) {
  node.on('input', (msg, send, done) => {
    if (!runtime) {
      done(new InterlockError('NO_INTERLOCK', 'no interlock is configured for this node'));
      return;
    }
    runtime.submit(node, done, (rt) => work(rt, msg, send, done));
  });
}

module.exports = { bindInterlock, onInput };
