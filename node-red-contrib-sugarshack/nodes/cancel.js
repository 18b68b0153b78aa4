// @ts-check
'use strict';
const { bindInterlock, onInterlockInput, always } = require('../lib/host/binding');
const { nodeValues, isPerMsg } = require('../lib/interlock/request');
const { useRED } = require('../lib/host/i18n');

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function CancelNode(props) {
    RED.nodes.createNode(this, props);
    const runtime = bindInterlock(RED, this, props.interlock);
    // A withdrawal never waits for a deploy's drain. An operation from msg, flow, global, env or
    // JSONata is read for each msg; a literal one (and a flow saved before the types) as deployed.
    const operation = isPerMsg(props, 'operation') ? undefined : props.operation;
    onInterlockInput(this, runtime, { kind: 'cancel', operation }, { urgent: always, values: nodeValues(RED, this, props, ['operation']) });
  }

  RED.nodes.registerType('sugarshack-cancel', CancelNode);
};
