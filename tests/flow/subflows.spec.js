'use strict';
// The palette's subflow modules, loaded the way Node-RED loads them
// (RED.nodes.registerSubflow) and placed in flows as nodes of their type.
const assert = require('node:assert/strict');
const { mock } = require('node:test');
const helper = require('node-red-node-test-helper');
const {
  paletteNodes, subflowNodes, subflowCoreNodes, catchOnce, linkNodes, lockoutOf, TAB, interlockConfig, acquire, release,
  sinkNode, collect, until, startServer, stopServer, settled, clock,
} = require('./support');

helper.init(require.resolve('node-red'));

const NODE_MODULES = [...paletteNodes, ...subflowNodes, ...subflowCoreNodes, catchOnce, linkNodes];
const runtimeOf = () => helper.getNode('il').runtime;
const counts = () => runtimeOf().core.counts();
const quiet = () => settled(helper, 'il');

/** An instance of the singular operation subflow, as the editor saves it (every property set). */
function operation(id, props, wires) {
  return {
    id, z: 'f1', type: 'sugarshack-singular-operation', name: '', x: 100, y: 100,
    interlock: 'il', operation: '', priority: 0, resources: '', steps: 'steps', timeout: 30, ...props, wires,
  };
}

/** The user's steps: link in `name`, a helper node `work` the test drives, link out return. */
function steps(name, work) {
  return [
    { id: `${work}-in`, z: 'f1', type: 'link in', name, links: [], x: 100, y: 300, wires: [[work]] },
    { id: work, z: 'f1', type: 'helper', x: 200, y: 300, wires: [[`${work}-ret`]] },
    { id: `${work}-ret`, z: 'f1', type: 'link out', mode: 'return', links: [], x: 300, y: 300, wires: [] },
  ];
}

/** `until` for while setTimeout is mocked: turns of the event loop instead of sleeps. */
async function untilTurns(predicate, what, turns = 5000) {
  for (let i = 0; i < turns && !predicate(); i++) await new Promise((resolve) => setImmediate(resolve));
  if (!predicate()) throw new Error(`${what} did not happen within ${turns} turns of the event loop`);
}

/** Sends a msg held in the steps back to its operation (the steps completed). */
const finishStep = (work, msg) => helper.getNode(work).send(msg);

