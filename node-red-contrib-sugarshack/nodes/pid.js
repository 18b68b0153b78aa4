// @ts-check
'use strict';
const { SugarshackError, asSugarshackError } = require('../lib/errors');
const { refuseDeploy } = require('../lib/deploy-refusal');
const { errorStatus, status, StatusBoard } = require('../lib/status');
const { translator, useRED } = require('../lib/i18n');
const { isNumber, configNumber, configDurationMs, msgNumber, describe, fmt, revivable } = require('../lib/control');
const { clock } = require('../lib/clock');
const { UntilReady } = require('../lib/until-ready');
const { FileStore, Committer, stateDir } = require('../lib/durable');
const wasm = require('../lib/wasm');
const { quietOf, standbyStatus } = require('../lib/cluster');

// Where flows saved before the state file kept the loop's state: read once, carried over, deleted.
const CONTEXT_KEY = 'pid';
const PID_STATE = {
  kind: 'pid',
  note: 'This pid node has run here: if its state file is missing, it starts from its configuration.\n',
};
// A msg with one of these (or topic "setpoint") changes the loop and is not a measurement.
const CONTROL_KEYS = ['setpoint', 'mode', 'manual', 'tunings', 'limits'];
const board = new StatusBoard();

/** What reading a msg threw: ours and the core's pass; anything else (a getter, a proxy) is the sender's INVALID_INPUT. */
const inputError = (t, err) => (err instanceof SugarshackError || (err && typeof err.code === 'string' && err.message)
  ? err
  : new SugarshackError('INVALID_INPUT', t('errors.msgUnreadable', { why: String(err && typeof err.message === 'string' ? err.message : typeof err).slice(0, 100) })));

/** @typedef {import('../wasm/sugarshack_wasm').StationConfig} StationConfig */

/**
 * The node's fields as the core's PidStation configuration; the rules on them are the core's.
 * @param {NodeRed.NodeProps} props
 * @param {(key: string, subs?: Record<string, any>) => string} t
 * @returns {StationConfig}
 */
function readConfig(props, t) {
  const tsS = configNumber(props.ts, t('config.ts'), { required: true });
  /** @type {StationConfig['loop']['pid']} */
  const pid = {
    kp: configNumber(props.kp, t('config.kp'), { required: true }),
    tiS: configNumber(props.ti, t('config.ti'), { fallback: 0 }),
    tdS: configNumber(props.td, t('config.td'), { fallback: 0 }),
    outMin: configNumber(props.outMin, t('config.outMin'), { required: true }),
    outMax: configNumber(props.outMax, t('config.outMax'), { required: true }),
    action: props.action === 'direct' ? 'direct' : 'reverse',
    fallback: configNumber(props.fallback, t('config.fallback'), { fallback: null }),
    // Saved flows from before this setting act on the error, as they did.
    proportionalOn: props.pOn === 'measurement' ? 'measurement' : 'error',
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
          alpha: configNumber(props.alpha, t('config.alpha'), { fallback: 0.1 }),
          // 'h' in flows written by hand before the setting was named 'horizon'.
          h: configNumber(props.horizon ?? props.h, t('config.horizon'), { fallback: 3 }),
        },
      maxSamples: configNumber(props.maxSamples, t('config.maxSamples'), { fallback: 400 }),
    };
  } else if (predictor !== 'off') {
    throw new SugarshackError('INVALID_CONFIG', t('errors.smithMode', { got: predictor }));
  }
  return {
    loop: { pid, smith },
    tsS,
    staleMs: configDurationMs(props, 'staleS', 'staleMs', t('config.staleS'), { fallbackMs: 3 * tsS * 1000 }),
    setpoint: configNumber(props.setpoint, t('config.setpoint'), { required: true }),
    mode: props.mode === 'manual' ? 'manual' : 'auto',
    manual: configNumber(props.manual, t('config.manual'), { fallback: null }),
  };
}

