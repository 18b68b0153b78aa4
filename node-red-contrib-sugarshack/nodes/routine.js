// @ts-check
'use strict';
const { bindInterlock } = require('../lib/host/binding');
const { SugarshackError, asSugarshackError } = require('../lib/host/errors');
const { refuseDeploy } = require('../lib/host/deploy-refusal');
const { errorStatus } = require('../lib/host/status');
const { translator, useRED } = require('../lib/host/i18n');
const { readMsg, attributionOf } = require('../lib/interlock/request');
const operator = require('../lib/interlock/operator');
const wasm = require('../lib/wasm');
const { configuredOrRefused } = require('../lib/host/node-config');

// The operator's commands (hold, restart, stop, abort, reset): as msg topics, commands to the routine.
const COMMANDS = new Set(/** @type {string[]} */ (wasm.load().operatorCommands()));

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
    const config = configuredOrRefused(node, 'routine', props);
    if (!config) return;
    const id = /** @type {string} */ (config.id);
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

    /** A refusal shows on the node until the routine's next change shows its state; the msg completes with it. */
    const refused = (err) => {
      const e = asSugarshackError(err);
      node.status(errorStatus(e.code));
      return e;
    };

    // A msg's topic is its trigger, completed at once; an operator's command (hold, restart, stop, abort,
    // reset) goes to the routine as the core allows, completed once the state it entered is saved.
    node.on('input', (msg, send, done) => {
      if (!interlock) {
        done(refusal ?? undefined); // set whenever the config node is missing
        return;
      }
      let topic = '';
      let unreadable = null;
      try {
        topic = readMsg(() => String(msg.topic ?? ''));
      } catch (err) {
        unreadable = err;
      }
      const command = COMMANDS.has(topic);
      interlock.submit(node, done, (rt) => {
        if (refusal) throw refusal;
        if (!host) throw new SugarshackError('UNKNOWN_ROUTINE', t('errors.notRunning', { id }));
        try {
          if (unreadable) throw unreadable;
          if (topic.length > MAX_TOPIC) {
            throw new SugarshackError('INVALID_INPUT', t('errors.topicTooLong', { max: MAX_TOPIC, length: topic.length }));
          }
          if (!command) {
            host.onMsg(topic);
            done();
            return;
          }
          const who = readMsg(() => attributionOf(msg));
          operator.command(rt, { routine: id }, topic, who).then(() => done(), (err) => done(refused(err)));
        } catch (err) {
          throw refused(err);
        }
      }, { urgent: command }); // an operator's command never waits for a deploy's drain
    });

    node.on('close', (removed, done) => {
      if (host) host.detach(node);
      done();
    });
  }

  RED.nodes.registerType('sugarshack-routine', RoutineNode);
};
