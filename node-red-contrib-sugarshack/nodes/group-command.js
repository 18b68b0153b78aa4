// @ts-check
'use strict';
const { bindPlant, onInput } = require('../lib/host/binding');
const { isLockout } = require('../lib/plant/group');
const { useRED } = require('../lib/host/i18n');
const { configuredOrRefused } = require('../lib/host/node-config');

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function GroupCommandNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const config = configuredOrRefused(node, 'groupCommand', props);
    if (!config) return;
    const { timeoutMs } = config;
    const runtime = bindPlant(RED, node, props.plant);

    // Holds the msg until every actuator of the group has completed; the same msg then goes on.
    onInput(node, runtime, (rt, msg, send, done) => {
      rt.commands.command({ node, msg, send, done, timeoutMs });
    }, 'plant', { urgent: isLockout }); // a lockout never waits for a deploy's drain
  }

  RED.nodes.registerType('sugarshack-group-command', GroupCommandNode);
};
