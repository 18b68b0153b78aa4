'use strict';
// What every device impersonator shares: one mqtt.js connection with the
// firmware's last will, a log of the commands it received, a clock that moves
// only with advance(ms) (the firmware's own millis()), and two ways to end:
// stop() as a clean shutdown, crash() as a power cut (the socket dies without a
// DISCONNECT, so the broker publishes the will).
//
// The firmware-specific modules (esphome.js, tasmota.js, shelly-gen2.js) say
// what is published and how commands are parsed; nothing here knows a topic.
const mqtt = require('mqtt');
const { topicMatches } = require('../mqtt-probe');

class Impersonator {
  /**
   * @param {string} url broker URL
   * @param {object} options { clientId, will: { topic, payload, qos, retain }, startMs }
   */
  constructor(url, { clientId, will, startMs = 1_700_000_000_000 }) {
    this.url = url;
    this.clientId = clientId;
    this.will = will;
    this.nowMs = startMs;
    this.commands = []; // { topic, text, at } every message received on a subscribed topic
    this.warnings = []; // what the firmware would log at WARN level (an unparsed command)
    this.published = []; // { topic, text, retain, qos } in publish order
    this.flushes = 0;
    this.pending = new Set();
    this.subscriptions = [];
    this.client = null;
  }

  async connect() {
    this.client = await mqtt.connectAsync(this.url, {
      clientId: this.clientId,
      clean: true,
      reconnectPeriod: 0, // a crashed device stays away until the test brings it back
      will: this.will ? { ...this.will, payload: Buffer.from(this.will.payload) } : undefined,
    });
    this.client.on('message', (topic, payload) => {
      const text = payload.toString();
      this.commands.push({ topic, text, at: this.nowMs });
      this.onMessage(topic, text);
    });
    await this.onConnect();
    return this;
  }

  /** Subclasses: subscribe and publish what the firmware does once connected. */
  async onConnect() {}

  /** Subclasses: the firmware's reaction to a message on a subscribed topic. */
  onMessage() {}

  /** Subclasses: move the firmware's own time forward (motion, periodic reports). */
  async step() {}

  async subscribe(topics, qos = 0) {
    this.subscriptions.push(...topics);
    await this.client.subscribeAsync(topics, { qos });
  }

  publish(topic, text, { qos = 0, retain = false } = {}) {
    this.published.push({ topic, text, retain, qos, at: this.nowMs });
    if (!this.client) return Promise.resolve();
    const sent = this.client.publishAsync(topic, text, { qos, retain }).finally(() => this.pending.delete(sent));
    this.pending.add(sent);
    return sent;
  }

  /**
   * Moves time by `ms` in `stepMs` slices, publishing what the firmware would in
   * each; resolves once everything is on the broker.
   */
  async advance(ms, stepMs = 50) {
    for (let left = ms; left > 0; left -= stepMs) {
      const dt = Math.min(stepMs, left);
      this.nowMs += dt;
      await this.step(dt);
    }
    await this.settled();
  }

  /** Resolves once every publish so far is written out (QoS 1 ones acknowledged). */
  async settled() {
    await Promise.allSettled([...this.pending]);
  }

  /**
   * A marker after everything published so far: a subscriber that sees it has
   * seen all of this device's earlier messages (a broker keeps one publisher's
   * order per subscriber).
   */
  async flush() {
    this.flushes += 1;
    await this.settled();
    await this.client.publishAsync(`test/flush/${this.clientId}`, String(this.flushes), { qos: 1 });
    return this.flushes;
  }

  /** Whether this device subscribes to `topic`. */
  listensTo(topic) {
    return this.subscriptions.some((filter) => topicMatches(filter, topic));
  }

  commandsOn(topic) {
    return this.commands.filter((c) => c.topic === topic).map((c) => c.text);
  }

  /** A clean shutdown: the firmware's own goodbye (if it has one), then DISCONNECT (no will). */
  async stop() {
    if (!this.client) return;
    await this.onShutdown();
    await this.client.endAsync();
    this.client = null;
  }

  async onShutdown() {}

  /** A power cut: the TCP connection drops without DISCONNECT; the broker publishes the will. */
  crash() {
    if (!this.client) return;
    const { stream } = this.client;
    this.client.end(true);
    if (stream) stream.destroy();
    this.client = null;
  }
}

module.exports = { Impersonator };
