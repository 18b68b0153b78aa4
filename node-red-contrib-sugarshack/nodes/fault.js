// @ts-check
'use strict';
const { bindInterlock, onInterlockInput, always } = require('../lib/host/binding');
const { nodeValues, isPerMsg } = require('../lib/interlock/request');
const { useRED } = require('../lib/host/i18n');

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function FaultNode(props) {
    RED.nodes.createNode(this, props);
    const runtime = bindInterlock(RED, this, props.interlock);
    // Output 2 gets one lockout group command per latched line, once the fault is saved. Failing
    // the msg lets the Catch of whoever called the operation see the fault (a subflow's caller).
    // The operation (mode operation) or lines (mode e-stop) from msg, flow, global, env or JSONata
    // are read for each msg; literal ones (and flows saved before the types) as deployed.
    const byResources = props.mode === 'resources';
    const name = byResources ? 'resources' : 'operation';
    const deployed = (value) => (value === name && isPerMsg(props, name) ? undefined : props[value]);
    const spec = {
      kind: 'fault', byResources, failMsg: props.after === 'fail', operation: deployed('operation'), resources: deployed('resources'),
    };
    // An e-stop never waits for a deploy's drain.
    onInterlockInput(this, runtime, spec, { urgent: always, values: nodeValues(RED, this, props, [name]) });
  }

  RED.nodes.registerType('sugarshack-fault', FaultNode);
};
