// @ts-check
'use strict';
// Safety state that must survive a crash (a power cut, kill -9), whatever
// context store the user chose: each interlock's state (and each persisted
// pid node's loop state) is a file under
// <userDir>/sugarshack/, replaced atomically (temp file, fsync, rename, fsync
// of the directory). A marker file says "this interlock has run before", so a
// state that is missing, empty or unreadable after a previous run is reported
// as lost instead of being taken for a first start with every line free.
// Only bytes go through here: what a document says, and whether it is this
// node's, the core decides (it seals and opens them).
//
// Effects wait for their state: a runtime calls `committer.change(effect)`
// after changing state, and the effect (a grant sent, a lockout published, an
// event) runs once a write holding that change is on disk. What one turn of the
// event loop changes goes out in one write.
const fs = require('fs');
const path = require('path');
const i18n = require('./i18n');

/** What a FileStore keeps: its files' prefix and the marker's text. */
const INTERLOCK_STATE = {
  kind: 'interlock',
  note: 'This interlock has run here: if its state file is missing, it starts with every line faulted.\n',
};
// A saved state is read whole at start; past this it is refused as corrupt.
const MAX_STATE_BYTES = 16 * 1024 * 1024;
const RETRY_MS = 1000;

function safeName(id) {
  return String(id).replace(/[^A-Za-z0-9_.-]/g, '_');
}

/** The directory for sugarshack state in a Node-RED user directory. */
function stateDir(RED) {
  const settings = RED.settings || {};
  let userDir;
  try {
    userDir = settings.userDir || (typeof settings.get === 'function' ? settings.get('userDir') : undefined);
  } catch {
    userDir = undefined;
  }
  const home = process.env.NODE_RED_HOME || require('os').homedir();
  return path.join(userDir || path.join(home, '.node-red'), 'sugarshack');
}

class FileStore {
  /**
   * @param {string} dir the state directory
   * @param {string} name the owning node's id
   * @param {{ kind: string, note: string }} [of] what is kept (an interlock's state unless told)
   */
  constructor(dir, name, of = INTERLOCK_STATE) {
    this.dir = dir;
    this.of = of;
    this.file = path.join(dir, `${of.kind}-${safeName(name)}.json`);
    this.marker = path.join(dir, `${of.kind}-${safeName(name)}.ran`);
    this.tmp = `${this.file}.tmp`;
  }

  get where() {
    return this.file;
  }

  /** Effects wait for a write to this store. */
  get durable() {
    return true;
  }

  /**
   * What is on disk: { kind: 'first' } (never ran here), { kind: 'saved', text }
   * (the document, for the core to open) or { kind: 'lost', why } (ran before,
   * state missing, empty or unreadable).
   */
  read() {
    let why = null;
    try {
      const size = fs.statSync(this.file).size;
      if (size === 0) why = i18n.text('labels.stateFileEmpty', { file: this.file });
      else if (size > MAX_STATE_BYTES) why = i18n.text('labels.stateFileTooLarge', { file: this.file, size, max: MAX_STATE_BYTES });
      else return { kind: 'saved', text: fs.readFileSync(this.file, 'utf8') };
    } catch (err) {
      if (err.code === 'ENOENT' && !fs.existsSync(this.marker)) return { kind: 'first' };
      why = err.code === 'ENOENT' ? i18n.text('labels.stateFileMissing', { file: this.file }) : i18n.text('labels.stateFileUnreadable', { file: this.file, message: err.message });
    }
    return { kind: 'lost', why };
  }

  /** Marks that its owner ran here; from now on a missing state is a lost one. */
  markRan() {
    fs.mkdirSync(this.dir, { recursive: true });
    if (fs.existsSync(this.marker)) return;
    const fd = fs.openSync(this.marker, 'w');
    try {
      fs.writeSync(fd, this.of.note);
      fs.fsyncSync(fd);
    } finally {
      fs.closeSync(fd);
    }
    syncDir(this.dir);
  }

  /** Replaces the state atomically; resolves once it is on disk. */
  async write(text) {
    await fs.promises.mkdir(this.dir, { recursive: true });
    const handle = await fs.promises.open(this.tmp, 'w');
    try {
      await handle.writeFile(text, 'utf8');
      await handle.sync();
    } finally {
      await handle.close();
    }
    await fs.promises.rename(this.tmp, this.file);
    const dir = await fs.promises.open(this.dir, 'r');
    try {
      await dir.sync();
    } finally {
      await dir.close();
    }
  }
}

