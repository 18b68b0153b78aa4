'use strict';
// The address space of one plant: an interlock and the plant bound to it, in
// the namespace NAMESPACE_URI (the reference page docs/reference/opcua.md
// lists every node):
//
//   Objects/Plant                    EStop, Clear (methods.js); the alarms' events
//     Lines/<line>                   State, Holder, Priority, Since, FaultCause, FaultNote, QueueLength, ClearBlockers
//     Queue                          Length, Operations, Priorities, Lines, Since
//     Operations/<id>                State (ISA-88), Commands, Priority, Lines, Description; Hold, Restart, Stop, Abort, Reset
//     Routines/<id>                  State, RunState (ISA-88), Halted, PendingOperation, PendingPhase, Commands; the same methods
//     Devices/<id>                   Online, Stale, Actuators, Positions, Targets, Phases
//     Actuators/<id>                 Position, Target, Phase (plants of up to `actuatorLimit` actuators)
//     Sensors/<id>                   AnalogItemType (BaseAnalogType when the document gives no range)
//     Alarms                         Count, NotExposed, and the conditions (conditions.js)
//
// Values change by exception: when the palette says the interlock changed (it
// is described again, and only what differs is set) and when its plant says
// which actuators, devices and sensors its core touched (only those are read).
// Nothing is read on a timer. Node ids are the browse paths (`s=Lines/YEL/State`),
// so a SCADA's tag list survives a restart.
const { DataType, VariantArrayType, StatusCodes } = require('node-opcua');
const { engineeringUnits } = require('./units');

const NAMESPACE_URI = 'https://github.com/sugarshack/sugarshack/UA/';
const ROOT = 'Plant';
// A plant document's sensor freshness is read again at most this often, on changes.
const SENSOR_RECHECK_MS = 1000;

