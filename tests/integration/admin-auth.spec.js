'use strict';
// The editor's operator endpoints under adminAuth, in a real Node-RED process:
// POST /sugarshack/estop and /sugarshack/clear record the signed-in editor
// user in their events (with the reason), a user with only `read` may look at
// GET /sugarshack/state but not stop or clear, and nobody signed in may do
// either. No broker: an interlock without a plant.
//
// Run: npx mocha --timeout 30000 --exit tests/integration/admin-auth.spec.js
const assert = require('node:assert/strict');
const fs = require('fs');
const path = require('path');
// Node-RED's own bcrypt, as its `node-red admin hash-pw` uses.
const bcrypt = require(require.resolve('bcryptjs', { paths: [require.resolve('@node-red/editor-api')] }));
const { NodeRedProcess, sleep } = require('./support/node-red');
const { settingsFile } = require('../../scripts/lib/node-red-process');

const INTERLOCK = 'a0a0a0a0a0a0a001';

function flows(eventsFile) {
  return [
    { id: 'a0a0a0a0a0a0a0f0', type: 'tab', label: 'admin auth' },
    { id: INTERLOCK, type: 'sugarshack-interlock', name: 'lines', resources: [{ name: 'YEL' }, { name: 'RED' }], policy: 'greedy', queueBound: '1024', warnQueued: '', warnHeld: '', persist: false },
    { id: 'a0a0a0a0a0a0a002', type: 'sugarshack-interlock-events', z: 'a0a0a0a0a0a0a0f0', interlock: INTERLOCK, wires: [['a0a0a0a0a0a0a003']] },
    { id: 'a0a0a0a0a0a0a003', type: 'file', z: 'a0a0a0a0a0a0a0f0', filename: eventsFile, filenameType: 'str', appendNewline: true, createDir: true, overwriteFile: 'false', encoding: 'none', wires: [[]] },
  ];
}

