// @ts-check
'use strict';
// The palette's runtimes (one per interlock and per plant config node) live in
// the Node-RED process, not in node instances, so a deploy is not a crash:
//
// - a deploy that leaves a config node's settings as they were hands the
//   running runtime to the new node instances (operations go on, nothing faults);
// - a deploy that changes them drains: new work waits, running operations
//   finish, then every changed runtime takes its new settings at once;
// - a shutdown freezes every runtime where it is: nothing changes the saved
//   state any more, so a restart sees what the plant last saw.
//
// A shutdown and a deploy both stop the flows; Node-RED replaces its active
// configuration object before a deploy's stop, not before a shutdown's.
const { clock } = require('./clock');
const { stateOf, ChangeNotices } = require('../state');
const { SugarshackError } = require('./errors');
const { text } = require('./i18n');
const { quote } = require('../interlock/request');
const { messageBufferMax } = require('../interlock/config');
const operator = require('../interlock/operator');
const wasm = require('../wasm');

const palettes = new WeakMap(); // RED.events -> Palette

class Palette {
  constructor(RED) {
    this.RED = RED;
    this.started = false;
    this.startedConfig = null;
    this.phase = 'starting'; // running | deploying | shutdown
    this.runtimes = new Map(); // config node id -> runtime
    this.swaps = new Map(); // runtime -> settings waiting for the drain
    this.drainCheck = false; // a look at the drain is queued
    this.afterStart = [];
    this.changes = new ChangeNotices();
    RED.events.on('flows:started', (event) => this.flowsStarted(event));
    RED.events.on('flows:stopping', (event) => this.flowsStopping(event));
  }

  flowsStarted(event) {
    this.started = true;
    this.startedConfig = event && event.config;
    this.phase = 'running';
    // Runtimes whose config node did not come back in this deploy were removed.
    for (const runtime of [...this.runtimes.values()]) {
      if (!runtime.owner) this.retire(runtime);
    }
    // What a restarted node held and it did not come back for is withdrawn (a first start has none).
    for (const runtime of this.runtimes.values()) runtime.deployEnds();
    for (const fn of this.afterStart.splice(0)) setImmediate(fn);
    if (this.swaps.size > 0) this.pokeDrain();
  }

  flowsStopping(event) {
    this.started = false;
    const deploying = Boolean(event && this.startedConfig && event.config !== this.startedConfig);
    this.phase = deploying ? 'deploying' : 'shutdown';
    if (deploying) for (const runtime of this.runtimes.values()) runtime.deployBegins();
    if (!deploying) {
      // Frozen where they are: a drain in progress ends with the process.
      this.swaps.clear();
    }
  }

  get shuttingDown() {
    return this.phase === 'shutdown';
  }

  /** Runs `fn` once every node of the current deploy has started. */
  whenStarted(fn) {
    if (this.started) setImmediate(fn);
    else this.afterStart.push(fn);
  }

  /**
   * The runtime of config node `id`: the running one when its settings key is
   * unchanged, the running one draining towards new settings when it changed,
   * or a new one from `create()`.
   */
  runtimeFor(id, key, settings, create) {
    const existing = this.runtimes.get(id);
    if (existing && !existing.ended) {
      existing.targetKey = key;
      if (existing.key !== key) this.requestSwap(existing, key, settings);
      return existing;
    }
    const runtime = create();
    runtime.key = key;
    runtime.targetKey = key;
    runtime.palette = this;
    this.runtimes.set(id, runtime);
    // Made while a drain goes on (a config node new in this deploy): it waits for the drain like the rest.
    if (this.draining) runtime.closeGate();
    return runtime;
  }

  /** Its config node closed: shutdown freezes, a removal retires, a restart waits for the new instance. */
  detach(runtime, node, removed) {
    if (runtime.owner !== node) return Promise.resolve();
    runtime.owner = null;
    if (this.shuttingDown) {
      this.forget(runtime);
      return runtime.shutdown();
    }
    if (removed) this.retire(runtime);
    return Promise.resolve();
  }

  retire(runtime) {
    this.swaps.delete(runtime);
    this.forget(runtime);
    runtime.retire();
    this.pokeDrain();
  }

  forget(runtime) {
    for (const [id, r] of this.runtimes) if (r === runtime) this.runtimes.delete(id);
  }

  // ---- draining towards new settings ----------------------------------------

  requestSwap(runtime, key, settings) {
    this.swaps.set(runtime, { key, settings });
    for (const r of this.runtimes.values()) r.closeGate();
    this.pokeDrain();
  }

  get draining() {
    return this.swaps.size > 0;
  }

  /**
   * A runtime may have become quiet (a run ended or was held, a group command
   * or a wait ended, a runtime left): the drain is looked at once this turn's
   * work is done. No timer: every path that ends the last of them pokes.
   */
  pokeDrain() {
    if (this.swaps.size === 0 || !this.started || this.drainCheck) return;
    this.drainCheck = true;
    setImmediate(() => {
      this.drainCheck = false;
      this.checkDrained();
    });
  }

