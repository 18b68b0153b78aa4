// @ts-check
'use strict';
// What a node's configuration means (its id trimmed, its timeout in seconds,
// a wait's sensors) is the core's to say (engine/config.rs); a node hands it
// its properties once, when it is made.
const wasm = require('../wasm');
const { refusalError } = require('../interlock/engine-carrier');
const { refuseDeploy } = require('./deploy-refusal');

/**
 * The core's reading of `props` for a node of `kind`; throws its refusal in the catalog's words.
 * @param {'operation' | 'routine' | 'wait' | 'acquire' | 'groupCommand'} kind
 * @param {Record<string, any>} props
 * @returns {{ id?: string, timeoutMs?: number, sensors?: string[] }}
 */
function nodeConfig(kind, props) {
  const answer = wasm.load().nodeConfig(kind, props);
  if ('refused' in answer) throw refusalError(answer.refused);
  return answer.ok;
}

/**
 * The node's configuration, or null when the core refused it: then logged, shown in red, and every
 * msg the node gets ends with the refusal (as a Catch node sees it).
 * @param {NodeRed.Node} node @param {Parameters<typeof nodeConfig>[0]} kind @param {Record<string, any>} props
 */
function configuredOrRefused(node, kind, props) {
  try {
    return nodeConfig(kind, props);
  } catch (err) {
    const refusal = refuseDeploy(node, err);
    node.on('input', (msg, send, done) => done(refusal));
    return null;
  }
}

module.exports = { nodeConfig, configuredOrRefused };
