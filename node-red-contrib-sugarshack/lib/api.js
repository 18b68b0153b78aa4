// @ts-check
'use strict';
// The palette's API for other packages (the OPC UA server of
// node-red-contrib-sugarshack-opcua is the first), in one place: what they may
// read of an interlock and its plant, how they hear of changes (by exception,
// once per turn of the event loop), and what they may do as a person (e-stop,
// clear, acknowledge, shelve, command a run), by the same paths as the editor's admin
// endpoints. Nothing else of the runtimes is theirs to touch. Node-RED hands
// it over as the plugin 'sugarshack-api' (plugins/api.js):
//
//   const api = RED.plugins.get('sugarshack-api').api;
//
// Everything is named by the interlock config node's id; its plant is the one
// it is bound to. Handles (actuators, devices, sensors) are positions in the
// plant's lists, valid until a change says `rebuilt`.
const { paletteOf, readyInterlock, notRunningInterlock, runCommandOf } = require('./host/lifecycle');
const { clock } = require('./host/clock');
const operator = require('./interlock/operator');
const wasm = require('./wasm');
const { SignIn } = require('./host/sign-in');

// Raised when something is added (2: command); nothing is taken away.
const VERSION = 2;

/** @param {NodeRed.RED} RED */
function paletteApi(RED) {
  const palette = paletteOf(RED);
  const signIn = new SignIn(RED);

  const plantOf = (interlockId) => {
    const il = readyInterlock(palette, interlockId);
    return il && il.plant && il.plant.state === 'ready' ? il.plant : null;
  };
  /** The running interlock, or a refusal as the admin endpoints give it. */
  const interlock = (id) => {
    const il = readyInterlock(palette, id);
    if (!il) return Promise.reject(notRunningInterlock(palette, id));
    return Promise.resolve(il);
  };

  return {
    version: VERSION,

    /** The longest shelf, in ms. */
    maxShelveMs: wasm.load().maxShelveMs(),

    /** An alarm's id, as the state API lists it: `kind:subject` (`line-faulted:YEL`). */
    alarmId: (kind, subject) => `${kind}:${subject}`,

    /** Each alarm kind's priority as OPC UA's Severity (1 to 1000), the core's: { 'line-faulted': 800, ... }. */
    alarmSeverities: wasm.load().alarmSeverities(),

    /** Interlock `id` as GET /sugarshack/state lists it ({ id, name, lines, queue, routines, runs, alarms, ... }), or null when it does not run. */
    interlock(id) {
      const il = readyInterlock(palette, id);
      if (!il) return null;
      return { id, name: il.owner ? il.owner.name || '' : '', draining: !il.gateOpen, ...il.described() };
    },

    /**
     * The plant interlock `id` is bound to, as its document says it, or null:
     * { id, name, document, actuators: [{ handle, id, type, device, io, binary, idle, lockout }],
     * devices: [id by handle], sensors: [{ handle, ...the document's entry }] }.
     */
    plant(id) {
      const plant = plantOf(id);
      if (!plant) return null;
      const doc = plant.plant;
      return {
        id: plant.id,
        name: plant.owner ? plant.owner.name || '' : '',
        document: doc,
        actuators: plant.actuators.map(({ deviceHandle, ...a }) => a),
        devices: [...plant.devices],
        sensors: plant.guard(() => (doc.sensors || []).map((s) => ({ handle: plant.t.sensor(s.id), ...s }))),
      };
    },

    /** Actuators `handles` now: [{ target, position, phase }] (null where never commanded or never reported). */
    actuators(id, handles) {
      const plant = plantOf(id);
      if (!plant) return null;
      return plant.guard(() => handles.map((h) => ({ target: nullable(plant.t.target(h)), position: nullable(plant.t.position(h)), phase: plant.t.phase(h) })));
    },

    /** Devices `handles` now: [{ online, stale: [actuator ids with stale feedback] }]. */
    devices(id, handles) {
      const plant = plantOf(id);
      if (!plant) return null;
      return plant.guard(() => handles.map((h) => {
        const health = plant.t.deviceHealth(h);
        return { online: health.online, stale: health.stale };
      }));
    },

    /** Every sensor now, by handle: [{ sensor, value, receivedMs, fresh, why }]. */
    sensors(id) {
      const plant = plantOf(id);
      return plant ? plant.guard(() => plant.t.health(clock.now()).sensors) : null;
    },

    /**
     * Calls `listener(ids)` once per turn in which interlocks or plants
     * changed (`ids`: their config node ids); returns the function that stops it.
     */
    onChange(listener) {
      const relay = (sources) => listener(new Set([...(sources || [])].map((r) => r.id)));
      palette.changes.on('changed', relay);
      return () => palette.changes.removeListener('changed', relay);
    },

    /**
     * Calls `listener({ actuators, devices, sensors, rebuilt })` (Sets of
     * handles) once per turn in which the plant of interlock `id` changed;
     * null when it has none running now.
     */
    onPlantChange(id, listener) {
      const il = readyInterlock(palette, id);
      return il && il.plant ? il.plant.changes.listen(listener) : null;
    },

    /** An emergency stop of `lines` by `who` ({ by, reason }); `note` when no reason is given. */
    estop: (id, lines, who, note) => interlock(id).then((il) => operator.estop(il, lines, who, note)),
    /** A clear of `lines` by `who` ({ by, reason, force }); refused with CLEAR_REFUSED and `err.lines`. */
    clear: (id, lines, who) => interlock(id).then((il) => operator.clear(il, lines, who)),
    acknowledge: (id, ids, who) => interlock(id).then((il) => operator.acknowledge(il, ids, who)),
    /** `shelf`: { untilMs, oneShot }. */
    shelve: (id, alarm, shelf, who) => interlock(id).then((il) => operator.shelve(il, alarm, shelf, who)),
    unshelve: (id, alarm, who) => interlock(id).then((il) => operator.unshelve(il, alarm, who)),
    /**
     * An ISA-88 command (`hold`, `restart`, `stop`, `abort`, `reset`) to
     * `target` ({ operation } or { routine }) by `who` ({ by, reason });
     * resolves { operation | routine, command, state, by } once saved, refused
     * with COMMAND_REFUSED (the state does not allow it), UNKNOWN_RUN or INVALID_INPUT.
     */
    command: (id, target, command, who) => interlock(id).then((il) => {
      const asked = runCommandOf({ ...target, command });
      return operator.command(il, asked.target, asked.command, who);
    }),
    /** The commands a run may be given, the core's list. */
    commands: wasm.load().operatorCommands(),

    /** What `username` with `password` may do under Node-RED's adminAuth ({ by, read, write }), or null. */
    signIn: (username, password) => signIn.check(username, password),
  };
}

const nullable = (v) => (v === undefined ? null : v);

module.exports = { paletteApi, VERSION };
