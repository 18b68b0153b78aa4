// @ts-check
'use strict';
// Errors reported to flows. They look like the core's (name "SugarshackError"
// and a `code`) so a Catch node sees one shape, whichever layer refused the msg.
const { types } = require('util');
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
 * Whatever was thrown, as a SugarshackError with words; never throws, whatever it
 * is (a revoked proxy, a getter or Symbol.toPrimitive that throws).
 *
 * Kept as it is: an error with a string `code` and a message (the core's, ours,
 * Node's), and given `refuse` only one named SugarshackError (a msg's own code
 * throwing a coded error is still the sender's). Anything else becomes
 * `refuse(words)`, or INTERNAL with its words and stack.
 * @param {unknown} err whatever was thrown
 * @param {(words: string) => SugarshackError} [refuse] the refusal for what a msg's own code threw
 * @returns {SugarshackError}
 */
function asSugarshackError(err, refuse) {
  if (isCoded(err, refuse !== undefined)) return /** @type {SugarshackError} */ (err);
  const words = thrownWords(err);
  if (refuse) return refuse(words);
  const wrapped = new SugarshackError('INTERNAL', words);
  try {
    const stack = /** @type {any} */ (err).stack;
    if (typeof stack === 'string') wrapped.stack = stack;
  } catch {
    // a stack getter that throws: the wrapper's own stack
  }
  return wrapped;
}

/**
 * An error to pass on as it is. Its code, message and name are read as own data
 * properties, which runs none of its code; a proxy is never kept, since reading
 * its code later, as every caller does, could throw.
 * @param {unknown} err @param {boolean} oursOnly
 */
function isCoded(err, oursOnly) {
  if (err === null || (typeof err !== 'object' && typeof err !== 'function') || types.isProxy(err)) return false;
  const own = (/** @type {string} */ key) => {
    const property = Object.getOwnPropertyDescriptor(err, key);
    return property && typeof property.value === 'string' ? property.value : undefined;
  };
  return own('code') !== undefined && Boolean(own('message')) && (!oursOnly || own('name') === 'SugarshackError');
}

/**
 * What a thrown value says: its message, or itself as text; its type when even
 * reading it throws (a thrown proxy, a toString that throws).
 * @param {unknown} thrown
 */
function thrownWords(thrown) {
  try {
    const message = thrown !== null && (typeof thrown === 'object' || typeof thrown === 'function')
      ? /** @type {any} */ (thrown).message : undefined;
    return typeof message === 'string' && message !== '' ? message : String(thrown);
  } catch {
    return typeof thrown;
  }
}

module.exports = { SugarshackError, asSugarshackError, thrownWords };
