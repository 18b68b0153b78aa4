'use strict';
// Reads device msgs as core `mqtt in` delivers them (payload as text, Buffer or
// already-parsed JSON) into what the tracker takes: device, slot and value.
// Topics follow the plant contract; the device id is the topic prefix:
//   <dev>/status                  "online" | "offline"
//   <dev>/state                   {"ts", "<type>": {"<io>": value, ...}, ...}
//   <dev>/<type>/<io>/state       {"ts", "value"}
//   <dev>/sensor/<name>/state     {"ts", "value"}

/**
 * What a topic is: { kind: 'status' | 'batch' | 'single' | 'sensor' | 'other', device, type, io, name },
 * or null when it is not a device topic (the msg is then a command).
 * `isDevice(id)` says whether the plant names the device: any topic under a known
 * device (telemetry, our own commands) is device traffic.
 */
function classify(topic, isDevice) {
  if (typeof topic !== 'string') return null;
  const slash = topic.indexOf('/');
  if (slash <= 0) return null;
  const device = topic.slice(0, slash);
  const rest = topic.slice(slash + 1);
  if (rest === 'status') return { kind: 'status', device };
  if (rest === 'state') return { kind: 'batch', device };
  const parts = rest.split('/');
  const leaf = parts.length === 3 ? parts[2] : null;
  if (leaf === 'state' && parts[0] === 'sensor') return { kind: 'sensor', device, name: parts[1] };
  if (leaf === 'state') return { kind: 'single', device, type: parts[0], io: parts[1] };
  if (isDevice(device) || leaf === 'state' || leaf === 'command' || rest === 'telemetry') return { kind: 'other', device };
  return null;
}

class Malformed extends Error {
  constructor(reason, message) {
    super(message);
    this.reason = reason;
  }
}

function text(payload) {
  return Buffer.isBuffer(payload) ? payload.toString('utf8') : payload;
}

/** A JSON payload as a value (mqtt in "auto-detect" has parsed it already). */
function json(payload) {
  const value = text(payload);
  if (typeof value !== 'string') return value;
  try {
    return JSON.parse(value);
  } catch (err) {
    throw new Malformed('bad JSON', `payload is not JSON (${err.message}): ${clip(value)}`);
  }
}

/** A value as a short quote, whatever it is: JSON.stringify throws on a circular, deep or BigInt one. */
function clip(value) {
  let s;
  try {
    s = typeof value === 'string' ? value : JSON.stringify(value);
    if (s === undefined) s = String(value);
  } catch {
    s = typeof value; // even Array.isArray throws on a revoked proxy
  }
  return s.length > 60 ? `${s.slice(0, 57)}...` : s;
}

/** "online" -> true, "offline" -> false. */
function statusOf(payload) {
  const value = text(payload);
  if (value === 'online') return true;
  if (value === 'offline') return false;
  throw new Malformed('bad status', `status must be "online" or "offline", got ${clip(value)}`);
}

/** A sample as the tracker takes it: numbers as they are, booleans as 1/0; NaN when neither. */
function sampleValue(value) {
  if (typeof value === 'number') return Number.isFinite(value) ? value : NaN;
  if (typeof value === 'boolean') return value ? 1 : 0;
  return NaN;
}

/** The device's timestamp (ms), if it sent a usable one. */
function deviceTs(object) {
  const ts = object.ts;
  return typeof ts === 'number' && Number.isFinite(ts) && ts >= 0 ? ts : undefined;
}

function isObject(value) {
  return value !== null && typeof value === 'object' && !Array.isArray(value);
}

/** A batch: { ts, groups: [[type, { io: value }]] }. */
function batchOf(payload) {
  const value = json(payload);
  if (!isObject(value)) throw new Malformed('not an object', `a state batch must be a JSON object, got ${clip(value)}`);
  const groups = [];
  for (const key of Object.keys(value)) {
    if (key === 'ts') continue;
    groups.push([key, value[key]]);
  }
  return { ts: deviceTs(value), groups };
}

/** A single sample: {"ts", "value"}, or a bare number or boolean. */
function singleOf(payload) {
  const value = json(payload);
  if (isObject(value)) {
    const sample = sampleValue(value.value);
    if (Number.isNaN(sample)) throw new Malformed('non-numeric value', `value must be a number or a boolean, got ${clip(value.value)}`);
    return { ts: deviceTs(value), value: sample };
  }
  const sample = sampleValue(value);
  if (Number.isNaN(sample)) throw new Malformed('non-numeric value', `value must be a number or a boolean, got ${clip(value)}`);
  return { ts: undefined, value: sample };
}

/** An io number as in topics and batch keys ("12"), or null. */
function ioNumber(key) {
  return /^[1-9]\d{0,9}$/.test(key) && Number(key) <= 0xffffffff ? Number(key) : null;
}

module.exports = { classify, Malformed, statusOf, batchOf, singleOf, sampleValue, ioNumber, clip, isObject };
