'use strict';
// Reads the plant document into what the simulator needs: the devices to run,
// each actuator's output on its simulated panel, each station's datapoints and
// the optional `simulation` section. The document is first checked by the
// palette's core, as a deploy and the plant dialog check it: the simulator
// accepts and refuses the same documents, with the same words.
const fs = require('fs');
const path = require('path');

const { DeviceSide } = require(path.join(__dirname, '..', '..', 'node-red-contrib-sugarshack', 'wasm', 'sugarshack_wasm.js'));

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

/** The core's check of the document: its device side, or the core's refusal (every problem with its path). */
function checkedSide(doc) {
  try {
    return new DeviceSide(doc);
  } catch (err) {
    return fail(err.message);
  }
}

/**
 * Each actuator's output on its simulated panel: analog types move like
 * valves, binary ones switch like pumps. An actuator keeps its `io` when it
 * has one free on its panel; one without (ESPHome, Tasmota, Shelly and custom
 * devices are addressed by entity, not io) or with one taken gets the next
 * output above the panel's 16 valves / 1 pump. -> Map(id -> {family, slot})
 */
function assignSlots(doc) {
  const types = doc.actuatorTypes || {};
  const familyOf = (a) => (types[a.type] && types[a.type].signal === 'binary' ? 'pump' : 'valve');
  const used = new Map();
  const taken = (device, family) => {
    const key = `${device}/${family}`;
    if (!used.has(key)) used.set(key, new Set());
    return used.get(key);
  };
  const slots = new Map();
  const later = [];
  for (const a of doc.actuators || []) {
    const family = familyOf(a);
    const set = taken(a.device, family);
    if (Number.isInteger(a.io) && a.io >= 1 && !set.has(a.io)) {
      set.add(a.io);
      slots.set(a.id, { family, slot: a.io });
    } else {
      later.push([a, family]);
    }
  }
  for (const [a, family] of later) {
    const set = taken(a.device, family);
    const slot = Math.max(family === 'valve' ? PANEL_VALVES : PANEL_PUMPS, ...set) + 1;
    set.add(slot);
    slots.set(a.id, { family, slot });
  }
  return slots;
}

// -> { name, side (the core's DeviceSide), deviceKinds: Map(id -> kind), panels: [id],
//      panelSlots: {id: {valves: [slot], pumps: [slot]}}, stations: [{id, datapoints: [{name, unit, sensorId}]}],
//      actuators: {id: {id, type, family, device, io, slot, range: [min, max]}}, sensors: {id: {device, name}}, simulation }
function buildModel(doc) {
  const side = checkedSide(doc);
  const kinds = new Map(doc.devices.map((d) => [d.id, d.kind]));
  const slots = assignSlots(doc);
  const panelSlots = {};
  for (const [id, kind] of kinds) {
    if (kind === 'actuator-panel') panelSlots[id] = { valves: [...Array(PANEL_VALVES).keys()].map((i) => i + 1), pumps: [1] };
  }
  const actuators = {};
  for (const a of doc.actuators || []) {
    const { family, slot } = slots.get(a.id);
    const t = doc.actuatorTypes[a.type];
    const range = family === 'valve' ? [t.min ?? 0, t.max ?? 100] : [0, 1];
    actuators[a.id] = { id: a.id, type: a.type, family, device: a.device, io: a.io, slot, range };
    const list = panelSlots[a.device][family === 'valve' ? 'valves' : 'pumps'];
    if (!list.includes(slot)) list.push(slot);
  }
  for (const slots of Object.values(panelSlots)) for (const list of Object.values(slots)) list.sort((x, y) => x - y);

  const sensors = {};
  const byStation = new Map();
  for (const id of kinds.keys()) if (kinds.get(id) === 'sensor-station') byStation.set(id, new Map());
  const addDatapoint = (station, name, unit, sensorId) => {
    const map = byStation.get(station);
    if (!map.has(name)) map.set(name, { name, unit: unit || datapointDefaults(name).unit, sensorId });
  };
  for (const s of doc.sensors || []) {
    addDatapoint(s.device, s.name, s.unit, s.id);
    sensors[s.id] = { device: s.device, name: s.name };
  }

  const simulation = normalizeSimulation(doc.simulation || {}, { actuators, sensors, addDatapoint });

  for (const [station, map] of byStation) {
    if (map.size === 0) for (const name of defaultDatapoints(station)) addDatapoint(station, name);
  }

  return {
    name: doc.name || '',
    side,
    deviceKinds: kinds,
    panels: [...kinds].filter(([, k]) => k === 'actuator-panel').map(([id]) => id),
    panelSlots,
    stations: [...byStation].map(([id, map]) => ({ id, datapoints: [...map.values()] })),
    actuators,
    sensors,
    simulation,
  };
}

