// @ts-check
'use strict';
// Errors reported to flows. They look like the core's (name "SugarshackError"
// and a `code`) so a Catch node sees one shape, whichever layer refused the msg.
const { text } = require('./i18n');

class SugarshackError extends Error {
  /** @param {string} code @param {string} message */
  constructor(code, message) {
    super(message);
    this.name = 'SugarshackError';
    this.code = code;
    /**
     * Set on an operation's failure after its grant (see lib/operations/operation-run.js).
     * @type {{ id: string, step: number | null, kind: string, lockedOut: string[], aborted: boolean, state?: string } | undefined}
     */
    this.operation; // declared for the type checker; not set here
  }

  /**
   * An error whose text is lib/'s catalog entry "sugarshack.errors.<key>" (see lib/host/i18n.js).
   * @param {string} code @param {string} key @param {Record<string, any>} [subs]
   */
  static of(code, key, subs) {
    return new SugarshackError(code, text(`errors.${key}`, subs));
  }
}

/**
 * The error as thrown by the core, or wrapped so that it always carries a code.
 * @param {any} err whatever was thrown
 * @returns {SugarshackError}
 */
function asSugarshackError(err) {
  try {
    if (err && typeof err === 'object' && typeof err.code === 'string' && err.message) return err;
    const wrapped = new SugarshackError('INTERNAL', err && err.message ? err.message : String(err));
    if (err && err.stack) wrapped.stack = err.stack;
    return wrapped;
  } catch {
    // a thrown proxy that throws on being looked at: what it is, never a second throw
    return new SugarshackError('INTERNAL', thrownWords(err));
  }
}

/**
 * What a value a msg's code threw says: its message, or itself as text; its
 * type when even reading it throws (a thrown proxy, a toString that throws).
 * @param {unknown} thrown
 */
function thrownWords(thrown) {
  try {
    const message = thrown && /** @type {any} */ (thrown).message;
    return typeof message === 'string' ? message : String(thrown);
  } catch {
    return typeof thrown;
  }
}

module.exports = { SugarshackError, asSugarshackError, thrownWords };
