// @ts-check
'use strict';
const { bindPlant } = require('../lib/host/binding');
const { SugarshackError, asSugarshackError } = require('../lib/host/errors');
const { refuseDeploy } = require('../lib/host/deploy-refusal');
const { nodeConfig } = require('../lib/host/node-config');
const { errorStatus, status } = require('../lib/host/status');
const { translator, useRED } = require('../lib/host/i18n');
const { clock } = require('../lib/host/clock');

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function WaitNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const t = translator(RED, 'sugarshack-wait');
    const plant = bindPlant(RED, node, props.plant, { showCounts: false });
    let timeoutMs = 0;
    let condition = null;
    let refusal = plant ? null : new SugarshackError('NO_PLANT', t('errors.noPlant'));
    // Read by the core against the document in force (after a deploy's drain, the new one).
    if (plant) {
      plant.whenOpen(() => {
        try {
          if (plant.state !== 'ready') throw plant.failure || new SugarshackError('NO_PLANT', t('errors.plantStopped'));
          const config = nodeConfig('wait', props);
          timeoutMs = /** @type {number} */ (config.timeoutMs);
          condition = plant.sensors.condition(String(props.condition || ''), /** @type {string[]} */ (config.sensors));
          refusal = null;
          node.status({});
        } catch (err) {
          refusal = refuseDeploy(node, err);
        }
      });
    }
    const waiting = new Set();

    // Holds the msg until the condition holds on fresh values; then it goes on with msg.condition.
    node.on('input', (msg, send, done) => {
      if (!plant) {
        done(refusal ?? undefined); // set whenever the config node is missing
        return;
      }
      plant.submit(node, done, () => {
        if (refusal) throw refusal;
        const signal = {};
        const since = clock.now();
        waiting.add(signal);
        node.status(status('waiting', t('status.waiting', { count: waiting.size })));
        condition.waitUntil(timeoutMs, signal).then((values) => {
          waiting.delete(signal);
          msg.condition = { values, waitedMs: clock.now() - since };
          node.status(waiting.size ? status('waiting', t('status.waiting', { count: waiting.size })) : status('ok', t('status.held')));
          send(msg);
          done();
        }, (err) => {
          waiting.delete(signal);
          const e = asSugarshackError(err);
          if (e.code === 'ABORTED') {
            done();
            return;
          }
          node.status(errorStatus(e.code));
          done(e);
        });
      });
    });

    node.on('close', (removed, done) => {
      for (const signal of waiting) if (signal.cancel) signal.cancel(t('errors.nodeStopped'));
      done();
    });
  }

  RED.nodes.registerType('sugarshack-wait', WaitNode);
};
