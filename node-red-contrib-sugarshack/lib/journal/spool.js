// @ts-check
'use strict';
// The journal's store-and-forward buffer: complete line-protocol rows appended
// to segment files in a directory, read back in order from a saved cursor,
// and deleted once every row of a segment is acknowledged. The rows not yet
// acknowledged never take more than `maxBytes`: a row that would pass that
// bound is dropped (the newest go, so what is kept stays in order and the
// files stay append-only) and counted, and the count is kept on disk with the
// cursor so a restart does not forget it. The spool also keeps its writer's
// identity: the writer id (writer.json) and the last `seq` given to a row (in
// the cursor, and in the last row kept), so a restarted writer goes on from it.

const fs = require('fs');
const path = require('path');
const { writerId, lastSeqIn } = require('./files');

const SEGMENT_RE = /^(\d{12})\.lp$/;
const STATE_FILE = 'cursor.json';
const NEWLINE = 0x0a;

const segmentName = (n) => `${String(n).padStart(12, '0')}.lp`;

function countRows(buffer, from = 0, to = buffer.length) {
  let n = 0;
  for (let i = buffer.indexOf(NEWLINE, from); i !== -1 && i < to; i = buffer.indexOf(NEWLINE, i + 1)) n++;
  return n;
}

class Spool {
  /**
   * @param {object} o
   * @param {string} o.dir          directory of the segments (created)
   * @param {number} o.maxBytes     bound on the unacknowledged rows' bytes
   * @param {number} [o.segmentBytes] a segment is closed past this size
   */
  constructor({ dir, maxBytes, segmentBytes = 4 * 1024 * 1024 }) {
    if (!(Number.isSafeInteger(maxBytes) && maxBytes > 0)) throw new RangeError(`the buffer bound must be a positive whole number of bytes, got ${maxBytes}`);
    this.dir = dir;
    this.maxBytes = maxBytes;
    this.segmentBytes = Math.max(1, Math.min(segmentBytes, maxBytes));
    /** @type {{ n: number, size: number }[]} the segment files in order; the cursor is in the first */
    this.segments = [];
    this.offset = 0;
    this.bytes = 0;
    this.rows = 0;
    this.dropped = 0;
    /** @type {number | null} */
    this.droppedSince = null;
    /** The last seq given to a row appended (or dropped at the bound). */
    this.lastSeq = 0;
    fs.mkdirSync(dir, { recursive: true });
    this.writer = writerId(dir);
    this.load();
  }

  load() {
    const saved = this.readState();
    this.dropped = saved.dropped;
    this.droppedSince = saved.droppedSince;
    const found = fs.readdirSync(this.dir)
      .map((f) => SEGMENT_RE.exec(f))
      .filter((m) => m !== null)
      .map((m) => ({ n: Number(m[1]), size: fs.statSync(path.join(this.dir, m[0])).size }))
      .sort((a, b) => a.n - b.n);
    // Rows of segments older than the cursor's were all sent before a crash cut the clean-up short.
    for (const stale of found.filter((s) => s.n < saved.segment)) fs.rmSync(this.file(stale.n), { force: true });
    this.segments = found.filter((s) => s.n >= saved.segment);
    this.offset = this.segments.length && this.segments[0].n === saved.segment ? Math.min(saved.offset, this.segments[0].size) : 0;
    for (const s of this.segments) this.trimPartialRow(s);
    this.bytes = this.segments.reduce((sum, s) => sum + s.size, 0) - this.offset;
    this.rows = 0;
    this.segments.forEach((s, i) => {
      this.rows += countRows(fs.readFileSync(this.file(s.n)), i === 0 ? this.offset : 0);
    });
    // The cursor is saved at acknowledgements; rows appended since are on disk with their seq.
    const last = this.segments.filter((s) => s.size > 0).pop();
    this.lastSeq = Math.max(saved.seq, last ? lastSeqIn(this.file(last.n)) : 0);
  }

  /** Who writes these rows, and the seq the next row follows: { writer, seq }. */
  identity() {
    return { writer: this.writer, seq: this.lastSeq };
  }

  readState() {
    try {
      const s = JSON.parse(fs.readFileSync(path.join(this.dir, STATE_FILE), 'utf8'));
      return {
        segment: Number.isSafeInteger(s.segment) ? s.segment : 0,
        offset: Number.isSafeInteger(s.offset) && s.offset >= 0 ? s.offset : 0,
        dropped: Number.isSafeInteger(s.dropped) && s.dropped >= 0 ? s.dropped : 0,
        droppedSince: Number.isFinite(s.droppedSince) ? s.droppedSince : null,
        seq: Number.isSafeInteger(s.seq) && s.seq >= 0 ? s.seq : 0,
      };
    } catch {
      return { segment: 0, offset: 0, dropped: 0, droppedSince: null, seq: 0 };
    }
  }

