'use strict';
const { bindInterlock } = require('../lib/binding');
const { SugarshackError, asSugarshackError } = require('../lib/errors');
const { errorStatus } = require('../lib/status');
const { readMsg } = require('../lib/request');
const { clock } = require('../lib/clock');

// Longer than any transition's trigger a plant document names.
const MAX_TOPIC = 1024;

module.exports = function (RED) {
  function RoutineNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const id = String(props.routine || '').trim();
    const interlock = bindInterlock(RED, node, props.interlock, { showCounts: false });
    let host = null;
    let refusal = interlock ? null : new SugarshackError('NO_INTERLOCK', 'no interlock is configured for this node');

    // The routine lives in the interlock's runtime; this node is its port (a deploy hands it over).
    if (interlock) {
      interlock.whenOpen(() => {
        try {
          host = interlock.routineHost(id);
          if (!host.attach(node)) {
            host = null;
            throw new SugarshackError('ROUTINE_TAKEN', `routine '${id}' is already run by another routine node; one node per routine`);
          }
          refusal = null;
        } catch (err) {
          refusal = asSugarshackError(err);
          node.error(refusal.message);
          node.status(errorStatus(refusal.code));
        }
      });
    }

    // A msg's topic is its trigger ("reset" goes back to the initial state); the msg is completed at once.
    node.on('input', (msg, send, done) => {
      if (!interlock) {
        done(refusal);
        return;
      }
      interlock.submit(node, done, () => {
        if (refusal) throw refusal;
        if (!host) throw new SugarshackError('UNKNOWN_ROUTINE', `routine '${id}' is not running yet`);
        try {
          const topic = readMsg(() => String(msg.topic ?? ''));
          if (topic.length > MAX_TOPIC) {
            throw new SugarshackError('INVALID_INPUT', `a routine's trigger (msg.topic) is at most ${MAX_TOPIC} characters; this one has ${topic.length}`);
          }
          host.onMsg(topic);
        } catch (err) {
          const e = asSugarshackError(err);
          node.status(errorStatus(e.code));
          clock.setTimeout(() => host && host.refresh(), 5000);
          throw e;
        }
        done();
      });
    });

    node.on('close', (removed, done) => {
      if (host) host.detach(node);
      done();
    });
  }

  RED.nodes.registerType('sugarshack-routine', RoutineNode);
};
