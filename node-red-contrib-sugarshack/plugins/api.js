// @ts-check
'use strict';
// Hands the palette's API (lib/api.js) to other packages through Node-RED's
// plugin registry: RED.plugins.get('sugarshack-api').api.
const { paletteApi, VERSION } = require('../lib/api');

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  RED.plugins.registerPlugin('sugarshack-api', { type: 'sugarshack-api', version: VERSION, api: paletteApi(RED) });
};
