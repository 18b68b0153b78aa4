'use strict';
const { SugarshackError, asSugarshackError } = require('../lib/errors');
const { errorStatus, StatusBoard } = require('../lib/status');
const { isNumber, configNumber, msgNumber, describe, fmt, clip, Watchdog, revivable } = require('../lib/control');
const { clock } = require('../lib/clock');

const CONTEXT_KEY = 'pid';
// A msg with one of these (or topic "setpoint") changes the loop and is not a measurement.
const CONTROL_KEYS = ['setpoint', 'mode', 'manual', 'tunings', 'limits'];
const board = new StatusBoard();

const invalidConfig = (message) => new SugarshackError('INVALID_CONFIG', message);
const invalidInput = (message) => new SugarshackError('INVALID_INPUT', message);
/** What reading a msg threw: ours and the core's pass; anything else (a getter, a proxy) is the sender's INVALID_INPUT. */
const inputError = (err) => (err instanceof SugarshackError || (err && typeof err.code === 'string' && err.message)
  ? err
  : invalidInput(`could not read the msg: ${String(err && typeof err.message === 'string' ? err.message : typeof err).slice(0, 100)}`));

/** The node's fields as the core's PidLoop configuration, plus what the node itself uses. */
function readConfig(props) {
  const tsS = configNumber(props.ts, 'sample period Ts (s)', { required: true });
  if (!(tsS > 0)) throw invalidConfig(`sample period Ts must be a number of seconds greater than 0, got ${tsS}`);
  const pid = {
    kp: configNumber(props.kp, 'kp (proportional gain)', { required: true }),
    tiS: configNumber(props.ti, 'ti (integral time, s)', { fallback: 0 }),
    tdS: configNumber(props.td, 'td (derivative time, s)', { fallback: 0 }),
    outMin: configNumber(props.outMin, 'output min', { required: true }),
    outMax: configNumber(props.outMax, 'output max', { required: true }),
    action: props.action === 'direct' ? 'direct' : 'reverse',
    fallback: configNumber(props.fallback, 'fallback output', { fallback: null }),
  };
  let smith = null;
  const predictor = props.smith || 'off';
  if (predictor === 'fixed' || predictor === 'adaptive') {
    smith = {
      model: {
        gain: configNumber(props.modelGain, 'Smith predictor: model gain', { required: true }),
        tauS: configNumber(props.modelTau, 'Smith predictor: model time constant tau (s)', { required: true }),
      },
      tsS,
      deadTime: predictor === 'fixed'
        ? { mode: 'fixed', samples: configNumber(props.deadSamples, 'Smith predictor: dead time (samples)', { required: true }) }
        : {
          mode: 'adaptive',
          alpha: configNumber(props.alpha, 'Smith predictor: alpha', { fallback: 0.1 }),
          h: configNumber(props.h, 'Smith predictor: h', { fallback: 3 }),
        },
      maxSamples: configNumber(props.maxSamples, 'Smith predictor: max samples', { fallback: 400 }),
    };
  } else if (predictor !== 'off') {
    throw invalidConfig(`Smith predictor must be off, fixed or adaptive, got '${predictor}'`);
  }
  const staleMs = configNumber(props.staleMs, 'stale after (ms)', { fallback: 3 * tsS * 1000 });
  if (!(staleMs >= 0)) throw invalidConfig(`stale after must be a number of ms >= 0 (0 turns the watchdog off), got ${staleMs}`);
  const mode = props.mode === 'manual' ? 'manual' : 'auto';
  const manual = configNumber(props.manual, 'manual output', { fallback: null });
  if (mode === 'manual' && manual === null) throw invalidConfig('starting in manual mode needs a manual output');
  return {
    config: { pid, smith },
    tsS,
    staleMs,
    setpoint: configNumber(props.setpoint, 'set point', { required: true }),
    mode,
    manual,
  };
}

/** msg.rcc as the rcc node sends it: { id, engaged, firstCycle, track }. */
function readDecision(rcc) {
  if (!rcc || typeof rcc !== 'object' || typeof rcc.engaged !== 'boolean' || typeof rcc.firstCycle !== 'boolean'
    || !(rcc.track === undefined || rcc.track === null || isNumber(rcc.track))) {
    throw invalidInput('msg.rcc must be the rcc node\'s decision { id, engaged, firstCycle, track }: engaged and firstCycle true or false, track a number or null');
  }
  return { engaged: rcc.engaged, firstCycle: rcc.firstCycle, track: rcc.track ?? null };
}

