'use strict';
// A Shelly Gen2 (Plus/Pro) device on MQTT. Its firmware is closed: this follows
// Shelly's API documentation (shelly-api-docs.shelly.cloud/gen2: ComponentsAndServices/Mqtt,
// Switch, Cover; General/Notifications) and traffic captured from real devices in public code:
//
// - `<p>/online` `true` on connect, `false` as the last will, retained; QoS 1 for all
//   (the MQTT page: "The supported Quality of service level is 1").
// - status_ntf: the whole component status on `<p>/status/<component:id>` when it changes,
//   with Shelly's own spacing, e.g. `{"id":0, "source":"init", "output":false, "apower":0.0, ...}`
//   (captured: shellies/plus1pm/status/switch:0).
// - rpc_ntf: `<p>/events/rpc` NotifyStatus with the changed keys and `ts` in float seconds.
// - MQTT control: `<p>/command/switch:0` on|off|toggle; `<p>/command/cover:0`
//   open|close|stop|pos,<0..100> (docs Cover#mqtt-control); `<p>/command` status_update.
// - JSON-RPC on `<p>/rpc`: {"id","src","method","params"}; the answer goes to `<src>/rpc`
//   as {"id","src":<device id>,"dst":<src>,"result"} or {"error":{"code","message"}}.
// - cover status: state open|closed|opening|closing|stopped, current_pos 0..100, target_pos
//   while moving, last_direction, pos_control (docs Cover status).
// See FIRMWARE.md §3 (what is documented vs observed).
const { Impersonator } = require('./base');

const seconds = (ms) => Number((ms / 1000).toFixed(2));

class ShellyGen2Device extends Impersonator {
  /**
   * @param {string} url
   * @param {object} config {
   *   id: device id (src), prefix: mqtt.topic_prefix (default id),
   *   switches: [{ output }], covers: [{ position: 0..100, travelMs }],
   *   temperatures: [{ id: 100, tC }] }
   */
  constructor(url, config) {
    const prefix = config.prefix || config.id;
    super(url, {
      clientId: config.id,
      will: { topic: `${prefix}/online`, payload: 'false', qos: 1, retain: true },
      startMs: config.startMs,
    });
    this.id = config.id;
    this.prefix = prefix;
    this.switches = (config.switches || []).map((s, i) => ({ output: false, ...s, key: `switch:${i}`, n: i, source: 'init' }));
    this.covers = (config.covers || []).map((c, i) => ({
      position: 0, travelMs: 2000, ...c, key: `cover:${i}`, n: i, state: null, target: null, lastDirection: null, source: 'init', stuck: false, sinceMs: 0,
    }));
    for (const c of this.covers) c.state = c.position === 0 ? 'closed' : (c.position === 100 ? 'open' : 'stopped');
    this.temperatures = (config.temperatures || []).map((t) => ({ id: 100, tC: 20, ...t }));
  }

  async onConnect() {
    await this.subscribe([`${this.prefix}/rpc`, `${this.prefix}/command`, `${this.prefix}/command/+`], 1);
    this.publish(`${this.prefix}/online`, 'true', { qos: 1, retain: true });
    this.publishAll();
    await this.settled();
  }

  publishAll() {
    for (const s of this.switches) this.publishSwitch(s);
    for (const c of this.covers) this.publishCover(c);
    for (const t of this.temperatures) this.publishTemperature(t);
  }

  switchStatus(s) {
    return `{"id":${s.n}, "source":"${s.source}", "output":${s.output}, "apower":0.0, "voltage":230.1, "current":0.000, "aenergy":{"total":0.000,"by_minute":[0.000,0.000,0.000],"minute_ts":${Math.floor(this.nowMs / 1000)}},"temperature":{"tC":41.2, "tF":106.2}}`;
  }

  coverStatus(c) {
    const moving = c.state === 'opening' || c.state === 'closing';
    return `{"id":${c.n}, "source":"${c.source}", "state":"${c.state}", "apower":${moving ? '82.0' : '0.0'}, "voltage":230.1, "current":${moving ? '0.365' : '0.000'}, "pf":0.00, "freq":50.0, "aenergy":{"total":1.234,"by_minute":[0.000,0.000,0.000],"minute_ts":${Math.floor(this.nowMs / 1000)}},"temperature":{"tC":45.1, "tF":113.2},"pos_control":true,"last_direction":${c.lastDirection ? `"${c.lastDirection}"` : 'null'},"current_pos":${Math.round(c.position)}${moving ? `,"target_pos":${c.target}` : ''}}`;
  }

  notify(key, fields) {
    this.publish(`${this.prefix}/events/rpc`, JSON.stringify({
      src: this.id, dst: `${this.prefix}/events`, method: 'NotifyStatus', params: { ts: seconds(this.nowMs), [key]: { id: Number(key.split(':')[1]), ...fields } },
    }), { qos: 1 });
  }

  publishSwitch(s) {
    this.publish(`${this.prefix}/status/${s.key}`, this.switchStatus(s), { qos: 1 });
  }

  publishCover(c) {
    this.publish(`${this.prefix}/status/${c.key}`, this.coverStatus(c), { qos: 1 });
  }

  publishTemperature(t) {
    this.publish(`${this.prefix}/status/temperature:${t.id}`, `{"id":${t.id},"tC":${t.tC.toFixed(1)}, "tF":${(t.tC * 1.8 + 32).toFixed(1)}}`, { qos: 1 });
  }

