'use strict';
// A Tasmota device on MQTT, written from Tasmota's source (arendst/Tasmota), with
// the default FullTopic `%prefix%/%topic%/` (cmnd, stat, tele):
//
// - last will `tele/<t>/LWT` `Offline`, QoS 1, retained; on connect `tele/<t>/LWT` `Online`
//   retained, then an empty `cmnd/<t>/POWER` ("Satisfy iobroker"), subscribe `cmnd/<t>/#`,
//   `tele/<t>/INFO1`, and every relay's state (tasmota_xdrv_driver/xdrv_02_9_mqtt.ino
//   MqttReconnect, MqttConnected; MQTT_LWT_ONLINE/OFFLINE in include/tasmota_globals.h).
// - relay state: `stat/<t>/RESULT` `{"POWER1":"ON"}` then `stat/<t>/POWER1` `ON`, not retained
//   (PowerRetain off), after EVERY power command even when nothing changed
//   (xdrv_02_9_mqtt.ino MqttPublishPowerState; tasmota_support/support_tasmota.ino
//   ExecuteCommandPower `if (publish_power) MqttPublishPowerState(device)`).
//   Relay names POWER1.. (SetOption26 or more than one relay).
// - commands: case-insensitive names; POWER payload ON/OFF/TOGGLE/1/0/2, empty = query.
// - shutters (SetOption80 1): `cmnd/<t>/ShutterPosition<n>` 0..100 or UP/OPEN/DOWN/CLOSE/STOP/TOGGLE;
//   `stat/<t>/RESULT` `{"Shutter1":{"Position":54,"Direction":1,"Target":100,"Tilt":0}}` on the
//   command and every second while moving (tasmota_xdrv_driver/xdrv_27_esp32_shutter.ino
//   JSON_SHUTTER_POS, ShutterReportPosition, FUNC_EVERY_SECOND); the shutter's relays switch
//   (POWER reports). A locked shutter answers `{"ShutterPosition1":"Locked"}` and stays put.
//   Tasmota shutters are time-based (no position sensor), so a jammed motor still reports
//   motion; the stuck case here is a locked shutter, the one that does not move.
// - telemetry every TelePeriod (300 s default, my_user_config.h): `tele/<t>/STATE` and
//   `tele/<t>/SENSOR` JSON, not retained, with `"Time":"2023-11-14T22:13:20"` (local time,
//   seconds; tasmota_support/support.ino ResponseGetTime), never epoch ms.
// See FIRMWARE.md §2.
const { Impersonator } = require('./base');

// GetDateAndTime(DT_LOCAL): local ISO time without zone, to the second (the device's zone is UTC here).
const tasmotaTime = (ms) => new Date(ms).toISOString().slice(0, 19);

class TasmotaDevice extends Impersonator {
  /**
   * @param {string} url
   * @param {object} config {
   *   topic: %topic%, relays: number of relays,
   *   shutters: [{ position: 0..100, travelMs, locked }] (shutter n drives relays 2n-1 up, 2n down),
   *   sensors: { DS18B20: { Id, Temperature }, ANALOG: { A1: 12000 } } (SENSOR JSON sections),
   *   telePeriodMs: 300000 }
   */
  constructor(url, config) {
    const t = config.topic;
    super(url, {
      clientId: `DVES_${t.toUpperCase().replace(/[^A-Z0-9]/g, '')}`,
      will: { topic: `tele/${t}/LWT`, payload: 'Offline', qos: 1, retain: true },
      startMs: config.startMs,
    });
    this.t = t;
    this.shutters = (config.shutters || []).map((s, i) => ({
      position: 0, travelMs: 2000, locked: false, ...s, index: i + 1, target: 0, direction: 0, sinceReportMs: 0,
    }));
    for (const s of this.shutters) s.target = s.position;
    this.power = new Array(Math.max(config.relays || 0, this.shutters.length * 2)).fill(false);
    this.sensors = config.sensors || null;
    this.telePeriodMs = config.telePeriodMs || 300000;
    this.sinceTeleMs = 0;
    this.uptimeMs = 0;
  }