function syncDir(dir) {
  const fd = fs.openSync(dir, 'r');
  try {
    fs.fsyncSync(fd);
  } finally {
    fs.closeSync(fd);
  }
}

/**
 * Persistence off: nothing is kept, not even in memory. Effects need not wait
 * for a write, and no state is taken per change (the snapshot was most of a
 * grant's cost). A restart starts afresh; a rebuild after a core failure
 * finds the state lost, so every line starts faulted, as after a lost file.
 */
class MemoryStore {
  constructor() {
    this.ran = false;
  }

  get where() {
    return 'memory';
  }

  get durable() {
    return false;
  }

  read() {
    return this.ran ? { kind: 'lost', why: i18n.text('labels.persistenceOff') } : { kind: 'first' };
  }

  markRan() {
    this.ran = true;
  }

  write() {
    return Promise.resolve();
  }
}

/**
 * Group commit: state changes of one event-loop turn are written once, and the
 * effects waiting for them run after the write. With a store that is not
 * durable, a change's effect runs at once (nothing to wait for) and only the
 * effects collected per turn (event records) wait for the end of the turn. `snapshot()` returns the text to
 * write. An effect marked `evenUnsaved` (a lockout: isolating the line matters
 * more than the record of it) also runs when the write fails, or, with a store
 * that says `urgentAfterMs` (etcd, whose write may hang while it has no
 * quorum), once its write has taken that long; the others wait for the next
 * successful write, retried every second. No effect runs while `mayAct()` says no.
 */
class Committer {
  /**
   * `collect()`, called just before each write, may return one more effect for
   * that write (an interlock's event records, drained once per write).
   * @param {object} o
   * @param {{ durable: boolean, where: string, write: (text: any) => Promise<void>, urgentAfterMs?: number }} o.store
   * @param {() => string} o.snapshot the text to write
   * @param {{ setTimeout: Function, clearTimeout: Function }} o.clock times the retries
   * @param {(err: any) => void} [o.onError] a snapshot, write or effect failed
   * @param {() => void} [o.onSaved] a write is on disk
   * @param {() => ((() => void) | null)} [o.collect]
   * @param {() => boolean} [o.mayAct] false while effects may not leave at all (a standby, or a leader whose lease may have run out)
   */
  constructor({ store, snapshot, clock, onError, onSaved, collect, mayAct }) {
    this.store = store;
    this.snapshot = snapshot;
    this.collect = collect || (() => null);
    this.collects = Boolean(collect);
    this.mayAct = mayAct || (() => true);
    this.clock = clock;
    this.onError = onError || (() => {});
    this.onSaved = onSaved || (() => {});
    this.effects = [];
    this.dirty = false;
    this.writing = null;
    this.scheduled = null;
    this.retry = null;
    this.frozen = false;
    this.failing = false;
    this.idleWaiters = [];
    this.writes = 0;
  }

  /** Nothing is written and nothing waits: a change's effects would run at once (`change` and `after` alike). */
  get idle() {
    return !this.frozen && !this.store.durable && !this.collects && !this.dirty && !this.writing && this.effects.length === 0;
  }

  /** A state change happened; `effect` runs once it is durable. */
  change(effect, { evenUnsaved = false } = {}) {
    if (this.frozen) return;
    if (!this.store.durable && !this.collects && !this.dirty && this.effects.length === 0) {
      // Nothing is written and nothing waits: the effect goes now, without a turn of the event loop.
      if (effect) this.run(effect);
      return;
    }
    this.dirty = true;
    if (effect) {
      // In order behind effects still waiting (an `after` queued behind an earlier change).
      if (!this.store.durable && this.effects.length === 0) this.run(effect);
      else this.effects.push({ run: effect, evenUnsaved, ran: false });
    }
    this.schedule();
  }

  /** An effect with no state change of its own, kept in order behind the changes before it. */
  after(effect) {
    if (this.frozen) return;
    if (!this.dirty && !this.writing && this.effects.length === 0) {
      effect();
      return;
    }
    this.effects.push({ run: effect, evenUnsaved: false, ran: false });
    this.schedule();
  }

