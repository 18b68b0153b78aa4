#!/usr/bin/env node
'use strict';
// Command line for the plant simulator; see README.md beside this file.
const { Simulator, DEFAULTS } = require('./index');

const USAGE = `usage: node scripts/simulator/cli.js --plant <plant.json> [options]
  --broker URL           MQTT broker (default ${DEFAULTS.broker}, or $MQTT_URL)
  --plant FILE           plant document (devices, actuators, sensors, simulation)
  --sweep-s N            valve full-sweep time in seconds (default ${DEFAULTS.sweepS})
  --noise N              valve feedback noise, ± % (default ${DEFAULTS.noise})
  --sensor-noise N       sensor noise, ± % of the datapoint span (default ${DEFAULTS.sensorNoise})
  --delay-ms N           mean delay of outgoing publishes (default 0)
  --delay-jitter-ms N    ± uniform jitter around the mean (default 0)
  --drop R               share 0..1 of outgoing data messages lost (default 0)
  --speed N              simulated time runs N times faster (default 1)
  --single               per-actuator state topics instead of the <dev>/state batch
  --profile P            every device speaks P: esphome, tasmota, shelly-gen2, sugarshack or
                         modbus (default: each device's profile in the document; the palette
                         must be given the same document, see withProfile in plant.js)
  --modbus-port N        --profile modbus: the first device's Modbus TCP port, the next ones
                         after it in document order (default ${DEFAULTS.modbusPort})
  --loop FILE            also run the flow loop of FILE's simulation.loop as a Modbus/TCP
                         I/O module (a plant document, or a flow holding one plant node)
  --seed S               random seed (default ${DEFAULTS.seed})
  --pump-delay-ms N      pump spin-up/run-down (default ${DEFAULTS.pumpDelayMs})
  --dead-time-ms N       valve command-to-motion delay (default 0)
  --fault SPEC           fault at start, repeatable: stuck:ctrl-1:3, slow:ctrl-1:3:10,
                         dead:station-4, disconnect:ctrl-1:3000, noisy:ctrl-2:8,
                         drop:ctrl-3:0.3, drift:ctrl-1:5:40,
                         or an actuator id as target: stuck:V103, stuck:P1
  --control-topic T      take faults on T, answer on T/result (default ${DEFAULTS.controlTopic})
  --no-control           do not listen for faults
  --quiet                log only errors and faults
  -h, --help`;

const VALUE_FLAGS = {
  '--broker': 'broker',
  '--plant': 'plant',
  '--sweep-s': 'sweepS',
  '--noise': 'noise',
  '--sensor-noise': 'sensorNoise',
  '--delay-ms': 'delayMs',
  '--delay-jitter-ms': 'delayJitterMs',
  '--drop': 'drop',
  '--speed': 'speed',
  '--seed': 'seed',
  '--pump-delay-ms': 'pumpDelayMs',
  '--dead-time-ms': 'deadTimeMs',
  '--profile': 'profile',
  '--control-topic': 'controlTopic',
  '--modbus-port': 'modbusPort',
  '--loop': 'loop',
};
const NUMERIC = new Set(['sweepS', 'noise', 'sensorNoise', 'delayMs', 'delayJitterMs', 'drop', 'speed', 'pumpDelayMs', 'deadTimeMs', 'modbusPort']);

function parseArgs(argv) {
  const opts = { faults: [], broker: process.env.MQTT_URL || DEFAULTS.broker };
  for (let i = 0; i < argv.length; i++) {
    let arg = argv[i];
    let inline;
    const eq = arg.indexOf('=');
    if (arg.startsWith('--') && eq > 0) {
      inline = arg.slice(eq + 1);
      arg = arg.slice(0, eq);
    }
    const value = () => {
      if (inline !== undefined) return inline;
      if (i + 1 >= argv.length) throw new Error(`${arg} needs a value`);
      return argv[++i];
    };
    if (arg === '-h' || arg === '--help') opts.help = true;
    else if (arg === '--single') opts.single = true;
    else if (arg === '--no-control') opts.control = false;
    else if (arg === '--quiet') opts.quiet = true;
    else if (arg === '--fault') opts.faults.push(value());
    else if (VALUE_FLAGS[arg]) {
      const key = VALUE_FLAGS[arg];
      const v = value();
      if (NUMERIC.has(key)) {
        const n = Number(v);
        if (v === '' || !Number.isFinite(n)) throw new Error(`${arg}: ${JSON.stringify(v)} is not a number`);
        opts[key] = n;
      } else {
        opts[key] = v;
      }
    } else throw new Error(`unknown option ${arg}`);
  }
  return opts;
}

async function main() {
  let opts;
  try {
    opts = parseArgs(process.argv.slice(2));
  } catch (err) {
    console.error(`simulator: ${err.message}\n${USAGE}`);
    process.exit(2);
  }
  if (opts.help) {
    console.log(USAGE);
    return;
  }
  if (!opts.plant) {
    console.error(`simulator: --plant is required\n${USAGE}`);
    process.exit(2);
  }
  const stamp = () => new Date().toISOString().slice(11, 23);
  const quiet = opts.quiet;
  delete opts.quiet;
  opts.log = (line) => {
    if (!quiet || /fault|error|warning|ignored|stopped/.test(line)) console.log(`${stamp()} sim: ${line}`);
  };
  // The broker may come up after us: keep retrying instead of failing.
  opts.wait = false;

  let sim;
  try {
    sim = new Simulator(opts);
    await sim.start();
  } catch (err) {
    console.error(`simulator: ${err.message}`);
    process.exit(1);
  }
  let stopping = false;
  const shutdown = async (signal) => {
    if (stopping) process.exit(1); // second signal: no more waiting
    stopping = true;
    opts.log(`${signal}: stopping`);
    const force = setTimeout(() => process.exit(0), 4000);
    await sim.stop();
    clearTimeout(force);
    process.exit(0);
  };
  process.on('SIGINT', () => shutdown('SIGINT'));
  process.on('SIGTERM', () => shutdown('SIGTERM'));
}

if (require.main === module) main();

module.exports = { parseArgs };
