// @ts-check
'use strict';
const { bindInterlock, onInterlockInput } = require('../lib/host/binding');
const { nodeValues, isPerMsg } = require('../lib/interlock/request');
const { useRED } = require('../lib/host/i18n');
const { configuredOrRefused } = require('../lib/host/node-config');

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function AcquireNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const config = configuredOrRefused(node, 'acquire', props);
    if (!config) return;
    const { timeoutMs } = config;
    const runtime = bindInterlock(RED, node, props.interlock);

    // Holds the msg until granted; the same msg object then goes on (link call returns stay intact).
    // Values from msg, flow, global, env or JSONata are read for each msg; literal ones (and flows saved before the types) as deployed.
    const values = nodeValues(RED, node, props, ['operation', 'priority', 'resources']);
    const deployed = (name) => (isPerMsg(props, name) ? undefined : props[name]);
    const spec = { kind: 'acquire', timeoutMs, operation: deployed('operation'), priority: deployed('priority'), resources: deployed('resources') };
    onInterlockInput(node, runtime, spec, { values });
  }

  RED.nodes.registerType('sugarshack-acquire', AcquireNode);
};
