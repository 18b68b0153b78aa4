// @ts-check
'use strict';
// Connects a node to the runtime of its config node (an interlock or a plant).
// Runtimes outlive deploys: a node of a new deploy takes over what its previous
// instance held there (same node id), and a closing node lets go of it in the
// way the close asks for (restart, removal, or a shutdown that freezes all).
const { SugarshackError } = require('./errors');
const { errorStatus } = require('./status');
const { paletteOf } = require('./lifecycle');

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
 * @param {(runtime: any, msg: NodeRed.Message, send: NodeRed.Send, done: NodeRed.Done, values?: object) => void} work
 * @param {'interlock' | 'plant'} [kind]
 * @param {{ urgent?: (msg: NodeRed.Message) => boolean, passive?: boolean, values?: ((msg: NodeRed.Message, then: (err: Error | null, values?: object) => void) => void) | null }} [options]
 *   `passive`: the work runs on a standby too (device feedback keeps it warm); `values`: reads the
 *   node's values for each msg first (from context, env or JSONata), handed to `work` as its fifth argument
 */
function onInput(node, runtime, work, kind = 'interlock', { urgent = () => false, passive = false, values = null } = {}) {
  node.on('input', (msg, send, done) => {
    if (!runtime) {
      done(MISSING[kind]());
      return;
    }
    if (!values) {
      submitInput(runtime, node, msg, send, done, undefined, work, urgent, passive);
      return;
    }
    values(msg, (err, read) => {
      if (!err) return submitInput(runtime, node, msg, send, done, read, work, urgent, passive);
      // A value that cannot be read (a JSONata error) shows on the node until the interlock's next change.
      runtime.showError(node, /** @type {any} */ (err).code);
      return done(err);
    });
  });
}

/** Hands a msg's work to its runtime (see RuntimeBase.submit). */
function submitInput(runtime, node, msg, send, done, read, work, urgent, passive) {
  let now = false;
  try {
    now = !runtime.gateOpen && urgent(msg); // asked only while a deploy drains
  } catch {
    now = false; // an unreadable msg waits like any other and is refused when read
  }
  runtime.submit(node, done, (rt) => work(rt, msg, send, done, read), { urgent: now, passive });
}

/**
 * The input of an interlock node (acquire, release, cancel, fault, clear):
 * the node is bound to its interlock's engine under `spec`, and each msg is
 * one engine input. None waits for a deploy's drain here: the engine holds
 * new requests back itself, their timeouts running (only its start, before
 * it has an engine, holds them in JS).
 * @param {NodeRed.Node} node @param {any} runtime @param {object} spec
 * @param {{ urgent?: (msg: NodeRed.Message) => boolean, values?: any }} [options]
 */
function onInterlockInput(node, runtime, spec, options = {}) {
  if (!runtime || options.values) {
    if (runtime) runtime.addNodeSpec(node, spec);
    onInput(node, runtime, interlockWork(node), 'interlock', { ...options, urgent: always });
    return;
  }
  runtime.addNodeSpec(node, spec);
  const work = interlockWork(node);
  // Plain work taken now (running, no drain: nearly every msg): to the engine at once, nothing made per msg on the way.
  node.on('input', (msg, send, done) => {
    if (runtime.life.admit[0] === 'take') runtime.inputNow(node, msg, send, done);
    else submitInput(runtime, node, msg, send, done, undefined, work, always, false);
  });
}

/** @param {NodeRed.Node} node */
function interlockWork(node) {
  return (rt, msg, send, done, values) => rt.input(node, msg, send, done, values);
}

/** @type {(msg: NodeRed.Message) => boolean} */
const always = () => true;

module.exports = { bindInterlock, bindPlant, onInput, onInterlockInput, always };
