'use strict';
const { SugarshackError, asSugarshackError } = require('../lib/errors');
const { errorStatus, StatusBoard } = require('../lib/status');
const { configNumber, parseList, describe, Watchdog, revivable } = require('../lib/control');
const { readMsg } = require('../lib/request');

const board = new StatusBoard();

function readConfig(props) {
  const tsMs = configNumber(props.ts, 'sampling period Ts (ms)', { required: true });
  const thresholdsMs = parseList(props.thresholds, 'engagement thresholds D_1..D_n (ms)');
  const id = configNumber(props.controller, 'controller id', { required: true });
  if (!Number.isInteger(id) || id < 1) {
    throw new SugarshackError('INVALID_CONFIG', `controller id must be a whole number from 1 (primary) to ${thresholdsMs.length}, got ${id}`);
  }
  const pollTimeoutMs = configNumber(props.pollTimeout, 'poll timeout (ms)', { fallback: 3 * tsMs });
  if (!(pollTimeoutMs > 0)) {
    throw new SugarshackError('INVALID_CONFIG', `poll timeout must be a number of ms greater than 0, got ${pollTimeoutMs}`);
  }
  const smoothHandover = !(props.smooth === false || props.smooth === 'false');
  return { id, thresholdsMs, tsMs, smoothHandover, pollTimeoutMs };
}

module.exports = function (RED) {
  function RccNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    let rcc = null;
    let settings = null;
    let refusal = null;
    try {
      settings = readConfig(props);
      // The core refuses thresholds breaking D_i > D_j >= Ts.
      const { id, thresholdsMs, tsMs, smoothHandover } = settings;
      rcc = revivable(({ Rcc }) => new Rcc({ id, thresholdsMs, tsMs, smoothHandover }));
    } catch (err) {
      refusal = asSugarshackError(err);
      node.error(refusal.message);
      node.status(errorStatus(refusal.code));
    }
    const show = (status) => board.set(node, status);

    // Polling timed out (Fig. 7, line 11): the next scan re-seeds the controller's integrator.
    const watchdog = new Watchdog(settings ? settings.pollTimeoutMs : 0, () => {
      if (!rcc) return;
      rcc.pollTimedOut();
      show({ fill: 'yellow', shape: 'ring', text: 'no I/O' });
    });
    if (rcc) {
      show({ fill: 'grey', shape: 'ring', text: `C${settings.id} waiting` });
      watchdog.arm();
    }

    // The I/O module's state { procVar, lastAction, agesMs } -> the measurement with msg.rcc, for a pid node.
    node.on('input', (msg, send, done) => {
      if (refusal) {
        done(refusal);
        return;
      }
      let state;
      let decision;
      try {
        // Read once, as plain values: a getter or proxy that throws is INVALID_INPUT.
        state = readMsg(() => {
          const given = msg.payload;
          if (!given || typeof given !== 'object' || Array.isArray(given)) {
            throw new SugarshackError('INVALID_INPUT', `msg.payload must be the I/O module's state { procVar, lastAction, agesMs }, got ${describe(given)}`);
          }
          return { procVar: given.procVar, lastAction: given.lastAction, agesMs: given.agesMs };
        });
        decision = rcc.decide({ lastAction: state.lastAction, agesMs: state.agesMs });
      } catch (err) {
        const e = asSugarshackError(err);
        show(errorStatus(e.code));
        done(e);
        return;
      }
      watchdog.arm();
      msg.payload = state.procVar;
      msg.rcc = { id: settings.id, engaged: decision.engaged, firstCycle: decision.firstCycle, track: decision.track ?? null };
      show(decision.engaged ? { fill: 'green', shape: 'dot', text: 'engaged' } : { fill: 'grey', shape: 'dot', text: 'standby' });
      send(msg);
      done();
    });

    node.on('close', (removed, done) => {
      watchdog.stop();
      if (rcc) rcc.free();
      rcc = null;
      done();
    });
  }

  RED.nodes.registerType('sugarshack-rcc', RccNode);
};
