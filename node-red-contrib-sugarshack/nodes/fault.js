'use strict';
const { bindInterlock, onInput, always } = require('../lib/binding');
const { operationOf, resourcesOf, noteOf, readMsg } = require('../lib/request');
const { clock } = require('../lib/clock');
const { journal } = require('../lib/journal/bus');

module.exports = function (RED) {
  function FaultNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const runtime = bindInterlock(RED, node, props.interlock);
    const byResources = props.mode === 'resources';

    // Output 2 gets one lockout group command per latched line, once the fault is saved.
    onInput(node, runtime, (rt, msg, send, done) => {
      const request = readMsg(() => ({
        note: noteOf(msg),
        operation: byResources ? null : operationOf(msg, props.operation, { followAcquire: true }),
        resources: byResources ? resourcesOf(msg, props.resources) : null,
      }));
      const { note, operation } = request;
      const out = (lockouts) => {
        // faultAtMs lets the group command that applies the lockout report the fault lockout time.
        const faultAtMs = clock.now();
        const commands = lockouts.map(({ resource, command }) => ({
          topic: `lockout/${resource}`,
          payload: command,
          resource,
          operation,
          note: note === undefined ? null : note,
          faultAtMs,
        }));
        send([msg, commands]);
        done();
      };
      journal.action('fault', msg, byResources ? request.resources : operation);
      if (byResources) rt.faultResources(request.resources, note, out);
      else rt.fault(operation, note, out);
    }, 'interlock', { urgent: always }); // an e-stop never waits for a deploy's drain
  }

  RED.nodes.registerType('sugarshack-fault', FaultNode);
};
