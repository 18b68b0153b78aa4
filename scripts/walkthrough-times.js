'use strict';
// The times the README's fault walkthrough states, derived from the plant
// document (flows/plant.json) and the simulator's defaults, not measured:
// when the truck routine starts op 10, how long a stuck V101 takes to fault
// it (no motion, then its retries), how long YEL's lockout takes (a sweep).
//   node scripts/walkthrough-times.js          prints the figures and the README phrases
//   node scripts/walkthrough-times.js --check  exits 1 when README.md does not say them
const fs = require('fs');
const path = require('path');
const { DEFAULTS } = require('./simulator');

const ROOT = path.join(__dirname, '..');

function walkthroughTimes(plant = JSON.parse(fs.readFileSync(path.join(ROOT, 'flows', 'plant.json'), 'utf8'))) {
  const op10 = plant.operations.find((op) => op.id === '10');
  const v101 = plant.actuators.find((a) => a.id === 'V101');
  const valve = plant.actuatorTypes[v101.type];
  if (!Object.keys(op10.steps[0].command.valves).includes('V101')) throw new Error('op 10 no longer moves V101 first');
  const truck = plant.routines.find((r) => r.id === 'truck');
  const start = truck.transitions.find((t) => t.from === truck.initial && t.operation === '10');
  const s = (ms) => ms / 1000;
  const checkS = s(start.trigger.everyMs);
  // No motion within noMotionMs, commanded again `retries` times, each waited out as long.
  const faultS = s(valve.noMotionMs * ((valve.retries || 0) + 1));
  const sweepS = DEFAULTS.sweepS;
  return { checkS, faultS, firstFaultS: checkS + faultS, sweepS };
}

/** The phrases README.md must contain, each with its figure. */
function readmePhrases(t = walkthroughTimes()) {
  return [
    `within **${t.checkS} s** of the flows starting`,
    `about **${t.faultS} s** later`,
    `at most **${t.firstFaultS} s** after the start`,
    `a valve sweep (**${t.sweepS} s** in the simulator)`,
    `about **${t.faultS} s** after the click`,
  ];
}

if (require.main === module) {
  const phrases = readmePhrases();
  if (process.argv.includes('--check')) {
    const readme = fs.readFileSync(path.join(ROOT, 'README.md'), 'utf8');
    const missing = phrases.filter((p) => !readme.includes(p));
    for (const p of missing) console.error(`README.md does not say: ${p}`);
    process.exit(missing.length ? 1 : 0);
  }
  console.log(JSON.stringify(walkthroughTimes()));
  for (const p of phrases) console.log(p);
}

module.exports = { walkthroughTimes, readmePhrases };
