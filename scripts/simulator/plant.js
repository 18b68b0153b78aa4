'use strict';
// Reads the plant document into what the simulator needs: the devices to run,
// the actuator id -> device/io map, each station's datapoints and the
// optional `simulation` section (validated here so typos fail at start).
const fs = require('fs');

const PANEL_VALVES = 16;
const PANEL_PUMPS = 1;

// Datapoint defaults by name. `span` scales noise (noise amplitudes are % of span).
const DATAPOINTS = {
  volume: { unit: 'L', base: 5000, span: 20000, decimals: 0, min: 0 },
  level: { unit: '%', base: 50, span: 100, decimals: 1, min: 0, max: 100 },
  flow: { unit: 'L/min', base: 0, span: 1000, decimals: 1, min: 0 },
  temperature: { unit: '°C', base: 4, span: 120, decimals: 1 },
  conductivity: { unit: 'µS/cm', base: 150, span: 2000, decimals: 0, min: 0 },
  brix: { unit: '°Bx', base: 2.5, span: 70, decimals: 2, min: 0 },
  ph: { unit: 'pH', base: 6.8, span: 14, decimals: 2, min: 0, max: 14 },
  pressure: { unit: 'kPa', base: 0, span: 600, decimals: 1, min: 0 },
  viscosity: { unit: 'cP', base: 1.5, span: 200, decimals: 2, min: 0 },
};
const GENERIC = { unit: '', base: 0, span: 100, decimals: 2 };

function datapointDefaults(name) {
  const key = String(name).toLowerCase();
  if (DATAPOINTS[key]) return DATAPOINTS[key];
  const hit = Object.keys(DATAPOINTS).find((k) => key.includes(k));
  return hit ? DATAPOINTS[hit] : GENERIC;
}

// Stations the document lists without sensors still publish a few datapoints.
function defaultDatapoints(stationId) {
  const n = Number((/(\d+)$/.exec(stationId) || [])[1]) || 0;
  const extra = ['conductivity', 'brix', 'level'][n % 3];
  return ['volume', 'flow', 'temperature', extra];
}

function fail(msg) {
  throw new Error(`plant: ${msg}`);
}

function loadPlant(source) {
  if (source && typeof source === 'object') return source;
  if (typeof source !== 'string' || !source) fail('no plant document given');
  let text;
  try {
    text = fs.readFileSync(source, 'utf8');
  } catch (err) {
    fail(`cannot read ${source}: ${err.message}`);
  }
  try {
    return JSON.parse(text);
  } catch (err) {
    fail(`${source} is not JSON: ${err.message}`);
  }
  return null;
}

