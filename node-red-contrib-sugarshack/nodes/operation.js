// @ts-check
'use strict';
const { bindInterlock } = require('../lib/host/binding');
const { SugarshackError, asSugarshackError } = require('../lib/host/errors');
const { refuseDeploy } = require('../lib/host/deploy-refusal');
const { errorStatus, status } = require('../lib/host/status');
const { translator, useRED } = require('../lib/host/i18n');
const { seconds } = require('../lib/plant/plant');
const { readMsg, attributionOf, nodeValues } = require('../lib/interlock/request');
const operator = require('../lib/interlock/operator');
const wasm = require('../lib/wasm');
const { configuredOrRefused, nodeConfig } = require('../lib/host/node-config');

// The operator's commands (hold, restart, stop, abort, reset): as msg topics, commands to this operation's run.
const COMMANDS = new Set(/** @type {string[]} */ (wasm.load().operatorCommands()));

/**
 * The status of a run that entered an operator's state (`step`: its index, if in one).
 * @param {(key: string, subs?: object) => string} t @param {string} state @param {number | null | undefined} step @param {number} total
 */
function enteredStatus(t, state, step, total) {
  const n = (step ?? 0) + 1;
  switch (state) {
    case 'holding': return status('warning', t('status.holding', { step: n, total }));
    case 'held': return status('warning', t('status.held', { step: n, total }));
    case 'restarting': return status('running', t('status.restarting', { step: n, total }));
    case 'stopping': return status('warning', t('status.stopping', { step: n, total }));
    case 'aborting': return status('fault', t('status.aborting'));
    default: return null; // running again: its step shows next
  }
}

/** @returns {import('../lib/operations/operation-run').RunPort & Record<string, any>} */
function nodePort(t, node, msg, send, done, total, id) {
  const port = {
    owner: /** @type {{ kind: 'node', id: string }} */ ({ kind: 'node', id: node.id }),
    nodeId: node.id,
    node,
    send,
    done,
    /** @type {NodeRed.NodeStatus | null} the run's progress, shown again by the node's next instance */
    shown: null,
    progress(what, index, detail) {
      if (what === 'entered') {
        const entered = enteredStatus(t, detail, index, total);
        if (!entered) return;
        port.shown = entered;
      } else {
        port.shown = what === 'queued'
          ? status('warning', t('status.queued'))
          : status('running', t('status.step', { step: (index ?? 0) + 1, total, kind: detail.kind === 'returnToIdle' ? t('status.toIdle') : detail.kind }));
      }
      if (port.node) port.node.status(port.shown);
    },
    finish(result) {
      msg.operation = result;
      if (!port.node) return;
      port.node.status(status('ok', t('status.done', { time: seconds(result.runMs) })));
      port.send(msg);
      if (port.done) port.done();
    },
    // An operator's stop: the msg goes on with msg.operation.stopped = true (an orderly end, not an error).
    stop(result) {
      msg.operation = result;
      if (!port.node) return;
      port.node.status(status('idle', t('status.stopped', { time: seconds(result.runMs) })));
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
        // Aborted by an operator: the status says so, not where (it waits for a reset).
        const kind = failed ? (failed.state === 'aborted' ? 'acquire' : failed.kind) : 'acquire';
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
    // The operation's id: typed in (as every flow saved before the sources), or read for each msg from
    // a msg property, flow or global context, env or JSONata, as Node-RED's trigger node reads its values.
    const values = nodeValues(RED, node, props, ['operation']);
    const config = values ? { id: null } : configuredOrRefused(node, 'operation', props);
    if (!config) return;
    const deployed = config.id ?? null;
    const interlock = bindInterlock(RED, node, props.interlock, { showCounts: false });
    let total = 0; // the deployed operation's steps
    /** The steps of operation `id`, its conditions checked against the document in force. */
    const stepsOf = (plant, id) => {
      const plan = plant.guard(() => plant.t.operationPlan(id));
      for (const step of plan.steps) if (step.kind === 'wait') plant.sensors.condition(step.condition, step.sensors);
      return plan.steps.length;
    };
    if (interlock) {
      // Checked against the document in force, so a broken operation shows at deploy.
      interlock.whenOpen(() => {
        try {
          if (!interlock.plant) throw new SugarshackError('NO_PLANT', t('errors.noPlant'));
          if (interlock.plant.state !== 'ready') throw interlock.plant.failure || new SugarshackError('NO_PLANT', t('errors.plantStopped'));
          const plant = interlock.plant;
          if (deployed !== null) total = stepsOf(plant, deployed);
          // A run of this node saved held came back held after a restart: this node supervises it again.
          const held = interlock.heldRunOf({ kind: 'node', id: node.id });
          if (held) {
            const id = held.operation;
            const carrier = { _msgid: RED.util.generateId(), topic: `operation/${id}` };
            held.takePort(nodePort(t, node, carrier, (m) => node.send(m), null, id === deployed ? total : stepsOf(plant, id), id));
          }
          if (![...interlock.runs].some((run) => run.port.nodeId === node.id)) node.status(status('idle', t('status.idle')));
        } catch (err) {
          refuseDeploy(node, err);
        }
      });
    }

    // The msg is held while the operation runs and goes on with msg.operation = { id, queuedMs, runMs, heldMs, steps }.
    // A msg whose topic is an operator's command (hold, restart, stop, abort, reset) commands its run instead,
    // and is completed once the state it entered is saved (or with the refusal).
    const handle = (msg, send, done, id) => {
      let topic;
      try {
        topic = readMsg(() => msg.topic);
      } catch {
        topic = undefined; // read again as a start, where the refusal shows
      }
      if (typeof topic === 'string' && COMMANDS.has(topic)) {
        const command = topic;
        interlock.submit(node, done, (rt) => {
          const who = readMsg(() => attributionOf(msg));
          operator.command(rt, { operation: id }, command, who).then(() => done(), (err) => done(err));
        }, { urgent: true }); // an operator's command never waits for a deploy's drain
        return;
      }
      interlock.submit(node, done, (rt) => {
        const steps = id === deployed || !rt.plant ? total : stepsOf(rt.plant, id); // no plant: startRun refuses
        rt.startRun(id, msg, nodePort(t, node, msg, send, done, steps, id));
      });
    };
    node.on('input', (msg, send, done) => {
      if (!interlock) {
        done(new SugarshackError('NO_INTERLOCK', t('errors.noInterlock')));
        return;
      }
      if (!values) {
        handle(msg, send, done, deployed);
        return;
      }
      values(msg, (err, read) => {
        let id = null;
        try {
          if (err) throw err;
          id = nodeConfig('operation', /** @type {Record<string, any>} */ (read)).id;
        } catch (refusal) {
          // A value that cannot be read, or is no operation id, shows on the node; the msg fails with it.
          const e = asSugarshackError(refusal);
          interlock.showError(node, e.code);
          done(e);
          return;
        }
        handle(msg, send, done, id);
      });
    });
  }

  RED.nodes.registerType('sugarshack-operation', OperationNode);
};
