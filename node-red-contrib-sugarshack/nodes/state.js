'use strict';
// The plant's state as a msg: on request (any msg in), and, when set, on every
// change (at most once per interval). The same document as GET /sugarshack/state;
// a msg with topic 'sugarshack/stats' gets the timing figures instead, the same
// document as GET /sugarshack/stats (a dashboard needs no admin API access).
const { paletteOf } = require('../lib/lifecycle');
const { stateOf } = require('../lib/state');
const { clock } = require('../lib/clock');
const { stats } = require('../lib/stats');
const { status } = require('../lib/status');
const { translator } = require('../lib/i18n');

const STATS_TOPIC = 'sugarshack/stats';

const MIN_INTERVAL_MS = 100;

module.exports = function (RED) {
  function StateNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const t = translator(RED, 'sugarshack-state');
    const palette = paletteOf(RED);
    const intervalMs = Math.max(MIN_INTERVAL_MS, Number(props.intervalMs) || 1000);
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

    node.on('input', (msg, send, done) => {
      if (msg.topic === STATS_TOPIC) {
        send(Object.assign(msg, { trigger: 'request', payload: stats.report() }));
        done();
        return;
      }
      const answer = message('request');
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
