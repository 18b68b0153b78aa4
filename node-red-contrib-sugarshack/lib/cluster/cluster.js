// @ts-check
'use strict';
// One Node-RED instance's part in a hot-standby cluster: its etcd session
// (lease), the leader key it campaigns for, and its role:
//
//   connecting -> standby -> active <-> suspended
//                    ^                      |
//                    +------- deposed ------+
//
// Leadership is the key sugarshack/<name>/leader, created only where it does
// not exist (a transaction on its create revision) and attached to this
// instance's lease, so it goes when the lease expires. Its revision is the
// fencing token: every state write is a transaction that succeeds only while
// that key still has that revision (see etcd-store.js), so a deposed leader
// cannot write, whatever the election client believes.
//
// An active instance is `suspended` (it acts on nothing: mayAct() is false)
// from the moment its lease may have run out by its own monotonic clock, and
// active again once etcd acknowledges a keep-alive (the lease, and so its key,
// lived). Told the lease is gone, or seeing its key deleted or replaced, it is
// deposed: its runtimes stand down as after a shutdown, it records itself as
// standby and campaigns again with a new lease.
const { EventEmitter } = require('events');
const { Lease } = require('./lease');
const { MqttFence } = require('./mqtt-fence');

const CALL_MS = 2000;
// A failover's alarm condition holds this long after the takeover, then the alarm waits for its acknowledgement.
const FAILOVER_ACTIVE_MS = 10000;
const RETRY_MS = 500;
const HEALTH_MS = 2000;

/** @typedef {'connecting' | 'standby' | 'active' | 'suspended' | 'stopped'} Role */

class Cluster extends EventEmitter {
  /**
   * @param {import('./settings').ClusterSettings} settings
   * @param {{ log?: (level: string, text: string) => void, Etcd3?: any, now?: () => number }} [options]
   */
  constructor(settings, { log = () => {}, Etcd3, now } = {}) {
    super();
    this.setMaxListeners(0);
    this.settings = settings;
    this.log = log;
    this.now = now;
    this.Etcd3 = Etcd3 || require('etcd3').Etcd3;
    this.prefix = `sugarshack/${settings.name}/`;
    this.keys = {
      leader: `${this.prefix}leader`,
      member: (instance) => `${this.prefix}members/${instance}`,
      members: `${this.prefix}members/`,
      client: (instance) => `${this.prefix}mqtt-clients/${instance}`,
      clients: `${this.prefix}mqtt-clients/`,
    };
    /** @type {Role} */
    this.role = 'connecting';
    /** @type {string | null} the leader key's revision while this instance holds it */
    this.token = null;
    /** @type {{ instance: string, sinceMs: number | null, token: string, gone?: boolean } | null} as last seen */
    this.leader = null;
    /** @type {{ instance: string, sinceMs: number | null, token: string } | null} another instance seen leading since this one last led */
    this.lastOther = null;
    this.sinceMs = Date.now(); // when the role last changed (wall clock, for people)
    /** @type {Lease | null} */
    this.lease = null;
    /** @type {any} an Etcd3 client */
    this.client = null;
    /** @type {any[] | null} */
    this.memberClients = null;
    this.watchers = [];
    this.followers = new Set(); // { activate(), standDown() }
    this.fence = settings.mqtt ? new MqttFence(settings.mqtt) : null;
    /** @type {string | null} */
    this.fenceProblem = null;
    this.members = new Map(); // instance -> { role, sinceMs }
    this.health = []; // [{ endpoint, healthy, leader, error }]
    this.failovers = 0;
    /** @type {{ atMs: number, from: string, to: string, token: string } | null} */
    this.lastFailover = null;
    this.stopping = false;
    this.suspendTimer = null;
    this.healthTimer = null;
    this.campaigning = false;
  }

  get instance() {
    return this.settings.instance;
  }

  /** True only while this instance is the fenced leader and its lease cannot have run out. */
  mayAct() {
    if (this.role !== 'active' || !this.lease) return false;
    if (this.lease.valid()) return true;
    this.suspend(); // found out before its timer fired (a process that was paused)
    return false;
  }