  async onConnect() {
    this.publish(`tele/${this.t}/LWT`, 'Online', { qos: 1, retain: true });
    this.publish(`cmnd/${this.t}/POWER`, '', { qos: 0, retain: false });
    await this.subscribe([`cmnd/${this.t}/#`], 0);
    this.publish(`tele/${this.t}/INFO1`, JSON.stringify({
      Info1: {
        Module: 'ESP32-DevKit', Version: '14.4.1(release-tasmota32)', FallbackTopic: `cmnd/${this.clientId}_fb/`, GroupTopic: 'cmnd/tasmotas/',
      },
    }));
    for (let i = 1; i <= this.power.length; i++) this.publishPower(i);
    await this.settled();
  }

  relayName(i) {
    return `POWER${i}`;
  }

  publishPower(i) {
    const name = this.relayName(i);
    const text = this.power[i - 1] ? 'ON' : 'OFF';
    this.publish(`stat/${this.t}/RESULT`, `{"${name}":"${text}"}`);
    this.publish(`stat/${this.t}/${name}`, text, { retain: false });
  }

  shutterJson(s) {
    return `"Shutter${s.index}":{"Position":${Math.round(s.position)},"Direction":${s.direction},"Target":${Math.round(s.target)},"Tilt":0}`;
  }

  reportShutter(s) {
    this.publish(`stat/${this.t}/RESULT`, `{${this.shutterJson(s)}}`);
  }

  onMessage(topic, text) {
    const command = topic.slice(`cmnd/${this.t}/`.length);
    const upper = command.toUpperCase();
    const power = /^POWER(\d*)$/.exec(upper);
    if (power) return this.powerCommand(power[1] === '' ? 1 : Number(power[1]), text);
    const shutter = /^SHUTTERPOSITION(\d*)$/.exec(upper);
    if (shutter) return this.shutterCommand(shutter[1] === '' ? 1 : Number(shutter[1]), text);
    const named = /^SHUTTER(OPEN|CLOSE|STOP)(\d*)$/.exec(upper);
    if (named) return this.shutterCommand(named[2] === '' ? 1 : Number(named[2]), named[1]);
    this.warn(`unknown command ${command}`);
    return this.publish(`stat/${this.t}/RESULT`, '{"Command":"Unknown"}');
  }

  powerCommand(i, text) {
    if (i < 1 || i > this.power.length) return this.publish(`stat/${this.t}/RESULT`, '{"Command":"Unknown"}');
    const word = text.trim().toUpperCase();
    if (word === 'ON' || word === '1' || word === 'TRUE') this.power[i - 1] = true;
    else if (word === 'OFF' || word === '0' || word === 'FALSE') this.power[i - 1] = false;
    else if (word === 'TOGGLE' || word === '2') this.power[i - 1] = !this.power[i - 1];
    else if (word !== '') this.warn(`POWER${i}: unparsed payload ${text}`);
    return this.publishPower(i); // reported whether or not it changed
  }

  shutterCommand(n, text) {
    const s = this.shutters[n - 1];
    if (!s) return this.publish(`stat/${this.t}/RESULT`, '{"Command":"Unknown"}');
    const word = text.trim().toUpperCase();
    let target;
    if (word === 'UP' || word === 'OPEN') target = 100;
    else if (word === 'DOWN' || word === 'CLOSE') target = 0;
    else if (word === 'TOGGLE') target = s.position > 0 ? 0 : 100;
    else if (word === 'STOP') target = s.position;
    else if (/^-?\d+$/.test(word)) target = Math.min(100, Math.max(0, Number(word)));
    else {
      this.warn(`ShutterPosition${n}: unparsed payload ${text}`);
      return this.reportShutter(s);
    }
    if (s.locked) {
      this.reportShutter(s);
      return this.publish(`stat/${this.t}/RESULT`, `{"ShutterPosition${n}":"Locked"}`);
    }
    s.target = target;
    const direction = target === s.position ? 0 : (target > s.position ? 1 : -1);
    if (direction !== s.direction) this.setMotor(s, direction);
    return this.reportShutter(s);
  }

