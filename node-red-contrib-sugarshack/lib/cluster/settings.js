// @ts-check
'use strict';
// The hot standby is configured in settings.js, not in a config node: the
// flows are the same on every instance (a config node would carry one
// instance's name to all of them), the choice must be made before any flow
// starts (a standby must never act, not even for the moments before a config
// node is read), and etcd credentials belong beside the other process
// secrets, not in a flows file that a deploy can change. Without a
// `sugarshack.cluster` section nothing changes: state in files, one instance.
//
//   sugarshack: { cluster: {
//     name: 'shack',                       // the cluster: every key under sugarshack/<name>/
//     instance: 'edge-a',                  // this instance (default: the host name)
//     etcd: { hosts: ['http://10.0.0.5:2379', ...], auth: { username, password }, credentials: { rootCertificate, privateKey, certChain } },
//     leaseTtlS: 3,                        // see DEFAULT_TTL_S
//     mqtt: { url, username, password, client: 'nr-edge-a' },   // dynamic-security fencing (optional)
//   } }
const os = require('os');
const { SugarshackError } = require('../host/errors');

// A dead leader is replaced about one TTL after its last keep-alive: 3 s keeps
// failover p99 under 5 s with the keep-alives (every TTL/3) riding out an
// event-loop stall of up to 2 s without a false demotion (see the docs'
// failure table for the figures measured).
const DEFAULT_TTL_S = 3;
const MIN_TTL_S = 2; // etcd's own floor is 1.5 x its election timeout (1.5 s by default)
const MAX_TTL_S = 60;
const NAME = /^[A-Za-z0-9_.-]{1,100}$/;

/** @typedef {{ name: string, instance: string, hosts: string[], auth: { username: string, password: string } | null, credentials: object | null, ttlS: number, marginMs: number, mqtt: { url: string, username: string, password: string, client: string } | null }} ClusterSettings */

/**
 * The cluster section of Node-RED's settings, checked; null when there is none.
 * @returns {ClusterSettings | null}
 */
function clusterSettings(settings) {
  let section;
  try {
    section = settings && settings.sugarshack ? settings.sugarshack.cluster : undefined;
  } catch {
    section = undefined;
  }
  if (section === undefined || section === null || section === false) return null;
  const bad = (what) => SugarshackError.of('INVALID_CONFIG', 'clusterSetting', { what });
  if (typeof section !== 'object') throw bad('sugarshack.cluster');
  const name = section.name;
  if (typeof name !== 'string' || !NAME.test(name)) throw bad('name');
  const instance = section.instance === undefined ? os.hostname() : section.instance;
  if (typeof instance !== 'string' || !NAME.test(instance)) throw bad('instance');
  const etcd = section.etcd || {};
  const hosts = typeof etcd.hosts === 'string' ? etcd.hosts.split(',').map((h) => h.trim()) : etcd.hosts;
  if (!Array.isArray(hosts) || hosts.length === 0 || !hosts.every((h) => typeof h === 'string' && /^https?:\/\/\S+$/.test(h))) throw bad('etcd.hosts');
  const ttlS = section.leaseTtlS === undefined ? DEFAULT_TTL_S : section.leaseTtlS;
  if (!Number.isInteger(ttlS) || ttlS < MIN_TTL_S || ttlS > MAX_TTL_S) throw bad('leaseTtlS');
  let auth = null;
  if (etcd.auth) {
    if (typeof etcd.auth.username !== 'string' || typeof etcd.auth.password !== 'string') throw bad('etcd.auth');
    auth = { username: etcd.auth.username, password: etcd.auth.password };
  }
  let mqtt = null;
  if (section.mqtt) {
    const m = section.mqtt;
    if (typeof m.url !== 'string' || typeof m.username !== 'string' || typeof m.password !== 'string' || typeof m.client !== 'string' || !m.client) throw bad('mqtt');
    mqtt = { url: m.url, username: m.username, password: m.password, client: m.client };
  }
  return {
    name,
    instance,
    hosts,
    auth,
    credentials: etcd.credentials || null,
    ttlS,
    // Stops acting this long before the lease can have run out at etcd: covers a
    // keep-alive's way there and clock-rate drift, and leaves the broker quiet before a successor starts.
    marginMs: Math.max(500, Math.round(ttlS * 1000 / 3)),
    mqtt,
  };
}

module.exports = { clusterSettings, DEFAULT_TTL_S };
