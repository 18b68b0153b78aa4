// @ts-check
'use strict';
// A subflow module: the palette node is the subflow in subflows/singular-operation.json, built from the palette's nodes.
/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  RED.nodes.registerSubflow(require('./subflows/singular-operation.json'));
};
