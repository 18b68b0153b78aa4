// @ts-check
'use strict';
// The hot standby's entry: the cluster of this Node-RED process, made once from
// settings.js (see settings.js) and started when the palette loads, or null
// when none is configured (then nothing changes).
const { clusterSettings } = require('./settings');
const { Cluster } = require('./cluster');
const { EtcdStore } = require('./etcd-store');
const { standbyStatus } = require('../host/runtime-base');

const clusters = new WeakMap(); // RED.events -> Cluster | null

/** @returns {Cluster | null} */
function clusterOf(RED) {
  if (!RED || !RED.events) return null;
  if (clusters.has(RED.events)) return clusters.get(RED.events);
  const settings = clusterSettings(RED.settings);
  const log = (level, text) => {
    if (RED.log && RED.log[level]) RED.log[level](`[sugarshack] ${text}`);
  };
  const cluster = settings ? new Cluster(settings, { log }) : null;
  clusters.set(RED.events, cluster);
  if (cluster) {
    cluster.start();
    // A clean stop gives the lease back (acting on nothing from that moment): the standby takes over at once.
    process.once('SIGTERM', () => cluster.stop());
    process.once('SIGINT', () => cluster.stop());
  }
  return cluster;
}

/**
 * For the nodes outside the interlock and plant runtimes (pid, rcc, rcc-io):
 * a test that is true while this instance may not act (a hot standby, a
 * leader whose lease may have run out, a cluster section it cannot use).
 * @returns {() => boolean}
 */
function quietOf(RED) {
  let cluster;
  try {
    cluster = clusterOf(RED);
  } catch {
    return () => true;
  }
  return cluster ? () => !cluster.mayAct() : () => false;
}

module.exports = { clusterOf, quietOf, standbyStatus, EtcdStore };
