'use strict';
const { bindInterlock, onInput } = require('../lib/binding');
const { operationOf, priorityOf, resourcesOf } = require('../lib/request');

module.exports = function (RED) {
  function AcquireNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const timeoutMs = Math.max(0, Number(props.timeout) || 0) * 1000;
    const runtime = bindInterlock(RED, node, props.interlock);

    // Holds the msg until granted; the same msg object then goes on (link call returns stay intact).
    onInput(node, runtime, (rt, msg, send, done) => {
      rt.acquire({
        node,
        msg,
        send,
        done,
        operation: operationOf(msg, props.operation),
        priority: priorityOf(msg, props.priority),
        resources: resourcesOf(msg, props.resources),
        timeoutMs,
      });
    });
  }

  RED.nodes.registerType('sugarshack-acquire', AcquireNode);
};
