// @ts-check
'use strict';
// Msgs held while they wait: by the interlock's engine carrier under their msg
// handle (lib/interlock/engine-carrier.js); by group command and actuators nodes until
// their group command completes (lib/plant/plant-commands.js).

/**
 * A msg held by a node until its work is answered. Between a deploy's restart
 * of that node and its next instance taking the msg over (`adopt`), `node`,
 * `send` and `done` are null: the first instance completed the msg when it
 * closed (`detach`), and the next one sends it on. A class, not an object of
 * closures: one is made per msg. Whoever holds it adds its own fields
 * (`grant` and `refuse` for an acquire, `cancel` for a command's wait...).
 */
class HeldMsg {
  /**
   * @param {NodeRed.Node | null} node @param {NodeRed.Message | null} msg
   * @param {NodeRed.Send | null} send @param {NodeRed.Done | null} done
   */
  constructor(node, msg, send, done) {
    /** @type {NodeRed.Node | null} */
    this.node = node;
    /** @type {NodeRed.Message | null} */
    this.msg = msg;
    /** @type {NodeRed.Send | null} */
    this.send = send;
    /** @type {NodeRed.Done | null} */
    this.done = done;
    this.nodeId = node ? node.id : null;
  }

  /** The work failed: the msg ends with the error (a Catch node gets it). @param {Error} err */
  reject(err) {
    if (this.done) this.done(err);
    else if (this.node) this.node.error(err, this.msg);
    this.done = null;
  }

  /** Completed without being sent on (withdrawn, or the flows stop). */
  abandon() {
    if (this.done) this.done();
    this.done = null;
  }

  detach() {
    if (this.done) this.done();
    this.node = null;
    this.send = null;
    this.done = null;
  }

  /** @param {NodeRed.Node} next */
  adopt(next) {
    this.node = next;
    this.send = (m) => next.send(m);
  }
}

/**
 * A held msg with its holder's own fields.
 * @param {{ node: NodeRed.Node | null, msg: NodeRed.Message | null, send: NodeRed.Send | null,
 *   done: NodeRed.Done | null, [key: string]: any }} fields
 * @returns {HeldMsg & { [key: string]: any }}
 */
function heldMsg(fields) {
  return Object.assign(new HeldMsg(fields.node, fields.msg, fields.send, fields.done), fields);
}

module.exports = { HeldMsg, heldMsg };
