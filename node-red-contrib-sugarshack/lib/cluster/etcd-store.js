// @ts-check
'use strict';
// An interlock's state in etcd, for a hot-standby cluster: the same document
// a FileStore keeps in a file (sealed by the core: owner, configuration
// digest, checksum; the core opens it), read the same way (a marker key says
// "this interlock ran here", so a missing or empty state is lost, never a
// first start), at sugarshack/<cluster>/state/<kind>/<id>.
//
// Every write is a transaction guarded by the fencing token (the leader key
// still has the revision this instance was elected at), so a deposed leader
// writes nothing; the Committer lets effects leave only after it commits, and
// only while the lease cannot have run out. The standby follows each write
// through a watch, so it shows the committed state and takes it over at once;
// on election it reads it again under the token (a linearizable read after
// every write of the old leader).
const { safeName, INTERLOCK_STATE, MAX_STATE_BYTES } = require('../host/durable');
const i18n = require('../host/i18n');

// A commit takes about 5-10 ms on a healthy cluster; past this, isolation comes first.
const URGENT_AFTER_MS = 100;

class EtcdStore {
  /**
   * @param {import('./cluster').Cluster} cluster
   * @param {string} name the owning node's id
   * @param {{ kind: string, note: string }} [of]
   */
  constructor(cluster, name, of = INTERLOCK_STATE) {
    this.cluster = cluster;
    this.of = of;
    this.key = `${cluster.prefix}state/${of.kind}/${safeName(name)}`;
    this.marker = `${this.key}.ran`;
    /** @type {{ text: string | null, ran: boolean, revision: string | null }} as last read, written or followed */
    this.held = { text: null, ran: false, revision: null };
    this.watcher = null;
    this.writes = 0;
  }

  get where() {
    return `etcd:${this.key}`;
  }

  get durable() {
    return true;
  }

  /** A lockout waits this long for its write, then goes out anyway while the lease holds (etcd may have lost quorum). */
  get urgentAfterMs() {
    return URGENT_AFTER_MS;
  }

  mayAct() {
    return this.cluster.mayAct();
  }

  /** Follows what the leader commits (a standby's view); resolves once watching. */
  async follow() {
    if (this.watcher) return;
    await this.load({ fenced: false });
    const watcher = await this.cluster.client.watch().key(this.key).create();
    this.watcher = watcher;
    watcher.on('put', (kv) => {
      this.held = { text: kv.value.toString(), ran: true, revision: String(kv.mod_revision) };
      this.cluster.emit('changed');
    });
    watcher.on('error', () => {});
  }

  async unfollow() {
    const watcher = this.watcher;
    this.watcher = null;
    if (watcher) await watcher.cancel().catch(() => {});
  }

  /** Reads the committed state; `fenced`: under this instance's token, refused once it is deposed. */
  async load({ fenced = true } = {}) {
    const { client, keys } = this.cluster;
    let res;
    if (fenced) {
      res = await client.if(keys.leader, 'Mod', '==', this.cluster.token)
        .then(client.get(this.key), client.get(this.marker))
        .commit();
      if (!res.succeeded) throw new Error(i18n.text('labels.fencedOut', { where: this.where }));
    } else {
      res = await client.if(this.key, 'Create', '>', -1).then(client.get(this.key), client.get(this.marker)).commit();
    }
    const kv = res.responses[0].response_range.kvs[0];
    const ran = res.responses[1].response_range.kvs.length > 0;
    this.held = { text: kv ? kv.value.toString() : null, ran, revision: kv ? String(kv.mod_revision) : null };
  }

  /**
   * What was last loaded, as a FileStore reads its file: { kind: 'first' },
   * { kind: 'saved', text } (for the core to open) or { kind: 'lost', why }.
   */
  read() {
    const { text, ran } = this.held;
    if (text === null) return ran ? { kind: 'lost', why: i18n.text('labels.stateFileMissing', { file: this.where }) } : { kind: 'first' };
    if (text.length === 0) return { kind: 'lost', why: i18n.text('labels.stateFileEmpty', { file: this.where }) };
    if (text.length > MAX_STATE_BYTES) return { kind: 'lost', why: i18n.text('labels.stateFileTooLarge', { file: this.where, size: text.length, max: MAX_STATE_BYTES }) };
    return { kind: 'saved', text };
  }

  /** The marker goes with every write (one transaction), so nothing to do before. */
  markRan() {}

  /** Commits `text` under the fencing token; rejects when fenced out or when the lease may have run out meanwhile. */
  async write(text) {
    const { cluster } = this;
    const token = cluster.token;
    if (!cluster.mayAct() || token === null) throw new Error(i18n.text('labels.notActive', { instance: cluster.instance }));
    const res = await cluster.client.if(cluster.keys.leader, 'Mod', '==', token)
      .then(cluster.client.put(this.key).value(text), cluster.client.put(this.marker).value(this.of.note))
      .commit();
    if (!res.succeeded) {
      cluster.depose('a state write was fenced out');
      throw new Error(i18n.text('labels.fencedOut', { where: this.where }));
    }
    this.held = { text, ran: true, revision: String(res.header.revision) };
    this.writes += 1;
    // Committed, but a paused process may wake here: its effects must not leave.
    if (!cluster.mayAct()) throw new Error(i18n.text('labels.notActive', { instance: cluster.instance }));
  }
}

module.exports = { EtcdStore };
