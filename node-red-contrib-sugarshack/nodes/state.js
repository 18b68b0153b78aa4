// @ts-check
'use strict';
// The plant's state as a msg: on request (any msg in), and, when set, on every
// change (at most once per interval). The same document as GET /sugarshack/state;
// a msg with topic 'sugarshack/stats' gets the timing figures instead, the same
// document as GET /sugarshack/stats (a dashboard needs no admin API access).
// Topics 'ack', 'shelve' and 'unshelve' act on alarms, and the operator's
// commands ('hold', 'restart', 'stop', 'abort', 'reset') on msg.operation or
// msg.routine, as the dashboard user (msg._client) or msg.by, then answer with
// the state.
const { paletteOf, alarmIdOf, alarmIdsOf, shelfEndOf, runCommandOf } = require('../lib/host/lifecycle');
const operator = require('../lib/interlock/operator');
const wasm = require('../lib/wasm');
const { attributionOf } = require('../lib/interlock/request');
const { SugarshackError } = require('../lib/host/errors');
const { errorStatus } = require('../lib/host/status');
const { stateOf } = require('../lib/state');
const { clock } = require('../lib/host/clock');
const { stats } = require('../lib/host/stats');
const { status } = require('../lib/host/status');
const { translator, useRED } = require('../lib/host/i18n');
const { configDurationMs } = require('../lib/control');

const STATS_TOPIC = 'sugarshack/stats';

const MIN_INTERVAL_MS = 100;
/** @type {Set<string | undefined>} */
const ALARM_TOPICS = new Set(['ack', 'shelve', 'unshelve']);
/** Whether msg.topic is an operator's command to a run (the core's list). */
const isRunTopic = (topic) => /** @type {(string | undefined)[]} */ (wasm.load().operatorCommands()).includes(topic);

/**
 * The interlocks an alarm request goes to: msg.interlock when given, else
 * those listing the alarm (every one, to acknowledge all).
 */
function alarmTargets(t, palette, msg, id) {
  const ready = readyInterlocks(palette);
  if (msg.interlock !== undefined) {
    const found = ready.filter(([rid]) => rid === msg.interlock).map(([, rt]) => rt);
    if (found.length === 0) throw new SugarshackError('NO_INTERLOCK', t('errors.noInterlock', { id: String(msg.interlock).slice(0, 100) }));
    return found;
  }
  const targets = ready.map(([, rt]) => rt).filter((rt) => id === null || rt.guard(() => rt.hasAlarm(id)));
  if (targets.length === 0 && id !== null) throw new SugarshackError('UNKNOWN_ALARM', t('errors.noAlarm', { id: id.slice(0, 100) }));
  return targets;
}

/** The ready interlocks, by config node id. */
const readyInterlocks = (palette) => [...palette.runtimes].filter(([, rt]) => rt.kind !== 'plant' && rt.state === 'ready');

/**
 * Gives the run msg names the command msg.topic as msg asks; resolves with the
 * core's answer once saved. Without msg.interlock, the interlock that lists the
 * run (the only one, when just one runs).
 */
function runRequest(t, palette, msg) {
  const { target, command } = runCommandOf({ operation: msg.operation, routine: msg.routine, command: msg.topic });
  const who = attributionOf(msg);
  let ready = readyInterlocks(palette);
  if (msg.interlock !== undefined) ready = ready.filter(([rid]) => rid === msg.interlock);
  if (ready.length === 0) throw new SugarshackError('NO_INTERLOCK', t('errors.noInterlock', { id: String(msg.interlock).slice(0, 100) }));
  const listing = ready.find(([, rt]) => listsRun(rt.described(), target));
  return operator.command((listing || ready[0])[1], target, command, { by: who.by, reason: who.reason });
}

/**
 * Whether an interlock's description lists the run `target` names.
 * @param {any} described @param {{ operation?: string, routine?: string }} target
 */
function listsRun(described, { operation, routine }) {
  if (routine !== undefined) return (described.routines || []).some((r) => r.id === routine);
  return [...(described.runs || []), ...(described.aborted || [])].some((r) => r.operation === operation);
}

