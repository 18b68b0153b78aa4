// @ts-check
'use strict';
const { bindInterlock, onInterlockInput, always } = require('../lib/host/binding');
const { nodeValues, isPerMsg } = require('../lib/interlock/request');
const { useRED } = require('../lib/host/i18n');

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function ReleaseNode(props) {
    RED.nodes.createNode(this, props);
    const runtime = bindInterlock(RED, this, props.interlock);
    // The msg goes on once the release is saved. A release lets a drain end; it never waits for one.
    // An operation from msg, flow, global, env or JSONata is read for each msg; a literal one (and a flow saved before the types) as deployed.
    const operation = isPerMsg(props, 'operation') ? undefined : props.operation;
    onInterlockInput(this, runtime, { kind: 'release', operation }, { urgent: always, values: nodeValues(RED, this, props, ['operation']) });
  }

  RED.nodes.registerType('sugarshack-release', ReleaseNode);
};
