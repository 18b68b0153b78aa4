'use strict';
// A stock ESPHome node on MQTT, written from ESPHome's source (esphome/esphome),
// byte for byte what it publishes and how it parses commands:
//
// - topics `<topic_prefix>/<component_type>/<object_id>/<suffix>`:
//   esphome/components/mqtt/mqtt_component.cpp get_default_topic_for_to_;
//   object id = the entity name snake-cased and sanitized
//   (esphome/core/entity_base.cpp: to_sanitized_char(to_snake_case_char(c))), "V101" -> "v101".
// - birth/will/shutdown: `<p>/status` `online`/`offline`, QoS 0, retained
//   (esphome/components/mqtt/__init__.py validate_config); the birth goes out once
//   connected, then every entity resends its state (mqtt_client.cpp check_connected:
//   schedule_resend_state).
// - states retained by default (mqtt_component.h `bool retain_ : 1 {true}`), QoS 0, no timestamp.
// - discovery on by default, retained, `homeassistant/<type>/<node>/<oid>/config`,
//   abbreviated keys (mqtt_component.cpp send_discovery_, mqtt_const.h).
// - valve: `position/state` "0".."100" (value_accuracy_to_string(roundf(position * 100), 0)),
//   then `state` opening|closing|closed|open (mqtt_valve.cpp publish_state); command
//   OPEN/CLOSE/STOP/TOGGLE, case-insensitive, else "Unrecognized command" (valve/valve.cpp
//   ValveCall::set_command); `position/command` parse_number<float> / 100, clamped.
// - cover: the same topics and strings (mqtt_cover.cpp publish_state, cover/cover.cpp).
// - switch: `state` ON/OFF only when it changes (switch/switch.cpp publish_dedup_);
//   command parse_on_off: on/off/toggle case-insensitive (mqtt_switch.cpp).
// - number: state printf("%f") -> "37.000000" (mqtt_number.cpp); command parse_number<float>.
// - sensor: state snprintf("%.*f", accuracy_decimals) -> "12.3", NaN -> "nan"
//   (helpers.cpp value_accuracy_to_string; mqtt_sensor.cpp), every update_interval
//   (60 s default for polling platforms), no dedup.
// Nothing is published periodically except sensors. See FIRMWARE.md §1.
const { Impersonator } = require('./base');

const objectId = (name) => name.toLowerCase().replace(/ /g, '_').replace(/[^a-z0-9_-]/g, '_');

// C's "%.*f" for a float, with glibc/newlib's spelling of the non-finite values.
function printfFixed(value, decimals) {
  if (Number.isNaN(value)) return 'nan';
  if (!Number.isFinite(value)) return value > 0 ? 'inf' : '-inf';
  return Math.fround(value).toFixed(Math.max(0, decimals));
}

// value_accuracy_to_string(roundf(position * 100), 0): roundf rounds half away from zero.
const percent = (position) => String(Math.round(Math.fround(position) * 100));

// parse_number<float>: the whole string must be a number (strtod, no trailing junk).
function parseNumber(text) {
  const t = text.trim();
  if (t === '' || !/^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$/.test(t)) return null;
  return Number(t);
}

class EspHomeNode extends Impersonator {
  /**
   * @param {string} url
   * @param {object} config {
   *   name: node name (App name; discovery topic level), prefix: mqtt.topic_prefix (default name),
   *   valves: [{ name, component: 'valve'|'cover', position: 0..1, travelMs }],
   *   switches: [{ name, state }], numbers: [{ name, value, min, max, step }],
   *   sensors: [{ name, value, accuracy, updateMs, unit }], discovery: true }
   */
  constructor(url, config) {
    const prefix = config.prefix || config.name;
    super(url, {
      clientId: `${config.name}-a1b2c3d4e5f6`, // App name + "-" + MAC (mqtt_client.cpp)
      will: { topic: `${prefix}/status`, payload: 'offline', qos: 0, retain: true },
      startMs: config.startMs,
    });
    this.name = config.name;
    this.prefix = prefix;
    this.discovery = config.discovery !== false;
    this.valves = (config.valves || []).map((v) => ({
      component: 'valve', position: 0, travelMs: 2000, ...v, oid: objectId(v.name), target: null, operation: 'idle', stuck: false,
    }));
    this.switches = (config.switches || []).map((s) => ({ state: false, ...s, oid: objectId(s.name), stuck: false }));
    this.numbers = (config.numbers || []).map((n) => ({
      value: 0, min: 0, max: 100, step: 1, ...n, oid: objectId(n.name),
    }));
    this.sensors = (config.sensors || []).map((s) => ({
      accuracy: 1, updateMs: 60000, value: 0, ...s, oid: objectId(s.name), sinceMs: 0,
    }));
  }