/** Acts on alarms as msg asks; resolves with every change once saved. */
function alarmRequest(t, palette, msg) {
  const who = attributionOf(msg);
  const ids = msg.topic === 'ack' ? alarmIdsOf(msg.ids !== undefined ? msg.ids : msg.id !== undefined ? [msg.id] : undefined) : null;
  const id = msg.topic === 'ack' ? null : alarmIdOf(msg.id);
  const untilMs = msg.topic === 'shelve' ? shelfEndOf(msg, clock.now()) : null;
  const byInterlock = alarmTargets(t, palette, msg, id !== null ? id : ids && ids.length === 1 ? ids[0] : null);
  return Promise.all(byInterlock.map((rt) => new Promise((resolve) => rt.guard(() => {
    if (msg.topic === 'ack') {
      // Named ids: each interlock takes those it lists.
      const mine = ids === null ? null : ids.filter((a) => rt.hasAlarm(a));
      if (mine !== null && mine.length === 0) resolve([]);
      else rt.acknowledgeAlarms(mine, who, resolve);
    } else if (msg.topic === 'shelve') rt.shelveAlarm(id, untilMs, who, resolve, { oneShot: msg.oneShot === true });
    else rt.unshelveAlarm(id, who, resolve);
  })))).then((lists) => lists.flat());
}

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function StateNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const t = translator(RED, 'sugarshack-state');
    const palette = paletteOf(RED);
    let intervalMs = 1000;
    try {
      intervalMs = Math.max(MIN_INTERVAL_MS, configDurationMs(props, 'intervalS', 'intervalMs', t('config.interval'), { fallbackMs: 1000 }) || 1000);
    } catch (err) {
      node.error(t('errors.badInterval', { message: err.message })); // a bad interval still leaves a working state feed
    }
    let timer = null;
    let lastSentMs = -Infinity;

    const message = (trigger) => {
      const state = stateOf(palette);
      const lines = state.interlocks.reduce((n, il) => n + (il.lines ? il.lines.length : 0), 0);
      const faulted = state.interlocks.reduce((n, il) => n + (il.lines ? il.lines.filter((l) => l.fault).length : 0), 0);
      node.status(status(faulted ? 'fault' : 'ok', t('status.lines', { lines, faulted })));
      lastSentMs = clock.now();
      return { topic: 'sugarshack/state', trigger, payload: state };
    };

    const onChange = () => {
      if (timer) return;
      const wait = Math.max(0, lastSentMs + intervalMs - clock.now());
      timer = clock.setTimeout(() => {
        timer = null;
        node.send(message('change'));
      }, wait);
    };

    /** A person's request: answered with the state and what it changed (`field`), or done(err) with a red status. */
    const act = (msg, send, done, request, field) => {
      let asked;
      try {
        asked = request(t, palette, msg);
      } catch (err) {
        asked = Promise.reject(err);
      }
      asked.then((answer) => {
        send(Object.assign(msg, message('request'), { topic: msg.topic, [field]: answer }));
        done();
      }, (err) => {
        node.status(errorStatus(err.code));
        done(err);
      });
    };

    node.on('input', (msg, send, done) => {
      if (ALARM_TOPICS.has(msg.topic)) {
        act(msg, send, done, alarmRequest, 'alarmChanges');
        return;
      }
      if (isRunTopic(msg.topic)) {
        act(msg, send, done, runRequest, 'commanded');
        return;
      }
      if (msg.topic === STATS_TOPIC) {
        send(Object.assign(msg, { trigger: 'request', payload: stats.report() }));
        done();
        return;
      }
      let answer;
      try {
        answer = message('request');
      } catch (err) {
        node.status(errorStatus(err.code));
        done(err);
        return;
      }
      // The request's own fields (a dashboard's _client, a topic) ride along.
      send(Object.assign(msg, answer, { topic: msg.topic || answer.topic }));
      done();
    });
    if (props.onChange !== false) {
      palette.changes.on('changed', onChange);
      palette.whenStarted(onChange); // the state as started, for a dashboard already open
    }
    node.on('close', () => {
      palette.changes.removeListener('changed', onChange);
      if (timer) clock.clearTimeout(timer);
      timer = null;
    });
  }

  RED.nodes.registerType('sugarshack-state', StateNode);
};
