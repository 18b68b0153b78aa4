// @ts-check
'use strict';
const { bindInterlock } = require('../lib/binding');
const { SugarshackError, asSugarshackError } = require('../lib/errors');
const { refuseDeploy } = require('../lib/deploy-refusal');
const { errorStatus, status } = require('../lib/status');
const { translator, useRED } = require('../lib/i18n');
const { seconds } = require('../lib/plant');

/**
 * Where a run started by an operation node reports: the node's status, and its
 * msg sent on (or failed) by the instance of the node that is current then.
 */
function nodePort(t, node, msg, send, done, total, id) {
  const port = {
    nodeId: node.id,
    node,
    send,
    done,
    /** @type {NodeRed.NodeStatus | null} the run's progress, shown again by the node's next instance */
    shown: null,
    progress(phase, index, step) {
      port.shown = phase === 'queued'
        ? status('warning', t('status.queued'))
        : status('running', t('status.step', { step: index + 1, total, kind: step.kind === 'returnToIdle' ? t('status.toIdle') : step.kind }));
      if (port.node) port.node.status(port.shown);
    },
    finish(result) {
      msg.operation = result;
      if (!port.node) return;
      port.node.status(status('ok', t('status.done', { time: seconds(result.runMs) })));
      port.send(msg);
      if (port.done) port.done();
    },
    fail(err) {
      const e = asSugarshackError(err);
      if (!port.node) return;
      if (e.code === 'OPERATION_RUNNING') {
        port.node.status(errorStatus(e.code));
      } else {
        const failed = e.operation;
        msg.operation = failed || { id };
        const kind = failed ? failed.kind : 'acquire';
        const where = !failed || kind === 'acquire' ? null : kind === 'release' ? 'release' : `${(failed.step ?? 0) + 1}/${total}`;
        port.node.status(where ? status('fault', t('status.faultAt', { where })) : errorStatus(e.code));
      }
      if (port.done) port.done(e);
      else port.node.error(e, msg);
    },
    abandon() {
      if (port.done) port.done();
      port.done = null;
    },
    // A deploy restarts the node: the msg is completed by this instance and goes on from the next.
    detachNode(closing) {
      if (port.node !== closing) return;
      if (port.done) port.done();
      port.node = null;
      port.send = null;
      port.done = null;
    },
    adopt(next) {
      if (next.id !== port.nodeId || port.node) return;
      port.node = next;
      port.send = (m) => next.send(m);
      if (port.shown) next.status(port.shown);
    },
  };
  return port;
}

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function OperationNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const t = translator(RED, 'sugarshack-operation');
    const id = String(props.operation || '').trim();
    const interlock = bindInterlock(RED, node, props.interlock, { showCounts: false });
    let total = 0;
    if (interlock) {
      // Checked against the document in force, so a broken operation shows at deploy.
      interlock.whenOpen(() => {
        try {
          if (!interlock.plant) throw new SugarshackError('NO_PLANT', t('errors.noPlant'));
          if (interlock.plant.state !== 'ready') throw interlock.plant.failure || new SugarshackError('NO_PLANT', t('errors.plantStopped'));
          const plan = interlock.plant.plan(id);
          total = plan.steps.length;
          for (const step of plan.steps) if (step.kind === 'wait') interlock.plant.condition(step.condition, step.sensors);
          if (![...interlock.runs].some((run) => run.port.nodeId === node.id)) node.status(status('idle', t('status.idle')));
        } catch (err) {
          refuseDeploy(node, err);
        }
      });
    }

    // The msg is held while the operation runs and goes on with msg.operation = { id, queuedMs, runMs, steps }.
    node.on('input', (msg, send, done) => {
      if (!interlock) {
        done(new SugarshackError('NO_INTERLOCK', t('errors.noInterlock')));
        return;
      }
      interlock.submit(node, done, (rt) => rt.startRun(id, msg, nodePort(t, node, msg, send, done, total, id)));
    });
  }

  RED.nodes.registerType('sugarshack-operation', OperationNode);
};
