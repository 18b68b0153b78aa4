// @ts-check
'use strict';
// A node that cannot run as deployed (its settings, or what it names in the
// plant document, refused): the reason is logged once and shown in red, and
// each msg it gets ends with the same error so a Catch node sees it.
const { asSugarshackError } = require('./errors');
const { errorStatus } = require('./status');

/** Logs and shows why `node` cannot run; returns the error its msgs end with. */
function refuseDeploy(node, err) {
  const refusal = asSugarshackError(err);
  node.error(refusal.message);
  node.status(errorStatus(refusal.code));
  return refusal;
}

module.exports = { refuseDeploy };