  /** Every runtime quiet (no granted operation, no group command in flight): the changed ones swap, plants first. */
  checkDrained() {
    if (this.swaps.size === 0 || !this.started) return;
    const all = [...this.runtimes.values()];
    if (!all.every((r) => r.quiescent())) return;
    const swaps = [...this.swaps].sort(([a], [b]) => a.swapOrder - b.swapOrder);
    this.swaps.clear();
    const swapped = new Set();
    for (const [runtime, { key, settings }] of swaps) {
      runtime.key = key;
      runtime.swap(settings);
      swapped.add(runtime);
    }
    // An interlock bound to a swapped plant takes its lines from the new document, even if its own node kept its settings.
    for (const r of all) {
      if (r.plant && swapped.has(r.plant) && !swapped.has(r)) r.swap(r.settings);
    }
    for (const r of all) r.openGate();
  }
}

/** The palette's state in this Node-RED runtime; call at node registration. */
function paletteOf(RED) {
  let palette = palettes.get(RED.events);
  if (!palette) {
    palette = new Palette(RED);
    palettes.set(RED.events, palette);
  }
  // Once per admin app: a test harness makes a new one per load on the same runtime.
  serveState(RED, palette);
  return palette;
}

const served = new WeakSet();

/**
 * GET /sugarshack/state: every interlock's lines, holders, queue and routines,
 * every plant's devices, sensors and unconfirmed lockouts, as now (see state.js).
 * POST /sugarshack/clear and /sugarshack/estop: an operator's clear and
 * emergency stop from the editor, attributed to the signed-in editor user.
 * POST /sugarshack/alarms/ack, /shelve and /unshelve: the same for alarms.
 * POST /sugarshack/runs/command: an ISA-88 command (hold, restart, stop, abort,
 * reset) to a running operation or routine, the same way.
 * GET /sugarshack/access: what the caller may do here (read, write), as the
 * endpoints above decide it.
 */
function serveState(RED, palette) {
  if (!RED.httpAdmin || served.has(RED.httpAdmin)) return;
  served.add(RED.httpAdmin);
  RED.httpAdmin.get('/sugarshack/state', RED.auth.needsPermission('sugarshack.read'), (req, res) => {
    res.json(stateOf(palette));
  });
  const mayWrite = RED.auth.needsPermission('sugarshack.write');
  RED.httpAdmin.get('/sugarshack/access', RED.auth.needsPermission('sugarshack.read'), (req, res) => {
    // The write check of the endpoints above, on this same request: it calls on, or answers 401.
    const refused = { statusCode: 200, setHeader() {}, status() { return refused; }, end() { res.json({ read: true, write: false }); } };
    mayWrite(req, refused, () => res.json({ read: true, write: true }));
  });
  const operatorAction = (act) => (req, res) => {
    const body = req.body && typeof req.body === 'object' ? req.body : {};
    const runtime = readyInterlock(palette, body.interlock);
    if (!runtime) {
      const err = notRunningInterlock(palette, body.interlock);
      res.status(404).json({ code: err.code, message: err.message });
      return;
    }
    const lines = Array.isArray(body.lines) && body.lines.length <= 4096 && body.lines.every((l) => typeof l === 'string' && l.length <= 200)
      ? body.lines : null;
    const who = {
      by: req.user && typeof req.user.username === 'string' ? req.user.username : null,
      reason: typeof body.reason === 'string' ? body.reason.slice(0, 1000) : null,
      force: body.force === true,
    };
    let asked;
    try {
      asked = act(runtime, lines, who, body);
    } catch (err) {
      asked = Promise.reject(err);
    }
    asked.then((answer) => res.json(answer), (err) => {
      res.status(409).json({ code: err.code || 'INTERNAL', message: err.message, lines: err.lines || [] });
    });
  };
  RED.httpAdmin.post('/sugarshack/clear', mayWrite, operatorAction((rt, lines, who) => operator.clear(rt, lines, who)));
  RED.httpAdmin.post('/sugarshack/estop', mayWrite, operatorAction((rt, lines, who) => operator.estop(rt, lines, who, text('labels.editorEstop'))));
  RED.httpAdmin.post('/sugarshack/alarms/ack', mayWrite, operatorAction((rt, lines, who, body) => operator.acknowledge(rt, alarmIdsOf(body.ids), who)));
  RED.httpAdmin.post('/sugarshack/alarms/shelve', mayWrite, operatorAction((rt, lines, who, body) => {
    return operator.shelve(rt, alarmIdOf(body.id), { untilMs: shelfEndOf(body, clock.now()), oneShot: body.oneShot === true }, who);
  }));
  RED.httpAdmin.post('/sugarshack/alarms/unshelve', mayWrite, operatorAction((rt, lines, who, body) => operator.unshelve(rt, alarmIdOf(body.id), who)));
  RED.httpAdmin.post('/sugarshack/runs/command', mayWrite, operatorAction((rt, lines, who, body) => {
    const { target, command } = runCommandOf(body);
    return operator.command(rt, target, command, { by: who.by, reason: who.reason });
  }));
}

