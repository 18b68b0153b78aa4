'use strict';
// Fault descriptions: the JSON form (sim/control, inject()) and the CLI form
// (`--fault stuck:ctrl-1:3`). Both end up as one normalized object.

const KINDS = ['stuck', 'slow', 'dead', 'revive', 'disconnect', 'noisy', 'drop', 'drift', 'clear'];

// CLI: kind[:target[:arg[:arg]]], target = device id or plant actuator id.
//   stuck:ctrl-1:3   stuck:V103   stuck:P1   slow:ctrl-1:3:10   slow:V103:10
//   dead:station-4   revive:station-4   noisy:ctrl-2:8   drop:ctrl-3:0.3
//   drift:ctrl-1:5:40   drift:V105:40   disconnect:ctrl-1:3000   clear   clear:ctrl-1
function parseFaultArg(text, model) {
  const parts = String(text).split(':');
  const fault = { fault: parts.shift() };
  if (!KINDS.includes(fault.fault)) throw new Error(`fault ${JSON.stringify(text)}: unknown kind (${KINDS.join(', ')})`);
  if (parts.length === 0) return normalizeFault(fault, model);
  const target = parts.shift();
  const actuator = model.actuators[target];
  if (actuator) {
    fault.actuator = target;
  } else {
    fault.device = target;
    if (['stuck', 'slow', 'drift'].includes(fault.fault)) {
      const io = parts.shift();
      if (io === undefined) throw new Error(`fault ${JSON.stringify(text)}: needs a valve io (or an actuator id)`);
      fault.valve = Number(io);
    }
  }
  const arg = parts.shift();
  if (arg !== undefined) {
    const key = { slow: 'factor', noisy: 'amplitude', drop: 'ratio', drift: 'to', disconnect: 'forMs' }[fault.fault];
    if (!key) throw new Error(`fault ${JSON.stringify(text)}: unexpected argument ${arg}`);
    fault[key] = Number(arg);
  }
  if (parts.length) throw new Error(`fault ${JSON.stringify(text)}: too many fields`);
  try {
    return normalizeFault(fault, model);
  } catch (err) {
    throw new Error(`fault ${JSON.stringify(text)}: ${err.message}`);
  }
}

function num(value, name, lo, hi) {
  const n = Number(value);
  if (value === undefined || value === null || value === '' || !Number.isFinite(n) || n < lo || n > hi) {
    throw new Error(`${name} must be a number in ${lo}..${hi}`);
  }
  return n;
}

// Throws with a readable message when the fault cannot apply to this plant.
function normalizeFault(input, model) {
  if (!input || typeof input !== 'object' || Array.isArray(input)) throw new Error('fault must be a JSON object');
  const f = { fault: input.fault };
  if (!KINDS.includes(f.fault)) throw new Error(`unknown fault ${JSON.stringify(input.fault)} (${KINDS.join(', ')})`);
  let device = input.device;
  let valve = input.valve;
  let pump = input.pump;
  if (input.actuator !== undefined) {
    const a = model.actuators[input.actuator];
    if (!a) throw new Error(`unknown actuator ${input.actuator}`);
    device = a.device;
    if (a.family === 'valve') valve = a.slot;
    else pump = a.slot;
  }
  if (f.fault === 'clear' && device === undefined) return f;
  if (typeof device !== 'string' || !model.deviceKinds.has(device)) throw new Error(`unknown device ${JSON.stringify(device)}`);
  f.device = device;
  const kind = model.deviceKinds.get(device);
  const needsActuator = ['stuck', 'slow', 'drift'].includes(f.fault);
  if (needsActuator) {
    if (kind !== 'actuator-panel') throw new Error(`${f.fault}: ${device} is not an actuator panel`);
    const slots = model.panelSlots[device];
    if (pump !== undefined && f.fault === 'stuck') {
      f.pump = Number(pump);
      if (!slots.pumps.includes(f.pump)) throw new Error(`pump must be one of ${device}'s pumps (${slots.pumps.join(', ')})`);
    } else {
      f.valve = Number(valve);
      if (valve === undefined || valve === null || valve === '' || !slots.valves.includes(f.valve)) {
        throw new Error(`valve must be one of ${device}'s valve outputs (1..16${slots.valves.length > 16 ? `, ${slots.valves.slice(16).join(', ')}` : ''})`);
      }
    }
  }
  if (f.fault === 'slow') f.factor = num(input.factor ?? 10, 'factor', 1, 1e6);
  if (f.fault === 'drift') f.to = num(input.to, 'to', 0, 100);
  if (f.fault === 'noisy') f.amplitude = num(input.amplitude ?? 8, 'amplitude', 0, 100);
  if (f.fault === 'drop') f.ratio = num(input.ratio ?? 0.3, 'ratio', 0, 1);
  if (f.fault === 'disconnect') f.forMs = num(input.forMs ?? 3000, 'forMs', 0, 86400000);
  return f;
}

module.exports = { parseFaultArg, normalizeFault, KINDS };
