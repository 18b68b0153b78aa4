'use strict';
// EStop(Lines, Reason) and Clear(Lines, Reason, Force) on the plant object:
// the operator's e-stop and cause-aware clear of the HMI and the state API
// (api.estop, api.clear), as the session's user, journalled there; and
// Hold, Restart, Stop, Abort, Reset(Reason) on each operation and routine,
// the HMI's ISA-88 buttons (api.command). The core decides: a refused clear
// or command answers a Bad status code with the core's reasons as its Reasons
// output (a client's call result carries them; the lines' ClearBlockers and
// the runs' Commands show them too).
const { DataType, StatusCodes, Variant, VariantArrayType } = require('node-opcua');

// The core's refusals, as OPC UA says them.
const STATUS_OF = {
  CLEAR_REFUSED: StatusCodes.BadInvalidState,
  NOT_FAULTED: StatusCodes.BadInvalidState,
  UNKNOWN_RESOURCE: StatusCodes.BadInvalidArgument,
  INVALID_RESOURCES: StatusCodes.BadInvalidArgument,
  NO_INTERLOCK: StatusCodes.BadInvalidState,
  COMMAND_REFUSED: StatusCodes.BadInvalidState,
  UNKNOWN_RUN: StatusCodes.BadNotFound,
  INVALID_INPUT: StatusCodes.BadInvalidArgument,
};

const strings = (value) => new Variant({ dataType: DataType.String, arrayType: VariantArrayType.Array, value });

/** Adds the e-stop and clear to the plant object of `model`, and the commands to each run object it makes; `t` words the e-stop's note. */
function addMethods({ model, api, interlockId, users, t, onError }) {
  const { ns, root } = model;
  const linesArg = { name: 'Lines', description: t('methods.lines'), dataType: DataType.String, valueRank: 1, arrayDimensions: [0] };
  const reasonArg = { name: 'Reason', description: t('methods.reason'), dataType: DataType.String };

  const run = (context, callback, act, output) => {
    const who = users.caller(context);
    if (!who.write) return callback(null, { statusCode: StatusCodes.BadUserAccessDenied });
    act(who).then((answer) => callback(null, { statusCode: StatusCodes.Good, outputArguments: output(answer, []) }), (err) => {
      if (!STATUS_OF[err.code]) onError(err);
      // Every reason of every line, in the core's words.
      const reasons = err.lines ? err.lines.flatMap((l) => (l.texts || []).map((text) => `${l.line}: ${text}`)) : [err.message];
      callback(null, { statusCode: STATUS_OF[err.code] || StatusCodes.BadInternalError, outputArguments: output(null, reasons) });
    });
    return undefined;
  };
  const reasonsArg = { name: 'Reasons', description: t('methods.reasons'), dataType: DataType.String, valueRank: 1, arrayDimensions: [0] };
  const names = (variant) => (variant && Array.isArray(variant.value) ? variant.value.map(String) : []);
  const text = (variant) => (variant && typeof variant.value === 'string' && variant.value.trim() !== '' ? variant.value.slice(0, 1000) : null);

  const estop = ns.addMethod(root, {
    browseName: 'EStop',
    nodeId: 's=EStop',
    description: t('methods.estop'),
    inputArguments: [linesArg, reasonArg],
    outputArguments: [
      { name: 'Stopped', description: t('methods.stopped'), dataType: DataType.String, valueRank: 1, arrayDimensions: [0] },
      reasonsArg,
    ],
  });
  estop.bindMethod((inputArguments, context, callback) => {
    const lines = names(inputArguments[0]);
    if (lines.length === 0) return callback(null, { statusCode: StatusCodes.BadInvalidArgument });
    return run(context, callback,
      (who) => api.estop(interlockId, lines, { by: who.by, reason: text(inputArguments[1]) }, t('methods.estopNote')),
      (answer, reasons) => [strings(answer ? answer.stopped : []), strings(reasons)]);
  });

  const clear = ns.addMethod(root, {
    browseName: 'Clear',
    nodeId: 's=Clear',
    description: t('methods.clear'),
    inputArguments: [{ ...linesArg, description: t('methods.clearLines') }, reasonArg,
      { name: 'Force', description: t('methods.force'), dataType: DataType.Boolean }],
    outputArguments: [
      { name: 'Cleared', description: t('methods.cleared'), dataType: DataType.String, valueRank: 1, arrayDimensions: [0] },
      reasonsArg,
    ],
  });
  clear.bindMethod((inputArguments, context, callback) => {
    const lines = names(inputArguments[0]);
    const force = Boolean(inputArguments[2] && inputArguments[2].value === true);
    return run(context, callback,
      (who) => api.clear(interlockId, lines.length ? lines : null, { by: who.by, reason: text(inputArguments[1]), force }),
      (answer, reasons) => [strings(answer ? answer.cleared : []), strings(reasons)]);
  });

  // Each operation's and routine's object, as the model makes it: a method per command (Operations/10/Hold).
  model.onRunObject = (path, target) => {
    for (const command of api.commands) {
      const name = command[0].toUpperCase() + command.slice(1);
      const method = ns.addMethod(model.nodes.get(path), {
        browseName: name,
        nodeId: `s=${path}/${name}`,
        description: t(`methods.${command}`),
        inputArguments: [reasonArg],
        outputArguments: [{ name: 'State', description: t('methods.state'), dataType: DataType.String }, reasonsArg],
      });
      method.bindMethod((inputArguments, context, callback) => run(context, callback,
        (who) => api.command(interlockId, target, command, { by: who.by, reason: text(inputArguments[0]) }),
        (answer, reasons) => [new Variant({ dataType: DataType.String, value: answer ? answer.state : '' }), strings(reasons)]));
    }
  };
}

module.exports = { addMethods };
