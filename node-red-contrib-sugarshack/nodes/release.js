// @ts-check
'use strict';
const { bindInterlock, onEngineInput, followed } = require('../lib/binding');
const { useRED } = require('../lib/i18n');

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function ReleaseNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const runtime = bindInterlock(RED, node, props.interlock);
    const handle = runtime && runtime.addNode(node, { kind: 'release', operation: props.operation });

    // The msg goes on once the release is saved (a release never waits for a deploy's drain).
    onEngineInput(node, runtime, 1, (msg) => {
      const { operation } = msg;
      const follow = followed(msg);
      return (e, k, now) => e.release(handle, k, operation, follow, now);
    });
  }

  RED.nodes.registerType('sugarshack-release', ReleaseNode);
};
