'use strict';
const { bindInterlock } = require('../lib/binding');
const { SugarshackError, asSugarshackError } = require('../lib/errors');
const { Condition } = require('../lib/condition');
const { OperationRun, prepareOperation, plantOf, readyPlant, issueLockouts } = require('../lib/operation-runner');
const { trackFlows, whenFlowsStarted } = require('../lib/flows');
const { errorStatus, MAX_STATUS_LENGTH } = require('../lib/status');
const { stats } = require('../lib/stats');

// How often due conditions are looked for; each transition's own everyMs decides when it is checked.
const TICK_MS = 250;
const CONTEXT_KEY = 'routine';

function clip(text) {
  return text.length <= MAX_STATUS_LENGTH ? text : `${text.slice(0, MAX_STATUS_LENGTH - 1)}…`;
}

module.exports = function (RED) {
  trackFlows(RED);

  function RoutineNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const id = String(props.routine || '').trim();
    const interlock = bindInterlock(RED, node, props.interlock, { showCounts: false });
    const store = props.store && props.store !== 'default' ? props.store : undefined;
    let machine = null;
    let refusal = interlock ? null : new SugarshackError('NO_INTERLOCK', 'no interlock is configured for this node');
    const operations = new Map(); // operation id -> prepared plan and conditions
    const conditions = new Map(); // transition index -> Condition
    if (interlock) {
      try {
        const plant = readyPlant(plantOf(interlock));
        machine = plant.routine(id);
        for (const op of machine.operations()) operations.set(op, prepareOperation(RED, node, interlock, op));
        for (const c of machine.conditions()) conditions.set(c.transition, new Condition(RED, node, c.when, c.sensors, plant, 'routine'));
      } catch (err) {
        refusal = asSugarshackError(err);
        node.error(refusal.message);
        node.status(errorStatus(refusal.code));
        if (machine) machine.free();
        machine = null;
      }
    }

    let ready = false;
    let closed = false;
    let run = null;
    let lastFault = false;
    const early = []; // msgs that arrived before the saved state was read
    const warned = new Set();
    let timer = null;

    function save() {
      node.context().set(CONTEXT_KEY, machine.snapshot(), store, (err) => {
        if (err) node.error(`cannot save routine '${id}' state: ${err.message || err}`);
      });
    }

    function refresh() {
      if (!machine || closed) return;
      const state = machine.state();
      const pending = machine.pending();
      if (machine.halted()) node.status({ fill: 'red', shape: 'ring', text: clip(`halted ${state}`) });
      else if (pending) node.status({ fill: 'blue', shape: 'dot', text: clip(`${state} › ${pending}`) });
      else node.status({ fill: lastFault ? 'red' : 'green', shape: 'dot', text: clip(state) });
    }

    /** Sends an event msg: { routine, event, state, pending, halted, ... }. */
    function emit(event, details) {
      const msg = {
        topic: `routine/${id}`,
        payload: { routine: id, event, state: machine.state(), pending: machine.pending() || null, halted: machine.halted(), ...details },
      };
      node.send(msg);
      refresh();
      return msg;
    }

    function dispatch(d) {
      save(); // with the operation pending: a restart meanwhile counts it as faulted
      emit('dispatched', { operation: d.operation, from: d.from, to: d.to });
      const carrier = { _msgid: RED.util.generateId(), topic: `routine/${id}`, routine: id };
      run = new OperationRun({ node, interlock, prepared: operations.get(d.operation), msg: carrier });
      run.start().then((result) => {
        run = null;
        if (closed) return;
        const moved = stats.time('routine', () => machine.completed());
        lastFault = false;
        save();
        emit('completed', { operation: d.operation, from: moved.from, to: moved.to, queuedMs: result.queuedMs, runMs: result.runMs });
      }, (err) => {
        run = null;
        const e = asSugarshackError(err);
        if (closed || e.code === 'ABORTED' || (e.operation && e.operation.aborted)) {
          if (e.operation) node.warn(e.message);
          return; // the saved state keeps it pending: the next start counts it as faulted
        }
        if (!e.operation) {
          // Refused before the grant (already running, queue full...): nothing ran, nothing locked out.
          machine.refused();
          save();
          const out = emit('refused', { operation: d.operation, error: { code: e.code, message: e.message } });
          node.error(e, out);
          return;
        }
        const moved = machine.faulted();
        lastFault = true;
        save();
        const out = emit('faulted', { operation: d.operation, from: moved.from, to: moved.to, error: { code: e.code, message: e.message } });
        node.error(e, out);
      });
    }

    /** Its operation did not finish before the restart: its lines lock out until a person clears them. */
    function lockOutInterrupted(operation) {
      const { plan, plant } = operations.get(operation);
      whenFlowsStarted(RED, () => {
        if (closed || interlock.state !== 'ready') return;
        // A persisted interlock restored them faulted and sent their lockouts already.
        const faulted = new Set(interlock.faultedResources());
        if (plan.resources.every((r) => faulted.has(r))) return;
        try {
          const lockouts = interlock.faultResources(plan.resources, `operation '${operation}' of routine '${id}' was interrupted by a restart`);
          issueLockouts(node, plant, lockouts, operation);
        } catch (err) {
          node.error(`cannot lock out the lines of interrupted operation '${operation}': ${err.message}`);
        }
      });
    }

    function checkConditions() {
      if (!ready || closed || run) return;
      const now = Date.now();
      const due = stats.time('routine', () => machine.due(now));
      for (const t of due) {
        conditions.get(t).check(now).then((outcome) => {
          if (!outcome.met || closed) return;
          const d = stats.time('routine', () => machine.conditionMet(t));
          if (d) dispatch(d);
        }, (err) => {
          if (warned.has(t)) return;
          warned.add(t);
          node.error(`routine '${id}': ${err.message}`);
        });
      }
    }

    function handle(msg, done) {
      try {
        if (msg.topic === 'reset') {
          const moved = machine.reset();
          lastFault = false;
          save();
          emit('reset', { from: moved.from, to: moved.to });
        } else {
          const d = stats.time('routine', () => machine.onMsg(String(msg.topic ?? '')));
          dispatch(d);
        }
        done();
      } catch (err) {
        const e = asSugarshackError(err);
        node.status(errorStatus(e.code));
        setTimeout(refresh, 5000).unref?.();
        done(e);
      }
    }

    if (machine) {
      node.context().get(CONTEXT_KEY, store, (err, snapshot) => {
        if (closed) return;
        if (err) node.warn(`cannot read routine '${id}' saved state (${err.message || err}); starting in its initial state`);
        if (snapshot) {
          try {
            const moved = machine.restore(snapshot);
            if (moved) {
              lastFault = true;
              save();
              emit('interrupted', { operation: moved.operation, from: moved.from, to: moved.to });
              lockOutInterrupted(moved.operation);
            }
          } catch (e) {
            node.warn(`routine '${id}': the saved state does not fit the routine any more (${e.message}); starting in its initial state`);
          }
        }
        ready = true;
        refresh();
        for (const [msg, done] of early.splice(0)) handle(msg, done);
        timer = setInterval(checkConditions, TICK_MS);
        checkConditions();
      });
    }

    // A msg's topic is its trigger ("reset" goes back to the initial state); the msg is completed at once.
    node.on('input', (msg, send, done) => {
      if (refusal) done(refusal);
      else if (!ready) early.push([msg, done]);
      else handle(msg, done);
    });

    node.on('close', (removed, done) => {
      closed = true;
      if (timer) clearInterval(timer);
      for (const [, held] of early.splice(0)) held();
      if (run) run.abort(`its routine node '${id}' was stopped (redeploy or shutdown)`);
      if (machine) machine.free();
      done();
    });
  }

  RED.nodes.registerType('sugarshack-routine', RoutineNode);
};
