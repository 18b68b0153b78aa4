'use strict';
const { bindInterlock, onInput } = require('../lib/binding');
const { operationOf, resourcesOf, noteOf } = require('../lib/request');

module.exports = function (RED) {
  function FaultNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const runtime = bindInterlock(RED, node, props.interlock);
    const byResources = props.mode === 'resources';

    onInput(node, runtime, (rt, msg, send, done) => {
      const note = noteOf(msg);
      let operation = null;
      let lockouts;
      if (byResources) {
        lockouts = rt.faultResources(resourcesOf(msg, props.resources), note);
      } else {
        operation = operationOf(msg, props.operation, { followAcquire: true });
        lockouts = rt.fault(operation, note);
      }
      // faultAtMs lets the group command that applies the lockout report the fault lockout time.
      const faultAtMs = Date.now();
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
    });
  }

  RED.nodes.registerType('sugarshack-fault', FaultNode);
};