  suspend() {
    this.setRole('suspended');
    this.log('warn', `cluster ${this.settings.name}: no keep-alive acknowledged in time; acting on nothing until etcd answers`);
  }

  get active() {
    return this.role === 'active' || this.role === 'suspended';
  }

  // ---- the session ---------------------------------------------------------

  start() {
    const { hosts, auth, credentials } = this.settings;
    this.client = new this.Etcd3({
      hosts,
      auth: auth || undefined,
      credentials: credentials || undefined,
      dialTimeout: CALL_MS,
      defaultCallOptions: (ctx) => (ctx.isStream ? {} : { deadline: Date.now() + CALL_MS }),
    });
    if (this.fence) this.fence.connect(); // ready before any election
    this.watchLeader();
    this.watchMembers();
    this.healthTimer = setInterval(() => this.checkHealth(), HEALTH_MS);
    this.checkHealth();
    this.session();
  }

  /** A new lease, this instance recorded as standby, then the campaign. */
  async session() {
    while (!this.stopping) {
      const lease = new Lease({ client: this.client, ttlS: this.settings.ttlS, marginMs: this.settings.marginMs, now: this.now });
      try {
        await lease.grant();
        const mqtt = this.settings.mqtt;
        await this.client.put(this.keys.client(this.instance)).value(mqtt ? mqtt.client : '').exec();
        await this.client.put(this.keys.member(this.instance)).value(this.memberValue('standby')).lease(lease.id).exec();
      } catch (err) {
        lease.close();
        this.log('warn', `etcd: ${err.message}`);
        await sleep(RETRY_MS);
        continue;
      }
      this.lease = lease;
      lease.on('lost', () => this.depose('lease lost'));
      lease.on('renewed', () => this.renewed());
      this.setRole('standby');
      this.campaign();
      return;
    }
  }

  memberValue(role) {
    return JSON.stringify({ instance: this.instance, role, sinceMs: Date.now() });
  }

  /** Takes the leader key if nobody holds it; otherwise waits for the watch to say it went. */
  async campaign() {
    if (this.campaigning || this.stopping || this.role !== 'standby' || !this.lease) return;
    this.campaigning = true;
    const lease = this.lease;
    try {
      const value = JSON.stringify({ instance: this.instance, sinceMs: Date.now() });
      const res = await this.client.if(this.keys.leader, 'Create', '==', 0)
        .then(
          this.client.put(this.keys.leader).value(value).lease(lease.id),
          this.client.put(this.keys.member(this.instance)).value(this.memberValue('active')).lease(lease.id),
        )
        .else(this.client.get(this.keys.leader))
        .commit();
      if (lease !== this.lease || this.role !== 'standby') return;
      if (res.succeeded) {
        await this.elected(res.header.revision);
        return;
      }
      const kv = res.responses[0].response_range.kvs[0];
      if (kv && kv.lease === lease.id) await this.elected(kv.mod_revision); // ours: an answer lost on the way
      else if (kv) this.sawLeader(kv);
      else setTimeout(() => this.campaign(), RETRY_MS); // gone between compare and read
    } catch (err) {
      this.log('warn', `etcd: campaign: ${err.message}`);
      setTimeout(() => this.campaign(), RETRY_MS);
    } finally {
      this.campaigning = false;
    }
  }

  /** This instance holds the key at revision `token`: fence the others, then act. */
  async elected(token) {
    this.token = String(token);
    // Not this.leader: the watch may have shown this instance's own key before the transaction answered.
    const previous = this.lastOther;
    this.lastOther = null;
    this.leader = { instance: this.instance, sinceMs: Date.now(), token: this.token };
    await this.fenceOthers();
    if (this.token !== String(token) || !this.lease || this.stopping) return;
    const failover = previous && previous.instance !== this.instance;
    if (failover) {
      this.failovers += 1;
      this.lastFailover = { atMs: Date.now(), from: previous.instance, to: this.instance, token: this.token };
    }
    this.setRole(this.lease.valid() ? 'active' : 'suspended');
    this.log('info', `cluster ${this.settings.name}: ${this.instance} is active (token ${this.token})`);
    for (const f of this.followers) f.activate();
    this.scheduleSuspendCheck();
  }

