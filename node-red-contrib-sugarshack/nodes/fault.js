// @ts-check
'use strict';
const { bindInterlock, onInterlockInput, always } = require('../lib/host/binding');
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
    const spec = {
      kind: 'fault', byResources: props.mode === 'resources', failMsg: props.after === 'fail', operation: props.operation, resources: props.resources,
    };
    // An e-stop never waits for a deploy's drain.
    onInterlockInput(this, runtime, spec, { urgent: always });
  }

  RED.nodes.registerType('sugarshack-fault', FaultNode);
};
