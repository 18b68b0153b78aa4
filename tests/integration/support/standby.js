'use strict';
// Two real Node-RED processes in one hot-standby cluster on a real etcd, each
// with the routines flow (support/routines-flow.js) under its own MQTT client
// id (and, with dynamic security, its own MQTT account), for the standby,
// chaos and failover tests.
//
//   const pair = new StandbyPair({ etcd, broker, cluster: 'chaos', ttlS: 3 });
//   await pair.start();                      // both running, one active
//   const leader = await pair.leader();      // the NodeRedProcess that is active
const { NodeRedProcess, waitFor } = require('./node-red');
const { flow } = require('./routines-flow');

const INSTANCES = ['a', 'b'];

/**
 * The routines flow with the broker's client id and account read from the
 * environment, a pid loop (test/pid in, test/pid/out) to show that a
 * standby's control nodes send nothing either, and a journal into local files
 * (`<dir>/journal`) that only the active instance writes.
 */
function clusterFlow(port) {
  return flow(port, 'standby').map((n) => (n.type === 'mqtt-broker'
    ? { ...n, clientid: '${MQTT_CLIENT_ID}', credentials: undefined }
    : n)).concat([
    {
      id: 'in-pid', z: 'tab', type: 'mqtt in', topic: 'test/pid', qos: '1', datatype: 'auto-detect', broker: 'br', nl: false, rap: true, rh: 0, inputs: 0, wires: [['pid']],
    },
    {
      id: 'pid', z: 'tab', type: 'sugarshack-pid', kp: '1', ti: '10', td: '0', outMin: '0', outMax: '100', action: 'reverse', ts: '1', setpoint: '50', smith: 'off', mode: 'auto', persist: false, wires: [['pidout']],
    },
    { id: 'pidout', z: 'tab', type: 'mqtt out', topic: 'test/pid/out', qos: '1', retain: 'false', broker: 'br', wires: [] },
    {
      id: 'journal-files', z: 'tab', type: 'sugarshack-journal', target: 'files', dir: 'journal', plantId: 'standby', flushS: '0.1', wires: [],
    },
  ]);
}

class StandbyPair {
  /**
   * @param {object} o
   * @param {{ endpoints: string[] }} o.etcd
   * @param {{ port: number, url: string }} o.broker
   * @param {string} o.cluster
   * @param {number} [o.ttlS]
   * @param {{ admin: { username: string, password: string }, accounts: Record<string, { username: string, password: string }> }} [o.dynsec]
   * @param {string} [o.settings] more of settings.js for both
   */
  constructor({ etcd, broker, cluster, ttlS = 3, dynsec = null, settings: more = '' }) {
    this.nodes = {};
    for (const instance of INSTANCES) {
      const account = dynsec ? dynsec.accounts[instance] : null;
      const fence = dynsec
        ? `, mqtt: { url: ${JSON.stringify(broker.url)}, username: ${JSON.stringify(dynsec.admin.username)}, password: ${JSON.stringify(dynsec.admin.password)}, client: ${JSON.stringify(account.username)} }`
        : '';
      const settings = `\n  sugarshack: { cluster: { name: ${JSON.stringify(cluster)}, instance: '${instance}', etcd: { hosts: ${JSON.stringify(etcd.endpoints)} }, leaseTtlS: ${ttlS}${fence} } },${more}`;
      const red = new NodeRedProcess({
        flows: clusterFlow(broker.port), tag: `standby-${instance}`, settings, env: { MQTT_CLIENT_ID: `nr-${instance}` },
      });
      red.instance = instance;
      if (account) {
        require('fs').writeFileSync(require('path').join(red.dir, 'flows_cred.json'), JSON.stringify({ br: { user: account.username, password: account.password } }));
      }
      this.nodes[instance] = red;
    }
  }

  get list() {
    return INSTANCES.map((i) => this.nodes[i]);
  }

  /** Starts both (or the ones not running); resolves once one of them is active. */
  async start() {
    await Promise.all(this.list.filter((r) => !r.alive).map((r) => r.start({ waitForBroker: false })));
    return this.leader();
  }

  /** The cluster as an instance reports it, or null when it does not answer. */
  async clusterOf(red) {
    if (!red.answering) return null;
    try {
      return (await red.get('/sugarshack/state')).cluster;
    } catch {
      return null;
    }
  }

  /** Resolves with the process that reports itself active (and whose interlock runs), waiting up to `ms`. */
  async leader(ms = 30000) {
    let found = null;
    await waitFor(async () => {
      for (const red of this.list) {
        if (!red.answering) continue;
        try {
          const state = await red.get('/sugarshack/state');
          const il = state.interlocks.find((i) => i.id === 'il');
          if (state.cluster && state.cluster.role === 'active' && il && il.state === 'ready') {
            found = red;
            return true;
          }
        } catch {
          // not answering yet
        }
      }
      return false;
    }, 'an active instance with its interlock running', ms);
    return found;
  }

  other(red) {
    return this.list.find((r) => r !== red);
  }

  async finish(test) {
    for (const red of this.list) {
      red.signal('SIGCONT');
      await red.finish(test);
    }
  }
}

module.exports = { StandbyPair, clusterFlow, INSTANCES };
