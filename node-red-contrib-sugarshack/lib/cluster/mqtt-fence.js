// @ts-check
'use strict';
// Fencing at the resource: where the broker is Mosquitto with its dynamic
// security plugin, the active instance disables the MQTT account of every
// other instance that is not known to stand by, before its first command, and
// enables it again once that instance records itself as standby. A paused
// leader that wakes up is then disconnected by the broker and refused on
// reconnect, whatever its own clock believes.
const { EventEmitter } = require('events');

const CONTROL = '$CONTROL/dynamic-security/v1';
// Loaded only where fencing is configured; by name, so the type check does not read mqtt's browser typings.
const MQTT_MODULE = 'mqtt';
const ANSWER_MS = 2000;

class MqttFence extends EventEmitter {
  /** @param {{ url: string, username: string, password: string }} settings the broker and its dynamic-security admin */
  constructor(settings) {
    super();
    this.settings = settings;
    /** @type {any} */
    this.client = null;
    this.waiting = new Map(); // correlation -> { resolve, reject, timer }
    this.next = 1;
    this.disabled = new Set();
    /** @type {Promise<void> | null} resolves once the broker's answers are subscribed to */
    this.ready = null;
  }

  /** Connects (once, and again after a loss); commands wait until the answers are subscribed to. */
  connect() {
    if (this.client) return;
    const mqtt = require(MQTT_MODULE);
    const { url, username, password } = this.settings;
    const client = mqtt.connect(url, { username, password, reconnectPeriod: 500, connectTimeout: 2000, clean: true });
    this.client = client;
    let subscribed = () => {};
    this.ready = new Promise((resolve) => { subscribed = resolve; });
    client.on('connect', () => client.subscribe(`${CONTROL}/response`, { qos: 1 }, () => subscribed()));
    client.on('error', (err) => this.emit('problem', err));
    client.on('message', (topic, payload) => this.answer(payload));
  }

  answer(payload) {
    let doc;
    try {
      doc = JSON.parse(String(payload));
    } catch {
      return;
    }
    for (const r of Array.isArray(doc.responses) ? doc.responses : []) {
      const w = this.waiting.get(r.correlationData);
      if (!w) continue;
      this.waiting.delete(r.correlationData);
      clearTimeout(w.timer);
      if (r.error) w.reject(new Error(`${r.command}: ${r.error}`));
      else w.resolve();
    }
  }

  /** Sends one dynamic-security command; resolves once the broker answered it. */
  async command(command, username) {
    this.connect();
    const { client } = this;
    const correlationData = `sugarshack-${process.pid}-${this.next++}`;
    await Promise.race([this.ready, new Promise((resolve) => setTimeout(resolve, ANSWER_MS))]);
    return new Promise((resolve, reject) => {
      const timer = setTimeout(() => {
        this.waiting.delete(correlationData);
        reject(new Error(`${command} ${username}: no answer from the broker in ${ANSWER_MS} ms`));
      }, ANSWER_MS);
      this.waiting.set(correlationData, { resolve, reject, timer });
      client.publish(CONTROL, JSON.stringify({ commands: [{ command, username, correlationData }] }), { qos: 1 });
    });
  }

  async disable(username) {
    await this.command('disableClient', username);
    this.disabled.add(username);
  }

  async enable(username) {
    await this.command('enableClient', username);
    this.disabled.delete(username);
  }

  close() {
    for (const w of this.waiting.values()) clearTimeout(w.timer);
    this.waiting.clear();
    if (this.client) this.client.end(true);
    this.client = null;
  }
}

module.exports = { MqttFence };