// -> { name, deviceKinds: Map(id -> kind), panels: [id], stations: [{id, datapoints: [{name, unit, sensorId}]}],
//      actuators: {id: {type, device, io}}, sensors: {id: {device, name}}, simulation }
function buildModel(doc, warn = () => {}) {
  if (!doc || typeof doc !== 'object') fail('document must be a JSON object');
  const devices = Array.isArray(doc.devices) ? doc.devices : fail('`devices` must be an array');
  const kinds = new Map();
  for (const d of devices) {
    if (!d || typeof d.id !== 'string' || !d.id) fail('every device needs a string `id`');
    if (kinds.has(d.id)) fail(`device ${d.id} listed twice`);
    if (d.kind !== 'actuator-panel' && d.kind !== 'sensor-station') {
      warn(`device ${d.id}: kind ${JSON.stringify(d.kind)} is not simulated`);
      continue;
    }
    kinds.set(d.id, d.kind);
  }

  const actuators = {};
  for (const a of doc.actuators || []) {
    if (!a || typeof a.id !== 'string') fail('every actuator needs a string `id`');
    if (kinds.get(a.device) !== 'actuator-panel') fail(`actuator ${a.id}: device ${a.device} is not an actuator panel`);
    const max = a.type === 'valve' ? PANEL_VALVES : a.type === 'pump' ? PANEL_PUMPS : 0;
    if (!max) fail(`actuator ${a.id}: type ${JSON.stringify(a.type)} is neither valve nor pump`);
    if (!Number.isInteger(a.io) || a.io < 1 || a.io > max) fail(`actuator ${a.id}: io must be 1..${max}`);
    actuators[a.id] = { id: a.id, type: a.type, device: a.device, io: a.io };
  }

  const sensors = {};
  const byStation = new Map();
  for (const id of kinds.keys()) if (kinds.get(id) === 'sensor-station') byStation.set(id, new Map());
  const addDatapoint = (station, name, unit, sensorId) => {
    const map = byStation.get(station);
    if (!map) fail(`datapoint ${name}: device ${station} is not a sensor station`);
    if (typeof name !== 'string' || !/^[A-Za-z0-9_-]+$/.test(name)) fail(`station ${station}: datapoint name ${JSON.stringify(name)} must be [A-Za-z0-9_-]`);
    if (!map.has(name)) map.set(name, { name, unit: unit || datapointDefaults(name).unit, sensorId });
  };
  for (const s of doc.sensors || []) {
    if (!s || typeof s.id !== 'string') fail('every sensor needs a string `id`');
    addDatapoint(s.device, s.name, s.unit, s.id);
    sensors[s.id] = { device: s.device, name: s.name };
  }

  const simulation = normalizeSimulation(doc.simulation || {}, { actuators, sensors, addDatapoint });

  for (const [station, map] of byStation) {
    if (map.size === 0) for (const name of defaultDatapoints(station)) addDatapoint(station, name);
  }

  return {
    name: doc.name || '',
    deviceKinds: kinds,
    panels: [...kinds].filter(([, k]) => k === 'actuator-panel').map(([id]) => id),
    stations: [...byStation].map(([id, map]) => ({ id, datapoints: [...map.values()] })),
    actuators,
    sensors,
    simulation,
  };
}

// A sensor reference is either {"sensor": "<plant sensor id>"} or {"station", "datapoint"}.
function sensorRef(obj, where, ctx, datapointKey = 'datapoint') {
  if (obj.sensor !== undefined) {
    const s = ctx.sensors[obj.sensor];
    if (!s) fail(`simulation ${where}: unknown sensor ${obj.sensor}`);
    return { station: s.device, datapoint: s.name };
  }
  if (obj.station === undefined && obj[datapointKey] === undefined) return null;
  ctx.addDatapoint(obj.station, obj[datapointKey]);
  return { station: obj.station, datapoint: obj[datapointKey] };
}

function normalizeSimulation(sim, ctx) {
  if (typeof sim !== 'object' || Array.isArray(sim)) fail('`simulation` must be an object');
  const tanks = {};
  for (const t of sim.tanks || []) {
    if (!t || typeof t.id !== 'string') fail('simulation: every tank needs a string `id`');
    if (tanks[t.id]) fail(`simulation: tank ${t.id} listed twice`);
    const capacityL = Number(t.capacityL);
    if (!(capacityL > 0)) fail(`simulation tank ${t.id}: capacityL must be > 0`);
    const initialL = t.initialL === undefined ? 0 : Number(t.initialL);
    if (!(initialL >= 0 && initialL <= capacityL)) fail(`simulation tank ${t.id}: initialL must be 0..capacityL`);
    const volume = sensorRef(t, `tank ${t.id}`, ctx);
    const level = t.level === undefined ? null
      : typeof t.level === 'string' ? sensorRef({ station: t.station, datapoint: t.level }, `tank ${t.id}`, ctx)
        : sensorRef(t.level, `tank ${t.id} level`, ctx);
    tanks[t.id] = { id: t.id, capacityL, initialL, volume, level };
  }
  const transfers = [];
  (sim.transfers || []).forEach((x, i) => {
    const where = `transfer ${x && x.id ? x.id : i}`;
    if (!x || typeof x !== 'object') fail(`simulation ${where}: must be an object`);
    for (const end of ['from', 'to']) {
      // null/absent = outside the plant (unlimited source or drain)
      if (x[end] != null && !tanks[x[end]]) fail(`simulation ${where}: unknown tank ${x[end]}`);
    }
    let pump = null;
    if (x.pump != null) {
      pump = ctx.actuators[x.pump];
      if (!pump || pump.type !== 'pump') fail(`simulation ${where}: ${x.pump} is not a pump in \`actuators\``);
    }
    const valves = (x.valves || []).map((v) => {
      const a = ctx.actuators[v];
      if (!a || a.type !== 'valve') fail(`simulation ${where}: ${v} is not a valve in \`actuators\``);
      return a;
    });
    const rateLpm = Number(x.rateLpm);
    if (!(rateLpm > 0)) fail(`simulation ${where}: rateLpm must be > 0`);
    const flow = x.flow ? sensorRef(x.flow, where, ctx) : x.flowSensor ? sensorRef({ sensor: x.flowSensor }, where, ctx) : null;
    transfers.push({ id: x.id || `${x.from || 'outside'}->${x.to || 'outside'}`, from: x.from ?? null, to: x.to ?? null, pump, valves, rateLpm, flow });
  });
  const signals = (sim.sensors || []).map((s, i) => {
    const ref = sensorRef(s, `sensors[${i}]`, ctx);
    if (!ref) fail(`simulation sensors[${i}]: give \`sensor\` or \`station\` + \`datapoint\``);
    return { ...ref, base: s.base, span: s.span };
  });
  return { tanks: Object.values(tanks), transfers, signals };
}

