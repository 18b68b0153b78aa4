// @ts-check
'use strict';
// The pid node's settings and msgs as the core's PidStation takes them: each
// field as the user set it (a number checked a number), or left out. What a
// blank becomes (alpha, h, max dead, stale after = 3 × Ts, action, P on...) and
// every rule on the values are the core's.
const { SugarshackError } = require('../host/errors');
const { translator } = require('../host/i18n');
const { isNumber, blank, configNumber, configDurationMs, msgNumber, describe } = require('./index');

/** @typedef {import('../../wasm/sugarshack_wasm').StationConfig} StationConfig */
/** @typedef {(key: string, subs?: Record<string, any>) => string} Translate */

// A msg with one of these (or topic "setpoint") changes the loop and is not a measurement.
const CONTROL_KEYS = ['setpoint', 'mode', 'manual', 'tunings', 'limits'];

/** Whether `msg` changes the loop rather than measuring. */
const isChange = (msg) => msg.topic === 'setpoint' || CONTROL_KEYS.some((k) => msg[k] !== undefined);

/** A setting that may be left blank: its number, or undefined for the core's default. */
const optionalNumber = (value, label) => configNumber(value, label) ?? undefined;

/** A choice from the editor's list, or undefined when blank: the core refuses one it does not know. */
const choice = (value) => (blank(value) ? undefined : value);

/** Reads a pid node's settings and msgs, with texts in the runtime's language. */
class PidReader {
  /** @param {NodeRed.RED} RED */
  constructor(RED) {
    /** @type {Translate} */
    this.t = translator(RED, 'sugarshack-pid');
  }

  /**
   * The node's fields as the core's PidStation configuration.
   * @param {NodeRed.NodeProps} props
   * @returns {StationConfig}
   */
  config(props) {
    const { t } = this;
    const tsS = configNumber(props.ts, t('config.ts'), { required: true });
    /** @type {StationConfig['loop']['pid']} */
    const pid = {
      kp: configNumber(props.kp, t('config.kp'), { required: true }),
      tiS: optionalNumber(props.ti, t('config.ti')),
      tdS: optionalNumber(props.td, t('config.td')),
      outMin: configNumber(props.outMin, t('config.outMin'), { required: true }),
      outMax: configNumber(props.outMax, t('config.outMax'), { required: true }),
      action: choice(props.action),
      fallback: optionalNumber(props.fallback, t('config.fallback')),
      // Flows saved before this setting have none: the core's default acts on the error, as they did.
      proportionalOn: choice(props.pOn),
    };
    /** @type {StationConfig['loop']['smith']} */
    let smith = null;
    const predictor = props.smith || 'off';
    if (predictor === 'fixed' || predictor === 'adaptive') {
      smith = {
        model: {
          gain: configNumber(props.modelGain, t('config.modelGain'), { required: true }),
          tauS: configNumber(props.modelTau, t('config.modelTau'), { required: true }),
        },
        tsS,
        deadTime: predictor === 'fixed'
          ? { mode: 'fixed', samples: configNumber(props.deadSamples, t('config.deadSamples'), { required: true }) }
          : {
            mode: 'adaptive',
            alpha: optionalNumber(props.alpha, t('config.alpha')),
            // 'h' in flows written by hand before the setting was named 'horizon'.
            h: optionalNumber(props.horizon ?? props.h, t('config.horizon')),
          },
        maxSamples: optionalNumber(props.maxSamples, t('config.maxSamples')),
      };
    } else if (predictor !== 'off') {
      throw new SugarshackError('INVALID_CONFIG', t('errors.smithMode', { got: predictor }));
    }
    return {
      loop: { pid, smith },
      tsS,
      staleMs: configDurationMs(props, 'staleS', 'staleMs', t('config.staleS')) ?? undefined,
      setpoint: configNumber(props.setpoint, t('config.setpoint'), { required: true }),
      mode: choice(props.mode),
      manual: optionalNumber(props.manual, t('config.manual')),
    };
  }

  /**
   * msg fields of a change as the core's Change: each checked a number here, the rules applied there.
   * @param {Record<string, any>} msg
   */
  change(msg) {
    const { t } = this;
    /** @type {Record<string, any>} */
    const change = {};
    if (msg.topic === 'setpoint') change.setpoint = msgNumber(msg.payload, t('input.setpointPayload'));
    else if (msg.setpoint !== undefined) change.setpoint = msgNumber(msg.setpoint, 'msg.setpoint');
    if (msg.mode !== undefined) {
      if (msg.mode !== 'auto' && msg.mode !== 'manual') throw new SugarshackError('INVALID_INPUT', t('errors.modeInvalid', { got: describe(msg.mode) }));
      change.mode = msg.mode;
    }
    if (msg.manual !== undefined) change.manual = msgNumber(msg.manual, t('input.manual'));
    const object = (v, what) => {
      if (!v || typeof v !== 'object' || Array.isArray(v)) throw new SugarshackError('INVALID_INPUT', t('errors.notObject', { what, got: describe(v) }));
      return v;
    };
    const fields = (obj, names, what) => {
      /** @type {Record<string, number>} */
      const out = {};
      for (const [key, as, label] of names) if (obj[key] !== undefined) out[as] = msgNumber(obj[key], `${what}.${label}`);
      return out;
    };
    if (msg.tunings !== undefined) {
      const tunings = object(msg.tunings, 'msg.tunings ({ kp, ti, td })');
      change.tunings = fields(tunings, [['kp', 'kp', 'kp'], ['ti', 'tiS', 'ti (s)'], ['td', 'tdS', 'td (s)']], 'msg.tunings');
    }
    if (msg.limits !== undefined) {
      const l = object(msg.limits, 'msg.limits ({ min, max })');
      change.limits = fields(l, [['min', 'min', 'min'], ['max', 'max', 'max']], 'msg.limits');
    }
    return change;
  }

  /**
   * msg.rcc as the rcc node sends it: { id, engaged, firstCycle, track }.
   * @param {any} rcc
   */
  decision(rcc) {
    const { t } = this;
    if (!rcc || typeof rcc !== 'object' || typeof rcc.engaged !== 'boolean' || typeof rcc.firstCycle !== 'boolean'
      || !(rcc.track === undefined || rcc.track === null || isNumber(rcc.track))) {
      throw new SugarshackError('INVALID_INPUT', t('errors.decisionInvalid'));
    }
    return { engaged: rcc.engaged, firstCycle: rcc.firstCycle, track: rcc.track ?? null };
  }
}

module.exports = { PidReader, isChange };