  topic(type, oid, suffix) {
    return `${this.prefix}/${type}/${oid}/${suffix}`;
  }

  state(text) {
    return { qos: 0, retain: true, text };
  }

  async onConnect() {
    const subs = [
      ...this.valves.flatMap((v) => [this.topic(v.component, v.oid, 'command'), this.topic(v.component, v.oid, 'position/command')]),
      ...this.switches.map((s) => this.topic('switch', s.oid, 'command')),
      ...this.numbers.map((n) => this.topic('number', n.oid, 'command')),
    ];
    if (subs.length) await this.subscribe(subs, 0);
    this.publish(`${this.prefix}/status`, 'online', { qos: 0, retain: true });
    if (this.discovery) this.publishDiscovery();
    for (const v of this.valves) this.publishValve(v);
    for (const s of this.switches) this.publishSwitch(s);
    for (const n of this.numbers) this.publishNumber(n);
    for (const s of this.sensors) this.publishSensor(s);
    await this.settled();
  }

  async onShutdown() {
    // The shutdown message (same topic and payload as the will) before a clean reboot.
    await this.publish(`${this.prefix}/status`, 'offline', { qos: 0, retain: true });
  }

  /** Home Assistant discovery configs, retained (mqtt_component.cpp send_discovery_ with abbreviations). */
  publishDiscovery() {
    const avty = `${this.prefix}/status`;
    const dev = {
      ids: 'a1b2c3d4e5f6', name: this.name, sw: '2025.2.0 (config hash 0x1a2b3c4d)', mdl: 'esp32dev', mf: 'Espressif', cns: [['mac', 'a1b2c3d4e5f6']],
    };
    const config = (type, oid, name, extra, withCommand = true) => {
      const root = { ...extra, name };
      root.stat_t = this.topic(type, oid, 'state');
      if (withCommand) root.cmd_t = this.topic(type, oid, 'command');
      root.avty_t = avty;
      root.uniq_id = `ESP${type}${oid}`;
      root.dev = dev;
      this.publish(`homeassistant/${type}/${this.name}/${oid}/config`, JSON.stringify(root), { qos: 0, retain: true });
    };
    for (const v of this.valves) {
      config(v.component, v.oid, v.name, { pos_t: this.topic(v.component, v.oid, 'position/state'), set_pos_t: this.topic(v.component, v.oid, 'position/command') });
    }
    for (const s of this.switches) config('switch', s.oid, s.name, {});
    for (const n of this.numbers) config('number', n.oid, n.name, { min: n.min, max: n.max, step: n.step });
    for (const s of this.sensors) config('sensor', s.oid, s.name, s.unit ? { unit_of_meas: s.unit, stat_cla: 'measurement' } : { stat_cla: 'measurement' }, false);
  }

  /** mqtt_valve.cpp / mqtt_cover.cpp publish_state: position first, then the state word. */
  publishValve(v) {
    this.publish(this.topic(v.component, v.oid, 'position/state'), percent(v.position), { retain: true });
    let word;
    if (v.operation === 'opening') word = 'opening';
    else if (v.operation === 'closing') word = 'closing';
    else if (v.position === 0) word = 'closed';
    else word = 'open'; // fully open, or any position when position is supported
    this.publish(this.topic(v.component, v.oid, 'state'), word, { retain: true });
  }

  publishSwitch(s) {
    this.publish(this.topic('switch', s.oid, 'state'), s.state ? 'ON' : 'OFF', { retain: true });
  }

  publishNumber(n) {
    this.publish(this.topic('number', n.oid, 'state'), printfFixed(n.value, 6), { retain: true });
  }

  publishSensor(s) {
    this.publish(this.topic('sensor', s.oid, 'state'), printfFixed(s.value, s.accuracy), { retain: true });
  }