describe('subflow modules', function () {
  beforeEach(startServer);
  afterEach(async function () {
    mock.timers.reset();
    await stopServer();
  });

  it('registers each subflow module as a node type of the palette', async function () {
    await helper.load(NODE_MODULES, [TAB]);
    const registry = require('@node-red/registry');
    for (const type of ['sugarshack-singular-operation', 'sugarshack-group-entry', 'sugarshack-condition-step', 'sugarshack-operator-panel']) {
      const ctor = registry.get(type);
      assert.ok(ctor && ctor.subflow, `${type} is registered as a subflow module`);
      assert.equal(ctor.subflow.meta.type, type);
      assert.equal(ctor.subflow.meta.module, 'node-red-contrib-sugarshack');
      const inner = ctor.subflow.flow;
      assert.ok(!inner.some((n) => n.type === 'function'), `${type}: no function node inside`);
    }
  });

  it('two operation instances with different properties contend for a line and are granted in priority order', async function () {
    await helper.load(NODE_MODULES, [
      TAB, interlockConfig(),
      acquire('hold', 'H', 5, 'YEL', 'held'), release('rel'), sinkNode('held'),
      operation('opA', { operation: 'A', priority: 10, resources: 'YEL' }, [['doneA'], ['lockA']]),
      operation('opB', { operation: 'B', priority: 50, resources: 'YEL' }, [['doneB'], ['lockB']]),
      ...steps('steps', 'work'),
      ...['doneA', 'doneB', 'lockA', 'lockB'].map(sinkNode),
      { id: 'errors', z: 'f1', type: 'catch', scope: null, uncaught: false, x: 100, y: 400, wires: [['caught']] }, sinkNode('caught'),
    ]);
    const [held, work, doneA, doneB, caught] = ['held', 'work', 'doneA', 'doneB', 'caught'].map((id) => collect(helper, id));
    helper.getNode('hold').receive({});
    await until(() => held.length === 1, 'H holding YEL');

    helper.getNode('opA').receive({ payload: 'call A' });
    helper.getNode('opB').receive({ payload: 'call B' });
    await quiet();
    assert.deepEqual(counts(), { holding: 1, queued: 2, faulted: 0 }, 'A and B queue behind H');
    assert.equal(work.length, 0);

    helper.getNode('rel').receive({ operation: 'H' });
    await until(() => work.length === 1, 'the first grant');
    assert.equal(work[0].interlock.operation, 'B', 'B (priority 50) before A (priority 10)');
    assert.equal(work[0].interlock.priority, 50);
    assert.deepEqual(work[0].interlock.resources, ['YEL']);
    assert.equal(work[0].target, 'steps', 'the call went to the link in named by the instance');
    await quiet();
    assert.deepEqual(counts(), { holding: 1, queued: 1, faulted: 0 }, 'A still waits while B runs');

    finishStep('work', work[0]);
    await until(() => doneB.length === 1 && work.length === 2, 'B returned and A granted');
    assert.equal(doneB[0].payload, 'call B', "the caller's msg returns");
    assert.equal(doneB[0].target, undefined, 'the call target does not leak to the caller');
    assert.equal(work[1].interlock.operation, 'A');
    assert.equal(work[1].interlock.priority, 10);

    finishStep('work', work[1]);
    await until(() => doneA.length === 1, 'A returned');
    assert.equal(doneA[0].payload, 'call A');
    await quiet();
    assert.deepEqual(counts(), { holding: 0, queued: 0, faulted: 0 }, 'both released');
    assert.deepEqual(caught, []);
  });

  it('a call timeout faults its operation and locks its line out, the error reaching the caller; the other goes on', async function () {
    await helper.load(NODE_MODULES, [
      TAB, interlockConfig(),
      operation('opA', { operation: 'A', priority: 10, resources: 'YEL', steps: 'stepsA', timeout: 2 }, [['doneA'], ['lockA']]),
      operation('opB', { operation: 'B', priority: 20, resources: 'GRN', steps: 'stepsB', timeout: 30 }, [['doneB'], ['lockB']]),
      ...steps('stepsA', 'workA'), ...steps('stepsB', 'workB'),
      ...['doneA', 'doneB', 'lockA', 'lockB'].map(sinkNode),
      { id: 'catchA', z: 'f1', type: 'catch', scope: ['opA'], uncaught: false, x: 100, y: 400, wires: [['caughtA']] }, sinkNode('caughtA'),
      { id: 'catchB', z: 'f1', type: 'catch', scope: ['opB'], uncaught: false, x: 100, y: 500, wires: [['caughtB']] }, sinkNode('caughtB'),
    ]);
    const [workA, workB, doneA, doneB, lockA, lockB, caughtA, caughtB] = ['workA', 'workB', 'doneA', 'doneB', 'lockA', 'lockB', 'caughtA', 'caughtB']
      .map((id) => collect(helper, id));
    // The link call's timeout is Node-RED's own (setTimeout): it is driven here instead of waited for.
    mock.timers.enable({ apis: ['setTimeout'] });
    helper.getNode('opA').receive({ payload: 'call A' });
    helper.getNode('opB').receive({ payload: 'call B' });
    await untilTurns(() => workA.length === 1 && workB.length === 1, 'both running');
    await quiet();
    assert.deepEqual(counts(), { holding: 2, queued: 0, faulted: 0 });

    mock.timers.tick(1999);
    await quiet();
    assert.equal(caughtA.length, 0, 'not before its 2 s');
    mock.timers.tick(1);
    await untilTurns(() => caughtA.length === 1 && lockA.length === 1, "A's fault at its caller's Catch and its lockout");
    assert.equal(caughtA[0].error.code, 'FAULTED');
    assert.match(caughtA[0].error.message, /operation 'A' faulted; YEL locked out until cleared: timeout/);
    assert.equal(caughtA[0].error.cause.message, 'timeout', 'the link call timeout is the cause');
    assert.equal(caughtA[0].payload, 'call A', "the caller's msg");
    assert.equal(lockA[0].topic, 'lockout/YEL');
    assert.deepEqual(lockA[0].payload, lockoutOf('YEL'));
    assert.equal(lockA[0].operation, 'A');
    await quiet();
    assert.deepEqual(counts(), { holding: 1, queued: 0, faulted: 1 }, 'YEL latched faulted, B still holds GRN');
    assert.deepEqual(doneA, [], 'a faulted call does not return');

    finishStep('workB', workB[0]);
    await untilTurns(() => doneB.length === 1, 'B returned');
    assert.equal(doneB[0].payload, 'call B');
    assert.deepEqual(lockB, []);
    assert.deepEqual(caughtB, []);
    await quiet();
    assert.deepEqual(counts(), { holding: 0, queued: 0, faulted: 1 });
  });

  it("a refused acquire reaches the caller's Catch with the acquire's code, holding nothing and faulting nothing", async function () {
    await helper.load(NODE_MODULES, [
      TAB, interlockConfig(),
      operation('opA', { operation: 'A', priority: 10, resources: 'YEL' }, [['doneA'], ['lockA']]),
      operation('bad', { operation: 'Z', priority: 10, resources: 'NOWHERE' }, [['doneA'], ['lockA']]),
      ...steps('steps', 'work'), sinkNode('doneA'), sinkNode('lockA'),
      { id: 'catchA', z: 'f1', type: 'catch', scope: ['opA', 'bad'], uncaught: false, x: 100, y: 400, wires: [['caught']] }, sinkNode('caught'),
    ]);
    const [work, caught, lockA] = ['work', 'caught', 'lockA'].map((id) => collect(helper, id));
    helper.getNode('opA').receive({ payload: 1 });
    await until(() => work.length === 1, 'A running');
    helper.getNode('opA').receive({ payload: 2 });
    helper.getNode('bad').receive({ payload: 3 });
    await until(() => caught.length === 2, 'the two refusals');
    assert.deepEqual(caught.map((m) => [m.payload, m.error.code]).sort(), [[2, 'ALREADY_HOLDING'], [3, 'UNKNOWN_RESOURCE']]);
    await quiet();
    assert.deepEqual(counts(), { holding: 1, queued: 0, faulted: 0 }, 'only the running A holds; nothing faulted');
    assert.deepEqual(lockA, []);
  });

  it("an instance's properties changed in the form take effect on deploy", async function () {
    const before = operation('opA', { operation: 'A', priority: 10, resources: 'YEL', steps: 'steps' }, [['doneA'], []]);
    const flow = (op) => [TAB, interlockConfig(), op, ...steps('steps', 'work'), ...steps('other steps', 'work2'), sinkNode('doneA')];
    await helper.load(NODE_MODULES, flow(before));
    let [work, work2, doneA] = ['work', 'work2', 'doneA'].map((id) => collect(helper, id));
    helper.getNode('opA').receive({ payload: 1 });
    await until(() => work.length === 1, 'A running');
    assert.equal(work[0].interlock.operation, 'A');
    assert.deepEqual(work[0].interlock.resources, ['YEL']);
    finishStep('work', work[0]);
    await until(() => doneA.length === 1, 'A returned');

    // The form writes the instance's properties; a deploy restarts the instance with them.
    await helper.setFlows(flow({ ...before, operation: 'A2', priority: 70, resources: 'GRN,BLU', steps: 'other steps' }), 'nodes');
    [work, work2, doneA] = ['work', 'work2', 'doneA'].map((id) => collect(helper, id));
    helper.getNode('opA').receive({ payload: 2 });
    await until(() => work2.length === 1, 'the changed instance running');
    assert.equal(work.length, 0, 'the old steps are not called');
    assert.equal(work2[0].interlock.operation, 'A2');
    assert.equal(work2[0].interlock.priority, 70);
    assert.deepEqual(work2[0].interlock.resources, ['GRN', 'BLU']);
    finishStep('work2', work2[0]);
    await until(() => doneA.length === 1, 'A2 returned');
    assert.equal(doneA[0].payload, 2);
    await quiet();
    assert.deepEqual(counts(), { holding: 0, queued: 0, faulted: 0 });
  });
});
