// @ts-check
'use strict';
const { bindInterlock, onEngineInput, followed } = require('../lib/binding');
const { useRED } = require('../lib/i18n');

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function CancelNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const runtime = bindInterlock(RED, node, props.interlock);
    const handle = runtime && runtime.addNode(node, { kind: 'cancel', operation: props.operation });

    // The held msg of the withdrawn request is completed unsent; this one goes on (never waits for a drain).
    onEngineInput(node, runtime, 1, (msg) => {
      const fields = { operation: msg.operation, follow: followed(msg), by: msg.by, reason: msg.reason };
      return (e, k, now) => e.cancel(handle, k, fields, now);
    });
  }

  RED.nodes.registerType('sugarshack-cancel', CancelNode);
};