/** A browse name as a node id segment: '/' and '%' escaped, so paths stay unique. */
const segment = (name) => String(name).replace(/%/g, '%25').replace(/\//g, '%2F');

class PlantModel {
  /**
   * addressSpace: node-opcua's; api: the palette's; interlockId: the interlock
   * served; actuatorLimit: actuators past which only the device arrays are made.
   */
  constructor({ addressSpace, api, interlockId, actuatorLimit, name }) {
    this.addressSpace = addressSpace;
    this.api = api;
    this.interlockId = interlockId;
    this.actuatorLimit = actuatorLimit;
    this.ns = addressSpace.registerNamespace(NAMESPACE_URI);
    /** @type {Map<string, any>} node by path */
    this.nodes = new Map();
    /** @type {Map<string, any>} the value last set, by path */
    this.values = new Map();
    this.structure = null; // what the address space was last built from
    this.sensorsReadMs = 0;
    const server = addressSpace.rootFolder.objects.server;
    this.root = this.ns.addObject({
      organizedBy: addressSpace.rootFolder.objects, browseName: ROOT, nodeId: `s=${ROOT}`, displayName: name || ROOT,
      eventNotifier: 1, eventSourceOf: server,
    });
    this.nodes.set(ROOT, this.root);
    for (const folder of ['Lines', 'Operations', 'Routines', 'Devices', 'Actuators', 'Sensors']) this.folder(folder);
    this.object(ROOT, 'Queue');
    this.object(ROOT, 'Alarms', { eventNotifier: 1 });
    this.variable('Queue', 'Length', DataType.UInt32);
    for (const [name, type] of [['Operations', DataType.String], ['Priorities', DataType.Int32], ['Lines', DataType.String], ['Since', DataType.DateTime]]) {
      this.variable('Queue', name, type, { array: true });
    }
    this.variable('Alarms', 'Count', DataType.UInt32);
    this.variable('Alarms', 'NotExposed', DataType.UInt32);
    this.plant = null; // api.plant(): ids and handles
    /** Called once per operation or routine object made: (path, { operation } or { routine }) (methods.js adds the commands). */
    this.onRunObject = null;
  }

  // ---- nodes ----------------------------------------------------------------

  folder(name) {
    const node = this.ns.addObject({ componentOf: this.root, typeDefinition: 'FolderType', browseName: name, nodeId: `s=${name}` });
    this.nodes.set(name, node);
    return node;
  }

  /** Object `name` under `parent` (a path), made once. */
  object(parent, name, { eventSource = false, eventNotifier = 0 } = {}) {
    const path = parent === ROOT ? segment(name) : `${parent}/${segment(name)}`;
    if (this.nodes.has(path)) return this.nodes.get(path);
    const parentNode = this.nodes.get(parent);
    const options = { browseName: name, nodeId: `s=${path}`, eventNotifier: eventSource ? 1 : eventNotifier };
    const node = parent === ROOT ? this.ns.addObject({ componentOf: parentNode, ...options }) : this.ns.addObject({ organizedBy: parentNode, ...options });
    // Alarms of a line or device have it as their source: its events reach the plant and the Server object.
    if (eventSource) this.root.addReference({ referenceType: 'HasEventSource', nodeId: node });
    this.nodes.set(path, node);
    return node;
  }

  /** Variable `name` of object `parent` (a path), read only, exception-based, made once. */
  variable(parent, name, dataType, { array = false, description } = {}) {
    const path = `${parent}/${segment(name)}`;
    if (this.nodes.has(path)) return this.nodes.get(path);
    const node = this.ns.addVariable({
      componentOf: this.nodes.get(parent), browseName: name, nodeId: `s=${path}`, dataType,
      valueRank: array ? 1 : -1, arrayDimensions: array ? [0] : undefined, minimumSamplingInterval: 0,
      accessLevel: 'CurrentRead', userAccessLevel: 'CurrentRead', description,
    });
    this.nodes.set(path, node);
    return node;
  }

  /** Sets a variable's value when it differs from the last one set; `statusCode` and `sourceTimestamp` as OPC UA has them. */
  set(path, dataType, value, { statusCode = StatusCodes.Good, sourceTimestamp = null } = {}) {
    const node = this.nodes.get(path);
    if (!node) return;
    const array = Array.isArray(value) || ArrayBuffer.isView(value);
    const last = this.values.get(path);
    if (last && last.statusCode === statusCode && sameValue(last.value, value)) return;
    this.values.set(path, { value: array ? Array.from(/** @type {any} */ (value)) : value, statusCode });
    // No value yet (an actuator never reported, a sensor never sampled): a Null variant with the status that says why.
    const variant = value === null && dataType !== DataType.DateTime
      ? { dataType: DataType.Null }
      : { dataType, arrayType: array ? VariantArrayType.Array : VariantArrayType.Scalar, value };
    node.setValueFromSource(variant, statusCode, sourceTimestamp || new Date());
  }

  // ---- structure: what the document and the interlock name ----------------------

  /**
   * Makes the nodes the interlock and its plant name now (once each), then
   * sets every value. Called at start and when the plant is rebuilt.
   */
  build() {
    const il = this.api.interlock(this.interlockId);
    const plant = this.api.plant(this.interlockId);
    this.plant = plant ? indexPlant(plant) : null;
    if (il) for (const line of il.lines || []) this.line(line.name);
    if (plant) this.buildPlant(plant);
    this.refreshInterlock(il);
    if (this.plant) this.refreshPlant({ all: true });
  }

  line(name) {
    const path = this.object('Lines', name, { eventSource: true }) && `Lines/${segment(name)}`;
    for (const [v, type] of [['State', DataType.String], ['Holder', DataType.String], ['Priority', DataType.Int32], ['Since', DataType.DateTime],
      ['FaultCause', DataType.String], ['FaultNote', DataType.String], ['QueueLength', DataType.UInt32]]) this.variable(path, v, type);
    this.variable(path, 'ClearBlockers', DataType.String, { array: true });
  }

  buildPlant(plant) {
    const doc = plant.document;
    for (const op of doc.operations || []) {
      const path = this.runObject('Operations', op.id, { operation: op.id });
      this.variable(path, 'State', DataType.String);
      this.variable(path, 'Commands', DataType.String, { array: true });
      this.variable(path, 'Priority', DataType.Int32);
      this.variable(path, 'Lines', DataType.String, { array: true });
      this.variable(path, 'Description', DataType.String);
      this.set(`${path}/Priority`, DataType.Int32, op.priority || 0);
      this.set(`${path}/Lines`, DataType.String, op.resources || []);
      this.set(`${path}/Description`, DataType.String, op.description || '');
    }
    for (const r of doc.routines || []) {
      const path = this.runObject('Routines', r.id, { routine: r.id });
      for (const [v, type] of [['State', DataType.String], ['Halted', DataType.Boolean], ['PendingOperation', DataType.String], ['PendingPhase', DataType.String]]) this.variable(path, v, type);
      this.variable(path, 'RunState', DataType.String);
      this.variable(path, 'Commands', DataType.String, { array: true });
    }
    for (const device of plant.devices) {
      const path = `Devices/${segment(device)}`;
      this.object('Devices', device, { eventSource: true });
      this.variable(path, 'Online', DataType.Boolean);
      this.variable(path, 'Stale', DataType.Boolean);
      this.variable(path, 'Actuators', DataType.String, { array: true });
      this.variable(path, 'Positions', DataType.Double, { array: true });
      this.variable(path, 'Targets', DataType.Double, { array: true });
      this.variable(path, 'Phases', DataType.String, { array: true });
      this.set(`${path}/Actuators`, DataType.String, this.plant.byDevice.get(device).map((h) => plant.actuators[h].id));
    }
    if (plant.actuators.length <= this.actuatorLimit) {
      for (const a of plant.actuators) {
        const path = `Actuators/${segment(a.id)}`;
        this.object('Actuators', a.id);
        this.variable(path, 'Position', DataType.Double);
        this.variable(path, 'Target', DataType.Double);
        this.variable(path, 'Phase', DataType.String);
      }
    }
    for (const s of plant.sensors) this.sensor(s);
  }

  /** An operation's or routine's object in `folder`, made once; its path. */
  runObject(folder, id, target) {
    const path = `${folder}/${segment(id)}`;
    const made = this.nodes.has(path);
    this.object(folder, id);
    if (!made && this.onRunObject) this.onRunObject(path, target);
    return path;
  }

  /** A sensor as an AnalogItem: its unit as EngineeringUnits, its min and max as EURange (a BaseAnalogType without them). */
  sensor(s) {
    const path = `Sensors/${segment(s.id)}`;
    if (this.nodes.has(path)) return;
    const units = engineeringUnits(s.unit);
    const common = { componentOf: this.nodes.get('Sensors'), browseName: s.id, nodeId: `s=${path}`, dataType: 'Double', minimumSamplingInterval: 0, accessLevel: 'CurrentRead', userAccessLevel: 'CurrentRead' };
    let node;
    if (typeof s.min === 'number' && typeof s.max === 'number') {
      node = this.ns.addAnalogDataItem({ ...common, engineeringUnitsRange: { low: s.min, high: s.max }, ...(units ? { engineeringUnits: units } : {}) });
    } else {
      node = this.ns.addVariable({ ...common, typeDefinition: 'BaseAnalogType' });
      if (units) {
        this.ns.addVariable({
          propertyOf: node, browseName: { name: 'EngineeringUnits', namespaceIndex: 0 }, dataType: 'EUInformation',
          typeDefinition: 'PropertyType', value: { dataType: DataType.ExtensionObject, value: units },
        });
      }
    }
    this.nodes.set(path, node);
  }

  // ---- values ------------------------------------------------------------------

  /** The interlock's lines, queue, operations and routines as described now (`il`: api.interlock(), or read here). */
  refreshInterlock(il = this.api.interlock(this.interlockId)) {
    if (!il) return null;
    const structure = (il.lines || []).map((l) => l.name).join('\u0000');
    if (structure !== this.structure) {
      this.structure = structure;
      for (const line of il.lines || []) this.line(line.name);
    }
    for (const line of il.lines || []) this.setLine(line);
    const queue = il.queue || [];
    this.set('Queue/Length', DataType.UInt32, queue.length);
    this.set('Queue/Operations', DataType.String, queue.map((q) => q.operation));
    this.set('Queue/Priorities', DataType.Int32, Int32Array.from(queue, (q) => q.priority));
    this.set('Queue/Lines', DataType.String, queue.map((q) => q.resources.join('+')));
    this.set('Queue/Since', DataType.DateTime, queue.map((q) => new Date(q.sinceMs)));
    if (this.plant) this.setOperations(il, queue);
    for (const r of il.routines || []) {
      const path = `Routines/${segment(r.id)}`;
      this.set(`${path}/State`, DataType.String, r.state || '');
      this.set(`${path}/Halted`, DataType.Boolean, Boolean(r.halted));
      this.set(`${path}/PendingOperation`, DataType.String, r.pending ? String(r.pending.operation) : '');
      this.set(`${path}/PendingPhase`, DataType.String, r.pending ? String(r.pending.phase) : '');
      this.set(`${path}/RunState`, DataType.String, r.runState || '');
      this.set(`${path}/Commands`, DataType.String, r.commands || []);
    }
    return il;
  }

  setLine(line) {
    const path = `Lines/${segment(line.name)}`;
    const { state, holder, fault } = line;
    this.set(`${path}/State`, DataType.String, state.state);
    this.set(`${path}/Holder`, DataType.String, holder ? holder.operation : '');
    this.set(`${path}/Priority`, DataType.Int32, holder ? holder.priority : 0);
    const since = holder ? holder.sinceMs : fault ? fault.sinceMs : null;
    this.set(`${path}/Since`, DataType.DateTime, since === null || since === undefined ? null : new Date(since));
    this.set(`${path}/FaultCause`, DataType.String, fault ? String(fault.cause) : '');
    this.set(`${path}/FaultNote`, DataType.String, fault && fault.note ? fault.note : '');
    this.set(`${path}/QueueLength`, DataType.UInt32, (line.waiting || []).length);
    this.set(`${path}/ClearBlockers`, DataType.String, (line.clearBlockers || []).map((b) => b.text));
  }

  /**
   * Each operation of the document: its run's ISA-88 state (running, held,
   * ...) and the commands it allows, aborted until reset, else queued or idle.
   */
  setOperations(il, queue) {
    const runs = new Map([...(il.aborted || []).map((a) => ({ ...a, state: 'aborted' })), ...(il.runs || [])].map((r) => [r.operation, r]));
    const holding = new Set((il.holds || []).map((h) => h.operation));
    const queued = new Set(queue.map((q) => q.operation));
    for (const op of this.plant.document.operations || []) {
      const run = runs.get(op.id);
      const fallback = holding.has(op.id) ? 'running' : queued.has(op.id) ? 'queued' : 'idle';
      const path = `Operations/${segment(op.id)}`;
      this.set(`${path}/State`, DataType.String, run && run.state ? run.state : fallback);
      this.set(`${path}/Commands`, DataType.String, run ? run.commands || [] : []);
    }
  }

  /**
   * What the plant's core touched (api.onPlantChange), or `{ all: true }`:
   * those actuators (and every one of a touched device), devices and sensors are read again.
   */
  refreshPlant(change) {
    const { plant } = this;
    if (!plant) return;
    const devices = new Set(change.all ? plant.devices.keys() : change.devices || []);
    const actuators = new Set(change.all ? plant.actuators.keys() : change.actuators || []);
    for (const h of actuators) devices.add(plant.actuators[h].deviceHandle);
    for (const d of change.devices || []) for (const h of plant.byDevice.get(plant.devices[d])) actuators.add(h);
    if (actuators.size) this.setActuators([...actuators]);
    if (devices.size) this.setDevices([...devices]);
    const now = Date.now();
    if (plant.sensors.length && (change.all || (change.sensors && change.sensors.size) || now - this.sensorsReadMs >= SENSOR_RECHECK_MS)) {
      this.sensorsReadMs = now;
      this.setSensors();
    }
  }

  setActuators(handles) {
    const { plant } = this;
    const values = this.api.actuators(this.interlockId, handles);
    if (!values) return;
    const perActuator = plant.actuators.length <= this.actuatorLimit;
    handles.forEach((h, i) => {
      const v = values[i];
      plant.positions[h] = v.position === null ? NaN : v.position;
      plant.targets[h] = v.target === null ? NaN : v.target;
      plant.phases[h] = v.phase;
      if (!perActuator) return;
      const path = `Actuators/${segment(plant.actuators[h].id)}`;
      this.set(`${path}/Position`, DataType.Double, v.position, { statusCode: v.position === null ? StatusCodes.BadWaitingForInitialData : StatusCodes.Good });
      this.set(`${path}/Target`, DataType.Double, v.target); // null (a Null value) until first commanded
      this.set(`${path}/Phase`, DataType.String, v.phase);
    });
  }

  setDevices(deviceHandles) {
    const { plant } = this;
    const health = this.api.devices(this.interlockId, deviceHandles);
    if (!health) return;
    deviceHandles.forEach((d, i) => {
      const id = plant.devices[d];
      const path = `Devices/${segment(id)}`;
      const members = plant.byDevice.get(id);
      this.set(`${path}/Online`, DataType.Boolean, health[i].online);
      this.set(`${path}/Stale`, DataType.Boolean, health[i].stale.length > 0);
      this.set(`${path}/Positions`, DataType.Double, Float64Array.from(members, (h) => plant.positions[h]));
      this.set(`${path}/Targets`, DataType.Double, Float64Array.from(members, (h) => plant.targets[h]));
      this.set(`${path}/Phases`, DataType.String, members.map((h) => plant.phases[h]));
    });
  }

  setSensors() {
    const sensors = this.api.sensors(this.interlockId);
    if (!sensors) return;
    for (const s of sensors) {
      const statusCode = s.value === null ? StatusCodes.BadWaitingForInitialData : s.fresh ? StatusCodes.Good : StatusCodes.UncertainLastUsableValue;
      this.set(`Sensors/${segment(s.sensor)}`, DataType.Double, s.value, { statusCode, sourceTimestamp: s.receivedMs === null ? null : new Date(s.receivedMs) });
    }
  }
}

/** The plant's ids by handle, its actuators per device, and the last values read (for the device arrays). */
function indexPlant(plant) {
  const deviceHandle = new Map(plant.devices.map((id, h) => [id, h]));
  const byDevice = new Map(plant.devices.map((id) => [id, []]));
  const actuators = plant.actuators.map((a) => ({ ...a, deviceHandle: deviceHandle.get(a.device) }));
  for (const a of actuators) byDevice.get(a.device).push(a.handle);
  const n = actuators.length;
  return {
    id: plant.id, document: plant.document, devices: plant.devices, sensors: plant.sensors, actuators, byDevice,
    positions: new Float64Array(n).fill(NaN), targets: new Float64Array(n).fill(NaN), phases: new Array(n).fill(''),
  };
}

function sameValue(a, b) {
  if (Array.isArray(a)) {
    if (!(Array.isArray(b) || ArrayBuffer.isView(b))) return false;
    const bb = /** @type {any} */ (b);
    if (a.length !== bb.length) return false;
    for (let i = 0; i < a.length; i++) if (!sameScalar(a[i], bb[i])) return false;
    return true;
  }
  return sameScalar(a, b);
}

function sameScalar(a, b) {
  if (a instanceof Date && b instanceof Date) return a.getTime() === b.getTime();
  return a === b || (Number.isNaN(a) && Number.isNaN(b));
}

module.exports = { PlantModel, NAMESPACE_URI, ROOT, segment };
