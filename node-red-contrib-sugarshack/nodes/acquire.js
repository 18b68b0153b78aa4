// @ts-check
'use strict';
const { bindInterlock, onInterlockInput } = require('../lib/binding');
const { operationOf, priorityOf, resourcesOf, readMsg } = require('../lib/request');
const { useRED } = require('../lib/i18n');

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function AcquireNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const timeoutMs = Math.max(0, Number(props.timeout) || 0) * 1000;
    const runtime = bindInterlock(RED, node, props.interlock);

    // Holds the msg until granted; the same msg object then goes on (link call returns stay intact).
    const spec = { kind: 'acquire', timeoutMs, operation: props.operation, priority: props.priority, resources: props.resources };
    onInterlockInput(node, runtime, spec, (rt, msg, send, done) => {
      const request = readMsg(() => ({
        operation: operationOf(msg, props.operation),
        priority: priorityOf(msg, props.priority),
        resources: resourcesOf(msg, props.resources),
      }));
      rt.acquire({ node, msg, send, done, ...request, timeoutMs });
    });
  }

  RED.nodes.registerType('sugarshack-acquire', AcquireNode);
};
