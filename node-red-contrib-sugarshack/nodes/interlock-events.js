'use strict';
const { bindInterlock } = require('../lib/binding');

module.exports = function (RED) {
  function InterlockEventsNode(props) {
    RED.nodes.createNode(this, props);
    const runtime = bindInterlock(RED, this, props.interlock);
    if (runtime) runtime.addEventsNode(this);
  }

  RED.nodes.registerType('sugarshack-interlock-events', InterlockEventsNode);
};