const PROFILES = ['sugarshack', 'esphome', 'tasmota', 'shelly-gen2', 'modbus'];
// The first Modbus server's port; the devices listen on consecutive ports, in document order.
const MODBUS_PORT = 5020;
// A 4-20 mA signal in µA, as an I/O module's analog channels hold it.
const FOUR_TO_TWENTY = [4000, 20000];

/** Where a modbus panel keeps an actuator: a valve on a 4-20 mA output and input, a pump on a coil and a discrete input. */
function modbusActuator(a) {
  const address = a.io - 1;
  if (a.type === 'pump') return { command: { kind: 'coil', address }, feedback: { kind: 'discrete', address } };
  const scale = { raw: FOUR_TO_TWENTY, value: [0, 100] };
  return { command: { kind: 'holding', address, scale }, feedback: { kind: 'input', address, scale } };
}

/**
 * The document with every device speaking `profile`, entities named from each
 * actuator's io (Tasmota `Shutter3` / `POWER1`, Shelly `cover:2` / `switch:0`;
 * ESPHome's object ids come from the actuator ids) and sensors' from their
 * names. `modbus`: a Modbus TCP server per device on 127.0.0.1, from
 * `modbusPort` on in document order; each sensor a float in input registers
 * 100, 102... of its station. The palette must be given the same document.
 */
function withProfile(doc, profile, { modbusPort = MODBUS_PORT } = {}) {
  if (!PROFILES.includes(profile)) fail(`profile ${JSON.stringify(profile)} is not one of ${PROFILES.join(', ')}`);
  const out = JSON.parse(JSON.stringify(doc));
  (out.devices || []).forEach((d, i) => {
    delete d.prefix;
    delete d.custom;
    delete d.modbus;
    if (profile === 'sugarshack') delete d.profile;
    else d.profile = profile;
    if (profile === 'modbus') d.modbus = { host: '127.0.0.1', port: modbusPort + i, unit: 1, pollMs: 500, timeoutMs: 500 };
  });
  for (const a of out.actuators || []) {
    delete a.entity;
    delete a.component;
    delete a.modbus;
    if (profile === 'tasmota') a.entity = a.type === 'pump' ? `POWER${a.io}` : `Shutter${a.io}`;
    if (profile === 'shelly-gen2') a.entity = a.type === 'pump' ? `switch:${a.io - 1}` : `cover:${a.io - 1}`;
    if (profile === 'modbus') a.modbus = modbusActuator(a);
  }
  const perStation = new Map();
  for (const s of out.sensors || []) {
    delete s.entity;
    delete s.modbus;
    if (profile === 'shelly-gen2') s.entity = `${s.name}:0.value`;
    if (profile === 'modbus') {
      const n = perStation.get(s.device) || 0;
      perStation.set(s.device, n + 1);
      s.modbus = { kind: 'input', address: 100 + 2 * n, type: 'f32' };
    }
  }
  return out;
}

module.exports = {
  loadPlant, buildModel, withProfile, datapointDefaults, PANEL_VALVES, PANEL_PUMPS, PROFILES, MODBUS_PORT,
};
