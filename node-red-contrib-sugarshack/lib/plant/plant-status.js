// @ts-check
'use strict';
// What the nodes of a plant show: on each, the core's counts of the actuators
// it serves (one core call per node), its bad and ignored msgs and offline
// devices; a refusal instead for a while; "draining" or "mqtt down" when that
// is what matters. Paced: at plant scale the counts move hundreds of times a second.
const { actuatorStatus, errorStatus, status } = require('../host/status');
const { clock } = require('../host/clock');
const { drainingStatus } = require('../host/runtime-base');
const i18n = require('../host/i18n');
const { StatusPacer } = require('../host/status-pacer');

// How long a refusal shows on an actuators node before its counts come back.
const BUS_ERROR_MS = 10000;

class PlantStatus {
  /** plant: the PlantRuntime (its core `t`, users, bus, status board). */
  constructor(plant) {
    this.plant = plant;
    this.sticky = new Map(); // node -> { status, until }: a refusal shown instead of the counts
    this.countsShown = new WeakMap(); // node -> { figures, key }: the counts its status shows
    this.pacer = new StatusPacer(() => plant.refreshStatus(), () => plant.state === 'ready'); // after feedback
  }

  /** A status update soon (paced): after feedback that changed counts. */
  request() {
    this.pacer.request();
  }

  stop() {
    this.pacer.stop();
  }

  /** A node's command was accepted, or the node left: no refusal shows on it any more. */
  dropRefusal(node) {
    this.sticky.delete(node);
  }

  /** When the first refusal shown for a while ends (the plant's timer then shows the counts again), or Infinity. */
  shownUntil() {
    let until = Infinity;
    for (const { until: end } of this.sticky.values()) until = Math.min(until, end);
    return until;
  }

  /** A short reason in a red ring: on an actuators node for a while, on other nodes until their next accepted command. */
  showError(node, code) {
    const shown = errorStatus(code);
    const bus = this.plant.bus.of(node);
    this.sticky.set(node, { status: shown, until: bus ? clock.now() + BUS_ERROR_MS : Infinity });
    this.plant.statusBoard.set(node, shown);
    if (bus) this.plant.arm();
  }

  /** `allCounts`: the core's counts of every actuator, when the call that changed them answered them. */
  refresh(only, allCounts) {
    const { plant } = this;
    const board = plant.statusBoard;
    if (plant.palette) plant.palette.changes.touch(plant);
    const nodes = only ? [only] : plant.users;
    if (plant.state === 'failed') {
      for (const node of nodes) board.set(node, errorStatus(plant.failure.code));
      return;
    }
    if (plant.state !== 'ready') return;
    const now = clock.now();
    let all = null;
    for (const node of nodes) {
      const sticky = this.sticky.get(node);
      if (sticky && sticky.until > now) {
        board.set(node, sticky.status);
        continue;
      }
      if (sticky) this.sticky.delete(node);
      if (!plant.gateOpen) {
        board.set(node, drainingStatus());
        continue;
      }
      const bus = plant.bus.of(node);
      if (bus && bus.connected === false) {
        board.set(node, status('error', i18n.text('status.mqttDown')));
        continue;
      }
      let counts;
      if (bus && bus.devices) {
        counts = this.countsOn(bus);
      } else {
        if (!all) all = countsOf(allCounts || plant.t.counts());
        counts = all;
      }
      const offline = counts.offline;
      const bad = bus ? bus.bad : 0;
      const ignored = bus ? bus.ignored : 0;
      // The same counts as last shown on this node: no text to make again (hundreds of changes a second at plant scale).
      const seen = this.countsShown.get(node);
      const figures = [counts.moving, counts.stopped, counts.faulted, counts.lockouts, bad, ignored, offline];
      if (seen && board.shown.get(node) === seen.key && figures.every((n, i) => n === seen.figures[i])) continue;
      board.set(node, actuatorStatus({ ...counts, bad, ignored }, { offline }));
      this.countsShown.set(node, { figures, key: board.shown.get(node) });
    }
  }

  /** Counts of the actuators on a bus's devices (phases and unconfirmed lockouts, kept by the core). */
  countsOn(bus) {
    return countsOf(this.plant.t.countsOn(bus.deviceHandles));
  }
}

/** The core's counts as the actuators status reads them. */
function countsOf(c) {
  return { moving: c.moving, stopped: c.stopped, faulted: c.faulted, lockouts: c.lockoutsPending, offline: c.offlineDevices };
}

module.exports = { PlantStatus };
