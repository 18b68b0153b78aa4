'use strict';
const { bindPlant, onInput } = require('../lib/binding');
const { heldResources, isLockout } = require('../lib/group');
const { splitNames } = require('../lib/request');

module.exports = function (RED) {
  function ActuatorsNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const runtime = bindPlant(RED, node, props.plant);
    const devices = props.devices && String(props.devices).trim() ? splitNames(String(props.devices), 'the device list') : null;
    if (runtime) runtime.addBus(node, devices);

    // Device feedback is telemetry: consumed here, completed with done(). Anything
    // else is a group command, held until it completes and returned on output 2.
    onInput(node, runtime, (rt, msg, send, done) => {
      if (rt.feedback(node, msg)) {
        done();
        return;
      }
      rt.command({ node, msg, send, done, output: 1, outputs: 3, within: isLockout(msg) ? undefined : heldResources(msg) });
    }, 'plant');
  }

  RED.nodes.registerType('sugarshack-actuators', ActuatorsNode);
};
