// @ts-check
'use strict';
const { bindInterlock, onEngineInput } = require('../lib/binding');
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
    const handle = runtime && runtime.addNode(node, {
      kind: 'acquire', timeoutMs, operation: props.operation, priority: props.priority, resources: props.resources,
    });

    // Holds the msg until granted; the same msg object then goes on (link call returns stay intact).
    onEngineInput(node, runtime, 1, (msg) => {
      const { operation, priority, resources } = msg;
      if (operation === undefined && priority === undefined && resources === undefined) return (e, k, now) => e.acquire(handle, k, now);
      return (e, k, now) => e.acquireNamed(handle, k, operation, priority, resources, now);
    });
  }

  RED.nodes.registerType('sugarshack-acquire', AcquireNode);
};
