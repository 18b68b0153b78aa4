// @ts-check
'use strict';
// A subflow module: the palette node is the subflow in subflows/condition-step.json, built from the palette's nodes.
/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  RED.nodes.registerSubflow(require('./subflows/condition-step.json'));
};