  /**
   * Every other instance's MQTT account is disabled unless it records itself as
   * standby; this one's enabled. Bounded: a broker that does not answer is logged
   * and the leader goes on (the residual window: see the docs).
   */
  async fenceOthers() {
    if (!this.fence) return;
    try {
      const clients = await this.client.getAll().prefix(this.keys.clients).strings();
      const members = await this.client.getAll().prefix(this.keys.members).strings();
      const work = [];
      const { fence } = this;
      for (const [key, username] of Object.entries(clients)) {
        if (!username) continue;
        const instance = key.slice(this.keys.clients.length);
        const member = parseJson(members[this.keys.member(instance)]);
        if (instance === this.instance || (member && member.role === 'standby')) work.push(fence.enable(username));
        else work.push(fence.disable(username));
      }
      await Promise.all(work);
      this.fenceProblem = null;
    } catch (err) {
      this.fenceProblem = err.message;
      this.log('warn', `cluster ${this.settings.name}: MQTT fencing: ${err.message}`);
    }
  }

  // ---- watching the leader key and the members -------------------------------

  async watchLeader() {
    const watcher = await this.client.watch().key(this.keys.leader).create();
    this.watchers.push(watcher);
    watcher.on('put', (kv) => this.leaderChanged(kv));
    watcher.on('delete', () => this.leaderChanged(null));
    watcher.on('error', () => {});
  }

  leaderChanged(kv) {
    if (this.active && (!kv || String(kv.mod_revision) !== this.token)) {
      this.depose(kv ? 'leader key replaced' : 'leader key deleted');
      return;
    }
    if (kv) this.sawLeader(kv);
    else if (this.role === 'standby') {
      this.leader = this.leader ? { ...this.leader, gone: true } : null;
      this.campaign();
    }
  }

  sawLeader(kv) {
    const value = parseJson(kv.value.toString()) || {};
    const seen = { instance: value.instance || '?', sinceMs: value.sinceMs || null, token: String(kv.mod_revision) };
    if (!this.active) this.leader = seen;
    if (seen.instance !== this.instance) this.lastOther = seen;
    this.emit('changed');
  }

  async watchMembers() {
    let seed = null;
    while (!seed && !this.stopping) {
      seed = await this.client.getAll().prefix(this.keys.members).exec().catch(() => null);
      if (!seed) await sleep(RETRY_MS);
    }
    if (!seed) return;
    for (const kv of seed.kvs) this.memberSeen(kv.key.toString(), kv.value.toString());
    // From just after the read: a member recorded in between is not missed.
    const watcher = await this.client.watch().prefix(this.keys.members).startRevision(String(BigInt(seed.header.revision) + 1n)).create();
    this.watchers.push(watcher);
    watcher.on('put', (kv) => this.memberSeen(kv.key.toString(), kv.value.toString()));
    watcher.on('delete', (kv) => this.memberSeen(kv.key.toString(), null));
    watcher.on('error', () => {});
  }

  memberSeen(key, value) {
    const instance = key.slice(this.keys.members.length);
    const member = value === null ? null : parseJson(value);
    if (member) this.members.set(instance, { role: member.role, sinceMs: member.sinceMs });
    else this.members.delete(instance);
    // The leader fences and unfences the others as they come and go.
    if (this.fence && this.active && instance !== this.instance) this.fenceOthers();
    this.emit('changed');
  }

  // ---- suspension and deposition ----------------------------------------------

  /** Marks the role suspended when the lease's local validity ends (mayAct() already says so). */
  scheduleSuspendCheck() {
    if (this.suspendTimer) clearTimeout(this.suspendTimer);
    this.suspendTimer = null;
    if (this.role !== 'active' || !this.lease) return;
    this.suspendTimer = setTimeout(() => {
      this.suspendTimer = null;
      if (this.role === 'active' && this.lease && !this.lease.valid()) this.suspend();
      else this.scheduleSuspendCheck();
    }, Math.max(10, this.lease.remainingMs() + 1));
  }

