// @ts-check
'use strict';
const path = require('path');
const { journal } = require('../lib/journal/bus');
const { JournalWriter, httpTarget, DEFAULT_TIMEOUT_MS } = require('../lib/journal/writer');
const { Spool } = require('../lib/journal/spool');
const { filesTarget } = require('../lib/journal/files');
const { compact, status } = require('../lib/host/status');
const { translator, useRED } = require('../lib/host/i18n');
const { configDurationMs } = require('../lib/control');
const { quietOf } = require('../lib/cluster');

const MB = 1024 * 1024;
const writers = new Map(); // node id (or 'default') -> JournalWriter

/** A whole number in [min, max] from an editor field, or `fallback` when empty. */
function bounded(t, value, fallback, min, max, what) {
  if (value === undefined || value === null || value === '') return fallback;
  const n = Number(value);
  if (!Number.isFinite(n) || n < min || n > max) throw new Error(t('errors.outOfRange', { what, min, max, got: value }));
  return n;
}

function statusOf(t, m) {
  if (m.state === 'down') return status('error', t('status.down', { backlog: compact(m.backlog) }));
  if (m.dropped > 0) return status('manual', t('status.dropped', { count: compact(m.dropped) }));
  if (m.backlog > 0) return status('running', t('status.backlog', { count: compact(m.backlog) }));
  return status('ok', t('status.rows', { count: compact(m.rows) }));
}

/**
 * The writer for a node's settings: local files, or a database with a spool in the user dir.
 * @param {(key: string, subs?: Record<string, any>) => string} t
 * @param {{ props: Record<string, any>, credentials: Record<string, any>, userDir: string, id: string, onChange?: () => void }} options
 */
function writerFor(t, { props, credentials, userDir, id, onChange }) {
  const plant = String(props.plantId || '').trim();
  const flushMs = configDurationMs(props, 'flushS', 'flushMs', t('config.flush'), { fallbackMs: 1000 });
  if (!(flushMs >= 50 && flushMs <= 60000)) throw new Error(t('errors.badFlush', { got: flushMs / 1000 }));
  const base = path.join(userDir, 'sugarshack-journal');
  if ((props.target || 'files') === 'files') {
    const dir = props.dir ? path.resolve(userDir, props.dir) : path.join(base, 'files');
    const maxMB = bounded(t, props.filesMB, 512, 1, 1e6, t('config.filesMB'));
    const fileBytes = Math.max(MB, Math.floor((maxMB * MB) / 32));
    return new JournalWriter({ plant, flushMs, onChange, target: filesTarget({ dir, fileBytes, maxFiles: 32 }) });
  }
  const host = String(props.host || '').trim();
  if (!host) throw new Error(t('errors.noHost'));
  const port = bounded(t, props.port, 9000, 1, 65535, t('config.port'));
  const spool = new Spool({ dir: path.join(base, `spool-${id.replace(/[^\w.-]/g, '_')}`), maxBytes: Math.floor(bounded(t, props.bufferMB, 64, 0.001, 1e6, t('config.bufferMB')) * MB) });
  const timeoutMs = bounded(t, props.timeoutS, DEFAULT_TIMEOUT_MS / 1000, 0.1, 300, t('config.timeoutS')) * 1000;
  // HTTPS is the text 'true' when the flow file sets it from the environment (${NAME}).
  const target = httpTarget({
    host, port, timeoutMs, tls: props.tls === true || props.tls === 'true', username: credentials.username, password: credentials.password, token: credentials.token,
  });
  return new JournalWriter({ plant, flushMs, onChange, spool, target });
}

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  const t = translator(RED, 'sugarshack-journal');
  const userDir = (RED.settings && RED.settings.userDir) || process.cwd();

  // In a hot-standby cluster only the active instance keeps the journal (a standby hears the same plant).
  const quiet = quietOf(RED);
  const attachWhileActive = (writer) => journal.attach({ row: (row) => { if (!quiet()) writer.row(row); }, failed: (err) => writer.failed(err) });

  // `npm start` sets sugarshackJournal.dir: with no database, the plant still keeps its journal in files.
  const embedded = RED.settings && RED.settings.sugarshackJournal;
  if (embedded && typeof embedded.dir === 'string' && !writers.has('default')) {
    const writer = writerFor(t, { props: { target: 'files', dir: embedded.dir, plantId: embedded.plant, filesMB: embedded.maxMB }, credentials: {}, userDir, id: 'default' });
    writer.detach = attachWhileActive(writer);
    writers.set('default', writer);
    RED.log.info(t('log.localFiles', { where: writer.target.where }));
  }

  if (RED.httpAdmin) {
    RED.httpAdmin.get('/sugarshack/journal', RED.auth.needsPermission('sugarshack.read'), (req, res) => {
      const out = {};
      for (const [id, w] of writers) out[id] = w.metrics();
      res.json(out);
    });
  }

  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */

  function JournalNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    let writer;
    let shown = '';
    const refresh = () => {
      const s = statusOf(t, writer.metrics());
      if (s.text + s.fill === shown) return;
      shown = s.text + s.fill;
      node.status(s);
    };
    try {
      writer = writerFor(t, { props, credentials: node.credentials || {}, userDir, id: node.id, onChange: () => writer && refresh() });
    } catch (err) {
      node.error(t('errors.notStarted', { message: err.message }));
      node.status(status('error', t('status.badSettings')));
      return;
    }
    writer.detach = attachWhileActive(writer);
    writers.set(node.id, writer);
    refresh();

    // An operator's note from a dashboard: { who, why, topic } goes in as an action.
    node.on('input', (msg, send, done) => {
      journal.action(typeof msg.action === 'string' ? msg.action : 'note', msg, msg.topic);
      if (msg.flush === true) writer.flush();
      msg.journal = writer.metrics();
      send(msg);
      done();
    });

    node.on('close', (removed, done) => {
      writer.detach();
      writers.delete(node.id);
      writer.close().then(() => done());
    });
  }

  RED.nodes.registerType('sugarshack-journal', JournalNode, {
    credentials: { username: { type: 'text' }, password: { type: 'password' }, token: { type: 'password' } },
  });
};

module.exports.writers = writers;
module.exports.statusOf = statusOf;
