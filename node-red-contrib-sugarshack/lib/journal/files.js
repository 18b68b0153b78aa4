// @ts-check
'use strict';
// The embedded journal: line protocol appended to local files, rotated at
// `fileBytes`, the oldest removed past `maxFiles`. The files are plain line
// protocol, so they can be replayed into a database later
// (`curl --data-binary @journal-000000000001.lp http://questdb:9000/write`).
// The reader here parses the rows the writer produces (the season report's
// input).

const crypto = require('crypto');
const fs = require('fs');
const path = require('path');

const FILE_RE = /^journal-(\d{12})\.lp$/;
const fileName = (n) => `journal-${String(n).padStart(12, '0')}.lp`;
const IDENTITY_FILE = 'writer.json';
const WRITER_RE = /^[0-9a-f]{12}$/;
// A row is a few hundred bytes (each text is cut at 200 characters): its end is in this much of a file's tail.
const TAIL_BYTES = 64 * 1024;

/**
 * The id of the writer whose rows are kept in `dir`: made at random the first
 * time, then read from `writer.json` there, so it survives restarts. Each row
 * carries it with its `seq`: (writer, seq) names a row in any database.
 */
function writerId(dir) {
  const file = path.join(dir, IDENTITY_FILE);
  try {
    const { writer } = JSON.parse(fs.readFileSync(file, 'utf8'));
    if (typeof writer === 'string' && WRITER_RE.test(writer)) return writer;
  } catch {
    // none yet, or unreadable: a new writer
  }
  const writer = crypto.randomBytes(6).toString('hex');
  const tmp = `${file}.tmp`;
  const fd = fs.openSync(tmp, 'w');
  try {
    fs.writeSync(fd, JSON.stringify({ writer }));
    fs.fsyncSync(fd);
  } finally {
    fs.closeSync(fd);
  }
  fs.renameSync(tmp, file);
  return writer;
}

/** The `seq` of the last whole row of `file` (0 when it has none): where a restarted writer goes on from. */
function lastSeqIn(file) {
  let data;
  try {
    const size = fs.statSync(file).size;
    const from = Math.max(0, size - TAIL_BYTES);
    data = Buffer.alloc(size - from);
    const fd = fs.openSync(file, 'r');
    try {
      fs.readSync(fd, data, 0, data.length, from);
    } finally {
      fs.closeSync(fd);
    }
  } catch {
    return 0;
  }
  const lines = data.toString('utf8').split('\n');
  lines.pop(); // after the last newline: nothing, or a row cut short
  for (let i = lines.length - 1; i >= 0; i--) {
    const row = parseLine(lines[i]);
    if (row && Number.isSafeInteger(row.fields.seq)) return row.fields.seq;
  }
  return 0;
}

function listFiles(dir) {
  let names = [];
  try {
    names = fs.readdirSync(dir);
  } catch (err) {
    if (err.code !== 'ENOENT') throw err;
  }
  return names.map((f) => FILE_RE.exec(f)).filter((m) => m !== null).map((m) => ({ n: Number(m[1]), file: path.join(dir, m[0]) })).sort((a, b) => a.n - b.n);
}

function filesTarget({ dir, fileBytes = 16 * 1024 * 1024, maxFiles = 32 }) {
  fs.mkdirSync(dir, { recursive: true });
  const files = listFiles(dir);
  let current = files.length ? files[files.length - 1] : { n: 1, file: path.join(dir, fileName(1)) };
  let size = fs.existsSync(current.file) ? fs.statSync(current.file).size : 0;
  return {
    where: dir,
    identity: { writer: writerId(dir), seq: lastSeqIn(current.file) },
    append(rows) {
      const body = Buffer.concat(rows);
      if (size > 0 && size + body.length > fileBytes) {
        current = { n: current.n + 1, file: path.join(dir, fileName(current.n + 1)) };
        size = 0;
        const all = listFiles(dir);
        for (const old of all.slice(0, Math.max(0, all.length - (maxFiles - 1)))) fs.rmSync(old.file, { force: true });
      }
      fs.appendFileSync(current.file, body);
      size += body.length;
    },
    close() {},
  };
}

// ---- reading ----------------------------------------------------------------

/** Splits `s` at unescaped `sep` characters outside double quotes. */
function splitUnescaped(s, sep) {
  const out = [];
  let start = 0;
  let quoted = false;
  for (let i = 0; i < s.length; i++) {
    const c = s[i];
    if (c === '\\') i++;
    else if (c === '"') quoted = !quoted;
    else if (c === sep && !quoted) {
      out.push(s.slice(start, i));
      start = i + 1;
    }
  }
  out.push(s.slice(start));
  return out;
}

const unescape = (s) => s.replace(/\\(.)/g, '$1');

function fieldValue(raw) {
  if (raw.startsWith('"')) return unescape(raw.slice(1, -1));
  if (/i$/.test(raw)) return Number(raw.slice(0, -1));
  if (raw === 't' || raw === 'true') return 1;
  if (raw === 'f' || raw === 'false') return 0;
  return Number(raw);
}

/** One line of line protocol: { table, tags, fields, at } (at in ms), or null for a blank or comment line. */
function parseLine(line) {
  if (!line || line.startsWith('#')) return null;
  const [head, fieldPart, ts] = splitUnescaped(line, ' ');
  const [table, ...tagPairs] = splitUnescaped(head, ',');
  const tags = {};
  for (const pair of tagPairs) {
    const [k, v] = splitUnescaped(pair, '=');
    tags[unescape(k)] = unescape(v);
  }
  const fields = {};
  for (const pair of splitUnescaped(fieldPart || '', ',')) {
    const [k, v] = splitUnescaped(pair, '=');
    if (v !== undefined) fields[unescape(k)] = fieldValue(v);
  }
  return { table: unescape(table), tags, fields, at: ts === undefined ? null : Number(BigInt(ts) / 1000000n) };
}

/** Every row in the journal files of `dir` whose time is in [fromMs, toMs); a row without a time (the writer never writes one) is skipped. */
function readJournal(dir, { fromMs = -Infinity, toMs = Infinity } = {}) {
  const rows = [];
  for (const { file } of listFiles(dir)) {
    for (const line of fs.readFileSync(file, 'utf8').split('\n')) {
      const row = parseLine(line);
      if (row && row.at !== null && row.at >= fromMs && row.at < toMs) rows.push(row);
    }
  }
  return rows;
}

module.exports = { filesTarget, readJournal, parseLine, listFiles, writerId, lastSeqIn };
