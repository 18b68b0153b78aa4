// @ts-check
'use strict';
// Reads the outputs an engine call left in wasm memory (see the core's
// engine/wire.rs): a header of six numbers at the engine's headerPtr(), then
// the batch as words and text, or as one JSON text. Names (operations,
// lines) cross once: this keeps the mirror of the engine's string table.
// Each output goes to a visitor's method, so nothing is made per output
// that the visitor does not keep.
const wasm = require('./');

// Record tags and what a send sets (engine/wire.rs), as plain constants: read per record.
const COMMIT = 1;
const AFTER = 2;
const SEND = 3;
const EMIT = 4;
const COMPLETE = 5;
const OTHER = 6;
const COUNTS = 7;
const NAME = 8;
const NAMES_RESET = 9;
const ALARM = 10;
const SET_NOTHING = 0;
const SET_INTERLOCK = 1;
const decoder = new TextDecoder('utf-8', { ignoreBOM: true });

/** UTF-8 bytes as text; a short ASCII run (a name) is read byte by byte, cheaper than a decoder call. @param {Uint8Array} bytes @param {number} at @param {number} length */
function textAt(bytes, at, length) {
  if (length > 32) return decoder.decode(bytes.subarray(at, at + length));
  let text = '';
  for (let i = at; i < at + length; i++) {
    const b = bytes[i];
    if (b >= 0x80) return decoder.decode(bytes.subarray(at, at + length));
    text += String.fromCharCode(b);
  }
  return text;
}

/** The text field at word `i` (its start and length in the batch's text). @param {string} text @param {Float64Array} w @param {number} i */
function str(text, w, i) {
  return text.substr(w[i], w[i + 1]);
}

/**
 * What a batch's outputs go to, in order.
 * @typedef {{
 *   commit(urgent: boolean): void,
 *   after(): void,
 *   send(msg: number, port: number, set: any): void,
 *   emit(msg: number, port: number, msgs: any[]): void,
 *   complete(msg: number, refusal: any): void,
 *   counts(holding: number, queued: number, faulted: number, lost: boolean): void,
 *   other(output: any): void,
 * }} Visitor
 */

class Wire {
  /** @param {{ headerPtr(): number }} engine */
  constructor(engine) {
    this.headerPtr = engine.headerPtr();
    // Each view's length is 0 once wasm memory grew (its buffer is then
    // detached): read inline, where the buffer's byteLength is a builtin call.
    this.header = new Float64Array(0);
    this.memory = new Float64Array(0);
    /** @type {string[]} the engine's string table */
    this.names = [];
    this.bytes = new Uint8Array(0);
    this.refresh();
  }

  /** Views on the memory as it is now (it is replaced when wasm memory grows). */
  refresh() {
    const { buffer } = wasm.load().wasmMemory();
    this.header = new Float64Array(buffer, this.headerPtr, 6);
    this.memory = new Float64Array(buffer);
    this.bytes = new Uint8Array(buffer);
  }

  /** When the engine is next due (-1: never), after the last call. */
  nextDeadline() {
    if (this.header.length === 0) this.refresh();
    return this.header[4];
  }

  /**
   * Hands the last call's outputs to `visitor`, in order.
   * @param {Visitor} visitor
   */
  read(visitor) {
    if (this.header.length === 0) this.refresh(); // detached: memory grew
    const h = this.header;
    const textLen = h[3];
    const text = textLen > 0 ? textAt(this.bytes, h[2], textLen) : '';
    const words = h[1];
    // Read once: a batch read again would repeat its sends.
    h[1] = 0;
    h[3] = 0;
    if (h[5] === 1) {
      if (text) for (const output of JSON.parse(text)) dispatch(output, visitor);
      return;
    }
    const w = this.memory;
    const names = this.names;
    const at = h[0] / 8;
    const end = at + words;
    for (let i = at; i < end;) {
      switch (w[i]) {
        case COMMIT: visitor.commit(w[i + 1] === 1); i += 2; break;
        case AFTER: visitor.after(); i += 1; break;
        case SEND: {
          const msg = w[i + 1];
          const port = w[i + 2];
          const kind = w[i + 3];
          if (kind === SET_NOTHING) {
            visitor.send(msg, port, null);
            i += 4;
          } else if (kind === SET_INTERLOCK) {
            const n = w[i + 7];
            // Pushed, not new Array(n): that is a builtin call, and a holey array.
            const resources = [];
            for (let k = 0; k < n; k++) resources.push(names[w[i + 8 + k]]);
            visitor.send(msg, port, { kind: 'interlock', operation: names[w[i + 4]], priority: w[i + 5], resources, waitedMs: w[i + 6] });
            i += 8 + n;
          } else {
            visitor.send(msg, port, JSON.parse(str(text, w, i + 4)));
            i += 6;
          }
          break;
        }
        case EMIT: visitor.emit(w[i + 1], w[i + 2], JSON.parse(str(text, w, i + 3))); i += 5; break;
        case COMPLETE:
          if (w[i + 2] === 0) {
            visitor.complete(w[i + 1], null);
            i += 3;
          } else {
            visitor.complete(w[i + 1], JSON.parse(str(text, w, i + 3)));
            i += 5;
          }
          break;
        case COUNTS: visitor.counts(w[i + 1], w[i + 2], w[i + 3], w[i + 4] === 1); i += 5; break;
        case OTHER: visitor.other(JSON.parse(str(text, w, i + 1))); i += 3; break;
        case NAME: names[w[i + 1]] = str(text, w, i + 2); i += 4; break;
        case NAMES_RESET: names.length = 0; i += 1; break;
        case ALARM: {
          /** @type {any} the change as serde writes it */
          const change = { id: str(text, w, i + 2), action: str(text, w, i + 4), from: str(text, w, i + 6), to: str(text, w, i + 8), atMs: w[i + 1] };
          let at = i + 10;
          if (w[at] === 1) {
            change.by = str(text, w, at + 1);
            at += 3;
          } else at += 1;
          if (w[at] === 1) {
            change.reason = str(text, w, at + 1);
            at += 3;
          } else at += 1;
          visitor.other({ kind: 'alarm', change });
          i = at;
          break;
        }
        default: throw new Error(`engine wire: unknown record ${w[i]} at word ${i - at}`);
      }
    }
  }
}

/** One output as serde writes it (the JSON batch), to the visitor. */
function dispatch(o, visitor) {
  switch (o.kind) {
    case 'commit': visitor.commit(o.urgent); break;
    case 'after': visitor.after(); break;
    case 'send': visitor.send(o.msg, o.port, o.set.kind === 'nothing' ? null : o.set); break;
    case 'emit': visitor.emit(o.msg, o.port, o.msgs); break;
    case 'complete': visitor.complete(o.msg, o.refusal); break;
    case 'counts': visitor.counts(o.holding, o.queued, o.faulted, o.lost); break;
    default: visitor.other(o);
  }
}

module.exports = { Wire };
