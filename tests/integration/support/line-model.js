'use strict';
// The lines of the routines plant as the interlock's events tell them, for
// the tests that kill Node-RED (crash.spec.js) or its leader (chaos.spec.js):
// replaying the events finds every grant of a line held by another operation
// or faulted.
const { LINES } = require('./routines-flow');

/**
 * The lines as the interlock's events tell them, across runs: replaying them
 * finds every grant of a line held by another operation or faulted.
 */
class LineModel {
  constructor(lines = LINES) {
    this.lines = Object.fromEntries(lines.map((l) => [l, { holder: null, faulted: false, faultSeenAt: 0, grantSeenAt: 0 }]));
    this.violations = [];
  }

  /** After a restart: the state the interlock reports. */
  reset(lines) {
    for (const [name, state] of Object.entries(lines)) {
      const line = this.lines[name];
      line.holder = state.startsWith('held:') ? state.slice(5) : null;
      line.faulted = state.startsWith('faulted');
    }
  }

  /** A new leader opened the committed state as after a restart: a held line comes back faulted. */
  failover(at) {
    for (const line of Object.values(this.lines)) {
      if (line.holder) Object.assign(line, { holder: null, faulted: true, faultSeenAt: at });
    }
  }

  /** The lines faulted now. */
  faulted() {
    return Object.keys(this.lines).filter((l) => this.lines[l].faulted);
  }

  apply(e, at) {
    const names = (e.resources || []).filter((r) => this.lines[r]);
    switch (e.kind) {
      case 'granted':
        for (const r of names) {
          const line = this.lines[r];
          if (line.faulted || (line.holder && line.holder !== e.operation)) {
            this.violations.push(`${e.operation} granted ${r} while ${line.faulted ? 'faulted' : `held by ${line.holder}`}`);
          }
          line.holder = e.operation;
          line.grantSeenAt = at;
        }
        break;
      case 'released':
        for (const r of names) this.lines[r].holder = null;
        break;
      case 'faulted':
      case 'resource-faulted':
      case 'interrupted':
        for (const r of names) {
          Object.assign(this.lines[r], { holder: null, faulted: true, faultSeenAt: at });
        }
        break;
      case 'state-unknown':
        for (const line of Object.values(this.lines)) Object.assign(line, { holder: null, faulted: true, faultSeenAt: at });
        break;
      case 'cleared':
        for (const r of names) this.lines[r].faulted = false;
        break;
      default:
    }
  }
}

module.exports = { LineModel };
