// @ts-check
'use strict';
// An etcd lease whose validity is counted by this process's monotonic clock.
// etcd3's own Lease counts from when a keep-alive answer arrives, by the wall
// clock, and reports a loss only after twice the TTL: a fencing rule cannot use
// that. Here the lease is valid until (send time of the last keep-alive etcd
// acknowledged) + TTL - margin: etcd started its TTL when it received that
// keep-alive, later than we sent it, so a leader that stops acting at this
// instant stops before etcd can expire it, even if the process was paused.
const { EventEmitter } = require('events');
const { performance } = require('perf_hooks');

const RETRY_MS = 100;

class Lease extends EventEmitter {
  /**
   * @param {object} o
   * @param {any} o.client an Etcd3 client
   * @param {number} o.ttlS
   * @param {number} o.marginMs
   * @param {() => number} [o.now] monotonic milliseconds
   */
  constructor({ client, ttlS, marginMs, now = () => performance.now() }) {
    super();
    this.client = client;
    this.ttlS = ttlS;
    this.marginMs = marginMs;
    this.now = now;
    this.id = null;
    this.validUntil = -Infinity;
    this.lastAckAt = null; // monotonic: when the last acknowledged keep-alive was sent
    this.sent = []; // send times of keep-alives not yet answered, in order
    this.stream = null;
    this.timer = null;
    this.closed = false;
    this.lost = false;
  }

  /** Asks etcd for the lease; resolves with its id. */
  async grant() {
    const sentAt = this.now();
    const res = await this.client.leaseClient.leaseGrant({ TTL: this.ttlS });
    this.id = res.ID;
    this.ttlS = Number(res.TTL) || this.ttlS;
    this.acknowledged(sentAt);
    this.keepAlive();
    return this.id;
  }

  /** True while etcd cannot have let the lease expire, by this process's clock. */
  valid() {
    return !this.lost && !this.closed && this.now() < this.validUntil;
  }

  /** Milliseconds of validity left (negative once past). */
  remainingMs() {
    return this.validUntil - this.now();
  }

  acknowledged(sentAt) {
    const until = sentAt + this.ttlS * 1000 - this.marginMs;
    if (until > this.validUntil) this.validUntil = until;
    this.lastAckAt = sentAt;
    this.emit('renewed', until);
  }

  keepAlive() {
    if (this.closed) return;
    this.client.leaseClient.leaseKeepAlive().then((stream) => {
      if (this.closed) {
        stream.end();
        return;
      }
      this.stream = stream;
      this.sent = [];
      stream.on('data', (res) => {
        const sentAt = this.sent.shift();
        if (res.TTL === '0' || Number(res.TTL) <= 0) {
          this.lose(new Error(`etcd lease ${this.id} has expired`));
          return;
        }
        if (sentAt !== undefined) this.acknowledged(sentAt);
      });
      stream.on('error', () => this.restartStream());
      stream.on('end', () => this.restartStream());
      this.fire();
      this.timer = setInterval(() => this.fire(), Math.max(100, Math.floor(this.ttlS * 1000 / 3)));
    }, () => this.restartStream());
  }

  fire() {
    if (!this.stream || this.closed) return;
    this.sent.push(this.now());
    try {
      this.stream.write({ ID: this.id });
    } catch {
      this.restartStream();
    }
  }

  restartStream() {
    if (this.timer) clearInterval(this.timer);
    this.timer = null;
    const stream = this.stream;
    this.stream = null;
    if (stream) {
      stream.removeAllListeners('end');
      stream.removeAllListeners('error');
      stream.on('error', () => {});
      try {
        stream.end();
      } catch {
        // already gone
      }
    }
    if (this.closed) return;
    setTimeout(() => this.keepAlive(), RETRY_MS);
  }

  lose(err) {
    if (this.lost) return;
    this.lost = true;
    this.close();
    this.emit('lost', err);
  }

  close() {
    this.closed = true;
    if (this.timer) clearInterval(this.timer);
    this.timer = null;
    if (this.stream) {
      const stream = this.stream;
      this.stream = null;
      stream.removeAllListeners();
      stream.on('error', () => {});
      try {
        stream.end();
      } catch {
        // already gone
      }
    }
  }

  /** Gives the lease back (a clean stop): its keys go at once. */
  async revoke() {
    this.close();
    if (this.id === null) return;
    try {
      await this.client.leaseClient.leaseRevoke({ ID: this.id });
    } catch {
      // expired or unreachable: it runs out by itself
    }
  }
}

module.exports = { Lease };
