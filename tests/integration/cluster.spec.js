'use strict';
// The hot standby's election, fencing and store against a real three-member
// etcd cluster (Debian's etcd-server on loopback ports): one leader at a time,
// a write under a stale fencing token refused by etcd itself, self-demotion by
// the local monotonic clock before the lease can run out, the standby
// following the committed state, and quorum loss and return.
//
// Run: npx mocha --timeout 30000 --exit tests/integration/cluster.spec.js
const assert = require('node:assert/strict');
const { Etcd3 } = require('etcd3');
const { startEtcd } = require('./support/etcd');
const { waitFor } = require('./support/node-red');
const { Cluster } = require('../../node-red-contrib-sugarshack/lib/cluster/cluster');
const { EtcdStore } = require('../../node-red-contrib-sugarshack/lib/cluster/etcd-store');
const { clusterSettings } = require('../../node-red-contrib-sugarshack/lib/cluster/settings');

const TTL_S = 2;
// The store keeps bytes (the core seals and opens the interlock's document); these are documents enough to tell apart.
const doc = (n) => JSON.stringify({ n });
const docOf = (read) => JSON.parse(read.text);

describe('hot standby: election, fencing and state on a real etcd cluster', function () {
  this.timeout(120000);
  let etcd;
  let admin;
  const made = [];
  let names = 0;

  before(async function () {
    etcd = await startEtcd();
    admin = new Etcd3({ hosts: etcd.endpoints });
  });

  afterEach(async function () {
    for (const c of made.splice(0)) await c.stop();
    for (let i = 0; i < 3; i++) if (!etcd.alive(i)) await etcd.restart(i);
  });

  after(async function () {
    if (admin) admin.close();
    if (etcd) await etcd.stop();
  });

  /** Instances of a fresh cluster name; `now`: an injected monotonic clock. */
  function contenders(count, { now } = {}) {
    const name = `c${++names}`;
    return Array.from({ length: count }, (_, i) => {
      const settings = clusterSettings({ sugarshack: { cluster: { name, instance: `i${i}`, etcd: { hosts: etcd.endpoints }, leaseTtlS: TTL_S } } });
      const c = new Cluster(settings, { now });
      made.push(c);
      return c;
    });
  }

  const started = (list) => {
    for (const c of list) c.start();
    return list;
  };

  const leaderOf = (list) => waitFor(() => list.filter((c) => c.role === 'active').length === 1, 'one active instance', 15000)
    .then(() => list.find((c) => c.role === 'active'));

  it('elects one leader among three; its token is the leader key\'s revision; the others stand by', async function () {
    const list = started(contenders(3));
    const leader = await leaderOf(list);
    await waitFor(() => list.every((c) => c === leader || c.role === 'standby'), 'the others standby');
    const kv = (await admin.get(`sugarshack/${leader.settings.name}/leader`).exec()).kvs[0];
    assert.equal(String(kv.mod_revision), leader.token);
    assert.equal(JSON.parse(kv.value.toString()).instance, leader.instance);
    for (const c of list) if (c !== leader) assert.equal(c.mayAct(), false);
    assert.equal(leader.mayAct(), true);
    // Sampled for a while: never two.
    for (let i = 0; i < 20; i++) {
      assert.equal(list.filter((c) => c.mayAct()).length, 1);
      await new Promise((r) => setTimeout(r, 50));
    }
  });

  it('refuses in etcd a write under a stale token, and the writer deposes itself', async function () {
    const [a, b] = started(contenders(2));
    const first = await leaderOf([a, b]);
    const other = first === a ? b : a;
    const store = new EtcdStore(first, 'il');
    await store.load();
    await store.write(doc(1));
    const staleToken = first.token;
    // A leader that stops renewing (a paused process) loses its key when the lease runs out; the other takes over.
    first.lease.close();
    await waitFor(() => other.role === 'active', 'the other elected', 15000);
    await waitFor(() => first.role !== 'active' && first.role !== 'suspended', 'the first deposed', 5000);
    // Now pretend it never noticed: its own checks pass, only etcd's compare stands in the way.
    const pretend = new EtcdStore({ ...first, client: first.client, keys: first.keys, prefix: first.prefix, token: staleToken, instance: first.instance, mayAct: () => true, depose: () => { pretend.deposed = true; }, emit: () => {} }, 'il');
    await assert.rejects(pretend.write(doc(2)), /fenced out/);
    assert.equal(pretend.deposed, true);
    const saved = await admin.get(store.key).string();
    assert.equal(JSON.parse(saved).n, 1, 'the stale write changed nothing');
    // The new leader writes under its own token.
    const next = new EtcdStore(other, 'il');
    await next.load();
    assert.equal(docOf(next.read()).n, 1, 'the new leader reads what the old one committed');
    await next.write(doc(3));
    assert.equal(JSON.parse(await admin.get(store.key).string()).n, 3);
  });

  it('stops acting by its own monotonic clock before the lease can run out, and acts again once etcd renews it', async function () {
    let skew = 0;
    const now = () => performance.now() + skew;
    const [a] = started(contenders(1, { now }));
    await leaderOf([a]);
    const store = new EtcdStore(a, 'il');
    await store.load();
    // A pause as SIGSTOP makes it: the clock jumps past TTL - margin with no keep-alive answered.
    skew += TTL_S * 1000;
    assert.equal(a.mayAct(), false, 'acts on nothing at once, before any timer or answer');
    assert.equal(a.role, 'suspended');
    await assert.rejects(store.write(doc(1)), /not the active leader/);
    // The lease lived at etcd (the process only looked paused): the next keep-alive answer resumes it, same token.
    const token = a.token;
    await waitFor(() => a.role === 'active', 'active again', 5000);
    assert.equal(a.token, token);
    await store.write(doc(2));
  });

  it('lets the standby follow each committed write, and reads a missing or empty state as lost, never as a first start', async function () {
    const [a, b] = started(contenders(2));
    const leader = await leaderOf([a, b]);
    const standby = leader === a ? b : a;
    const store = new EtcdStore(leader, 'il');
    await store.load();
    assert.equal(store.read().kind, 'first');
    const followed = new EtcdStore(standby, 'il');
    await followed.follow();
    await store.write(doc(7));
    await waitFor(() => followed.read().kind === 'saved' && docOf(followed.read()).n === 7, 'the standby sees the write');
    await followed.unfollow();
    // Someone deletes the state but not its marker: lost, so every line would start faulted.
    await admin.delete().key(store.key).exec();
    await store.load();
    assert.equal(store.read().kind, 'lost');
    await admin.put(store.key).value('').exec();
    await store.load();
    assert.equal(store.read().kind, 'lost', 'an empty state is lost (a damaged one is the core\'s to find, as for a file)');
  });

  it('rides out one member down; with quorum lost it commits nothing and suspends, and resumes by itself when etcd is back', async function () {
    const [a, b] = started(contenders(2));
    const leader = await leaderOf([a, b]);
    const store = new EtcdStore(leader, 'il');
    await store.load();
    const token = leader.token;
    await etcd.kill(0);
    // The member killed may have led etcd's Raft or carried the client's keep-alives: at this test's 2 s
    // lease a write may wait for the client to move to another member; it commits under the same token.
    await waitFor(() => store.write(doc(1)).then(() => true, () => false), 'a write committed with one member down', 10000);
    assert.equal(leader.token, token, 'one member down: no failover');
    assert.equal(leader.mayAct(), true, 'one member down: the same leader acts');
    await etcd.kill(1);
    await assert.rejects(store.write(doc(2)));
    await waitFor(() => leader.role === 'suspended', 'suspended once its lease may have run out', TTL_S * 1000 + 3000);
    assert.equal(a.mayAct() || b.mayAct(), false, 'nobody acts without quorum');
    await etcd.restart(0);
    await etcd.restart(1);
    await waitFor(() => leader.role === 'active', 'the same leader active again', 20000);
    assert.equal(leader.token, token, 'no failover: its lease and key lived through the outage');
    // While etcd settles, a keep-alive may come late: the write goes through once the lease holds (the Committer retries so).
    await waitFor(() => store.write(doc(3)).then(() => true, () => false), 'a write committed', 20000);
    assert.equal(JSON.parse(await admin.get(store.key).string()).n, 3);
  });

  it('takes the settings.js section of docs/how-to/hot-standby.md as written', function () {
    const page = require('fs').readFileSync(require('path').join(__dirname, '..', '..', 'docs/how-to/hot-standby.md'), 'utf8');
    const block = /```js by=tests\/integration\/cluster\.spec\.js\n([\s\S]*?)```/.exec(page)[1];
    const settings = new Function(`return {\n${block}\n};`)(); // eslint-disable-line no-new-func
    const cluster = clusterSettings(settings);
    assert.deepEqual([cluster.name, cluster.instance, cluster.hosts.length, cluster.ttlS, cluster.marginMs, cluster.mqtt.client], ['shack', 'edge-a', 3, 3, 1000, 'nodered-a']);
  });

  it('refuses a cluster section it cannot use, naming the setting', function () {
    assert.equal(clusterSettings({}), null);
    assert.throws(() => clusterSettings({ sugarshack: { cluster: { name: 'x', etcd: { hosts: [] } } } }), /etcd\.hosts/);
    assert.throws(() => clusterSettings({ sugarshack: { cluster: { name: 'x', etcd: { hosts: ['http://a:1'] }, leaseTtlS: 1 } } }), /leaseTtlS/);
    assert.throws(() => clusterSettings({ sugarshack: { cluster: { name: 'a b', etcd: { hosts: ['http://a:1'] } } } }), /name/);
  });
});
