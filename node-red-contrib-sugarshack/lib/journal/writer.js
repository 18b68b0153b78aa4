// @ts-check
'use strict';
// A journal writer: takes rows from the bus, encodes them as line protocol
// with QuestDB's client, and either appends them to local files (no database)
// or stores them in the on-disk spool and forwards the spool, oldest first, to
// the database over HTTP, acknowledging each chunk only when the server said
// 204. While the server is unreachable rows wait in the spool; retries follow
// the palette clock, so tests drive them instead of waiting.
//
// Delivery is at least once: a request that fails (a 500, a cut connection,
// no answer in time) may still have been written, and its rows are sent
// again. Each row carries its writer's id and a `seq` that goes on across
// restarts, so (writer, seq) names it: a database that deduplicates on it
// (QuestDB's DEDUP UPSERT KEYS, set up by deploy/) keeps it once, and a reader
// counts it once. Chunks are small (64 KB), and after a failure the next ones
// start at 512 bytes (a few rows) and double with each success, so a flaky
// server costs few rows sent twice.

const { clock } = require('../host/clock');
const i18n = require('../host/i18n');
const { INT_FIELDS } = require('./schema');

const ENCODER_OPTIONS = 'http::addr=localhost:9000;protocol_version=1';
const RETRY_MS = [500, 1000, 2000, 5000];
// The largest request body, and the first after a failure (doubling back up).
const CHUNK_BYTES = 64 * 1024;
const FIRST_CHUNK_AFTER_FAILURE = 512;
// A request not answered in this long failed (its rows may still have been written).
const DEFAULT_TIMEOUT_MS = 10000;

// QuestDB's client (and the HTTP stack it brings) takes about 20 MB and 0.4 s
// to load: only a journal node that writes needs it, so it loads then.
let questdbClient = null;
function questdb() {
  if (!questdbClient) questdbClient = require('@questdb/nodejs-client');
  return questdbClient;
}

// Series remembered for stamping before the map starts over (a plant names far fewer).
const MAX_SERIES = 100000;

/** Line-protocol rows (Buffers, one row each, newline-terminated) from journal rows. */
class Encoder {
  /** `plant` and `writer` tag every row. */
  constructor(plant, writer = '') {
    this.plant = plant;
    this.writer = writer;
    this.buffer = questdb().createBuffer(new (questdb().SenderOptions)(ENCODER_OPTIONS));
    // Last ms stamped per series: a time-series server keeps one value per series and
    // millisecond (VictoriaMetrics does), so a second row in the same ms goes 1 ms later.
    this.lastMs = new Map();
  }

  stamp(row) {
    let key = row.table;
    for (const k in row.tags) key += `\u0000${row.tags[k]}`;
    const last = this.lastMs.get(key);
    const at = Math.round(row.at);
    // A clock set back by more than a burst's worth is followed, not outrun.
    const ms = last !== undefined && at <= last && at > last - 1000 ? last + 1 : at;
    if (this.lastMs.size >= MAX_SERIES && last === undefined) this.lastMs.clear();
    this.lastMs.set(key, ms);
    return ms;
  }

  encode(row, seq) {
    const b = this.buffer;
    try {
      b.table(row.table);
      if (this.plant) b.symbol('plant', this.plant);
      if (this.writer) b.symbol('writer', this.writer);
      // Line protocol has no empty tag value: an empty tag is left out.
      for (const [k, v] of Object.entries(row.tags)) if (v !== '') b.symbol(k, v);
      for (const [k, v] of Object.entries(row.fields)) {
        if (v === undefined) continue;
        if (INT_FIELDS.has(k)) b.intColumn(k, v);
        else b.floatColumn(k, v);
      }
      b.intColumn('seq', seq);
      b.at(this.stamp(row), 'ms');
      return b.toBufferNew();
    } catch (err) {
      b.reset();
      throw err;
    }
  }
}

/** The database over HTTP line protocol (QuestDB's /write; VictoriaMetrics and InfluxDB take the same). */
function httpTarget({ host, port, username, password, token, tls, timeoutMs = DEFAULT_TIMEOUT_MS }) {
  const parts = [`addr=${host}:${port}`, 'protocol_version=1', 'retry_timeout=0', 'stdlib_http=on', `request_timeout=${timeoutMs}`];
  if (token) parts.push(`token=${token}`);
  else if (username) parts.push(`username=${username}`, `password=${password || ''}`);
  if (/[;\n]/.test(parts.join(''))) throw new Error(i18n.text('errors.journalSettings'));
  const options = new (questdb().SenderOptions)(`${tls ? 'https' : 'http'}::${parts.join(';')}`);
  const transport = questdb().createTransport(options);
  return {
    where: `${tls ? 'https' : 'http'}://${host}:${port}`,
    send: (body) => transport.send(body),
    close: () => transport.close(),
  };
}

