// @ts-check
'use strict';
const { bindPlant, onInput, always } = require('../lib/host/binding');
const { readGroup, isLockout } = require('../lib/plant/group');
const { splitNames, readMsg } = require('../lib/interlock/request');
const { translator, useRED } = require('../lib/host/i18n');
const { SugarshackError } = require('../lib/host/errors');
const { describe } = require('../lib/control');

const OUTPUT_PREFIX = 'output/';

/** An output's value from msg.payload: a finite number, or true/false (1/0) for a coil. */
function outputValue(id, payload) {
  if (typeof payload === 'boolean') return payload ? 1 : 0;
  if (typeof payload === 'number' && Number.isFinite(payload)) return payload;
  throw SugarshackError.of('INVALID_INPUT', 'outputValue', { id, got: describe(payload) });
}

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function ActuatorsNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const t = translator(RED, 'sugarshack-actuators');
    const runtime = bindPlant(RED, node, props.plant);
    const devices = props.devices && String(props.devices).trim() ? splitNames(String(props.devices), t('config.devices')) : null;
    // Its broker's connection tells the plant when commands cannot reach the devices.
    const broker = props.broker ? RED.nodes.getNode(props.broker) : null;
    if (runtime) runtime.addBus(node, devices, broker);

    // Device feedback is telemetry: consumed here, completed with done(). Anything
    // else is a group command, held until it completes and returned on output 2.
    // While a deploy drains, feedback and lockouts still go in (the operations
    // being drained wait for feedback; a lockout never waits); commands wait.
    onInput(node, runtime, (rt, msg, send, done) => {
      const seen = readMsg(() => ({
        topic: msg.topic,
        payload: msg.payload,
        // A lockout topic the core tells in its feedback read; msg.lockout, when set, it is asked about.
        lockout: msg.lockout !== undefined && isLockout(msg),
        // As an `mqtt in` node gives it: only such msgs on foreign topics may be someone else's traffic.
        fromMqtt: typeof msg.qos === 'number' && typeof msg.retain === 'boolean',
      }));
      if (!seen.lockout && rt.bus.feedback(node, seen.topic, seen.payload, seen.fromMqtt)) {
        done();
        return;
      }
      // A hot standby follows the feedback (above) and commands nothing.
      if (rt.standby) {
        rt.standbyDone(node, done);
        return;
      }
      // "output/<id>": a Modbus output written as given (a pid's action), untracked.
      if (typeof seen.topic === 'string' && seen.topic.startsWith(OUTPUT_PREFIX)) {
        const id = seen.topic.slice(OUTPUT_PREFIX.length);
        rt.output(id, outputValue(id, seen.payload));
        done();
        return;
      }
      const issue = () => rt.commands.command({ node, msg, send, done, output: 1, outputs: 3 });
      // Only a lockout goes in while a deploy drains (the core reads the msg again as it issues it).
      if (rt.draining && !readMsg(() => readGroup(msg)).lockout) rt.submit(node, done, issue);
      else issue();
    }, 'plant', { urgent: always, passive: true });
  }

  RED.nodes.registerType('sugarshack-actuators', ActuatorsNode);
};
