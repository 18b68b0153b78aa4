// @ts-check
'use strict';
const { bindInterlock } = require('../lib/host/binding');
const { useRED } = require('../lib/host/i18n');

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function InterlockEventsNode(props) {
    RED.nodes.createNode(this, props);
    const runtime = bindInterlock(RED, this, props.interlock);
    if (runtime) runtime.addEventsNode(this);
  }

  RED.nodes.registerType('sugarshack-interlock-events', InterlockEventsNode);
};
