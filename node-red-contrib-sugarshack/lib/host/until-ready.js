// @ts-check
'use strict';
// Msgs that arrive before what handles them can take them (a runtime starting
// or draining for a deploy, a pid node reading its saved state): kept in
// arrival order, then handed on, or completed when their node closes, the
// runtime fails or everything stops. Each task is { node, done, ... }.

class UntilReady {
  constructor() {
    this.tasks = [];
  }

  get length() {
    return this.tasks.length;
  }

  hold(task) {
    this.tasks.push(task);
  }

  /** Every held task, oldest first, taken out to be handled now. */
  take() {
    return this.tasks.splice(0);
  }

  /** Completes every held task with `err`, or unsent without one. */
  completeAll(err) {
    for (const task of this.tasks.splice(0)) finish(task, err);
  }

  /** A closing node's held tasks are completed unsent. */
  completeOf(node) {
    const mine = this.tasks.filter((task) => task.node === node);
    this.tasks = this.tasks.filter((task) => task.node !== node);
    for (const task of mine) finish(task);
  }
}

function finish(task, err) {
  if (err) task.done(err);
  else task.done();
}

module.exports = { UntilReady };