  onMessage(topic, text) {
    for (const v of this.valves) {
      if (topic === this.topic(v.component, v.oid, 'command')) return this.valveCommand(v, text);
      if (topic === this.topic(v.component, v.oid, 'position/command')) {
        const value = parseNumber(text);
        if (value === null) return this.warn(`Invalid position value: '${text}'`);
        return this.valveTarget(v, value / 100);
      }
    }
    for (const s of this.switches) {
      if (topic === this.topic('switch', s.oid, 'command')) {
        const word = text.toLowerCase();
        if (word === 'on') return this.setSwitch(s, true);
        if (word === 'off') return this.setSwitch(s, false);
        if (word === 'toggle') return this.setSwitch(s, !s.state);
        return this.warn(`'${s.name}': Received unknown status payload: ${text}`);
      }
    }
    for (const n of this.numbers) {
      if (topic === this.topic('number', n.oid, 'command')) {
        const value = parseNumber(text);
        if (value === null) return this.warn(`Can't convert '${text}' to number!`);
        n.value = value;
        return this.publishNumber(n);
      }
    }
    return undefined;
  }

  /** ValveCall::set_command: OPEN/CLOSE/STOP/TOGGLE (strcasecmp), else a warning and nothing. */
  valveCommand(v, text) {
    const word = text.toUpperCase();
    if (word === 'OPEN') return this.valveTarget(v, 1);
    if (word === 'CLOSE') return this.valveTarget(v, 0);
    if (word === 'STOP') {
      v.target = null;
      v.operation = 'idle';
      return this.publishValve(v);
    }
    if (word === 'TOGGLE') return this.valveTarget(v, v.position > 0 ? 0 : 1);
    return this.warn(`'${v.name}' - Unrecognized command ${text}`);
  }

  valveTarget(v, position) {
    const target = Math.min(1, Math.max(0, position)); // ValveCall::validate_ clamps to [0, 1]
    if (v.stuck) return undefined; // the motor does not turn: the position sensor never changes, nothing is published
    v.target = target;
    if (target === v.position) {
      v.operation = 'idle';
    } else {
      v.operation = target > v.position ? 'opening' : 'closing';
    }
    return this.publishValve(v);
  }

  setSwitch(s, on) {
    if (s.stuck) return;
    if (s.state === on) return; // Switch::publish_state: publish_dedup_ drops a repeat
    s.state = on;
    this.publishSwitch(s);
  }

  warn(line) {
    this.warnings.push(line);
  }

  async step(dt) {
    for (const v of this.valves) {
      if (v.target === null || v.operation === 'idle') continue;
      const before = percent(v.position);
      const delta = dt / v.travelMs;
      v.position = v.operation === 'opening' ? Math.min(v.target, v.position + delta) : Math.max(v.target, v.position - delta);
      if (v.position === v.target) {
        v.operation = 'idle';
        v.target = null;
        this.publishValve(v);
      } else if (percent(v.position) !== before) {
        this.publishValve(v); // a valve platform publishes as its position changes
      }
    }
    for (const s of this.sensors) {
      s.sinceMs += dt;
      if (s.sinceMs >= s.updateMs) {
        s.sinceMs -= s.updateMs;
        this.publishSensor(s);
      }
    }
  }

  /** The valve's motor no longer turns (a stuck valve): commands are accepted, nothing moves. */
  stick(name) {
    const v = this.valves.find((x) => x.name === name) || this.switches.find((x) => x.name === name);
    v.stuck = true;
  }

  /** A new sensor reading, published at the sensor's next update (NaN for a failed probe). */
  setSensor(name, value) {
    this.sensors.find((s) => s.name === name).value = value;
  }

  /** Publishes a sensor now (as a sensor with `force_update` or at its update interval). */
  publishSensorNow(name) {
    this.publishSensor(this.sensors.find((s) => s.name === name));
    return this.settled();
  }

  valve(name) {
    return this.valves.find((v) => v.name === name);
  }

  switch(name) {
    return this.switches.find((s) => s.name === name);
  }

  number(name) {
    return this.numbers.find((n) => n.name === name);
  }
}

async function startEspHome(url, config) {
  return new EspHomeNode(url, config).connect();
}

module.exports = { EspHomeNode, startEspHome, objectId, printfFixed };
