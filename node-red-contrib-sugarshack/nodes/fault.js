// @ts-check
'use strict';
const { bindInterlock, onEngineInput, askedBy, followed } = require('../lib/binding');
const { translator, useRED } = require('../lib/i18n');

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function FaultNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const t = translator(RED, 'sugarshack-fault');
    const runtime = bindInterlock(RED, node, props.interlock);
    // Failing the msg lets the Catch of whoever called the operation see the fault (a subflow's caller).
    const handle = runtime && runtime.addNode(node, {
      kind: 'fault', byResources: props.mode === 'resources', failMsg: props.after === 'fail', operation: props.operation, resources: props.resources,
    });

    // Output 2 gets one lockout group command per latched line, once the fault is saved (an e-stop never waits for a drain).
    onEngineInput(node, runtime, 2, (msg) => {
      const error = msg.error;
      const fields = {
        operation: msg.operation,
        follow: followed(msg),
        resources: msg.resources,
        errorMessage: error ? error.message : undefined,
        payload: msg.payload,
        ...askedBy(msg),
      };
      return (e, k, now) => e.fault(handle, k, fields, now);
    }, ({ operation, lines, note }) => {
      // The error a faulted msg ends with when the node is set to fail it: what was faulted and locked out.
      const joined = lines.join(', ');
      const what = operation === null
        ? t('errors.stopped', { lines: joined || t('errors.nothing') })
        : t(joined ? 'errors.faultedLocked' : 'errors.faultedHeldNothing', { operation, lines: joined });
      return note ? t('errors.withNote', { what, note }) : what;
    });
  }

  RED.nodes.registerType('sugarshack-fault', FaultNode);
};
