// @ts-check
'use strict';
const { bindInterlock, onInterlockInput, always } = require('../lib/host/binding');
const { clearOf, readMsg } = require('../lib/interlock/request');
const { journal } = require('../lib/journal/bus');
const { useRED } = require('../lib/host/i18n');

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function ClearNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const runtime = bindInterlock(RED, node, props.interlock);
    const allFaulted = props.mode === 'all';
    // A refusal is an answer a dashboard shows: out of output 2 when it is wired, else to the Catch nodes.
    const refusalsWired = Array.isArray(props.wires) && Array.isArray(props.wires[1]) && props.wires[1].length > 0;

    const spec = { kind: 'clear', allFaulted, refusalsWired, resources: props.resources };
    onInterlockInput(node, runtime, spec, (rt, msg, send, done) => {
      const request = readMsg(() => clearOf(msg, props.resources, allFaulted));
      const target = request.names === null ? 'all' : request.names;
      try {
        rt.clear(request.names, (cleared) => {
          msg.cleared = cleared;
          journal.action(request.who.force ? 'clear-forced' : 'clear', request.who, target);
          msg.clearedBy = { by: request.who.by || 'unknown', reason: request.who.reason, forced: request.who.force };
          send([msg, null]);
          done();
        }, request.who);
      } catch (err) {
        if (err.code === 'CLEAR_REFUSED') journal.action('clear-refused', request.who, target);
        if (err.code !== 'CLEAR_REFUSED' || !refusalsWired) throw err;
        msg.refused = { code: err.code, message: err.message, lines: err.lines || [] };
        rt.showError(node, err.code);
        send([null, msg]);
        done();
      }
    }, { urgent: always }); // an operator's clear never waits for a deploy's drain
  }

  RED.nodes.registerType('sugarshack-clear', ClearNode);
};