  schedule() {
    if (this.scheduled || this.writing || this.retry || this.frozen) return;
    this.scheduled = setImmediate(() => {
      this.scheduled = null;
      this.flush();
    });
  }

  async flush() {
    if (this.writing || this.frozen) return;
    let ok = true;
    if (this.dirty) {
      try {
        const extra = this.collect();
        if (extra) this.effects.push({ run: extra, evenUnsaved: false, ran: false });
      } catch (err) {
        this.onError(err);
      }
    }
    const effects = this.effects;
    this.effects = [];
    if (this.dirty && !this.store.durable) {
      this.dirty = false;
    } else if (this.dirty) {
      this.dirty = false;
      let text;
      try {
        text = this.snapshot();
      } catch (err) {
        this.onError(err);
        ok = false;
      }
      if (ok) {
        this.writing = this.store.write(text);
        const early = this.urgentEarly(effects);
        try {
          await this.writing;
          this.writes++;
          if (this.failing) this.failing = false;
          this.onSaved();
        } catch (err) {
          ok = false;
          this.failing = true;
          this.dirty = true;
          this.onError(err);
        } finally {
          this.writing = null;
          if (early) this.clock.clearTimeout(early);
        }
      }
    }
    if (this.frozen) {
      this.wake();
      return;
    }
    const waiting = [];
    for (const effect of effects) {
      if (effect.ran) continue;
      if (ok || (effect.evenUnsaved && this.mayAct())) this.run(effect.run);
      else waiting.push(effect);
    }
    if (!ok) {
      this.effects = waiting.concat(this.effects);
      this.retry = this.clock.setTimeout(() => {
        this.retry = null;
        this.schedule();
      }, RETRY_MS);
      return;
    }
    if (this.dirty || this.effects.length > 0) this.schedule();
    else this.wake();
  }

  /** Urgent effects of a write that takes longer than the store's `urgentAfterMs` go out before it ends. */
  urgentEarly(effects) {
    const ms = this.store.urgentAfterMs;
    if (typeof ms !== 'number' || !effects.some((e) => e.evenUnsaved)) return null;
    return this.clock.setTimeout(() => {
      for (const effect of effects) {
        if (!effect.evenUnsaved || effect.ran || this.frozen || !this.mayAct()) continue;
        effect.ran = true;
        this.run(effect.run);
      }
    }, ms);
  }

  /**
   * Runs `effect(a, b, c, d)`; what it throws is reported.
   * @param {(a?: any, b?: any, c?: any, d?: any) => void} effect @param {any} [a] @param {any} [b] @param {any} [c] @param {any} [d]
   */
  run(effect, a, b, c, d) {
    try {
      effect(a, b, c, d);
    } catch (err) {
      this.onError(err);
    }
  }

  wake() {
    for (const resolve of this.idleWaiters.splice(0)) resolve();
  }

  /** Resolves once every change so far is written and its effects have run. */
  settled() {
    if (!this.dirty && !this.writing && !this.scheduled && this.effects.length === 0) return Promise.resolve();
    return new Promise((resolve) => this.idleWaiters.push(resolve));
  }

  /**
   * Stops writing (shutdown): a write in flight completes, nothing after it is
   * written and no waiting effect runs. The saved state stays the last one whose
   * effects went out.
   */
  async freeze() {
    this.frozen = true;
    if (this.scheduled) clearImmediate(this.scheduled);
    this.scheduled = null;
    if (this.retry) this.clock.clearTimeout(this.retry);
    this.retry = null;
    this.effects = [];
    if (this.writing) await this.writing.catch(() => {});
    this.wake();
  }

  /** Forgets changes not yet written and their effects (the core that made them is gone). */
  discard() {
    if (this.scheduled) clearImmediate(this.scheduled);
    this.scheduled = null;
    this.effects = [];
    this.dirty = false;
  }

  /** Writes what is pending now, effects included, regardless of the turn (a retiring runtime). */
  async drain() {
    if (this.scheduled) {
      clearImmediate(this.scheduled);
      this.scheduled = null;
    }
    while (this.writing) await this.writing.catch(() => {});
    await this.flush();
  }
}

module.exports = { FileStore, MemoryStore, Committer, stateDir, safeName, INTERLOCK_STATE, MAX_STATE_BYTES };
