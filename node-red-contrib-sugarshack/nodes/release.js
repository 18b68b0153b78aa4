// @ts-check
'use strict';
const { bindInterlock, onInterlockInput, always } = require('../lib/host/binding');
const { operationOf, readMsg } = require('../lib/interlock/request');
const { useRED } = require('../lib/host/i18n');

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function ReleaseNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const runtime = bindInterlock(RED, node, props.interlock);

    // The msg goes on once the release is saved.
    onInterlockInput(node, runtime, { kind: 'release', operation: props.operation }, (rt, msg, send, done) => {
      const operation = readMsg(() => operationOf(msg, props.operation));
      rt.release(operation, () => {
        send(msg);
        done();
      });
    }, { urgent: always }); // a release lets a drain end; it never waits for one
  }

  RED.nodes.registerType('sugarshack-release', ReleaseNode);
};
