'use strict';
// Power cuts of an interlock bound to no plant (run by the core's engine). A
// real Node-RED process takes acquires, releases, e-stops and clears over
// HTTP, with the interlock persisted; it is killed with SIGKILL while
// requests are in flight, and restarted on the same user directory, 12 times.
// After each restart, from outside (GET /sugarshack/state):
//
// - a line whose grant or e-stop was answered, with nothing else of it in
//   flight, is faulted (a grant "interrupted"), never free;
// - a line whose release or clear was answered, with nothing in flight, is free;
// - with a request of a line in flight at the kill, the line is free only if
//   its last answer or that request could leave it free.
//
// Run: npx mocha --timeout 30000 --exit tests/integration/crash-interlock.spec.js
const assert = require('node:assert/strict');
const http = require('http');
const { mulberry32: random } = require('../../scripts/simulator/random');
const { NodeRedProcess, sleep } = require('./support/node-red');

const KILLS = 12;
const SEED = 20261127;
const LINES = ['YEL', 'GRN', 'BLU', 'RED'];
const INTERLOCK = 'c1c1c1c1c1c1c101';
const TAB = 'c1c1c1c1c1c1c1f0';

/** An endpoint POST /<path> whose body's operation and resources go into `type`'s node; answered once it sends the msg on. */
function endpoint(n, path, type, wires = 1) {
  const id = (k) => `c1c1c1c1c1c1c${n}${k}`;
  return [
    { id: id(1), type: 'http in', z: TAB, url: `/${path}`, method: 'post', upload: false, wires: [[id(2)]] },
    { id: id(2), type: 'function', z: TAB, func: 'msg.operation = msg.payload.operation;\nmsg.resources = msg.payload.resources;\nmsg.payload = "ok";\nreturn msg;', outputs: 1, wires: [[id(3)]] },
    { id: id(3), type, z: TAB, interlock: INTERLOCK, operation: '', priority: 0, resources: '', timeout: 0, wires: Array.from({ length: wires }, (_, i) => (i === 0 ? [id(4)] : [])) },
    { id: id(4), type: 'http response', z: TAB, statusCode: '200', headers: {}, wires: [] },
  ];
}

function flows() {
  return [
    { id: TAB, type: 'tab', label: 'power cuts' },
    {
      id: INTERLOCK, type: 'sugarshack-interlock', name: 'lines', resources: LINES.map((name) => ({ name })),
      policy: 'greedy', queueBound: '1024', warnQueued: '', warnHeld: '', persist: true,
    },
    ...endpoint(2, 'acquire', 'sugarshack-acquire'),
    ...endpoint(3, 'release', 'sugarshack-release'),
    // A refusal answers too (409), so it is not taken for a request in flight.
    { id: 'c1c1c1c1c1c1c191', type: 'catch', z: TAB, scope: null, uncaught: false, wires: [['c1c1c1c1c1c1c192']] },
    { id: 'c1c1c1c1c1c1c192', type: 'http response', z: TAB, statusCode: '409', headers: {}, wires: [] },
  ];
}

/** A failed admin request's status: a refusal (409), or null when the process died first. */
function statusOf(err) {
  return /ECONNRESET|socket hang up|ECONNREFUSED|timeout/i.test(String(err && err.message)) ? null : 409;
}

/** POST `body` to `path`: resolves with the status, or null when the process died first. */
function post(port, path, body) {
  const text = JSON.stringify(body);
  return new Promise((resolve) => {
    const req = http.request({
      host: '127.0.0.1', port, path, method: 'POST',
      headers: { 'Content-Type': 'application/json', 'Content-Length': Buffer.byteLength(text) },
    }, (res) => {
      res.resume();
      res.on('end', () => resolve(res.statusCode));
      res.on('error', () => resolve(null));
    });
    req.on('error', () => resolve(null));
    req.end(text);
  });
}

