// @ts-check
'use strict';
const { SugarshackError, asSugarshackError } = require('../lib/host/errors');
const { refuseDeploy } = require('../lib/host/deploy-refusal');
const { errorStatus, status, StatusBoard } = require('../lib/host/status');
const { translator, useRED } = require('../lib/host/i18n');
const { isNumber, configNumber, configDurationMs, describe, fmt, revivable } = require('../lib/control');
const { quietOf, standbyStatus } = require('../lib/cluster');
const { clock } = require('../lib/host/clock');
const { readMsg } = require('../lib/interlock/request');

const board = new StatusBoard();

function readConfig(props, t) {
  const controllers = configNumber(props.controllers, t('config.controllers'), { required: true }); // a whole number >= 1: the core checks
  const periodMs = configDurationMs(props, 'periodS', 'period', t('config.period'), { required: true });
  if (!(periodMs > 0)) throw new SugarshackError('INVALID_CONFIG', t('errors.badPeriod', { got: periodMs / 1000 }));
  return { controllers, initialAction: configNumber(props.initialAction, t('config.initialAction'), { fallback: 0 }), periodMs };
}

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function RccIoNode(props) {
    RED.nodes.createNode(this, props);
    const quiet = quietOf(RED);
    const node = this;
    const t = translator(RED, 'sugarshack-rcc-io');
    /** @type {import('../wasm/sugarshack_wasm').IoModule | null} */
    let io = null;
    let settings = null;
    let lastWritten = null;
    let refusal = null;
    try {
      settings = readConfig(props, t);
      // After a trap the module starts again from the last action written, not the initial one.
      io = revivable(({ IoModule }) => new IoModule(settings.controllers, lastWritten ?? settings.initialAction));
    } catch (err) {
      refusal = refuseDeploy(node, err);
    }
    let procVar = null; // no measurement yet
    const show = (shown) => board.set(node, shown);

    // Output 1, every period: the state tuple (a, u_1..u_n) and the measurement, for the controllers.
    function publish() {
      if (!io || quiet()) return;
      const now = clock.now();
      const { lastAction, agesMs } = io.state(now);
      node.send([{ payload: { procVar, lastAction, agesMs }, timestamp: now }, null]);
    }
    let timer = null;
    if (io && settings) {
      show(status('idle', t('status.idle', { value: fmt(settings.initialAction) })));
      timer = clock.setInterval(publish, settings.periodMs);
    }

    node.on('input', (msg, send, done) => {
      if (refusal || !settings || !io) {
        done(refusal ?? undefined); // the settings and the core object exist whenever nothing was refused
        return;
      }
      if (quiet()) {
        show(standbyStatus());
        done();
        return;
      }
      // Read once, as plain values: a getter or proxy that throws is INVALID_INPUT.
      let topic;
      let payload;
      try {
        ({ topic, payload } = readMsg(() => ({ topic: msg.topic, payload: msg.payload })));
      } catch (err) {
        show(errorStatus(err.code));
        done(err);
        return;
      }
      if (topic === 'measurement') {
        if (isNumber(payload)) {
          procVar = payload;
          done();
          return;
        }
        procVar = null; // the controllers see no measurement and output their fallback
        const e = new SugarshackError('BAD_MEASUREMENT', t('errors.badMeasurement', { got: describe(payload) }));
        show(errorStatus(e.code));
        done(e);
        return;
      }
      try {
        const id = readMsg(() => (msg.controller !== undefined ? msg.controller : msg.rcc && msg.rcc.id));
        if (!Number.isInteger(id) || id < 1) {
          throw new SugarshackError(id === undefined ? 'INVALID_INPUT' : 'UNKNOWN_CONTROLLER',
            t('errors.noController', { controllers: settings.controllers, got: describe(id) }));
        }
        if (!isNumber(payload)) {
          throw new SugarshackError('INVALID_INPUT', t('errors.badAction', { id, got: describe(payload) }));
        }
        io.write(id, payload, clock.now()); // Conditional Acting: a := action, u_id := 0
        lastWritten = payload;
        show(status('ok', t('status.written', { id, value: fmt(payload) })));
      } catch (err) {
        const e = asSugarshackError(err);
        show(errorStatus(e.code));
        done(e);
        return;
      }
      // Output 2: the action, to the actuator.
      send([null, msg]);
      done();
    });

    node.on('close', (removed, done) => {
      if (timer) clock.clearInterval(timer);
      if (io) io.free();
      io = null;
      done();
    });
  }

  RED.nodes.registerType('sugarshack-rcc-io', RccIoNode);
};
