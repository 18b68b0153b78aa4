// @ts-check
'use strict';
// Connects a node to the runtime of its config node (an interlock or a plant).
// Runtimes outlive deploys: a node of a new deploy takes over what its previous
// instance held there (same node id), and a closing node lets go of it in the
// way the close asks for (restart, removal, or a shutdown that freezes all).
const { SugarshackError, asSugarshackError } = require('./errors');
const { errorStatus } = require('./status');
const { paletteOf } = require('./lifecycle');
const { readMsg } = require('./request');

// What a node says when its config node is unset.
const MISSING = {
  interlock: () => SugarshackError.of('NO_INTERLOCK', 'noInterlockConfigured'),
  plant: () => SugarshackError.of('NO_PLANT', 'noPlantConfigured'),
};

/**
 * Returns the runtime of config node `configId`, registering `node` for status
 * updates and handing it what its previous instance held; null (with a red
 * status) when unset.
 */
function bindRuntime(RED, node, configId, kind, { showCounts = true } = {}) {
  const configNode = configId ? RED.nodes.getNode(configId) : null;
  const runtime = configNode && configNode.runtime;
  if (!runtime) {
    node.status(errorStatus(MISSING[kind]().code));
    return null;
  }
  const palette = paletteOf(RED);
  // Nodes with a status of their own (operation, routine, wait) do not show the runtime's counts.
  if (showCounts) runtime.addUser(node);
  runtime.adopt(node);
  node.on('close', (removed, done) => {
    runtime.removeUser(node);
    if (!palette.shuttingDown && !runtime.ended) runtime.nodeClosed(node, removed);
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

/**
 * The input handler every node of a runtime shares: `work(runtime, msg, send, done)`
 * does the node's part. `urgent(msg)` says whether the msg may go in while a
 * deploy drains (see RuntimeBase.submit); reading it must not throw.
 */
/**
 * @param {NodeRed.Node} node
 * @param {any} runtime the interlock or plant runtime, null when unset
 * @param {(runtime: any, msg: NodeRed.Message, send: NodeRed.Send, done: NodeRed.Done) => void} work
 * @param {'interlock' | 'plant'} [kind]
 * @param {{ urgent?: (msg: NodeRed.Message) => boolean }} [options]
 */
function onInput(node, runtime, work, kind = 'interlock', { urgent = () => false } = {}) {
  node.on('input', (msg, send, done) => {
    if (!runtime) {
      done(MISSING[kind]());
      return;
    }
    let now = false;
    try {
      now = urgent(msg);
    } catch {
      now = false; // an unreadable msg waits like any other and is refused when read
    }
    runtime.submit(node, done, (rt) => work(rt, msg, send, done), { urgent: now });
  });
}

/** @type {(msg: NodeRed.Message) => boolean} */
const always = () => true;

/**
 * The input handler of an interlock's msg nodes: `read(msg)` reads what the
 * msg carries and returns the engine call that hands it in (`(engine,
 * handle, now) => ...`); the interlock holds the msg under its handle and
 * performs what the engine answers. `ports`: the node's outputs.
 * @param {NodeRed.Node} node @param {any} runtime @param {number} ports
 * @param {(msg: NodeRed.Message) => (engine: any, handle: number, now: number) => void} read
 * @param {((text: any) => string) | null} [words] how the node words a fault it made
 */
function onEngineInput(node, runtime, ports, read, words = null) {
  node.on('input', (msg, send, done) => {
    if (!runtime) {
      done(MISSING.interlock());
      return;
    }
    let call;
    try {
      call = readMsg(() => read(msg));
    } catch (err) {
      const e = asSugarshackError(err);
      node.status(errorStatus(e.code));
      done(e);
      return;
    }
    runtime.input(node, msg, send, done, ports, call, words);
  });
}

/** msg.interlock.operation: the acquire a release, cancel or fault follows. */
function followed(msg) {
  const { interlock } = msg;
  return interlock && typeof interlock === 'object' ? interlock.operation : undefined;
}

/** Who asks (a clear, an emergency stop), as a msg says: the dashboard's signed-in user, msg.by, msg.reason, msg.force. */
function askedBy(msg) {
  const client = msg._client && typeof msg._client === 'object' ? msg._client : null;
  const user = client && client.user && typeof client.user === 'object' ? client.user : null;
  return {
    user: user ? user.username || user.name || user.email || user.userId : undefined,
    by: msg.by,
    reason: msg.reason,
    force: msg.force === true,
  };
}

module.exports = { bindInterlock, bindPlant, onInput, always, onEngineInput, followed, askedBy };