describe('power cuts of an interlock run by the engine: SIGKILL of a real Node-RED process', function () {
  this.timeout(10 * 60 * 1000);
  let red;

  before(async function () {
    red = new NodeRedProcess({ flows: flows(), tag: 'crash-interlock' });
    await red.start({ waitForBroker: false });
  });

  after(async function () {
    if (red) await red.finish(this.currentTest);
  });

  it(`keeps every answered grant and e-stop locked out across ${KILLS} kills, and frees what was answered free`, async function () {
    const rand = random(SEED);
    let op = 0;
    let checkedHeld = 0;
    for (let life = 0; life < KILLS; life++) {
      // Each life starts with every line free.
      await red.request('POST', '/sugarshack/clear', { interlock: INTERLOCK, reason: 'next life' });
      assert.deepEqual(await red.lines(INTERLOCK), Object.fromEntries(LINES.map((l) => [l, 'free'])), `life ${life} starts free`);
      const answered = new Map(); // line -> 'held' | 'faulted' | 'free', by its last answer
      const inFlight = new Map(); // line -> the kind of its one request not answered
      const holders = new Map(); // line -> the operation granted it
      // One request per line at a time, so that its answers come in the order the interlock took them.
      const ask = (line, kind, request) => {
        inFlight.set(line, kind);
        return request.then((status) => {
          if (status === null) return; // killed first
          inFlight.delete(line);
          if (status !== 200) return;
          const last = answered.get(line) || 'free';
          if (kind === 'acquire') answered.set(line, 'held');
          else if (kind === 'estop') answered.set(line, 'faulted');
          else if (kind === 'release' && last === 'held') answered.set(line, 'free');
          else if (kind === 'clear') answered.set(line, 'free');
        });
      };
      const requests = [];
      const steps = 6 + Math.floor(rand() * 10);
      for (let s = 0; s < steps; s++) {
        const line = LINES[Math.floor(rand() * LINES.length)];
        const roll = rand();
        if (inFlight.has(line)) {
          // its request still waits: this step goes by
        } else if (roll < 0.5) {
          const operation = `op${op++}`;
          requests.push(ask(line, 'acquire', post(red.port, '/acquire', { operation, resources: line }).then((status) => {
            if (status === 200) holders.set(line, operation);
            return status;
          })));
        } else if (roll < 0.75 && holders.has(line)) {
          requests.push(ask(line, 'release', post(red.port, '/release', { operation: holders.get(line) })));
        } else if (roll < 0.9) {
          requests.push(ask(line, 'estop', red.request('POST', '/sugarshack/estop', { interlock: INTERLOCK, lines: [line], reason: 'test' })
            .then(() => 200, (err) => statusOf(err))));
        } else {
          requests.push(ask(line, 'clear', red.request('POST', '/sugarshack/clear', { interlock: INTERLOCK, lines: [line], reason: 'test' })
            .then(() => 200, (err) => statusOf(err))));
        }
        await sleep(rand() * 6);
      }
      await sleep(rand() * 15);
      await red.kill();
      await Promise.all(requests);
      await red.start({ waitForBroker: false });
      const lines = await red.lines(INTERLOCK);
      for (const line of LINES) {
        const last = answered.get(line) || 'free';
        const pending = inFlight.get(line);
        const state = lines[line];
        const why = `life ${life}: ${line} last answered ${last}, in flight ${pending || 'nothing'}, now ${state}`;
        if (!pending) {
          if (last === 'held') assert.equal(state, 'faulted:interrupted', why);
          else if (last === 'faulted') assert.match(state, /^faulted:/, why);
          else assert.equal(state, 'free', why);
          if (last === 'held') checkedHeld++;
        } else if (state === 'free') {
          assert.ok(last === 'free' || pending === 'release' || pending === 'clear', why);
        }
      }
    }
    assert.ok(checkedHeld > 0, 'some kill came after an answered grant');
  });
});