  renewed() {
    if (this.role === 'suspended' && this.lease && this.lease.valid()) {
      this.setRole('active');
      this.log('info', `cluster ${this.settings.name}: etcd answered; active again (token ${this.token})`);
      for (const f of this.followers) if (f.resumed) f.resumed();
    }
    if (this.role === 'active') this.scheduleSuspendCheck();
  }

  /** Leadership is lost: every follower stands down, then this instance is standby with a new lease. */
  async depose(why) {
    const lease = this.lease;
    if (!lease || this.stopping) return;
    const wasActive = this.active;
    this.lease = null;
    this.token = null;
    lease.close();
    if (this.suspendTimer) clearTimeout(this.suspendTimer);
    this.suspendTimer = null;
    this.setRole('connecting');
    if (wasActive) {
      this.log('warn', `cluster ${this.settings.name}: ${this.instance} stands down (${why})`);
      await Promise.all([...this.followers].map((f) => Promise.resolve(f.standDown()).catch(() => {})));
    }
    lease.revoke();
    this.session();
  }

  setRole(role) {
    if (role === this.role) return;
    this.role = role;
    this.sinceMs = Date.now();
    this.emit('role', role);
    this.emit('changed');
  }

  /** A runtime that acts only while this instance is active: `activate()` on election, `standDown()` when deposed. */
  follow(follower) {
    this.followers.add(follower);
    return () => this.followers.delete(follower);
  }

  // ---- what operators see -------------------------------------------------------

  async checkHealth() {
    const { Etcd3 } = this;
    if (!this.memberClients) {
      const { auth, credentials } = this.settings;
      this.memberClients = this.settings.hosts.map((host) => new Etcd3({ hosts: [host], auth: auth || undefined, credentials: credentials || undefined, dialTimeout: 1000 }));
    }
    this.health = await Promise.all(this.memberClients.map(async (c, i) => {
      const endpoint = this.settings.hosts[i];
      try {
        const s = await c.maintenance.status({ deadline: Date.now() + 1000 });
        return { endpoint, healthy: true, leader: s.leader === s.header.member_id, error: null };
      } catch (err) {
        return { endpoint, healthy: false, leader: false, error: String(err.message || err).slice(0, 200) };
      }
    }));
    this.emit('changed');
  }

  /** This instance's alarm conditions: a failover it just made, etcd members that do not answer. */
  alarmConditions(nowMs = Date.now()) {
    /** @type {{ kind: string, subject: string }[]} */
    const conditions = [];
    const f = this.lastFailover;
    if (f && f.to === this.instance && nowMs - f.atMs < FAILOVER_ACTIVE_MS) conditions.push({ kind: 'failover', subject: this.instance });
    for (const member of this.health) if (!member.healthy) conditions.push({ kind: 'etcd-member-down', subject: member.endpoint });
    return conditions;
  }

  /** The cluster as GET /sugarshack/state shows it. */
  describe() {
    const lease = this.lease;
    return {
      name: this.settings.name,
      instance: this.instance,
      role: this.role,
      sinceMs: this.sinceMs,
      token: this.token,
      leader: this.leader,
      lease: lease ? { id: lease.id, ttlS: lease.ttlS, validForMs: Math.max(0, Math.round(lease.remainingMs())) } : null,
      members: [...this.members].map(([instance, m]) => ({ instance, ...m })),
      etcd: this.health,
      fencing: this.fence ? { disabled: [...this.fence.disabled], problem: this.fenceProblem } : null,
      failovers: this.failovers,
      lastFailover: this.lastFailover,
    };
  }

  /** A clean stop: the lease is given back, so a standby takes over at once. */
  async stop() {
    if (this.stopping) return;
    this.stopping = true;
    this.setRole('stopped');
    if (this.suspendTimer) clearTimeout(this.suspendTimer);
    if (this.healthTimer) clearInterval(this.healthTimer);
    for (const w of this.watchers) await w.cancel().catch(() => {});
    if (this.lease) await this.lease.revoke();
    if (this.fence) this.fence.close();
    for (const c of this.memberClients || []) c.close();
    if (this.client) this.client.close();
  }
}

function parseJson(text) {
  if (typeof text !== 'string') return null;
  try {
    return JSON.parse(text);
  } catch {
    return null;
  }
}

const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

module.exports = { Cluster };