// A datapoint reference is either {"sensor": "<plant sensor id>"} or {"station", "datapoint"}.
function sensorRef(obj, ctx, datapointKey = 'datapoint') {
  if (obj.sensor !== undefined) {
    const s = ctx.sensors[obj.sensor];
    return { station: s.device, datapoint: s.name };
  }
  if (obj.station === undefined && obj[datapointKey] === undefined) return null;
  ctx.addDatapoint(obj.station, obj[datapointKey]);
  return { station: obj.station, datapoint: obj[datapointKey] };
}

// The section as the core checked it (src/plant/simulation.rs), built into tanks, transfers and baselines.
function normalizeSimulation(sim, ctx) {
  const tanks = {};
  for (const t of sim.tanks || []) {
    const volume = sensorRef(t, ctx);
    const level = t.level === undefined ? null
      : typeof t.level === 'string' ? sensorRef({ station: t.station, datapoint: t.level }, ctx)
        : sensorRef(t.level, ctx);
    tanks[t.id] = { id: t.id, capacityL: t.capacityL, initialL: t.initialL ?? 0, volume, level };
  }
  const transfers = (sim.transfers || []).map((x) => ({
    id: x.id || `${x.from || 'outside'}->${x.to || 'outside'}`,
    // null/absent = outside the plant (unlimited source or drain)
    from: x.from ?? null,
    to: x.to ?? null,
    pump: x.pump != null ? ctx.actuators[x.pump] : null,
    valves: (x.valves || []).map((v) => ctx.actuators[v]),
    rateLpm: x.rateLpm,
    flow: x.flow ? sensorRef(x.flow, ctx) : x.flowSensor ? sensorRef({ sensor: x.flowSensor }, ctx) : null,
  }));
  const signals = (sim.sensors || []).map((s) => ({ ...sensorRef(s, ctx), base: s.base, span: s.span }));
  return { tanks: Object.values(tanks), transfers, signals };
}

const PROFILES = ['sugarshack', 'esphome', 'tasmota', 'shelly-gen2', 'modbus'];
// The first Modbus server's port; the devices listen on consecutive ports, in document order.
const MODBUS_PORT = 5020;
// A 4-20 mA signal in µA, as an I/O module's analog channels hold it.
const FOUR_TO_TWENTY = [4000, 20000];

/**
 * Where a modbus panel keeps an actuator on output `slot`: an analog one on a
 * 4-20 mA output and input spanning its type's range, a binary one on a coil
 * and a discrete input.
 */
function modbusActuator(family, slot, type) {
  const address = slot - 1;
  if (family === 'pump') return { command: { kind: 'coil', address }, feedback: { kind: 'discrete', address } };
  const scale = { raw: FOUR_TO_TWENTY, value: [type.min ?? 0, type.max ?? 100] };
  return { command: { kind: 'holding', address, scale }, feedback: { kind: 'input', address, scale } };
}

/**
 * The document with every device speaking `profile`, entities named from each
 * actuator's output (Tasmota `Shutter3` / `POWER1`, Shelly `cover:2` / `switch:0`;
 * ESPHome's object ids come from the actuator ids) and sensors' from their
 * names. `modbus`: a Modbus TCP server per device on 127.0.0.1, from
 * `modbusPort` on in document order; each sensor a float in input registers
 * 100, 102... of its station. The palette must be given the same document.
 */
function withProfile(doc, profile, { modbusPort = MODBUS_PORT } = {}) {
  if (!PROFILES.includes(profile)) fail(`profile ${JSON.stringify(profile)} is not one of ${PROFILES.join(', ')}`);
  const out = JSON.parse(JSON.stringify(doc));
  const slots = assignSlots(out);
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
    const { family, slot } = slots.get(a.id);
    if (profile === 'tasmota') a.entity = family === 'pump' ? `POWER${slot}` : `Shutter${slot}`;
    if (profile === 'shelly-gen2') a.entity = family === 'pump' ? `switch:${slot - 1}` : `cover:${slot - 1}`;
    if (profile === 'modbus') a.modbus = modbusActuator(family, slot, (out.actuatorTypes || {})[a.type] || {});
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
  loadPlant, checkedSide, buildModel, withProfile, assignSlots, datapointDefaults, PANEL_VALVES, PANEL_PUMPS, PROFILES, MODBUS_PORT,
};
