'use strict';
const { bindInterlock, onInput } = require('../lib/binding');
const { operationOf } = require('../lib/request');

module.exports = function (RED) {
  function ReleaseNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const runtime = bindInterlock(RED, node, props.interlock);

    onInput(node, runtime, (rt, msg, send, done) => {
      rt.release(operationOf(msg, props.operation, { followAcquire: true }));
      send(msg);
      done();
    });
  }

  RED.nodes.registerType('sugarshack-release', ReleaseNode);
};