  onMessage(topic, text) {
    if (topic === `${this.prefix}/command`) {
      if (text === 'status_update') this.publishAll();
      return undefined;
    }
    if (topic === `${this.prefix}/rpc`) return this.rpc(text);
    const key = topic.slice(`${this.prefix}/command/`.length);
    const sw = this.switches.find((s) => s.key === key);
    if (sw) {
      if (text === 'on') return this.setSwitch(sw, true, 'MQTT');
      if (text === 'off') return this.setSwitch(sw, false, 'MQTT');
      if (text === 'toggle') return this.setSwitch(sw, !sw.output, 'MQTT');
      return this.warn(`${key}: unknown command ${text}`);
    }
    const cover = this.covers.find((c) => c.key === key);
    if (cover) {
      if (text === 'open') return this.coverTo(cover, 100, 'MQTT');
      if (text === 'close') return this.coverTo(cover, 0, 'MQTT');
      if (text === 'stop') return this.coverStop(cover, 'MQTT');
      const pos = /^pos,(\d{1,3})$/.exec(text);
      if (pos && Number(pos[1]) <= 100) return this.coverTo(cover, Number(pos[1]), 'MQTT');
      return this.warn(`${key}: unknown command ${text}`);
    }
    return undefined;
  }

  rpc(text) {
    let req;
    try {
      req = JSON.parse(text);
    } catch {
      return this.warn(`rpc: bad frame ${text}`);
    }
    const { id, src, method } = req;
    const params = req.params || {};
    if (typeof src !== 'string' || src === '') return this.warn('rpc: frame without src');
    const answer = (body) => this.publish(`${src}/rpc`, JSON.stringify({ id, src: this.id, dst: src, ...body }), { qos: 1 });
    const sw = this.switches[params.id];
    const cover = this.covers[params.id];
    switch (method) {
      case 'Switch.Set':
        if (!sw || typeof params.on !== 'boolean') return answer({ error: { code: -103, message: 'Invalid argument' } });
        answer({ result: { was_on: sw.output } });
        return this.setSwitch(sw, params.on, 'MQTT');
      case 'Switch.Toggle':
        if (!sw) return answer({ error: { code: -103, message: 'Invalid argument' } });
        answer({ result: { was_on: sw.output } });
        return this.setSwitch(sw, !sw.output, 'MQTT');
      case 'Cover.GoToPosition':
        if (!cover || !Number.isInteger(params.pos) || params.pos < 0 || params.pos > 100) return answer({ error: { code: -103, message: 'Invalid argument' } });
        answer({ result: null });
        return this.coverTo(cover, params.pos, 'MQTT');
      case 'Cover.Open':
      case 'Cover.Close':
        if (!cover) return answer({ error: { code: -103, message: 'Invalid argument' } });
        answer({ result: null });
        return this.coverTo(cover, method === 'Cover.Open' ? 100 : 0, 'MQTT');
      case 'Cover.Stop':
        if (!cover) return answer({ error: { code: -103, message: 'Invalid argument' } });
        answer({ result: null });
        return this.coverStop(cover, 'MQTT');
      default:
        return answer({ error: { code: -114, message: `Method ${method} failed: Method not found!` } });
    }
  }

  setSwitch(s, on, source) {
    if (s.stuck) return;
    const changed = s.output !== on;
    s.output = on;
    s.source = source;
    if (!changed) return; // status_ntf on change
    this.notify(s.key, { output: on, source });
    this.publishSwitch(s);
  }

  coverTo(c, target, source) {
    c.source = source;
    if (target === Math.round(c.position)) {
      c.target = null;
      return undefined;
    }
    c.target = target;
    c.lastDirection = target > c.position ? 'open' : 'close';
    c.state = target > c.position ? 'opening' : 'closing';
    c.sinceMs = 0;
    this.notify(c.key, { state: c.state, source, target_pos: target });
    return this.publishCover(c);
  }

  coverStop(c, source) {
    c.source = source;
    c.target = null;
    c.state = 'stopped';
    this.notify(c.key, { state: c.state, source });
    this.publishCover(c);
  }

  async step(dt) {
    for (const c of this.covers) {
      if (c.target === null || c.stuck) continue;
      const delta = (100 * dt) / c.travelMs;
      c.position = c.state === 'opening' ? Math.min(c.target, c.position + delta) : Math.max(c.target, c.position - delta);
      c.sinceMs += dt;
      if (c.position === c.target) {
        c.state = c.target === 100 ? 'open' : (c.target === 0 ? 'closed' : 'stopped');
        c.target = null;
        this.notify(c.key, { state: c.state, current_pos: Math.round(c.position) });
        this.publishCover(c);
      } else if (c.sinceMs >= 1000) {
        // While moving the position is reported about once a second.
        c.sinceMs -= 1000;
        this.notify(c.key, { current_pos: Math.round(c.position) });
        this.publishCover(c);
      }
    }
  }

  warn(line) {
    this.warnings.push(line);
  }

  /** The motor does not turn: the cover says it is opening but its position never changes. */
  stick(key) {
    const part = [...this.covers, ...this.switches].find((x) => x.key === key);
    part.stuck = true;
  }

  cover(n = 0) {
    return this.covers[n];
  }

  switch(n = 0) {
    return this.switches[n];
  }
}

async function startShellyGen2(url, config) {
  return new ShellyGen2Device(url, config).connect();
}

module.exports = { ShellyGen2Device, startShellyGen2 };