class JournalWriter {
  /**
   * @param {object} o
   * @param {string} o.plant      plant id tag on every row
   * @param {object} [o.spool]    lib/journal/spool.js Spool; with it rows are stored and forwarded
   * @param {object} o.target     { send(Buffer): Promise, close(), where }
   * @param {number} [o.flushMs]  rows wait in memory at most this long
   * @param {number} [o.chunkBytes] largest request body
   * @param {number} [o.maxPending] rows held in memory before a flush is forced
   * @param {function} [o.onChange] called when the state or the backlog changed
   */
  constructor({ plant, spool, target, flushMs = 1000, chunkBytes = CHUNK_BYTES, maxPending = 10000, onChange }) {
    /** Detaches it from the journal bus; the node that attaches it sets this. */
    this.detach = () => {};
    this.spool = spool || null;
    // Who writes, and the seq the last run ended at: kept with the rows (the spool, the local files).
    const identity = this.spool ? this.spool.identity() : target.identity || { writer: '', seq: 0 };
    this.writerId = identity.writer;
    this.encoder = new Encoder(plant, this.writerId);
    this.target = target;
    this.flushMs = flushMs;
    this.chunkBytes = chunkBytes;
    this.chunkLimit = chunkBytes;
    this.maxPending = maxPending;
    this.onChange = onChange || (() => {});
    this.pending = [];
    this.seq = identity.seq;
    this.rows = 0; // rows of this run
    this.unacknowledged = 0; // rows sent in requests that failed: each may be in the database twice
    this.sent = 0;
    this.refused = 0;
    this.state = 'idle'; // idle | sending | down
    this.lastError = null;
    this.attempt = 0;
    this.retryTimer = null;
    this.closed = false;
    this.timer = clock.setInterval(() => this.flush(), flushMs);
    if (this.spool && this.spool.backlog().rows > 0) this.drain();
  }

  /** From the bus. */
  row(row) {
    if (this.closed) return;
    this.seq += 1;
    this.rows += 1;
    this.pending.push(this.encoder.encode(row, this.seq));
    if (this.pending.length >= this.maxPending) this.flush();
  }

  failed(err) {
    this.lastError = i18n.text('logs.rowNotEncoded', { message: err.message });
    this.refused += 1;
    this.onChange();
  }

  /** Moves the rows held in memory to the spool (or the local files) and sends what waits. */
  flush() {
    if (this.pending.length === 0) return;
    const rows = this.pending;
    this.pending = [];
    if (!this.spool) {
      this.target.append(rows);
      this.sent += rows.length;
      this.onChange();
      return;
    }
    this.spool.append(rows, clock.now(), this.seq);
    this.onChange();
    this.drain();
  }

  drain() {
    if (this.closed || !this.spool || this.state === 'sending' || this.retryTimer) return;
    const chunk = this.spool.peek(this.chunkLimit);
    if (!chunk) {
      if (this.state !== 'idle') {
        this.state = 'idle';
        this.onChange();
      }
      return;
    }
    this.state = 'sending';
    this.target.send(chunk.body).then(
      () => {
        this.spool.ack(chunk);
        this.sent += chunk.rows;
        this.chunkLimit = Math.min(this.chunkBytes, this.chunkLimit * 2);
        this.attempt = 0;
        this.lastError = null;
        this.state = 'idle';
        this.onChange();
        this.drain();
      },
      (err) => {
        if (this.closed) return;
        this.state = 'down';
        this.unacknowledged += chunk.rows;
        this.chunkLimit = Math.min(this.chunkBytes, FIRST_CHUNK_AFTER_FAILURE);
        this.lastError = String((err && err.message) || err).slice(0, 300);
        const delay = RETRY_MS[Math.min(this.attempt, RETRY_MS.length - 1)];
        this.attempt += 1;
        this.retryTimer = clock.setTimeout(() => {
          this.retryTimer = null;
          this.drain();
        }, delay);
        this.onChange();
      },
    );
  }

  metrics() {
    const backlog = this.spool ? this.spool.backlog() : { rows: 0, bytes: 0, dropped: 0, droppedSince: null, maxBytes: null };
    return {
      where: this.target.where,
      state: this.state,
      writer: this.writerId,
      seq: this.seq,
      rows: this.rows,
      sent: this.sent,
      unacknowledged: this.unacknowledged,
      pending: this.pending.length,
      backlog: backlog.rows,
      backlogBytes: backlog.bytes,
      maxBytes: backlog.maxBytes,
      dropped: backlog.dropped,
      droppedSince: backlog.droppedSince,
      refused: this.refused,
      lastError: this.lastError,
    };
  }

  /** Everything in memory goes to disk; the spool keeps what was not sent for the next start. */
  close() {
    this.flush();
    this.closed = true;
    clock.clearInterval(this.timer);
    if (this.retryTimer) clock.clearTimeout(this.retryTimer);
    this.retryTimer = null;
    return Promise.resolve(this.target.close && this.target.close()).catch(() => {});
  }
}

module.exports = { JournalWriter, Encoder, httpTarget, DEFAULT_TIMEOUT_MS };
