// @ts-check
'use strict';
// A pid node at run time: msgs into the core's PidStation and its outcomes
// into sends, statuses and the state file; one timer, for when the core says
// its stale rule is next due.
const { SugarshackError, asSugarshackError } = require('../host/errors');
const { unreadable } = require('../interlock/request');
const { refuseDeploy } = require('../host/deploy-refusal');
const { errorStatus, status, StatusBoard } = require('../host/status');
const { translator } = require('../host/i18n');
const { isNumber, msgNumber, describe, fmt, revivable } = require('./index');
const { PidReader, isChange } = require('./pid-config');
const { PidStateFile } = require('./pid-state');
const { clock } = require('../host/clock');
const { UntilReady } = require('../host/until-ready');
const { messageBufferMax } = require('../interlock/config');
const wasm = require('../wasm');
const { quietOf, standbyStatus } = require('../cluster');

const board = new StatusBoard();

/**
 * Runs `node` as a pid node with its settings `props`.
 * @param {NodeRed.RED} RED
 * @param {NodeRed.Node} node
 * @param {NodeRed.NodeProps} props
 */
function runPid(RED, node, props) {
  const quiet = quietOf(RED);
  const t = translator(RED, 'sugarshack-pid');
  const read = new PidReader(RED);
  const persist = props.persist === true || props.persist === 'true';
  // Made below unless the configuration is refused, and then every msg is refused before it is used.
  /** @type {import('../../wasm/sugarshack_wasm').PidStation} */
  let station = /** @type {any} */ (null);
  let refusal = null;
  let kept = null; // the loop's own state, kept outside the core to rebuild it after a trap
  /** @type {import('./pid-config').StationConfig} */
  let config = /** @type {any} */ (null); // set below unless the configuration is refused, and then never read
  try {
    config = read.config(props);
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
  // Node-RED's bound on buffered msgs (0: none), as its delay node keeps it: past it a msg is refused, not queued.
  const earlyMax = messageBufferMax(RED);

  const show = (shown) => board.set(node, shown);

  // With persist: sealed by the core as this node's, for this configuration.
  const file = persist && station
    ? new PidStateFile(RED, node, props, () => wasm.load().sealPidState(node.id, config, kept, clock.now()))
    : null;
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
    if (file) file.changed();
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

  /** Refuses the msg with `err`: a red status, and `done(err)` for a Catch node. */
  function refuse(err, done) {
    show(errorStatus(err.code));
    done(err);
  }

  function measure(msg, send, done) {
    let decision;
    let track;
    try {
      if (msg.rcc !== undefined) decision = read.decision(msg.rcc);
      if (msg.track !== undefined && msg.track !== null) track = msgNumber(msg.track, t('input.track'));
    } catch (err) {
      refuse(unreadable(err), done);
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
      refuse(asSugarshackError(err), done);
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
    refuse(new SugarshackError('BAD_MEASUREMENT', t('errors.badMeasurement', { got: describe(given), what })), done);
  }

  function handle(msg, send, done) {
    try {
      if (isChange(msg)) {
        station.change(read.change(msg));
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
      refuse(unreadable(err), done);
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
      refuse(unreadable(err), once);
    }
  }

  function start() {
    ready = true;
    show(lostWhy ? status('warning', t('status.stateLost')) : idleStatus());
    for (const { msg, send, done } of early.take()) safeHandle(msg, send, done);
  }

  if (file) {
    file.open({
      // A saved state that cannot be used is reported and the configuration used.
      restore: (open) => {
        try {
          station.restore(open());
        } catch (e) {
          lostWhy = e.message;
          node.warn(t('errors.unusable', { message: e.message }));
        }
      },
      lost: (why) => {
        lostWhy = why;
      },
      save,
      start,
      closed: () => closed,
    });
  } else if (station) start();

  node.on('input', (msg, send, done) => {
    if (refusal) done(refusal);
    else if (quiet()) {
      // A hot standby acts on nothing (the active instance got the same msg).
      show(standbyStatus());
      done();
    } else if (!ready) {
      if (earlyMax > 0 && early.length >= earlyMax) done(new SugarshackError('QUEUE_FULL', t('errors.notReadyFull', { max: earlyMax })));
      else early.hold({ node, msg, send, done });
    }
    else safeHandle(msg, send, done);
  });

  node.on('close', (removed, done) => {
    closed = true;
    if (timer) clock.clearTimeout(timer);
    timer = null;
    early.completeAll();
    if (station) station.free();
    station = /** @type {any} */ (null);
    if (!file) {
      done();
      return;
    }
    file.close().then(() => done(), () => done());
  });
}

module.exports = { runPid };
