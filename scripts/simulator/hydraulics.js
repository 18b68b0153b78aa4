'use strict';
// Tanks and transfer lines. A transfer flows when its pump runs (or it has
// none: gravity) and all its valves are open; the rate scales with the least
// open valve, and stops when the source is empty or the destination full.
// Deterministic: it only reads actuator positions and the step length.

class Hydraulics {
  constructor(simulation) {
    this.tanks = new Map(simulation.tanks.map((t) => [t.id, { ...t, volumeL: t.initialL }]));
    this.transfers = simulation.transfers.map((x) => ({ ...x, rateLpm: x.rateLpm, currentLpm: 0 }));
  }

  // readValve(device, slot) -> position %, readPump(device, slot) -> running
  step(dtS, readValve, readPump) {
    if (!(dtS > 0)) return;
    for (const x of this.transfers) {
      let opening = 1;
      for (const v of x.valves) opening = Math.min(opening, Math.max(0, readValve(v.device, v.slot)) / 100);
      const driven = x.pump ? readPump(x.pump.device, x.pump.slot) : true;
      let litres = driven ? (x.rateLpm * opening * dtS) / 60 : 0;
      const from = x.from && this.tanks.get(x.from);
      const to = x.to && this.tanks.get(x.to);
      if (from) litres = Math.min(litres, from.volumeL);
      if (to) litres = Math.min(litres, to.capacityL - to.volumeL);
      litres = Math.max(0, litres);
      if (from) from.volumeL -= litres;
      if (to) to.volumeL += litres;
      x.currentLpm = (litres * 60) / dtS;
    }
  }

  // station -> datapoint -> value, for the datapoints the hydraulics drive
  readings() {
    const out = new Map();
    const put = (ref, value) => {
      if (!ref) return;
      if (!out.has(ref.station)) out.set(ref.station, new Map());
      const m = out.get(ref.station);
      // a flow sensor shared by several transfers reads their sum
      m.set(ref.datapoint, (m.get(ref.datapoint) || 0) + value);
    };
    for (const t of this.tanks.values()) {
      put(t.volume, t.volumeL);
      put(t.level, (100 * t.volumeL) / t.capacityL);
    }
    for (const x of this.transfers) put(x.flow, x.currentLpm);
    return out;
  }

  snapshot() {
    return {
      tanks: Object.fromEntries([...this.tanks.values()].map((t) => [t.id, t.volumeL])),
      transfers: Object.fromEntries(this.transfers.map((x) => [x.id, x.currentLpm])),
    };
  }
}

module.exports = { Hydraulics };
