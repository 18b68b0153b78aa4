// @ts-check
'use strict';
// A persisted pid node's state file: written as the interlock's is (atomic,
// the changes of one turn in one write), sealed and opened by the core, and the
// one-time carry-over of a state earlier versions kept in the context store.
const { isNumber, describe } = require('./index');
const { clock } = require('../host/clock');
const { FileStore, Committer, stateDir } = require('../host/durable');
const wasm = require('../wasm');
const { translator } = require('../host/i18n');

// Where flows saved before the state file kept the loop's state: read once, carried over, deleted.
const CONTEXT_KEY = 'pid';
const PID_STATE = {
  kind: 'pid',
  note: 'This pid node has run here: if its state file is missing, it starts from its configuration.\n',
};

/** A saved state, field by field: what is unusable is left out, the rest restored. */
function readSaved(saved) {
  /** @type {Record<string, any>} */
  const out = {};
  if (isNumber(saved.integral)) out.integral = saved.integral;
  if (isNumber(saved.setpoint)) out.setpoint = saved.setpoint;
  if (saved.mode === 'auto' || saved.mode === 'manual') out.mode = saved.mode;
  if (isNumber(saved.manual)) out.manual = saved.manual;
  return out;
}

/** A state an earlier version kept in the context store, field by field: what is unusable is left out. */
function legacyState(saved) {
  if (!saved || typeof saved !== 'object' || Array.isArray(saved)) throw new Error(`it is ${describe(saved)}, not { integral, setpoint, mode, manual }`);
  return readSaved(saved);
}

/**
 * What the state file asks of the node's loop.
 * @typedef {object} PidLoopHost
 * @property {(open: () => any) => void} restore the loop from a saved state `open()` reads (which may throw)
 * @property {(why: string) => void} lost the saved state could not be read (shown until the first msg)
 * @property {() => void} save the loop's state as it is now, into the file's next write
 * @property {() => void} start the node runs
 * @property {() => boolean} closed whether the node was closed meanwhile
 */

class PidStateFile {
  /**
   * @param {NodeRed.RED} RED
   * @param {NodeRed.Node} node
   * @param {NodeRed.NodeProps} props
   * @param {() => string} seal the state document to write, sealed by the core
   */
  constructor(RED, node, props, seal) {
    this.node = node;
    const t = translator(RED, 'sugarshack-pid');
    this.t = t;
    // The context store of earlier versions: read only to carry their saved state over to the file.
    /** @type {any} undefined: the default store */
    this.legacyStore = props.store && props.store !== 'default' ? props.store : undefined;
    this.store = new FileStore(stateDir(RED), node.id, PID_STATE);
    let failing = false; // warned once per run of failed writes
    this.committer = new Committer({
      store: this.store,
      clock,
      snapshot: seal,
      onError: (err) => {
        if (!failing) node.warn(t('errors.notSaved', { where: this.store.where, message: err.message || err }));
        failing = true;
      },
      onSaved: () => {
        failing = false;
      },
    });
  }

  /** The loop's state changed: written with the other changes of this turn. */
  changed() {
    this.committer.change();
  }

  /**
   * The state file when there is one; a first start reads what an earlier
   * version left in the context store. The state as started is written at
   * once; only then is the node marked as run here and the old context value
   * deleted, so a crash before that write migrates again on the next start.
   * @param {PidLoopHost} loop
   */
  open(loop) {
    const { node, t, store, committer } = this;
    /** @type {{ kind: string, text?: string, why?: string }} */
    let saved;
    try {
      saved = store.read();
    } catch (err) {
      saved = { kind: 'lost', why: err.message };
    }
    const begin = (afterWrite) => {
      loop.save();
      committer.change(() => {
        try {
          store.markRan();
        } catch (err) {
          node.warn(t('errors.notSaved', { where: store.where, message: err.message }));
        }
        if (afterWrite) afterWrite();
      });
      loop.start();
    };
    if (saved.kind === 'saved') {
      // The core opens it: another node's, a damaged one or one of an unknown version is refused.
      loop.restore(() => wasm.load().openPidState(store.where, saved.text ?? '', node.id));
      begin();
    } else if (saved.kind === 'lost') {
      const why = saved.why ?? '';
      loop.lost(why);
      node.warn(t('errors.lost', { why }));
      begin();
    } else {
      this.readLegacy((value) => {
        if (loop.closed()) return;
        if (value === undefined || value === null) {
          begin();
          return;
        }
        loop.restore(() => legacyState(value));
        begin(() => node.context().set(CONTEXT_KEY, undefined, this.legacyStore, (err) => {
          if (err) node.warn(t('errors.legacyNotDeleted', { message: err.message || err }));
        }));
      });
    }
  }

  /** The state an earlier version saved in the node's context (undefined when none or unreadable). */
  readLegacy(then) {
    const { node, t } = this;
    try {
      node.context().get(CONTEXT_KEY, this.legacyStore, (err, value) => {
        if (err) node.warn(t('errors.notRead', { message: err.message || err }));
        then(err ? undefined : value);
      });
    } catch (err) {
      node.warn(t('errors.notRead', { message: err.message }));
      then(undefined);
    }
  }

  /** The last state on disk, then no more writes: before the node that replaces it (a redeploy, a restart) reads it. */
  close() {
    const { committer } = this;
    return committer.drain().then(() => committer.freeze());
  }
}

module.exports = { PidStateFile };
