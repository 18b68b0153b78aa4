// @ts-check
'use strict';
const { SugarshackError, asSugarshackError } = require('../lib/host/errors');
const { refuseDeploy } = require('../lib/host/deploy-refusal');
const { errorStatus, status, StatusBoard } = require('../lib/host/status');
const { translator, useRED } = require('../lib/host/i18n');
const { configNumber, configDurationMs, configDurationListMs, describe, revivable } = require('../lib/control');
const { clock } = require('../lib/host/clock');
const { readMsg } = require('../lib/interlock/request');
const { quietOf, standbyStatus } = require('../lib/cluster');

const board = new StatusBoard();

function readConfig(props, t) {
  const tsMs = configDurationMs(props, 'tsS', 'ts', t('config.ts'), { required: true });
  const thresholdsMs = configDurationListMs(props, 'thresholdsS', 'thresholds', t('config.thresholds'));
  const id = configNumber(props.controller, t('config.controller'), { required: true });
  if (!Number.isInteger(id) || id < 1) {
    throw new SugarshackError('INVALID_CONFIG', t('errors.badControllerId', { max: thresholdsMs.length, got: id }));
  }
  // Blank: the core's default, 3·Ts.
  const pollTimeoutMs = configDurationMs(props, 'pollTimeoutS', 'pollTimeout', t('config.pollTimeout'), { fallbackMs: null });
  const smoothHandover = !(props.smooth === false || props.smooth === 'false');
  return { id, thresholdsMs, tsMs, smoothHandover, pollTimeoutMs };
}

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function RccNode(props) {
    RED.nodes.createNode(this, props);
    const quiet = quietOf(RED);
    const node = this;
    const t = translator(RED, 'sugarshack-rcc');
    /** @type {import('../wasm/sugarshack_wasm').Rcc | null} */
    let rcc = null;
    let settings = null;
    let refusal = null;
    try {
      settings = readConfig(props, t);
      // The core refuses thresholds breaking D_i > D_j >= Ts, and a poll timeout <= 0.
      rcc = revivable(({ Rcc }) => {
        const fresh = new Rcc(settings);
        fresh.watchFrom(clock.now());
        return fresh;
      }, { onRevive: () => schedule() });
    } catch (err) {
      refusal = refuseDeploy(node, err);
    }
    const show = (status) => board.set(node, status);

    // One timer, for when the core says the polling timeout falls due (Fig. 7, line 11).
    let timer = null;
    function schedule() {
      if (timer) clock.clearTimeout(timer);
      timer = null;
      const due = rcc && rcc.nextTickMs();
      if (due === undefined || due === null) return;
      timer = clock.setTimeout(tick, Math.max(0, due - clock.now()));
    }
    function tick() {
      timer = null;
      if (!rcc) return;
      try {
        // the next scan re-seeds the controller's integrator
        if (rcc.tick(clock.now())) show(status('warning', t('status.noIo')));
      } catch (err) {
        node.error(t('errors.pollTimeout', { message: err.message }));
      }
      schedule();
    }
    if (rcc && settings) {
      show(status('idle', t('status.waiting', { id: settings.id })));
      schedule();
    }

    // The I/O module's state { procVar, lastAction, agesMs } -> the measurement with msg.rcc, for a pid node.
    node.on('input', (msg, send, done) => {
      if (refusal || !settings || !rcc) {
        done(refusal ?? undefined); // the settings and the core object exist whenever nothing was refused
        return;
      }
      if (quiet()) {
        show(standbyStatus());
        done();
        return;
      }
      let state;
      let decision;
      try {
        // Read once, as plain values: a getter or proxy that throws is INVALID_INPUT.
        state = readMsg(() => {
          const given = msg.payload;
          if (!given || typeof given !== 'object' || Array.isArray(given)) {
            throw new SugarshackError('INVALID_INPUT', t('errors.notState', { got: describe(given) }));
          }
          return { procVar: given.procVar, lastAction: given.lastAction, agesMs: given.agesMs };
        });
        decision = rcc.decide({ lastAction: state.lastAction, agesMs: state.agesMs }, clock.now());
      } catch (err) {
        const e = asSugarshackError(err);
        show(errorStatus(e.code));
        done(e);
        return;
      }
      schedule();
      msg.payload = state.procVar;
      msg.rcc = { id: settings.id, engaged: decision.engaged, firstCycle: decision.firstCycle, track: decision.track ?? null };
      show(decision.engaged ? status('ok', t('status.engaged')) : status('standby', t('status.standby')));
      send(msg);
      done();
    });

    node.on('close', (removed, done) => {
      if (timer) clock.clearTimeout(timer);
      timer = null;
      if (rcc) rcc.free();
      rcc = null;
      done();
    });
  }

  RED.nodes.registerType('sugarshack-rcc', RccNode);
};
