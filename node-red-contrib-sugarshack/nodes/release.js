// @ts-check
'use strict';
const { bindInterlock, onInterlockInput, always } = require('../lib/host/binding');
const { useRED } = require('../lib/host/i18n');

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function ReleaseNode(props) {
    RED.nodes.createNode(this, props);
    const runtime = bindInterlock(RED, this, props.interlock);
    // The msg goes on once the release is saved. A release lets a drain end; it never waits for one.
    onInterlockInput(this, runtime, { kind: 'release', operation: props.operation }, { urgent: always });
  }

  RED.nodes.registerType('sugarshack-release', ReleaseNode);
};