  /** A row cut short by a crash while appending is not a row: the segment ends at its last newline. */
  trimPartialRow(segment) {
    if (segment.size === 0) return;
    const file = this.file(segment.n);
    const data = fs.readFileSync(file);
    const end = data.lastIndexOf(NEWLINE) + 1;
    if (end < data.length) {
      fs.truncateSync(file, end);
      segment.size = end;
    }
  }

  file(n) {
    return path.join(this.dir, segmentName(n));
  }

  saveState() {
    const state = {
      segment: this.segments.length ? this.segments[0].n : 0,
      offset: this.offset,
      dropped: this.dropped,
      droppedSince: this.droppedSince,
      seq: this.lastSeq,
    };
    const tmp = path.join(this.dir, `${STATE_FILE}.tmp`);
    fs.writeFileSync(tmp, JSON.stringify(state));
    fs.renameSync(tmp, path.join(this.dir, STATE_FILE));
  }

  /**
   * Appends rows (each a Buffer ending in a newline) in order; the ones that
   * would pass the bound are dropped. `lastSeq` is the seq of the last of
   * them. Returns { kept, dropped } for this call.
   */
  append(rows, now = Date.now(), lastSeq = this.lastSeq + rows.length) {
    this.lastSeq = lastSeq;
    const parts = [];
    let size = 0;
    let dropped = 0;
    for (const row of rows) {
      if (this.bytes + size + row.length > this.maxBytes) {
        dropped++;
        continue;
      }
      parts.push(row);
      size += row.length;
    }
    if (parts.length) this.write(parts);
    this.rows += parts.length;
    this.bytes += size;
    if (dropped) {
      if (this.dropped === 0) this.droppedSince = now;
      this.dropped += dropped;
      this.saveState();
    }
    return { kept: parts.length, dropped };
  }

  write(parts) {
    let i = 0;
    while (i < parts.length) {
      let last = this.segments[this.segments.length - 1];
      if (!last || last.size >= this.segmentBytes) {
        last = { n: last ? last.n + 1 : this.firstSegmentNumber(), size: 0 };
        this.segments.push(last);
      }
      const chunk = [];
      let size = 0;
      // At least one row per segment, so a row larger than a segment still goes somewhere.
      while (i < parts.length && (chunk.length === 0 || last.size + size + parts[i].length <= this.segmentBytes)) {
        chunk.push(parts[i]);
        size += parts[i].length;
        i++;
      }
      fs.appendFileSync(this.file(last.n), Buffer.concat(chunk, size));
      last.size += size;
    }
  }

  firstSegmentNumber() {
    return this.readState().segment + 1;
  }

  /** The oldest unacknowledged rows, whole rows only, at most `maxBytes` (at least one row). */
  peek(maxBytes = 1024 * 1024) {
    if (this.rows === 0) return null;
    const first = this.segments[0];
    const fd = fs.openSync(this.file(first.n), 'r');
    try {
      const want = Math.min(first.size - this.offset, Math.max(1, maxBytes));
      let data = Buffer.alloc(want);
      fs.readSync(fd, data, 0, want, this.offset);
      let end = data.lastIndexOf(NEWLINE) + 1;
      if (end === 0) {
        // One row longer than maxBytes: read the whole row.
        data = fs.readFileSync(this.file(first.n)).subarray(this.offset);
        end = data.indexOf(NEWLINE) + 1;
      }
      const body = data.subarray(0, end);
      return { body, rows: countRows(body), segment: first.n, end: this.offset + end };
    } finally {
      fs.closeSync(fd);
    }
  }

  /** The rows of `chunk` (from peek) reached the database: move past them. */
  ack(chunk) {
    const first = this.segments[0];
    if (!first || first.n !== chunk.segment) return;
    this.bytes -= chunk.end - this.offset;
    this.rows -= chunk.rows;
    this.offset = chunk.end;
    // A finished segment is removed, unless it is the one still being written.
    if (this.offset >= first.size && (this.segments.length > 1 || first.size >= this.segmentBytes)) {
      this.segments.shift();
      fs.rmSync(this.file(first.n), { force: true });
      this.offset = 0;
      if (!this.segments.length) this.segments.push({ n: first.n + 1, size: 0 });
    }
    this.saveState();
  }

  /** Rows and bytes waiting, and rows ever dropped at the bound. */
  backlog() {
    return { rows: this.rows, bytes: this.bytes, dropped: this.dropped, droppedSince: this.droppedSince, maxBytes: this.maxBytes };
  }
}

module.exports = { Spool, countRows };