  /** ShutterMode 1: relay 2n-1 drives up, 2n down; each switch is a POWER report. */
  setMotor(s, direction) {
    const up = 2 * s.index - 1;
    const down = 2 * s.index;
    s.direction = direction;
    s.sinceReportMs = 0;
    for (const [relay, on] of [[up, direction === 1], [down, direction === -1]]) {
      if (this.power[relay - 1] !== on) {
        this.power[relay - 1] = on;
        this.publishPower(relay);
      }
    }
  }

  async step(dt) {
    this.uptimeMs += dt;
    for (const s of this.shutters) {
      if (s.direction === 0) continue;
      const delta = (100 * dt) / s.travelMs;
      s.position = s.direction === 1 ? Math.min(s.target, s.position + delta) : Math.max(s.target, s.position - delta);
      s.sinceReportMs += dt;
      if (s.position === s.target) {
        this.setMotor(s, 0);
        this.reportShutter(s); // the stop, with Direction 0
      } else if (s.sinceReportMs >= 1000) {
        s.sinceReportMs -= 1000;
        this.reportShutter(s); // FUNC_EVERY_SECOND while moving
      }
    }
    this.sinceTeleMs += dt;
    if (this.sinceTeleMs >= this.telePeriodMs) {
      this.sinceTeleMs -= this.telePeriodMs;
      this.publishTelemetry();
    }
  }

  publishTelemetry() {
    const time = `"Time":"${tasmotaTime(this.nowMs)}"`;
    const s = Math.floor(this.uptimeMs / 1000);
    const uptime = `0T${String(Math.floor(s / 3600)).padStart(2, '0')}:${String(Math.floor(s / 60) % 60).padStart(2, '0')}:${String(s % 60).padStart(2, '0')}`;
    const powers = this.power.map((on, i) => `"${this.relayName(i + 1)}":"${on ? 'ON' : 'OFF'}"`).join(',');
    this.publish(`tele/${this.t}/STATE`, `{${time},"Uptime":"${uptime}","UptimeSec":${s},"Heap":142,"SleepMode":"Dynamic","Sleep":50,"LoadAvg":19,"MqttCount":1${powers ? `,${powers}` : ''},"Wifi":{"AP":1,"SSId":"plant","RSSI":80,"Signal":-60}}`);
    const sections = [];
    if (this.sensors) {
      for (const [name, fields] of Object.entries(this.sensors)) sections.push(`"${name}":${JSON.stringify(fields)}`);
    }
    for (const sh of this.shutters) sections.push(this.shutterJson(sh));
    if (sections.length) {
      const unit = this.sensors && this.sensors.DS18B20 ? ',"TempUnit":"C"' : '';
      this.publish(`tele/${this.t}/SENSOR`, `{${time},${sections.join(',')}${unit}}`);
    }
  }

  /** Telemetry now (as at the end of a TelePeriod). */
  teleNow() {
    this.publishTelemetry();
    return this.settled();
  }

  warn(line) {
    this.warnings.push(line);
  }

  /** A shutter that does not move on command (ShutterLock; see the header). */
  stick(index) {
    this.shutters[index - 1].locked = true;
  }

  setSensor(section, field, value) {
    this.sensors[section][field] = value;
  }

  shutter(index) {
    return this.shutters[index - 1];
  }
}

async function startTasmota(url, config) {
  return new TasmotaDevice(url, config).connect();
}

module.exports = { TasmotaDevice, startTasmota, tasmotaTime };
