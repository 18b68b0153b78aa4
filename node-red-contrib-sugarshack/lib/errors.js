'use strict';
// Errors reported to flows. They look like the core's (name "InterlockError" and
// a `code`) so a Catch node sees one shape, whichever layer refused the msg.

class InterlockError extends Error {
  constructor(code, message) {
    super(message);
    this.name = 'InterlockError';
    this.code = code;
  }
}

/** The error as thrown by the core, or wrapped so that it always carries a code. */
function asInterlockError(err) {
  if (err && typeof err === 'object' && typeof err.code === 'string' && err.message) return err;
  const wrapped = new InterlockError('INTERNAL', err && err.message ? err.message : String(err));
  if (err && err.stack) wrapped.stack = err.stack;
  return wrapped;
}

module.exports = { InterlockError, asInterlockError };