/** msg fields of a change as the core's Change: each checked a number here, the rules applied there. */
function readChange(msg, t) {
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

/** A saved state, field by field: what is unusable is left out, the rest restored. */
function readSaved(saved) {
  const out = {};
  if (isNumber(saved.integral)) out.integral = saved.integral;
  if (isNumber(saved.setpoint)) out.setpoint = saved.setpoint;
  if (saved.mode === 'auto' || saved.mode === 'manual') out.mode = saved.mode;
  if (isNumber(saved.manual)) out.manual = saved.manual;
  return out;
}

/** msg.rcc as the rcc node sends it: { id, engaged, firstCycle, track }. */
function readDecision(rcc, t) {
  if (!rcc || typeof rcc !== 'object' || typeof rcc.engaged !== 'boolean' || typeof rcc.firstCycle !== 'boolean'
    || !(rcc.track === undefined || rcc.track === null || isNumber(rcc.track))) {
    throw new SugarshackError('INVALID_INPUT', t('errors.decisionInvalid'));
  }
  return { engaged: rcc.engaged, firstCycle: rcc.firstCycle, track: rcc.track ?? null };
}

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function PidNode(props) {
    RED.nodes.createNode(this, props);
    const quiet = quietOf(RED);
    const node = this;
    const t = translator(RED, 'sugarshack-pid');
    const persist = props.persist === true || props.persist === 'true';
    // The context store of earlier versions: read only to carry their saved state over to the file.
    const legacyStore = props.store && props.store !== 'default' ? props.store : undefined;
    // Made below unless the configuration is refused, and then every msg is refused before it is used.
    /** @type {import('../wasm/sugarshack_wasm').PidStation} */
    let station = /** @type {any} */ (null);
    let refusal = null;
    let kept = null; // the loop's own state, kept outside the core to rebuild it after a trap
    /** @type {StationConfig} */
    let config = /** @type {any} */ (null); // set below unless the configuration is refused, and then never read
    try {
      config = readConfig(props, t);
      // Rebuilt on a fresh wasm instance after a trap, with the state it had.
      station = revivable(({ PidStation }) => {
        const fresh = new PidStation(config);
        if (kept) fresh.restore(kept);
        return fresh;
      });
    } catch (err) {
      refusal = refuseDeploy(node, err);
    }

    let lastTopic;
    let timer = null;
    let ready = false;
    let closed = false;
    const early = new UntilReady(); // msgs that arrived while the saved state was read

    const show = (shown) => board.set(node, shown);

    let saveFailing = false; // warned once per run of failed writes
    /** With persist: the state file and the writes to it (the interlock's atomic writes, grouped per turn). */
    function durableState() {
      const store = new FileStore(stateDir(RED), node.id, PID_STATE);
      const committer = new Committer({
        store,
        clock,
        // Sealed by the core as this node's, for this configuration.
        snapshot: () => wasm.load().sealPidState(node.id, config, kept, clock.now()),
        onError: (err) => {
          if (!saveFailing) node.warn(t('errors.notSaved', { where: store.where, message: err.message || err }));
          saveFailing = true;
        },
        onSaved: () => {
          saveFailing = false;
        },
      });
      return { store, committer };
    }
    const durable = persist ? durableState() : null;
    let lostWhy = null; // why the saved state could not be used, shown until the first msg

    function idleStatus() {
      const { mode, manual, setpoint, lastOutput } = station.state();
      if (mode === 'manual') return status('manual', t('status.manual', { value: fmt(manual) }));
      return lastOutput === null
        ? status('idle', t('status.setpoint', { value: fmt(setpoint) }))
        : status('ok', t('status.auto', { value: fmt(lastOutput) }));
    }

    function save() {
      if (closed) return;
      const { integral, setpoint, mode, manual } = station.state();
      kept = { integral, setpoint, mode, manual };
      if (durable) durable.committer.change();
    }

    /** One timer, for when the core says its stale rule is next due. */
    function schedule() {
      if (timer) clock.clearTimeout(timer);
      timer = null;
      if (closed || !station) return;
      const due = station.nextTickMs();
      if (due === undefined || due === null) return;
      timer = clock.setTimeout(tick, Math.max(0, due - clock.now()));
    }

    function tick() {
      timer = null;
      if (closed || !ready) return;
      let stale;
      try {
        stale = station.tick(clock.now());
      } catch (err) {
        node.error(t('errors.staleWatch', { message: err.message }));
        schedule();
        return;
      }
      if (stale && stale.kind === 'noIo') {
        show(status('warning', t('status.staleNoIo')));
      } else if (stale) {
        save();
        if (!quiet()) node.send({ topic: lastTopic, payload: stale.pid.output, pid: stale.pid });
        show(status('warning', t(stale.pid.mode === 'manual' ? 'status.staleManual' : 'status.staleFallback')));
      }
      schedule();
    }

    function stepStatus(pid, engaged) {
      if (!engaged) return status('idle', t('status.standby'));
      const value = fmt(pid.output);
      if (pid.mode === 'manual') return status('manual', t('status.manual', { value }));
      if (pid.mode === 'tracking') return status('running', t('status.tracking', { value }));
      return status(pid.saturated ? 'degraded' : 'ok', t('status.auto', { value }));
    }

    function measure(msg, send, done) {
      let decision;
      let track;
      try {
        if (msg.rcc !== undefined) decision = readDecision(msg.rcc, t);
        if (msg.track !== undefined && msg.track !== null) track = msgNumber(msg.track, t('input.track'));
      } catch (err) {
        const e = inputError(t, err);
        show(errorStatus(e.code));
        done(e);
        return;
      }
      const now = clock.now();
      const sampleMs = isNumber(msg.timestamp) ? msg.timestamp : now;
      const given = msg.payload;
      const valid = isNumber(given);
      let outcome;
      try {
        outcome = station.measure(valid ? given : undefined, sampleMs, now, track, decision);
      } catch (err) {
        const e = asSugarshackError(err);
        show(errorStatus(e.code));
        done(e);
        return;
      }
      const { engaged, pid } = outcome;
      lastTopic = msg.topic;
      save();
      schedule();
      msg.payload = pid.output;
      msg.pid = pid;
      if (decision) msg.rcc = { ...msg.rcc, write: engaged ? pid.output : null };
      if (engaged) send(msg);
      if (valid) {
        show(stepStatus(pid, engaged));
        done();
        return;
      }
      const sent = t(pid.mode === 'tracking' ? 'errors.sentTracked' : pid.mode === 'manual' ? 'errors.sentManual' : 'errors.sentFallback', { value: fmt(pid.output) });
      const what = engaged ? sent : t('errors.sentNothing');
      const e = new SugarshackError('BAD_MEASUREMENT', t('errors.badMeasurement', { got: describe(given), what }));
      show(errorStatus(e.code));
      done(e);
    }

    function handle(msg, send, done) {
      try {
        if (msg.topic === 'setpoint' || CONTROL_KEYS.some((k) => msg[k] !== undefined)) {
          station.change(readChange(msg, t));
          save();
          show(idleStatus());
          if (msg.roundTripMs !== undefined) station.observeRoundTrip(msgNumber(msg.roundTripMs, 'msg.roundTripMs'));
          done();
          return;
        }
        if (msg.roundTripMs !== undefined) {
          station.observeRoundTrip(msgNumber(msg.roundTripMs, 'msg.roundTripMs'));
          if (msg.payload === undefined && msg.rcc === undefined) {
            done();
            return;
          }
        }
      } catch (err) {
        const e = inputError(t, err);
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
        const e = inputError(t, err);
        show(errorStatus(e.code));
        once(e);
      }
    }

    function start() {
      ready = true;
      show(lostWhy ? status('warning', t('status.stateLost')) : idleStatus());
      for (const { msg, send, done } of early.take()) safeHandle(msg, send, done);
    }

    /** The loop from a saved state (read by `open`); one that cannot be used is reported and the configuration used. */
    function restoreFrom(open) {
      try {
        station.restore(open());
      } catch (e) {
        lostWhy = e.message;
        node.warn(t('errors.unusable', { message: e.message }));
      }
    }

    /** A state an earlier version kept in the context store, field by field: what is unusable is left out. */
    function legacyState(saved) {
      if (!saved || typeof saved !== 'object' || Array.isArray(saved)) throw new Error(`it is ${describe(saved)}, not { integral, setpoint, mode, manual }`);
      return readSaved(saved);
    }

    /**
     * Persisted: the state file when there is one; a first start reads what an
     * earlier version left in the context store. The state as started is written
     * at once; only then is the node marked as run here and the old context value
     * deleted, so a crash before that write migrates again on the next start.
     */
    function startPersisted({ store, committer }) {
      let saved;
      try {
        saved = store.read();
      } catch (err) {
        saved = { kind: 'lost', why: err.message };
      }
      const begin = (afterWrite) => {
        save();
        committer.change(() => {
          try {
            store.markRan();
          } catch (err) {
            node.warn(t('errors.notSaved', { where: store.where, message: err.message }));
          }
          if (afterWrite) afterWrite();
        });
        start();
      };
      if (saved.kind === 'saved') {
        // The core opens it: another node's, a damaged one or one of an unknown version is refused.
        restoreFrom(() => wasm.load().openPidState(store.where, saved.text, node.id));
        begin();
      } else if (saved.kind === 'lost') {
        lostWhy = saved.why;
        node.warn(t('errors.lost', { why: saved.why }));
        begin();
      } else {
        readLegacy((value) => {
          if (closed) return;
          if (value === undefined || value === null) {
            begin();
            return;
          }
          restoreFrom(() => legacyState(value));
          begin(() => node.context().set(CONTEXT_KEY, undefined, legacyStore, (err) => {
            if (err) node.warn(t('errors.legacyNotDeleted', { message: err.message || err }));
          }));
        });
      }
    }

    /** The state an earlier version saved in the node's context (undefined when none or unreadable). */
    function readLegacy(then) {
      try {
        node.context().get(CONTEXT_KEY, legacyStore, (err, value) => {
          if (err) node.warn(t('errors.notRead', { message: err.message || err }));
          then(err ? undefined : value);
        });
      } catch (err) {
        node.warn(t('errors.notRead', { message: err.message }));
        then(undefined);
      }
    }

    if (station) {
      if (durable) startPersisted(durable);
      else start();
    }

    node.on('input', (msg, send, done) => {
      if (refusal) done(refusal);
      else if (quiet()) {
        // A hot standby acts on nothing (the active instance got the same msg).
        show(standbyStatus());
        done();
      } else if (!ready) early.hold({ node, msg, send, done });
      else safeHandle(msg, send, done);
    });

    node.on('close', (removed, done) => {
      closed = true;
      if (timer) clock.clearTimeout(timer);
      timer = null;
      early.completeAll();
      if (station) station.free();
      station = /** @type {any} */ (null);
      if (!durable) {
        done();
        return;
      }
      // The last state is on disk before the node that replaces it (a redeploy, a restart) reads it.
      const { committer } = durable;
      committer.drain().then(() => committer.freeze()).then(() => done(), () => done());
    });
  }

  RED.nodes.registerType('sugarshack-pid', PidNode);
};
