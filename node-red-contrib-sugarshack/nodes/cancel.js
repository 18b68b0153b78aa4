// @ts-check
'use strict';
const { bindInterlock, onInterlockInput, always } = require('../lib/host/binding');
const { operationOf, readMsg } = require('../lib/interlock/request');
const { journal } = require('../lib/journal/bus');
const { useRED } = require('../lib/host/i18n');

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function CancelNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const runtime = bindInterlock(RED, node, props.interlock);

    onInterlockInput(node, runtime, { kind: 'cancel', operation: props.operation }, (rt, msg, send, done) => {
      const operation = readMsg(() => operationOf(msg, props.operation));
      journal.action('cancel', msg, operation);
      rt.cancel(operation, () => {
        send(msg);
        done();
      });
    }, { urgent: always }); // a withdrawal never waits for a deploy's drain
  }

  RED.nodes.registerType('sugarshack-cancel', CancelNode);
};
