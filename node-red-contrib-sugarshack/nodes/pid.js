// @ts-check
'use strict';
const { runPid } = require('../lib/control/pid-node');
const { useRED } = require('../lib/host/i18n');

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function PidNode(props) {
    RED.nodes.createNode(this, props);
    runPid(RED, this, props);
  }

  RED.nodes.registerType('sugarshack-pid', PidNode);
};