module.exports = function (RED) {
  function PidNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const persist = props.persist === true || props.persist === 'true';
    const store = props.store && props.store !== 'default' ? props.store : undefined;
    let settings = null;
    let loop = null;
    let refusal = null;
    let lastIntegral = null; // kept outside the core, to rebuild the loop after a trap
    try {
      settings = readConfig(props);
      // Rebuilt on a fresh wasm instance after a trap, with the integral it had.
      loop = revivable(({ PidLoop }) => {
        const fresh = new PidLoop(settings.config);
        if (lastIntegral !== null) fresh.setIntegral(lastIntegral);
        return fresh;
      }, { onRevive: () => { overTs = true; } });
    } catch (err) {
      refusal = asSugarshackError(err);
      node.error(refusal.message);
      node.status(errorStatus(refusal.code));
    }

    let setpoint = settings && settings.setpoint;
    let mode = settings && settings.mode;
    let manual = settings && settings.manual;
    let prevTs = null; // the previous measurement's time (ms): msg.timestamp, else its receipt
    let overTs = true; // the next step integrates over Ts: the first sample, or the first after the watchdog
    let viaRcc = false; // the last measurement came from an rcc node
    let lastTopic;
    let lastOutput = null;
    let ready = false;
    let closed = false;
    const early = []; // msgs that arrived while the saved state was read
    const watchdog = new Watchdog(settings ? settings.staleMs : 0, stale);

    const show = (status) => board.set(node, { ...status, text: clip(status.text) });

    function idleStatus() {
      if (mode === 'manual') return { fill: 'yellow', shape: 'dot', text: `manual ${fmt(manual)}` };
      return lastOutput === null
        ? { fill: 'grey', shape: 'ring', text: `sp ${fmt(setpoint)}` }
        : { fill: 'green', shape: 'dot', text: `auto ${fmt(lastOutput)}` };
    }

    function save() {
      if (closed) return;
      lastIntegral = loop.integral();
      if (!persist) return;
      const state = { integral: lastIntegral, setpoint, mode, manual: manual ?? null };
      node.context().set(CONTEXT_KEY, state, store, (err) => {
        if (err) node.warn(`cannot save the PID state: ${err.message || err}`);
      });
    }

    /** One step of the loop; in manual mode its integrator tracks the manual output. */
    function stepLoop(measurement, dtS, track, decision) {
      if (decision) {
        const follow = mode === 'manual' ? manual : decision.track ?? track ?? null;
        const scan = loop.stepDecided({ ...decision, track: follow }, setpoint, measurement, dtS);
        return { step: scan.step, engaged: scan.engaged };
      }
      return { step: loop.step(setpoint, measurement, dtS, mode === 'manual' ? manual : track), engaged: true };
    }

    /** msg.pid: every term of the step, for telemetry. */
    function report(step, output, measurement, dtS) {
      return {
        p: step.p,
        i: step.i,
        d: step.d,
        output,
        mode: mode === 'manual' ? 'manual' : step.mode,
        saturated: step.saturated,
        setpoint,
        measurement,
        seen: step.seen,
        deadTimeSamples: step.deadTimeSamples,
        dtS,
      };
    }

    function stepStatus(step, output, engaged) {
      if (!engaged) return { fill: 'grey', shape: 'ring', text: 'standby' };
      if (mode === 'manual') return { fill: 'yellow', shape: 'dot', text: `manual ${fmt(output)}` };
      if (step.mode === 'tracking') return { fill: 'blue', shape: 'dot', text: `tracking ${fmt(output)}` };
      return { fill: 'green', shape: step.saturated ? 'ring' : 'dot', text: `auto ${fmt(output)}` };
    }

    function measure(msg, send, done) {
      let decision = null;
      let track;
      try {
        if (msg.rcc !== undefined) decision = readDecision(msg.rcc);
        if (msg.track !== undefined && msg.track !== null) track = msgNumber(msg.track, 'msg.track (the action applied by someone else)');
      } catch (err) {
        const e = inputError(err);
        show(errorStatus(e.code));
        done(e);
        return;
      }
      const ts = isNumber(msg.timestamp) ? msg.timestamp : clock.now();
      const given = msg.payload;
      const valid = isNumber(given);
      const measurement = valid ? given : null;
      const dtS = overTs || prevTs === null ? settings.tsS : (ts - prevTs) / 1000;
      let result;
      try {
        result = stepLoop(valid ? measurement : undefined, dtS, track, decision);
      } catch (err) {
        const e = asSugarshackError(err);
        show(errorStatus(e.code));
        done(e);
        return;
      }
      const { step, engaged } = result;
      prevTs = ts;
      overTs = false;
      viaRcc = decision !== null;
      lastTopic = msg.topic;
      if (valid) watchdog.arm();
      save();
      const output = step.output; // in manual mode the core tracks the manual value and returns it clamped
      if (!isNumber(output)) { // the core never gives one; never send it on
        const e = new SugarshackError('INTERNAL', `the loop computed an output that is not a number (${output}); nothing sent`);
        show(errorStatus(e.code));
        done(e);
        return;
      }
      lastOutput = output;
      msg.payload = output;
      msg.pid = report(step, output, measurement, dtS);
      if (decision) msg.rcc = { ...msg.rcc, write: engaged ? output : null };
      if (engaged) send(msg);
      if (valid) {
        show(stepStatus(step, output, engaged));
        done();
        return;
      }
      const sent = step.mode === 'fallback' ? 'the fallback output' : 'the tracked action';
      const what = engaged ? `sent ${sent} ${fmt(output)}` : 'in standby: nothing sent';
      const e = new SugarshackError('BAD_MEASUREMENT', `the measurement in msg.payload must be a number, got ${describe(given)}; ${what}`);
      show(errorStatus(e.code));
      done(e);
    }

    /** No valid measurement for staleMs: one fallback step and send, then again every staleMs. */
    function stale() {
      if (closed || !ready) return;
      if (viaRcc) {
        // The rcc node skips scans without I/O state (Fig. 7, line 11); writing blind would keep the backup out.
        show({ fill: 'yellow', shape: 'ring', text: 'stale: no I/O' });
        return;
      }
      const dtS = settings.staleMs / 1000;
      let step;
      try {
        ({ step } = stepLoop(undefined, dtS, undefined, null));
      } catch (err) {
        node.error(`PID watchdog: ${err.message}`);
        return;
      }
      overTs = true;
      save();
      const output = step.output; // in manual mode the core tracks the manual value and returns it clamped
      lastOutput = output;
      node.send({ topic: lastTopic, payload: output, pid: report(step, output, null, dtS) });
      show({ fill: 'yellow', shape: 'ring', text: mode === 'manual' ? 'stale: manual' : 'stale: fallback' });
      watchdog.arm();
    }

    /** Set point, mode, manual output, tunings, limits: all checked before any is applied. */
    function control(msg) {
      let sp;
      if (msg.topic === 'setpoint') sp = msgNumber(msg.payload, 'the set point (msg.payload with topic "setpoint")');
      else if (msg.setpoint !== undefined) sp = msgNumber(msg.setpoint, 'msg.setpoint');
      if (msg.mode !== undefined && msg.mode !== 'auto' && msg.mode !== 'manual') {
        throw invalidInput(`msg.mode must be 'auto' or 'manual', got ${describe(msg.mode)}`);
      }
      if (msg.manual !== undefined) msgNumber(msg.manual, 'msg.manual (the manual output)');
      const current = loop.config();
      const field = (obj, key, what, value) => (obj[key] === undefined ? value : msgNumber(obj[key], what));
      const object = (v, what) => {
        if (!v || typeof v !== 'object' || Array.isArray(v)) throw invalidInput(`${what} must be an object, got ${describe(v)}`);
        return v;
      };
      let tunings = null;
      // An object naming none of its fields (a misspelt key) is refused, not taken as "no change".
      const naming = (obj, keys, what) => {
        if (!keys.some((k) => obj[k] !== undefined)) throw invalidInput(`${what} names none of ${keys.join(', ')}`);
        return obj;
      };
      if (msg.tunings !== undefined) {
        const t = naming(object(msg.tunings, 'msg.tunings ({ kp, ti, td })'), ['kp', 'ti', 'td'], 'msg.tunings');
        tunings = [field(t, 'kp', 'msg.tunings.kp', current.kp), field(t, 'ti', 'msg.tunings.ti (s)', current.tiS), field(t, 'td', 'msg.tunings.td (s)', current.tdS)];
      }
      let limits = null;
      if (msg.limits !== undefined) {
        const l = naming(object(msg.limits, 'msg.limits ({ min, max })'), ['min', 'max'], 'msg.limits');
        limits = [field(l, 'min', 'msg.limits.min', current.outMin), field(l, 'max', 'msg.limits.max', current.outMax)];
      }
      const nextMode = msg.mode ?? mode;
      // Into manual without msg.manual: hold the output the loop gave last (bumpless), else the configured one.
      let nextManual = msg.manual ?? (nextMode === 'manual' && mode !== 'manual' ? loop.lastOutput() ?? manual : manual);
      if (nextManual === undefined) nextManual = null;
      if (nextMode === 'manual' && nextManual === null) {
        throw invalidInput('manual mode needs msg.manual (the manual output): the loop has no output yet to hold');
      }
      if (tunings) loop.setTunings(...tunings);
      if (limits) {
        try {
          loop.setLimits(...limits);
        } catch (err) {
          if (tunings) loop.setTunings(current.kp, current.tiS, current.tdS);
          throw err;
        }
      }
      if (sp !== undefined) setpoint = sp;
      mode = nextMode;
      manual = nextManual;
      save();
      show(idleStatus());
    }

    function handle(msg, send, done) {
      try {
        if (msg.topic === 'setpoint' || CONTROL_KEYS.some((k) => msg[k] !== undefined)) {
          control(msg);
          if (msg.roundTripMs !== undefined) loop.observeRoundTrip(msgNumber(msg.roundTripMs, 'msg.roundTripMs'));
          done();
          return;
        }
        if (msg.roundTripMs !== undefined) {
          loop.observeRoundTrip(msgNumber(msg.roundTripMs, 'msg.roundTripMs'));
          if (msg.payload === undefined && msg.rcc === undefined) {
            done();
            return;
          }
        }
      } catch (err) {
        const e = inputError(err);
        show(errorStatus(e.code));
        done(e);
        return;
      }
      measure(msg, send, done);
    }

    /** `handle`, with whatever still throws out of it (a getter or proxy read further on) refused, and done called once. */
    function safeHandle(msg, send, done) {
      let finished = false;
      const once = (err) => {
        if (finished) return;
        finished = true;
        done(err);
      };
      try {
        handle(msg, send, once);
      } catch (err) {
        const e = inputError(err);
        show(errorStatus(e.code));
        once(e);
      }
    }

    function start() {
      ready = true;
      show(idleStatus());
      for (const [msg, send, done] of early.splice(0)) safeHandle(msg, send, done);
    }

    if (loop) {
      if (!persist) {
        start();
      } else {
        node.context().get(CONTEXT_KEY, store, (err, saved) => {
          if (closed) return;
          if (err) node.warn(`cannot read the saved PID state (${err.message || err}); starting from the configuration`);
          if (saved && typeof saved === 'object') {
            try {
              if (isNumber(saved.integral)) {
                loop.setIntegral(saved.integral);
                lastIntegral = saved.integral;
              }
              if (isNumber(saved.setpoint)) setpoint = saved.setpoint;
              if (saved.mode === 'auto' || saved.mode === 'manual') mode = saved.mode;
              if (isNumber(saved.manual)) manual = saved.manual;
              if (mode === 'manual' && !isNumber(manual)) mode = 'auto';
            } catch (e) {
              node.warn(`the saved PID state cannot be used (${e.message}); starting from the configuration`);
            }
          }
          start();
        });
      }
    }

    node.on('input', (msg, send, done) => {
      if (refusal) done(refusal);
      else if (!ready) early.push([msg, send, done]);
      else safeHandle(msg, send, done);
    });

    node.on('close', (removed, done) => {
      closed = true;
      watchdog.stop();
      for (const [, , held] of early.splice(0)) held();
      if (loop) loop.free();
      loop = null;
      done();
    });
  }

  RED.nodes.registerType('sugarshack-pid', PidNode);
};
