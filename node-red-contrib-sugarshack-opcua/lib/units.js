'use strict';
// A plant document's unit text as OPC UA's EUInformation: UNECE common codes
// (OPC 10000-8 Annex E) for the units plants write, else the text alone
// (unitId -1, "no code"), so a client still shows what the document says.
const { makeEUInformation } = require('node-opcua');
// Text as written in plant documents -> UNECE common code.
const CODES = {
  '%': 'P1',
  L: 'LTR',
  l: 'LTR',
  'L/min': 'L2',
  'L/h': 'E32',
  'm³': 'MTQ',
  'm3': 'MTQ',
  'm³/h': 'MQH',
  '°C': 'CEL',
  '°F': 'FAH',
  K: 'KEL',
  bar: 'BAR',
  mbar: 'MBR',
  Pa: 'PAL',
  kPa: 'KPA',
  psi: 'PS',
  m: 'MTR',
  cm: 'CMT',
  mm: 'MMT',
  s: 'SEC',
  ms: 'C26',
  min: 'MIN',
  h: 'HUR',
  kg: 'KGM',
  g: 'GRM',
  W: 'WTT',
  kW: 'KWT',
  A: 'AMP',
  V: 'VLT',
  Hz: 'HTZ',
  rpm: 'RPM',
};

/** EUInformation for `unit` (a plant document's text), or null when there is none. */
function engineeringUnits(unit) {
  if (typeof unit !== 'string' || unit.trim() === '') return null;
  const code = CODES[unit.trim()];
  const info = makeEUInformation(code || '', unit, unit);
  if (!code) info.unitId = -1;
  return info;
}

module.exports = { engineeringUnits };
