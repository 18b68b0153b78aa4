// @ts-check
'use strict';
const { bindInterlock, onInterlockInput, always } = require('../lib/host/binding');
const { operationOf, stopOf, noteOf, readMsg } = require('../lib/interlock/request');
const { clock } = require('../lib/host/clock');
const { journal } = require('../lib/journal/bus');
const { SugarshackError } = require('../lib/host/errors');
const { translator, useRED } = require('../lib/host/i18n');

/**
 * The error a faulted msg ends with when the node is set to fail it: it names
 * what was faulted and what locked out, and keeps the Catch's error as `cause`.
 */
function faultedError(t, msg, operation, lockouts, note) {
  const lines = lockouts.map((l) => l.resource).join(', ');
  const what = operation === null
    ? t('errors.stopped', { lines: lines || t('errors.nothing') })
    : t(lines ? 'errors.faultedLocked' : 'errors.faultedHeldNothing', { operation, lines });
  const error = new SugarshackError('FAULTED', note ? t('errors.withNote', { what, note }) : what);
  if (msg.error && typeof msg.error === 'object') error.cause = msg.error;
  return error;
}

/** @param {NodeRed.RED} RED */
module.exports = function (RED) {
  useRED(RED);
  /** @this {NodeRed.Node} @param {NodeRed.NodeProps} props */
  function FaultNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const t = translator(RED, 'sugarshack-fault');
    const runtime = bindInterlock(RED, node, props.interlock);
    const byResources = props.mode === 'resources';
    // Failing the msg lets the Catch of whoever called the operation see the fault (a subflow's caller).
    const failMsg = props.after === 'fail';

    // Output 2 gets one lockout group command per latched line, once the fault is saved.
    const spec = { kind: 'fault', byResources, failMsg, operation: props.operation, resources: props.resources };
    onInterlockInput(node, runtime, spec, (rt, msg, send, done) => {
      const request = readMsg(() => {
        const stop = byResources ? stopOf(msg, props.resources) : null;
        const who = stop ? stop.who : null;
        return {
          // The error a Catch node caught is the note; else an operator's stated reason (kept with the e-stop either way).
          note: noteOf(msg, who && who.reason),
          operation: byResources ? null : operationOf(msg, props.operation),
          resources: stop ? stop.resources : null,
          who,
        };
      });
      const { note, operation } = request;
      const out = (lockouts) => {
        // faultAtMs lets the group command that applies the lockout report the fault lockout time.
        const faultAtMs = clock.now();
        const commands = lockouts.map(({ resource, topic, command }) => ({
          topic,
          payload: command,
          resource,
          operation,
          note: note === undefined ? null : note,
          faultAtMs,
        }));
        if (failMsg) {
          send([null, commands]);
          done(faultedError(t, msg, operation, lockouts, note));
          return;
        }
        send([msg, commands]);
        done();
      };
      if (byResources) journal.action('e-stop', request.who, request.resources);
      if (byResources) rt.faultResources(request.resources, note, out, request.who);
      else rt.fault(operation, note, out);
    }, { urgent: always }); // an e-stop never waits for a deploy's drain
  }

  RED.nodes.registerType('sugarshack-fault', FaultNode);
};
