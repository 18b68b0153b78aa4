'use strict';
// The cloud-automation paper's controlled process (Hegazy & Hefeeda, §4 and
// §6: a flow loop whose controller runs away from the plant) as the commercial
// I/O module the paper reaches it through: a Modbus/TCP server whose analog
// output drives a valve and whose analog input reads the flow, 4-20 mA each.
// The process is first order, y' = (K·u − y)/τ, stepped every 50 ms; the
// network between the palette and the module adds a delay with jitter to
// every request and reply, so the pid's Smith predictor has a round trip to
// learn. Everything about it is in a plant document's `simulation.loop`:
//
//   "simulation": { "loop": { "output": "FCV-101", "sensor": "FT-101", "gain": 0.02, "tauS": 2,
//                             "initial": 0.69, "delayMs": 300, "jitterMs": 150, "noise": 0.002 } }
//
// `node scripts/simulator/cli.js --loop <file>` runs it (the file: that plant
// document, or a flow holding one sugarshack-plant node with it, such as the
// palette's modbus-pid-loop example).
const fs = require('fs');
const { ModbusServer } = require('./modbus');
const { checkedSide } = require('./plant');
const { stream } = require('./random');

const STEP_MS = 50;

/** The plant document of `file`: the document itself, or the one sugarshack-plant node of a flow. */
function loopPlant(file) {
  const data = JSON.parse(fs.readFileSync(file, 'utf8'));
  if (!Array.isArray(data)) return data;
  const plants = data.filter((n) => n.type === 'sugarshack-plant' && n.plant && n.plant.simulation && n.plant.simulation.loop);
  if (plants.length !== 1) throw new Error(`loop: ${file} holds ${plants.length} plant nodes with a simulation.loop, not one`);
  return plants[0].plant;
}

class FlowLoop {
  constructor(doc, { seed = 1, log = () => {} } = {}) {
    const spec = (doc.simulation || {}).loop;
    if (!spec) throw new Error('loop: the plant document has no simulation.loop');
    // Checked by the core (src/plant/simulation.rs), as a deploy checks it.
    this.side = checkedSide(doc);
    const owner = doc.devices.findIndex((d) => d.modbus && (d.modbus.outputs || []).some((o) => o.id === spec.output));
    this.sensor = doc.sensors.findIndex((s) => s.id === spec.sensor);
    this.spec = { initial: 0, delayMs: 0, jitterMs: 0, noise: 0, ...spec };
    this.device = owner;
    this.id = doc.devices[owner].id;
    this.log = log;
    this.rng = stream(seed, `${this.id}/loop`);
    this.y = this.spec.initial;
    this.u = this.spec.initial / this.spec.gain;
    const { delayMs, jitterMs } = this.spec;
    this.server = new ModbusServer({
      side: this.side,
      device: owner,
      endpoint: this.side.modbusEndpoint(owner),
      network: { delay: () => Math.max(0, delayMs + this.rng.symmetric(jitterMs)), drop: () => false },
      onWrite: (written) => {
        for (const w of written) if (w.output === spec.output) this.u = w.value;
      },
      log: (line) => this.log(`${this.id}: ${line}`),
    });
  }

  async start() {
    await this.server.listen();
    this.hold();
    this.at = performance.now();
    this.timer = setInterval(() => this.step(), STEP_MS);
    const { host, port } = this.server;
    this.log(`${this.id}: flow loop on modbus ${host}:${port} (K ${this.spec.gain}, tau ${this.spec.tauS} s, delay ${this.spec.delayMs} ± ${this.spec.jitterMs} ms)`);
  }

  step() {
    const now = performance.now();
    const dtS = (now - this.at) / 1000;
    this.at = now;
    this.y += (this.spec.gain * this.u - this.y) * (1 - Math.exp(-dtS / this.spec.tauS));
    this.hold();
  }

  /** The flow as the module's input holds it, with its measurement noise. */
  hold() {
    const measured = Math.max(0, this.y + this.rng.symmetric(this.spec.noise));
    this.server.hold(this.side.modbusImage(this.device, new Uint32Array(0), new Float64Array(0), Uint32Array.of(this.sensor), Float64Array.of(measured)));
  }

  async stop() {
    clearInterval(this.timer);
    await this.server.close();
  }
}

module.exports = { FlowLoop, loopPlant };
