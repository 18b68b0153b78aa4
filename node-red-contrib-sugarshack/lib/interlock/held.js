// @ts-check
'use strict';
// What waits on an engine's answer, by the handle the host chose: a msg a
// node holds (sent on, or completed, as the engine says), or a request of an
// operation run (its answers go to callbacks). Between a deploy's restart of
// a node and its next instance taking the msg over (`adopt`), `node`, `send`
// and `done` are null: the first instance completed the msg when it closed,
// the next one sends it on.

class HeldMsg {
  /**
   * @param {NodeRed.Node | null} node @param {NodeRed.Message} msg
   * @param {NodeRed.Send | null} send @param {NodeRed.Done | null} done @param {number} ports its node's outputs
   */
  constructor(node, msg, send, done, ports) {
    this.node = node;
    this.nodeId = node ? node.id : null;
    this.msg = msg;
    this.send = send;
    this.done = done;
    this.ports = ports;
    /** @type {((text: any) => string) | null} how its node words a fault it made */
    this.words = null;
  }

  /**
   * Sends the msg on output `port` (null: none), and `extra` msgs on theirs, then completes it.
   * @param {number | null} port @param {{ port: number, msgs: any[] } | null} extra @param {Error | null} err
   */
  answer(port, extra, err) {
    if (this.send && (port !== null || extra)) {
      if (this.ports === 1) this.send(this.msg);
      else {
        /** @type {any[]} */
        const out = new Array(this.ports).fill(null);
        if (port !== null) out[port] = this.msg;
        if (extra) out[extra.port] = extra.msgs;
        this.send(out);
      }
    }
    if (this.done) {
      if (err) this.done(err);
      else this.done();
    } else if (err && this.node) this.node.error(err, this.msg);
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
 * A request of an operation run: granted (with msg.interlock's fields),
 * answered (sent on: released, withdrawn; with the lockouts of a fault),
 * refused with an error, or dropped (completed unsent).
 * @typedef {{ granted?: (grant: any) => void, answered?: (lockouts: any[] | null) => void,
 *   refused?: (err: Error) => void, dropped?: () => void }} Answers
 */
class HeldCall {
  /** @param {Answers} answers */
  constructor(answers) {
    this.answers = answers;
    this.node = null;
    this.nodeId = null;
  }

  answer(port, extra, err) {
    const a = this.answers;
    if (err) {
      if (a.refused) a.refused(err);
    } else if (port === null && !extra) {
      if (a.dropped) a.dropped();
    } else if (a.answered) a.answered(extra ? extra.msgs : null);
  }

  detach() {}

  adopt() {}
}

module.exports = { HeldMsg, HeldCall };
