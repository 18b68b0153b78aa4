// @ts-check
'use strict';
// Hands what a msg asks for (operation, priority, resources, who asks) to the
// core, which reads it by its rules (engine/request.rs): msg's values first,
// then the node's, trimmed, defaulted, attributed. Whether a request is
// allowed is for the interlock to say.
const { SugarshackError, asSugarshackError, thrownWords } = require('../host/errors');
const i18n = require('../host/i18n');
const wasm = require('../wasm');
const { refusalError } = require('./engine-carrier');

// A refusal quotes at most this much of the value it refuses.
const QUOTE_MAX = 100;

/** A value as a short quote for a message, whatever it is (BigInt, circular, huge). */
function quote(value) {
  let text;
  try {
    text = typeof value === 'string' ? JSON.stringify(value) : typeof value === 'bigint' ? `${value}n` : JSON.stringify(value);
  } catch {
    text = undefined;
  }
  if (text === undefined) text = Array.isArray(value) ? i18n.text('labels.anArray') : typeof value;
  return text.length > QUOTE_MAX ? `${text.slice(0, QUOTE_MAX - 1)}…` : text;
}

/**
 * Reads what a msg asks for. A refusal of ours passes unchanged; anything else a
 * msg makes the reading throw (a getter that throws, a proxy) is the sender's
 * error: INVALID_INPUT.
 */
function readMsg(read) {
  try {
    return read();
  } catch (err) {
    throw unreadable(err);
  }
}

/** What reading a msg threw, as readMsg throws it: ours and a trap pass, anything else is the sender's. */
function unreadable(err) {
  return wasm.isTrap(err) ? err : asSugarshackError(err, msgUnreadable);
}

/** @param {string} words */
function msgUnreadable(words) {
  return SugarshackError.of('INVALID_INPUT', 'msgUnreadable', { why: words.slice(0, QUOTE_MAX) });
}

/**
 * What a msg carries for the core's request rules, read off it as it is: the
 * core trims, defaults and picks who asks (wasm's readRequest bounds the text
 * that crosses and turns numbers that are not finite away).
 */
function fieldsOf(msg) {
  const client = msg._client && typeof msg._client === 'object' ? msg._client : null;
  const error = msg.error;
  return {
    operation: msg.operation,
    priority: msg.priority,
    resources: msg.resources,
    follow: msg.interlock ? msg.interlock.operation : undefined,
    errorMessage: error ? error.message : undefined,
    payload: msg.payload,
    user: client ? client.user : undefined,
    by: msg.by,
    reason: msg.reason,
    force: msg.force === true,
  };
}

/** The core's answer to a read: its value, or the refusal thrown in the catalog's words. */
function answered(answer) {
  if (answer.refused) throw refusalError(answer.refused);
  return answer.ok;
}

/** What the core reads of `msg` for `asks`, the node's `configured` values where the msg has none. */
function ask(asks, msg, configured = {}) {
  return answered(wasm.load().readRequest(asks, fieldsOf(msg), configured));
}

const WHO = { kind: 'who' };

/** Who asks, and why ({ by, reason, force }): the core's precedence (a signed-in user over msg.by). */
function attributionOf(msg) {
  return ask(WHO, msg).who;
}

/** Names from a list or comma-separated text, trimmed; `from` names them in a refusal. */
function splitNames(value, from) {
  return answered(wasm.load().namesOf(value, from));
}

// The words that name a node's value in a refusal.
/** @type {Record<string, () => string>} */
const LABELS = {
  operation: () => i18n.text('labels.configuredOperation'),
  priority: () => i18n.text('labels.configuredPriority'),
  resources: () => i18n.text('labels.configuredResources'),
};
// typedInput types read for each msg; a literal, or a flow saved before the types, is the node's value as deployed.
const PER_MSG = new Set(['msg', 'flow', 'global', 'env', 'jsonata']);

/** Whether the node reads its value `name` for each msg (its typedInput's type says where from). */
function isPerMsg(props, name) {
  return PER_MSG.has(props[`${name}Type`]);
}

/**
 * The node's values that come from msg, flow, global, env or JSONata (as the
 * trigger node reads its values, through RED.util.evaluateNodeProperty): a
 * function reading them for a msg into `then(err, values)`, the literal ones
 * as deployed; null when every one of `names` is literal (read by the core as
 * deployed). What a value means is the core's to say, as for any other.
 * @param {any} RED @param {NodeRed.Node} node @param {Record<string, any>} props @param {string[]} names
 * @returns {((msg: NodeRed.Message, then: (err: Error | null, values?: Record<string, any>) => void) => void) | null}
 */
function nodeValues(RED, node, props, names) {
  const perMsg = names.filter((name) => isPerMsg(props, name));
  if (perMsg.length === 0) return null;
  const inOrder = arrivalOrder();
  return (msg, whenRead) => {
    const then = inOrder(whenRead);
    /** @type {Record<string, any>} */
    const values = Object.fromEntries(names.map((name) => [name, props[name]]));
    let left = perMsg.length;
    let failed = false;
    const fail = (name, err) => {
      if (failed) return;
      failed = true;
      const why = `${LABELS[name] ? LABELS[name]() : name}: ${thrownWords(err)}`;
      then(SugarshackError.of('INVALID_INPUT', 'msgUnreadable', { why: why.slice(0, QUOTE_MAX) }));
    };
    for (const name of perMsg) {
      try {
        RED.util.evaluateNodeProperty(props[name], props[`${name}Type`], node, msg, (err, value) => {
          if (err) fail(name, err);
          else if (!failed) {
            values[name] = value;
            left -= 1;
            if (left === 0) then(null, values);
          }
        });
      } catch (err) {
        fail(name, err); // an expression that does not parse, a msg path that is not one
      }
    }
  };
}

/**
 * Answers in the order their msgs came, whatever order their reads end in (a
 * JSONata expression over a long array resolves after one over a short one):
 * the queue's order among equals is arrival order.
 */
function arrivalOrder() {
  /** @type {{ deliver: Function, args: any[] | null }[]} */
  const waiting = [];
  return (deliver) => {
    /** @type {{ deliver: Function, args: any[] | null }} */
    const slot = { deliver, args: null };
    waiting.push(slot);
    return (...args) => {
      if (slot.args) return;
      slot.args = args;
      while (waiting.length > 0 && waiting[0].args) {
        const next = /** @type {{ deliver: Function, args: any[] }} */ (waiting.shift());
        next.deliver(...next.args);
      }
    };
  };
}

module.exports = { nodeValues, isPerMsg, attributionOf, splitNames, fieldsOf, readMsg, unreadable, quote };
