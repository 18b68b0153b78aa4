'use strict';
const { bindInterlock, onInput } = require('../lib/binding');
const { resourcesOf } = require('../lib/request');

module.exports = function (RED) {
  function ClearNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const runtime = bindInterlock(RED, node, props.interlock);
    const allFaulted = props.mode === 'all';

    onInput(node, runtime, (rt, msg, send, done) => {
      const names = allFaulted && msg.resources === undefined ? null : resourcesOf(msg, props.resources);
      msg.cleared = rt.clear(names);
      send(msg);
      done();
    });
  }

  RED.nodes.registerType('sugarshack-clear', ClearNode);
};
