'use strict';
// Whether the flows are running: lockouts found at start-up (restored faults,
// interrupted operations) can only go out once the actuators nodes are up.

const running = new WeakMap(); // RED.events -> { started }

/** Follows the runtime's flow start/stop events; call at node registration. */
function trackFlows(RED) {
  if (running.has(RED.events)) return;
  const state = { started: false };
  running.set(RED.events, state);
  RED.events.on('flows:started', () => { state.started = true; });
  RED.events.on('flows:stopping', () => { state.started = false; });
}

/** Runs `fn` once every node of the current deploy has started. */
function whenFlowsStarted(RED, fn) {
  if (running.get(RED.events)?.started) setImmediate(fn);
  else RED.events.once('flows:started', () => setImmediate(fn));
}

module.exports = { trackFlows, whenFlowsStarted };