describe('the editor\'s e-stop and clear under adminAuth (a real Node-RED process)', function () {
  this.timeout(60000);
  let red;
  let eventsFile;

  before(async function () {
    red = new NodeRedProcess({ flows: [], tag: 'adminauth' });
    eventsFile = path.join(red.dir, 'events.jsonl');
    fs.writeFileSync(path.join(red.dir, 'flows.json'), JSON.stringify(flows(eventsFile)));
    const hash = bcrypt.hashSync('secret-pass', 8);
    const adminAuth = `
  adminAuth: { type: 'credentials', users: [
    { username: 'ana', password: ${JSON.stringify(hash)}, permissions: '*' },
    { username: 'viewer', password: ${JSON.stringify(hash)}, permissions: 'read' },
  ] },`;
    fs.writeFileSync(path.join(red.dir, 'settings.js'), settingsFile(red.dir, { extra: adminAuth }));
    await red.start({ waitForBroker: false });
  });

  after(async function () {
    if (red) await red.finish(this.currentTest);
  });

  const url = (p) => `http://127.0.0.1:${red.port}${p}`;
  async function tokenOf(username, scope = '*') {
    const res = await fetch(url('/auth/token'), {
      method: 'POST', headers: { 'Content-Type': 'application/json' },
      body: JSON.stringify({ client_id: 'node-red-admin', grant_type: 'password', scope, username, password: 'secret-pass' }),
    });
    assert.equal(res.status, 200, `sign-in of ${username}`);
    return (await res.json()).access_token;
  }
  async function call(method, p, token, body) {
    const headers = { 'Content-Type': 'application/json' };
    if (token) headers.Authorization = `Bearer ${token}`;
    const res = await fetch(url(p), { method, headers, body: body === undefined ? undefined : JSON.stringify(body) });
    const text = await res.text();
    return { status: res.status, body: text && /json/.test(res.headers.get('content-type') || '') ? JSON.parse(text) : text };
  }
  async function events(kind, count) {
    const deadline = Date.now() + 10000;
    for (;;) {
      const all = fs.existsSync(eventsFile) ? fs.readFileSync(eventsFile, 'utf8').trim().split('\n').filter(Boolean).map((l) => JSON.parse(l)) : [];
      const found = all.filter((e) => e.kind === kind);
      if (found.length >= count) return found;
      if (Date.now() > deadline) throw new Error(`no ${count} '${kind}' events: ${JSON.stringify(all)}`);
      await sleep(50);
    }
  }
  const lineOf = async (token, name) => (await call('GET', '/sugarshack/state', token)).body.interlocks[0].lines.find((l) => l.name === name);

  it('nobody signed in may read the state, stop or clear', async function () {
    assert.equal((await call('GET', '/sugarshack/state')).status, 401);
    assert.equal((await call('POST', '/sugarshack/estop', null, { interlock: INTERLOCK, lines: ['YEL'] })).status, 401);
    assert.equal((await call('POST', '/sugarshack/clear', null, { interlock: INTERLOCK, lines: ['YEL'] })).status, 401);
  });

  it('a read-only user sees the state but may not stop or clear', async function () {
    const viewer = await tokenOf('viewer', 'read');
    assert.equal((await lineOf(viewer, 'YEL')).state.state, 'free');
    assert.equal((await call('POST', '/sugarshack/estop', viewer, { interlock: INTERLOCK, lines: ['YEL'] })).status, 401);
    assert.equal((await lineOf(viewer, 'YEL')).state.state, 'free', 'nothing stopped');
  });

  it('GET /sugarshack/access says what the caller may do, as the endpoints decide it', async function () {
    assert.equal((await call('GET', '/sugarshack/access')).status, 401);
    assert.deepEqual((await call('GET', '/sugarshack/access', await tokenOf('viewer', 'read'))).body, { read: true, write: false });
    assert.deepEqual((await call('GET', '/sugarshack/access', await tokenOf('ana'))).body, { read: true, write: true });
  });

  it('an e-stop and a clear by the signed-in editor user are recorded as hers, with her reasons', async function () {
    const ana = await tokenOf('ana');
    let res = await call('POST', '/sugarshack/estop', ana, { interlock: INTERLOCK, lines: ['YEL'], reason: 'smell of burning at the evaporator' });
    assert.equal(res.status, 200, JSON.stringify(res.body));
    assert.deepEqual(res.body, { stopped: ['YEL'], by: 'ana' });
    const [faulted] = await events('resource-faulted', 1);
    assert.deepEqual(faulted.resources, ['YEL']);
    assert.equal(faulted.by, 'ana');
    assert.equal(faulted.reason, 'smell of burning at the evaporator');
    assert.equal((await lineOf(ana, 'YEL')).fault.note, 'smell of burning at the evaporator');

    // No plant bound: nothing to check the line's isolation against, so the clear goes through.
    res = await call('POST', '/sugarshack/clear', ana, { interlock: INTERLOCK, lines: ['YEL'], reason: 'checked: a belt, not the pan' });
    assert.equal(res.status, 200, JSON.stringify(res.body));
    assert.deepEqual(res.body, { cleared: ['YEL'], by: 'ana' });
    const [cleared] = await events('cleared', 1);
    assert.equal(cleared.by, 'ana');
    assert.equal(cleared.reason, 'checked: a belt, not the pan');
    assert.equal((await lineOf(ana, 'YEL')).state.state, 'free');

    res = await call('POST', '/sugarshack/clear', ana, { interlock: INTERLOCK, lines: ['YEL'] });
    assert.equal(res.status, 409);
    assert.equal(res.body.code, 'NOT_FAULTED');
  });

  it('an alarm acknowledged and shelved by the signed-in editor user is recorded as hers; a read-only user may not', async function () {
    const ana = await tokenOf('ana');
    const viewer = await tokenOf('viewer', 'read');
    await call('POST', '/sugarshack/estop', ana, { interlock: INTERLOCK, lines: ['RED'], reason: 'steam leak' });
    const alarmOf = async (id) => (await call('GET', '/sugarshack/state', ana)).body.interlocks.find((il) => il.id === INTERLOCK).alarms.find((a) => a.id === id);
    const deadline = Date.now() + 10000;
    while (!(await alarmOf('line-faulted:RED')) && Date.now() < deadline) await new Promise((r) => setTimeout(r, 100));
    assert.equal((await call('POST', '/sugarshack/alarms/ack', viewer, { interlock: INTERLOCK, ids: ['line-faulted:RED'] })).status, 401);
    assert.equal((await alarmOf('line-faulted:RED')).state, 'active-unacknowledged', 'the viewer changed nothing');
    let res = await call('POST', '/sugarshack/alarms/ack', ana, { interlock: INTERLOCK, ids: ['line-faulted:RED'], reason: 'on it' });
    assert.equal(res.status, 200, JSON.stringify(res.body));
    assert.equal(res.body.by, 'ana');
    const acked = await alarmOf('line-faulted:RED');
    assert.equal(acked.state, 'active-acknowledged');
    assert.deepEqual([acked.acked.by, acked.acked.reason], ['ana', 'on it']);
    res = await call('POST', '/sugarshack/alarms/shelve', ana, { interlock: INTERLOCK, id: 'line-faulted:RED', forMs: 60000 });
    assert.equal(res.status, 200, JSON.stringify(res.body));
    assert.equal((await alarmOf('line-faulted:RED')).shelved.by, 'ana');
    await call('POST', '/sugarshack/clear', ana, { interlock: INTERLOCK, lines: ['RED'] });
  });
});
