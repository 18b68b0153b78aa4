'use strict';
const { bindInterlock, onInput, always } = require('../lib/binding');
const { operationOf, readMsg } = require('../lib/request');

module.exports = function (RED) {
  function ReleaseNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const runtime = bindInterlock(RED, node, props.interlock);

    // The msg goes on once the release is saved.
    onInput(node, runtime, (rt, msg, send, done) => {
      const operation = readMsg(() => operationOf(msg, props.operation, { followAcquire: true }));
      rt.release(operation, () => {
        send(msg);
        done();
      });
    }, 'interlock', { urgent: always }); // a release lets a drain end; it never waits for one
  }

  RED.nodes.registerType('sugarshack-release', ReleaseNode);
};
