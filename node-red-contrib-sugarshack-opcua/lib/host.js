'use strict';
// One OPC UA server serving one interlock and its plant: node-opcua's server
// with the plant's address space (model.js), its alarms as conditions
// (conditions.js), its methods (methods.js) and Node-RED's people (users.js),
// kept up to date from the palette's change notices.
const os = require('os');
const { OPCUAServer, nodesets, makeApplicationUrn } = require('node-opcua');
const { endpointOf, certificateManager } = require('./security');
const { Users } = require('./users');
const { PlantModel, NAMESPACE_URI } = require('./model');
const { Conditions } = require('./conditions');
const { addMethods } = require('./methods');
const { exceptionBased } = require('./exception-based');
const { version } = require('../package.json');

const WILDCARD = new Set(['0.0.0.0', '::']);

class ServerHost {
  /**
   * api: the palette's; settings: the node's (see nodes/opcua-server.js);
   * userDir: where the certificate is kept; t(key, values): the catalog;
   * log(level, text) and onStatus(status) reach the node serving it now.
   */
  constructor({ api, settings, userDir, t, log, onStatus }) {
    this.api = api;
    this.settings = settings;
    this.userDir = userDir;
    this.t = t;
    this.log = log;
    this.onStatus = onStatus;
    this.server = null;
    this.stopped = false;
    this.unsubscribe = [];
    this.anyFaulted = false;
  }

  /** Starts listening; rejects with a SettingsError (or node-opcua's error) when it cannot. */
  start() {
    this.starting = this.run();
    return this.starting;
  }

  async run() {
    const { settings, t, api } = this;
    const endpoint = endpointOf(settings, t);
    this.users = new Users(api, (err) => this.log('warn', t('logs.signInFailed', { message: err.message })));
    const certificates = certificateManager(this.userDir, settings.trustClients);
    await certificates.initialize();
    const host = os.hostname();
    this.server = new OPCUAServer({
      ...endpoint,
      hostname: WILDCARD.has(endpoint.host) ? undefined : endpoint.host,
      nodeset_filename: [nodesets.standard],
      serverCertificateManager: certificates,
      userManager: this.users.manager(),
      maxSessions: settings.maxSessions,
      maxConnectionsPerEndpoint: settings.maxSessions * 2,
      serverInfo: {
        applicationUri: makeApplicationUrn(host, 'sugarshack-opcua'),
        productUri: 'urn:sugarshack:opcua',
        applicationName: { text: `sugarshack ${settings.name || 'plant'}` },
      },
      buildInfo: { productName: 'node-red-contrib-sugarshack-opcua', manufacturerName: 'sugarshack', softwareVersion: version },
      serverCapabilities: { maxSessions: settings.maxSessions },
      isAuditing: false,
    });
    await this.server.initialize();
    // node-opcua makes each session's diagnostics objects in the address space, about 100 ms of the
    // event loop each: a client opening sessions by the hundred would hold the interlock up for seconds.
    // They are not made (the Server object's diagnostics summary stays).
    this.server.on('create_session', (session) => {
      if (typeof session._createSessionObjectInAddressSpace === 'function') session._createSessionObjectInAddressSpace = () => false;
    });
    if (!exceptionBased(NAMESPACE_URI)) this.log('warn', t('logs.sampled'));
    const addressSpace = this.server.engine.addressSpace;
    // A&C's methods on the types (ConditionRefresh among them); conditions.js then rebinds the ones the core answers.
    addressSpace.installAlarmsAndConditionsService();
    const common = { api, interlockId: settings.interlock };
    this.model = new PlantModel({ addressSpace, ...common, actuatorLimit: settings.actuatorLimit, name: settings.name });
    const onError = (err) => this.log('error', t('logs.failed', { message: err.message }));
    this.conditions = new Conditions({ model: this.model, ...common, users: this.users, limit: settings.conditionLimit, onError });
    addMethods({ model: this.model, ...common, users: this.users, t, onError });
    this.follow();
    await this.server.start();
    for (const event of ['session_activated', 'session_closed']) this.server.on(event, () => this.showStatus());
    this.showStatus();
    this.log('info', t('logs.listening', { url: this.server.getEndpointUrl(), modes: endpoint.securityModes.map(String).join(', ') }));
  }

  /** Follows the palette's changes: the interlock's by description, its plant's by what its core touched. */
  follow() {
    const { api, settings } = this;
    const id = settings.interlock;
    this.unsubscribe.push(api.onChange((ids) => {
      if (!this.plantFollowed) this.followPlant();
      const plant = this.model.plant;
      // A plant's change moves a faulted line's reasons not to clear it.
      if (ids.has(id) || (this.anyFaulted && plant && ids.has(plant.id))) this.refreshInterlock();
    }));
    this.followPlant();
    if (!this.plantFollowed) this.model.build(); // the interlock alone, until its plant runs
    this.refreshInterlock();
  }

  followPlant() {
    const off = this.api.onPlantChange(this.settings.interlock, (change) => {
      if (change.rebuilt) {
        this.model.build();
        this.refreshInterlock();
      } else {
        this.model.refreshPlant(change);
      }
    });
    if (!off) return;
    this.plantFollowed = true;
    this.unsubscribe.push(off);
    this.model.build();
  }

  refreshInterlock() {
    const il = this.model.refreshInterlock();
    if (!il) return;
    this.anyFaulted = (il.lines || []).some((l) => l.fault);
    this.conditions.sync(il.alarms || []);
    // Each line's fault alarm made ahead: an e-stop's event goes out at once.
    this.conditions.prepare((il.lines || []).map((l) => ({ id: this.api.alarmId('line-faulted', l.name), kind: 'line-faulted', subject: l.name })));
  }

  showStatus() {
    if (this.stopped || !this.server) return;
    const sessions = this.server.currentSessionCount;
    this.onStatus({ fill: 'green', shape: 'dot', text: this.t('status.listening', { port: this.settings.port, sessions }) });
  }

  async stop() {
    this.stopped = true;
    if (this.starting) await this.starting.catch(() => {});
    for (const off of this.unsubscribe.splice(0)) off();
    if (this.conditions) this.conditions.stop();
    const { server } = this;
    this.server = null;
    if (server) await server.shutdown(0);
  }
}

module.exports = { ServerHost };
