'use strict';
const { bindInterlock } = require('../lib/binding');
const { SugarshackError, asSugarshackError } = require('../lib/errors');
const { OperationRun, prepareOperation } = require('../lib/operation-runner');
const { errorStatus } = require('../lib/status');
const { seconds } = require('../lib/plant');

module.exports = function (RED) {
  function OperationNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const interlock = bindInterlock(RED, node, props.interlock, { showCounts: false });
    let prepared = null;
    let refusal = interlock ? null : new SugarshackError('NO_INTERLOCK', 'no interlock is configured for this node');
    if (interlock) {
      try {
        // Plans and conditions are checked now, so a broken operation shows at deploy.
        prepared = prepareOperation(RED, node, interlock, String(props.operation || '').trim());
        node.status({ fill: 'grey', shape: 'ring', text: 'idle' });
      } catch (err) {
        refusal = asSugarshackError(err);
        node.error(refusal.message);
        node.status(errorStatus(refusal.code));
      }
    }
    const runs = new Set();
    let progress = null; // the status of the run in progress

    // The msg is held while the operation runs and goes on with msg.operation = { id, queuedMs, runMs, steps }.
    node.on('input', (msg, send, done) => {
      if (refusal) {
        done(refusal);
        return;
      }
      const total = prepared.plan.steps.length;
      const run = new OperationRun({
        node,
        interlock,
        prepared,
        msg,
        onStep: (phase, index, step) => {
          progress = phase === 'queued'
            ? { fill: 'yellow', shape: 'ring', text: 'queued' }
            : { fill: 'blue', shape: 'dot', text: `${index + 1}/${total} ${step.kind === 'returnToIdle' ? 'to idle' : step.kind}` };
          node.status(progress);
        },
      });
      runs.add(run);
      run.start().then((result) => {
        runs.delete(run);
        msg.operation = result;
        node.status({ fill: 'green', shape: 'dot', text: `done ${seconds(result.runMs)}` });
        send(msg);
        done();
      }, (err) => {
        runs.delete(run);
        const e = asSugarshackError(err);
        if (e.code === 'OPERATION_RUNNING') {
          // A run of this very node goes on and keeps showing its progress.
          node.status(runs.size > 0 && progress ? progress : errorStatus(e.code));
          done(e);
          return;
        }
        if (e.code === 'ABORTED' || (e.operation && e.operation.aborted)) {
          // Stopped with its node: the msg is completed unsent; a fault it caused is logged.
          if (e.operation) node.warn(e.message);
          done();
          return;
        }
        msg.operation = e.operation || { id: prepared.plan.id };
        const where = e.operation && (e.operation.kind === 'release' ? 'release' : `${e.operation.step + 1}/${total}`);
        node.status(e.operation ? { fill: 'red', shape: 'dot', text: `fault at ${where}` } : errorStatus(e.code));
        done(e);
      });
    });

    node.on('close', (removed, done) => {
      for (const run of runs) run.abort('its operation node was stopped (redeploy or shutdown)');
      done();
    });
  }

  RED.nodes.registerType('sugarshack-operation', OperationNode);
};
