'use strict';
const { bindInterlock, onInput, always } = require('../lib/binding');
const { resourcesOf, readMsg } = require('../lib/request');
const { journal } = require('../lib/journal/bus');

module.exports = function (RED) {
  function ClearNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const runtime = bindInterlock(RED, node, props.interlock);
    const allFaulted = props.mode === 'all';

    onInput(node, runtime, (rt, msg, send, done) => {
      const names = readMsg(() => (allFaulted && msg.resources === undefined ? null : resourcesOf(msg, props.resources)));
      journal.action('clear', msg, names === null ? 'all' : names);
      rt.clear(names, (cleared) => {
        msg.cleared = cleared;
        send(msg);
        done();
      });
    }, 'interlock', { urgent: always }); // an operator's clear never waits for a deploy's drain
  }

  RED.nodes.registerType('sugarshack-clear', ClearNode);
};
