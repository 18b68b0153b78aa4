'use strict';
// The OPC UA server node: one server for one interlock and the plant bound to
// it (lib/host.js). It reaches the palette only through the API the palette
// hands over (RED.plugins.get('sugarshack-api')). A deploy that restarts the
// node with the same settings hands the running server to the new instance,
// so a SCADA's sessions and subscriptions go on; changed settings, a removed
// node or Node-RED stopping stop it.
const os = require('os');
const path = require('path');

const API_PLUGIN = 'sugarshack-api';
// The palette's API this node needs at least (2: commands to runs); a later one keeps what it had.
const API_VERSION = 2;
// How long a server waits for the next instance of its node after a deploy's close.
const HANDOVER_MS = 30000;

/** node id -> { host, key, timer, node } of every server running */
const servers = new Map();

module.exports = function (RED) {
  const t = (key, values) => RED._(`sugarshack-opcua-server.${key}`, values);

  function settingsOf(props) {
    const int = (value, fallback) => (value === '' || value === undefined || value === null ? fallback : Number(value));
    return {
      name: props.name || '',
      interlock: props.interlock || '',
      host: String(props.host || '0.0.0.0').trim(),
      port: int(props.port, 4840),
      none: props.none === true,
      sign: props.sign !== false,
      encrypt: props.encrypt !== false,
      anonymous: props.anonymous === true,
      trustClients: props.trustClients === true,
      maxSessions: Math.max(1, int(props.maxSessions, 20) || 20),
      actuatorLimit: Math.max(0, int(props.actuatorLimit, 5000)),
      conditionLimit: Math.max(0, int(props.conditionLimit, 500)),
    };
  }

  function OpcUaServerNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    const settings = settingsOf(props);
    const key = JSON.stringify(settings);
    const plugin = RED.plugins.get(API_PLUGIN);
    const api = plugin && plugin.api;
    if (!api || !(api.version >= API_VERSION)) {
      node.status({ fill: 'red', shape: 'ring', text: t('status.noPalette') });
      node.error(t('errors.noApi', { version: API_VERSION }));
      return;
    }
    if (!settings.interlock) {
      node.status({ fill: 'red', shape: 'ring', text: t('status.noInterlock') });
      node.error(t('errors.noInterlock'));
      return;
    }

    let entry = servers.get(node.id);
    if (entry && entry.key === key) {
      clearTimeout(entry.timer);
      entry.node = node;
      entry.host.showStatus();
    } else {
      // A server with other settings goes first: the new one may want its port.
      const previous = entry ? stop(entry).catch(() => {}) : Promise.resolve();
      entry = { id: node.id, key, node, timer: null, host: null };
      const current = entry;
      // node-opcua (tens of MB, a second to load) is loaded with the first server, not with the palette.
      const { ServerHost } = require('../lib/host');
      entry.host = new ServerHost({
        api,
        settings,
        userDir: RED.settings.userDir || path.join(os.homedir(), '.node-red'),
        t,
        log: (level, text) => current.node && current.node[level === 'info' ? 'log' : level](text),
        onStatus: (status) => current.node && current.node.status(status),
      });
      servers.set(node.id, entry);
      node.status({ fill: 'grey', shape: 'ring', text: t('status.starting') });
      previous.then(() => current.host.start()).catch((err) => {
        if (servers.get(node.id) !== current) return;
        servers.delete(node.id);
        current.host.stop().catch(() => {});
        if (current.node) {
          current.node.status({ fill: 'red', shape: 'ring', text: t('status.failed') });
          current.node.error(t('errors.notStarted', { message: err.message }));
        }
      });
    }

    node.on('close', (removed, done) => {
      const mine = servers.get(node.id);
      if (!mine || mine.node !== node) {
        done();
        return;
      }
      mine.node = null;
      if (removed) {
        stop(mine).then(() => done(), () => done());
        return;
      }
      // Restarted by a deploy: the next instance takes it over, if it comes with the same settings.
      mine.timer = setTimeout(() => stop(mine), HANDOVER_MS);
      mine.timer.unref();
      done();
    });
  }

  function stop(entry) {
    clearTimeout(entry.timer);
    if (servers.get(entry.id) === entry) servers.delete(entry.id);
    return entry.host.stop();
  }

  RED.nodes.registerType('sugarshack-opcua-server', OpcUaServerNode);
};
