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
 * @param {{ urgent?: (msg: NodeRed.Message) => boolean, passive?: boolean, engine?: boolean, values?: ((msg: NodeRed.Message, then: (err: Error | null, values?: object) => void) => void) | null }} [options]
 *   `passive`: the work runs on a standby too (device feedback keeps it warm); `values`: reads the
 *   node's values for each msg first (from context, env or JSONata), handed to `work` as its fifth argument
 */
function onInput(node, runtime, work, kind = 'interlock', { urgent = () => false, passive = false, engine = false, values = null } = {}) {
  const how = { urgent, passive, engine };
  node.on('input', (msg, send, done) => {
    if (!runtime) {
      done(MISSING[kind]());
      return;
    }
    if (!values) {
      submitInput(runtime, node, msg, send, done, undefined, work, how);
      return;
    }
    values(msg, (err, read) => {
      if (!err) return submitInput(runtime, node, msg, send, done, read, work, how);
      // A value that cannot be read (a JSONata error) shows on the node until the interlock's next change.
      runtime.showError(node, /** @type {any} */ (err).code);
      return done(err);
    });
  });
}

/**
 * Hands a msg's work to its runtime (see RuntimeBase.submit); `engine`: the
 * work is one input of the runtime's engine, which keeps it while it starts.
 * @param {any} runtime @param {NodeRed.Node} node @param {NodeRed.Message} msg @param {NodeRed.Send} send @param {NodeRed.Done} done
 * @param {object | undefined} read @param {Function} work
 * @param {{ urgent: (msg: NodeRed.Message) => boolean, passive: boolean, engine: boolean }} how
 */
function submitInput(runtime, node, msg, send, done, read, work, how) {
  const { urgent, passive, engine } = how;
  let now = false;
  try {
    now = !runtime.gateOpen && urgent(msg); // asked only while a deploy drains
  } catch {
    now = false; // an unreadable msg waits like any other and is refused when read
  }
  runtime.submit(node, done, (rt) => work(rt, msg, send, done, read), { urgent: now, passive, engine });
}

/**
 * The input of an interlock node (acquire, release, cancel, fault, clear):
 * the node is bound to its interlock's engine under `spec`, and each msg is
 * one engine input. None waits here, for a deploy's drain nor for the start:
 * the engine holds new requests back itself, and keeps msgs until it has
 * read its saved state, their timeouts running (it is made before that read).
 * @param {NodeRed.Node} node @param {any} runtime @param {object} spec
 * @param {{ urgent?: (msg: NodeRed.Message) => boolean, values?: any }} [options]
 */
function onInterlockInput(node, runtime, spec, options = {}) {
  if (!runtime || options.values) {
    if (runtime) runtime.addNodeSpec(node, spec);
    onInput(node, runtime, interlockWork(node), 'interlock', { ...options, urgent: always, engine: true });
    return;
  }
  runtime.addNodeSpec(node, spec);
  const work = interlockWork(node);
  // Plain work taken now (running, no drain: nearly every msg): to the engine at once, nothing made per msg on the way.
  node.on('input', (msg, send, done) => {
    if (runtime.life.admit[0] === 'take') runtime.inputNow(node, msg, send, done);
    else submitInput(runtime, node, msg, send, done, undefined, work, ENGINE_INPUT);
  });
}

/** @param {NodeRed.Node} node */
function interlockWork(node) {
  return (rt, msg, send, done, values) => rt.input(node, msg, send, done, values);
}

/** @type {(msg: NodeRed.Message) => boolean} */
const always = () => true;

/** How an interlock node's msg is submitted: never held for a drain, kept by the engine while it starts. */
const ENGINE_INPUT = { urgent: always, passive: false, engine: true };

module.exports = { bindInterlock, bindPlant, onInput, onInterlockInput, always };
