// @ts-check
'use strict';
const { bindInterlock, onInterlockInput, always } = require('../lib/host/binding');
const { useRED } = require('../lib/host/i18n');

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function CancelNode(props) {
    RED.nodes.createNode(this, props);
    const runtime = bindInterlock(RED, this, props.interlock);
    // A withdrawal never waits for a deploy's drain.
    onInterlockInput(this, runtime, { kind: 'cancel', operation: props.operation }, { urgent: always });
  }

  RED.nodes.registerType('sugarshack-cancel', CancelNode);
};
