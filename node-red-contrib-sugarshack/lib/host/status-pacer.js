// @ts-check
'use strict';
// Status is for people: at plant scale the counts a node shows move hundreds
// or thousands of times a second, and each status goes out to every editor.
// A pacer shows the first BURST updates of each WINDOW_MS at once (a person,
// and a test, sees every step of a slow sequence) and the rest once, at the
// end of the window: the last state always shows, never a stale one. Time is
// the palette's clock, so tests move it instead of waiting.
const { clock } = require('./clock');

const WINDOW_MS = 100;
const BURST = 10;

class StatusPacer {
  /** `show()` updates the status; `live()` says whether it still should (the runtime is running). */
  constructor(show, live) {
    this.show = show;
    this.live = live;
    this.start = -Infinity;
    this.shown = 0;
    this.timer = null;
  }

  request() {
    // The last state shows at the window's end anyway (the timer starts the next window): no clock read per request.
    if (this.timer) return;
    const now = clock.now();
    if (now - this.start >= WINDOW_MS) {
      this.start = now;
      this.shown = 0;
    }
    if (this.shown < BURST && !this.timer) {
      this.shown += 1;
      this.show();
      return;
    }
    this.timer = clock.setTimeout(() => {
      this.timer = null;
      this.start = clock.now();
      this.shown = 1;
      if (this.live()) this.show();
    }, Math.max(0, this.start + WINDOW_MS - now));
    this.timer.unref();
  }

  stop() {
    if (this.timer) clock.clearTimeout(this.timer);
    this.timer = null;
  }
}

module.exports = { StatusPacer, WINDOW_MS, BURST };
