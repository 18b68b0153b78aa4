// @ts-check
'use strict';
const { bindInterlock, onInterlockInput, always } = require('../lib/host/binding');
const { nodeValues, isPerMsg } = require('../lib/interlock/request');
const { useRED } = require('../lib/host/i18n');

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function ClearNode(props) {
    RED.nodes.createNode(this, props);
    const runtime = bindInterlock(RED, this, props.interlock);
    // A refusal is an answer a dashboard shows: out of output 2 when it is wired, else to the Catch nodes.
    const refusalsWired = Array.isArray(props.wires) && Array.isArray(props.wires[1]) && props.wires[1].length > 0;
    // Listed lines from msg, flow, global, env or JSONata are read for each msg; literal ones (and
    // flows saved before the types) as deployed. Clearing all faulted lines reads none.
    const allFaulted = props.mode === 'all';
    const perMsg = !allFaulted && isPerMsg(props, 'resources');
    const spec = { kind: 'clear', allFaulted, refusalsWired, resources: perMsg ? undefined : props.resources };
    // An operator's clear never waits for a deploy's drain.
    onInterlockInput(this, runtime, spec, { urgent: always, values: allFaulted ? null : nodeValues(RED, this, props, ['resources']) });
  }

  RED.nodes.registerType('sugarshack-clear', ClearNode);
};
