// @ts-check
'use strict';
// The one clock of the palette's runtimes: every time they read and every timer
// they set goes through here, so tests can drive time instead of waiting for it.
// The core never reads a clock; the JS passes it `clock.now()`.

class SystemClock {
  now() {
    return Date.now();
  }

  setTimeout(fn, ms) {
    return setTimeout(fn, ms);
  }

  clearTimeout(handle) {
    clearTimeout(handle);
  }

  setInterval(fn, ms) {
    return setInterval(fn, ms);
  }

  clearInterval(handle) {
    clearInterval(handle);
  }
}

/**
 * A clock that moves only when told: `advance(ms)` runs every timer due in that
 * span, in due order, with `now()` at each timer's due time.
 */
class ManualClock {
  constructor(startMs = 1_700_000_000_000) {
    this.ms = startMs;
    this.timers = new Map(); // id -> { due, fn, every }
    this.nextId = 1;
  }

  now() {
    return this.ms;
  }

  setTimeout(fn, ms) {
    return this.add(fn, ms, 0);
  }

  setInterval(fn, ms) {
    return this.add(fn, ms, Math.max(1, Number(ms) || 0));
  }

  clearTimeout(handle) {
    if (handle) this.timers.delete(handle.id);
  }

  clearInterval(handle) {
    this.clearTimeout(handle);
  }

  add(fn, ms, every) {
    const id = this.nextId++;
    this.timers.set(id, { due: this.ms + Math.max(0, Number(ms) || 0), fn, every, seq: id });
    // Shaped like a Node timer where the runtimes touch it.
    return { id, clock: this, unref() { return this; }, ref() { return this; }, hasRef: () => false };
  }

  /** Runs the timers due within `ms`, one at a time; resolves after the last one's follow-up work. */
  async advance(ms) {
    const until = this.ms + ms;
    for (;;) {
      let next = null;
      for (const [id, t] of this.timers) {
        if (t.due <= until && (!next || t.due < next.t.due || (t.due === next.t.due && t.seq < next.t.seq))) next = { id, t };
      }
      if (!next) break;
      this.ms = Math.max(this.ms, next.t.due);
      if (next.t.every) {
        next.t.due += next.t.every;
        next.t.seq = this.nextId++;
      } else {
        this.timers.delete(next.id);
      }
      next.t.fn();
      await settle();
    }
    this.ms = until;
    await settle();
  }
}

/** Lets promise callbacks and setImmediate work queued by the runtimes run. */
async function settle(turns = 3) {
  for (let i = 0; i < turns; i++) await new Promise((resolve) => setImmediate(resolve));
}

let current = new SystemClock();

const clock = {
  now: () => current.now(),
  setTimeout: (fn, ms) => current.setTimeout(fn, ms),
  setInterval: (fn, ms) => current.setInterval(fn, ms),
  // A timer is cleared by the clock that set it, even if the clock changed since.
  clearTimeout: (handle) => (handle && handle.clock instanceof ManualClock ? handle.clock.clearTimeout(handle) : clearTimeout(handle)),
  clearInterval: (handle) => (handle && handle.clock instanceof ManualClock ? handle.clock.clearTimeout(handle) : clearInterval(handle)),
};

/** Replaces the clock (a test's ManualClock); `useClock()` puts the system clock back. */
function useClock(replacement) {
  current = replacement || new SystemClock();
  return current;
}

module.exports = { clock, useClock, ManualClock, settle };
