// @ts-check
'use strict';
const { bindInterlock } = require('../lib/binding');
const { SugarshackError, asSugarshackError } = require('../lib/errors');
const { refuseDeploy } = require('../lib/deploy-refusal');
const { errorStatus } = require('../lib/status');
const { translator, useRED } = require('../lib/i18n');
const { readMsg } = require('../lib/request');
const { clock } = require('../lib/clock');

// Longer than any transition's trigger a plant document names.
const MAX_TOPIC = 1024;

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function RoutineNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const t = translator(RED, 'sugarshack-routine');
    const id = String(props.routine || '').trim();
    const interlock = bindInterlock(RED, node, props.interlock, { showCounts: false });
    let host = null;
    let refusal = interlock ? null : new SugarshackError('NO_INTERLOCK', t('errors.noInterlock'));

    // The routine lives in the interlock's runtime; this node is its port (a deploy hands it over).
    if (interlock) {
      interlock.whenOpen(() => {
        try {
          host = interlock.routineHost(id);
          if (!host.attach(node)) {
            host = null;
            throw new SugarshackError('ROUTINE_TAKEN', t('errors.taken', { id }));
          }
          refusal = null;
        } catch (err) {
          refusal = refuseDeploy(node, err);
        }
      });
    }

    // A msg's topic is its trigger (the core's reset topic goes back to the initial state); the msg is completed at once.
    node.on('input', (msg, send, done) => {
      if (!interlock) {
        done(refusal ?? undefined); // set whenever the config node is missing
        return;
      }
      interlock.submit(node, done, () => {
        if (refusal) throw refusal;
        if (!host) throw new SugarshackError('UNKNOWN_ROUTINE', t('errors.notRunning', { id }));
        try {
          const topic = readMsg(() => String(msg.topic ?? ''));
          if (topic.length > MAX_TOPIC) {
            throw new SugarshackError('INVALID_INPUT', t('errors.topicTooLong', { max: MAX_TOPIC, length: topic.length }));
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
