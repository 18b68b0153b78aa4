// @ts-check
'use strict';
const { bindInterlock, onEngineInput, askedBy } = require('../lib/binding');
const { useRED } = require('../lib/i18n');

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function ClearNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const runtime = bindInterlock(RED, node, props.interlock);
    // A refusal is an answer a dashboard shows: out of output 2 when it is wired, else to the Catch nodes.
    const refusalsWired = Array.isArray(props.wires) && Array.isArray(props.wires[1]) && props.wires[1].length > 0;
    const handle = runtime && runtime.addNode(node, { kind: 'clear', allFaulted: props.mode === 'all', refusalsWired, resources: props.resources });

    // An operator's clear never waits for a deploy's drain.
    onEngineInput(node, runtime, 2, (msg) => {
      const fields = { resources: msg.resources, ...askedBy(msg) };
      const namesGiven = msg.resources !== undefined;
      const tracker = runtime.tracker;
      if (tracker) return (e, k, now) => e.clearAgainst(handle, k, fields, namesGiven, now, tracker);
      return (e, k, now) => e.clear(handle, k, fields, namesGiven, now);
    });
  }

  RED.nodes.registerType('sugarshack-clear', ClearNode);
};