/** The interlock runtime of config node `id` when it runs, else null. */
function readyInterlock(palette, id) {
  const runtime = palette.runtimes.get(String(id || ''));
  return runtime && runtime.kind !== 'plant' && runtime.state === 'ready' ? runtime : null;
}

/** Why interlock `id` does not run here (readyInterlock gave null): on a hot standby, which instance acts instead. */
function notRunningInterlock(palette, id) {
  const shown = String(id).slice(0, 100);
  const runtime = palette.runtimes.get(String(id || ''));
  const cluster = runtime && runtime.state === 'standby' ? runtime.cluster : null;
  if (cluster) return SugarshackError.of('NO_INTERLOCK', 'standbyInterlock', { id: shown, active: cluster.leader ? cluster.leader.instance : '?' });
  return SugarshackError.of('NO_INTERLOCK', 'noRunningInterlock', { id: shown });
}

const MAX_RUN_ID = 200;

/**
 * What a person asks of a run, from `{ operation | routine, command }`:
 * `{ target: { operation } | { routine }, command }`. Only the shape is checked
 * here; whether the run's state allows the command is the core's to say.
 * @param {Record<string, any>} body
 * @returns {{ target: { operation?: string, routine?: string }, command: string }}
 */
function runCommandOf(body) {
  const { command } = body;
  const commands = wasm.load().operatorCommands();
  if (typeof command !== 'string' || !commands.includes(/** @type {any} */ (command))) {
    throw SugarshackError.of('INVALID_INPUT', 'runCommandInvalid', { got: quote(command), commands: commands.join(', ') });
  }
  const named = ['operation', 'routine'].filter((key) => body[key] !== undefined && body[key] !== null && body[key] !== '');
  const id = named.length === 1 ? body[named[0]] : undefined;
  if (!(typeof id === 'string' && id.length <= MAX_RUN_ID) && !(typeof id === 'number' && Number.isFinite(id))) {
    throw SugarshackError.of('INVALID_INPUT', 'runTargetInvalid', { got: quote(named.length === 1 ? id : named) });
  }
  return { target: { [named[0]]: String(id) }, command };
}

const MAX_ALARM_ID = 300;
const MAX_ALARM_IDS = 20000;

/** An alarm's id (`kind:subject`, as listed in the state). */
function alarmIdOf(id) {
  if (typeof id !== 'string' || id === '' || id.length > MAX_ALARM_ID) {
    throw SugarshackError.of('INVALID_INPUT', 'alarmIdInvalid', { got: JSON.stringify(id === undefined ? null : id).slice(0, 100) });
  }
  return id;
}

/** Alarm ids to acknowledge; absent: every unacknowledged one. */
function alarmIdsOf(ids) {
  if (ids === undefined || ids === null) return null;
  if (!Array.isArray(ids) || ids.length > MAX_ALARM_IDS) throw SugarshackError.of('INVALID_INPUT', 'alarmIdsInvalid', { max: MAX_ALARM_IDS });
  return ids.map(alarmIdOf);
}

/**
 * Until when a shelf lasts: `untilMs` (epoch ms) or `forMs` from now; a
 * one-shot shelf (`oneShot: true`) may leave both out: then the longest shelf.
 */
function shelfEndOf(body, now) {
  const { untilMs, forMs } = body;
  if (typeof untilMs === 'number' && Number.isFinite(untilMs)) return untilMs;
  if (typeof forMs === 'number' && Number.isFinite(forMs) && forMs > 0) return now + forMs;
  if (body.oneShot === true && untilMs === undefined && forMs === undefined) return now + wasm.load().maxShelveMs();
  throw SugarshackError.of('INVALID_SHELF', 'shelfUnbounded');
}

/**
 * The runtime behind config node `node` (see `Palette.runtimeFor`), attached to
 * it and started on first use; the node's close lets it go the way the close
 * asks (a shutdown freezes it, a removal retires it, a restart hands it over).
 */
function runtimeOfConfigNode(RED, node, key, settings, create) {
  const palette = paletteOf(RED);
  const runtime = palette.runtimeFor(node.id, key, settings, create);
  runtime.attach(node, messageBufferMax(RED));
  if (!runtime.started) {
    runtime.started = true;
    runtime.start();
  } else {
    runtime.refreshStatus();
  }
  node.on('close', (removed, done) => {
    palette.detach(runtime, node, removed).then(() => done(), (err) => {
      node.error(err);
      done();
    });
  });
  return runtime;
}

/** A stable text of the settings that decide a runtime's behaviour (object keys sorted). */
function settingsKey(value) {
  return JSON.stringify(value, (k, v) => (v && typeof v === 'object' && !Array.isArray(v)
    ? Object.fromEntries(Object.keys(v).sort().map((key) => [key, v[key]]))
    : v));
}

module.exports = { paletteOf, settingsKey, runtimeOfConfigNode, readyInterlock, notRunningInterlock, alarmIdOf, alarmIdsOf, shelfEndOf, runCommandOf };
