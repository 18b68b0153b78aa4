'use strict';
// Starts the plant simulator in-process for a test, on the small fixture
// plant with fast settings (1 s valve sweep, short pump spin-up) unless
// overridden. Log lines are kept on `sim.logs` instead of printed
// (SIM_LOG=1 prints them too).
//
//   const sim = await startTestSimulator(broker.url, { faults: ['stuck:ctrl-1:3'] });
//   ... sim.devices['ctrl-1'].valves[3].position ...
//   await sim.stop();
const path = require('path');
const { startSimulator } = require('../../../scripts/simulator');

const SMALL_PLANT = path.join(__dirname, '..', 'fixtures', 'plant-small.json');

async function startTestSimulator(url, overrides = {}) {
  const logs = [];
  const sim = await startSimulator({
    broker: url,
    plant: SMALL_PLANT,
    sweepS: 1,
    pumpDelayMs: 200,
    reconnectMs: 200,
    seed: 42,
    log: (line) => {
      logs.push(line);
      if (process.env.SIM_LOG) console.log(`      sim: ${line}`);
    },
    ...overrides,
  });
  sim.logs = logs;
  return sim;
}

module.exports = { startTestSimulator, SMALL_PLANT };
