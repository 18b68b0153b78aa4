'use strict';
// ISA-88 commands on running work, through the operation and routine nodes
// (msg topics hold, restart, stop, abort, reset) and lib/interlock/operator.js, against
// a fake panel that obeys commands (no broker), on the manual clock: a held
// run commands nothing and its step timeout stands still; restart goes on
// with what was left and completes with its normal result; stop ends in
// order (the msg goes on, marked stopped); abort sends the lockouts at once
// and refuses starts until a reset; a refused command reaches a Catch node
// with its code; a held run survives a crash and a deploy, held.
const assert = require('node:assert/strict');
const fs = require('fs');
const path = require('path');
const helper = require('node-red-node-test-helper');
const {
  paletteNodes, linkNodes, TAB, sinkNode, collect, until, trackCompletions, trackDeliveries, untrackCompletions,
  startServer, stopServer, userDir, clock, crashCopy, onInterlock,
} = require('./support');
const { hooks } = require('@node-red/util');
const {
  fakePanel: panelOf, sensor: sensorOf, stopPanels, fakePlant, fakeValve, fakePump, truckRoutine, loadTruck, unloadTruck, boundPlant,
} = require('./fake-panel');
const operator = require('../../node-red-contrib-sugarshack/lib/interlock/operator');
const wasm = require('../../node-red-contrib-sugarshack/lib/wasm');

helper.init(require.resolve('node-red'));

// Op 10 loads a truck: valves open, pump on, wait for LT-3, pump off, back to idle. Its hold stops the pump.
function plantDocument() {
  return {
    ...fakePlant([fakeValve('V101', 1, 'YEL'), fakeValve('V102', 2, 'YEL'), fakeValve('V501', 5, 'RED'), fakePump('YEL')]),
    sensors: [{ id: 'LT-3', device: 'station-3', name: 'volume', staleMs: 60000 }],
    resources: [{ id: 'YEL' }, { id: 'RED' }],
    operations: [loadTruck({ hold: { command: { pumps: { P1: false } }, timeoutMs: 3000 } }), unloadTruck()],
    routines: [truckRoutine({ from: 'full', to: 'empty', operation: '12', trigger: { msg: 'unload' } })],
  };
}

const SINKS = ['mqtt', 'ev', 'out', 'caught', 'events', 'rt', 'clr'];

function flowOf({ persist = false, doc = plantDocument() } = {}) {
  return [
    TAB,
    ...boundPlant(doc, { persist }),
    { id: 'op10', z: 'f1', type: 'sugarshack-operation', interlock: 'il', operation: '10', wires: [['out']] },
    { id: 'r', z: 'f1', type: 'sugarshack-routine', interlock: 'il', routine: 'truck', wires: [['rt']] },
    { id: 'clear', z: 'f1', type: 'sugarshack-clear', interlock: 'il', mode: 'all', resources: '', wires: [['clr']] },
    ...SINKS.map(sinkNode),
  ];
}

const { runtime, quiet, run, runTill, statusOf } = onInterlock(helper);
const stateFile = () => path.join(userDir(), 'sugarshack', 'interlock-il.json');
const saved = () => JSON.parse(fs.readFileSync(stateFile(), 'utf8')).state;
const runOf = (operation) => runtime().describe().runs.find((r) => r.operation === operation);
const lineState = (name) => runtime().core.snapshot(0).resources.find((r) => r.name === name).state;

describe('ISA-88 commands: hold, restart, stop, abort, reset', function () {
  let seen;
  let completions;
  let panel;

  beforeEach(startServer);

  afterEach(async function () {
    untrackCompletions();
    stopPanels();
    await stopServer();
  });

  async function start(options) {
    completions = trackCompletions();
    await load(options);
  }

  async function load(options) {
    await helper.load([...paletteNodes, linkNodes], flowOf(options));
    seen = {};
    for (const id of SINKS) seen[id] = collect(helper, id);
    panel = panelOf(helper, plantDocument());
    await quiet();
  }

  /** Node-RED killed now, started again on the files the kill left. */
  async function crashAndRestart() {
    await quiet();
    const crashed = crashCopy();
    await helper.unload();
    stopPanels();
    crashed();
    await load({ persist: true });
  }

  const sensor = (value) => sensorOf(helper, value);
  const send = (id, msg) => helper.getNode(id).receive(msg);
  const completed = (id, msgid) => completions.find((c) => c.nodeId === id && c.msgid === msgid);
  /** Sends a command msg to node `id`; resolves with its completion ({ error } on a refusal). */
  async function command(id, topic, extra = {}) {
    const msg = { _msgid: `${id}-${topic}-${completions.length}`, topic, ...extra };
    send(id, msg);
    await until(() => completed(id, msg._msgid), `the ${topic} msg to complete`);
    return completed(id, msg._msgid);
  }
  const commandsSince = (n) => panel.commands.slice(n).map((c) => [c.topic, c.payload]);

  /** Starts op 10 through its node and lets it reach its wait (step 3), 60 ms into it. */
  async function inWait(msg = { topic: 'load' }) {
    send('op10', msg);
    await run(100);
    assert.equal(statusOf('op10').text, '3/5 wait');
    return msg;
  }

  it('hold stops the pump and commands nothing more while held; the wait\'s timeout stands still; restart goes on with what was left and completes with its normal result', async function () {
    await start();
    const msg = await inWait();
    const before = panel.commands.length;
    const hold = await command('op10', 'hold', { by: 'ana', reason: 'check the gasket' });
    assert.equal(hold.error, undefined);
    await runTill(() => runOf('10').state === 'held', 'held');
    assert.deepEqual(commandsSince(before), [['ctrl-1/pump/1/command', 'OFF']], 'the hold command, and nothing else');
    assert.deepEqual(statusOf('op10'), { fill: 'yellow', shape: 'ring', text: 'held 3/5' });
    assert.deepEqual(runOf('10'), {
      operation: '10', granted: true, state: 'held', step: 2, commands: ['restart', 'stop', 'abort'], heldMs: 20, routine: null,
    });
    assert.deepEqual(lineState('YEL'), { state: 'held', operation: '10' }, 'the held operation keeps its line');

    // Held, nothing is timed: no step timer, no command timer (the clock's only timers repeat: ticks, status;
    // but the plant's one timer, on the tracker's next threshold, and it is no command's).
    const plantTimer = helper.getNode('pl').runtime.deadline;
    assert.deepEqual([...clock().timers].filter(([id, t]) => !t.every && !(plantTimer && id === plantTimer.timer.id)), [], 'no one-shot timer while held');
    assert.equal(helper.getNode('pl').runtime.commands.entries().length, 0, 'no group command in flight while held');
    // Held for ten times the wait's timeout: no fault, no command.
    await run(6000);
    assert.equal(seen.caught.length, 0, 'no timeout while held');
    assert.equal(panel.commands.length, before + 1);
    assert.equal(runOf('10').heldMs, 6020);
    const restarted = await operator.command(runtime(), { operation: '10' }, 'restart', { by: 'ana' });
    assert.deepEqual(restarted, { operation: '10', command: 'restart', state: 'restarting', by: 'ana' });
    // The restore puts the pump back on, then the wait goes on with 540 ms left (60 were used before the hold).
    await runTill(() => statusOf('op10').text === '3/5 wait', 'the wait again');
    assert.deepEqual(commandsSince(before + 1), [['ctrl-1/pump/1/command', 'ON']]);
    sensor(150);
    await runTill(() => seen.out.length === 1, 'the return');
    assert.equal(seen.out[0], msg, 'the start msg goes on, as without a hold');
    const { operation } = seen.out[0];
    assert.equal(operation.id, '10');
    assert.equal(operation.heldMs, 6040, 'held from the hold to the end of the restore');
    assert.deepEqual(operation.steps.map((s) => s.kind), ['command', 'command', 'wait', 'command', 'returnToIdle']);
    assert.equal(seen.caught.length, 0);
    assert.equal(completed('op10', seen.out[0]._msgid).error, undefined);
    const journalled = runtime().describe().runs;
    assert.deepEqual(journalled, [], 'nothing runs');
    assert.equal(seen.events.filter((e) => e.payload.kind === 'faulted').length, 0, 'nothing faulted');
  });

  it('after a restart the held step\'s timeout counts only what was left of it', async function () {
    await start();
    await inWait();
    await command('op10', 'hold');
    await runTill(() => runOf('10').state === 'held', 'held');
    await run(2000);
    await command('op10', 'restart');
    await runTill(() => statusOf('op10').text === '3/5 wait', 'the wait again');
    const waitedAgain = await runTill(() => seen.caught.length === 1, 'the timeout');
    assert.ok(waitedAgain >= 535 && waitedAgain <= 545, `the wait timed out ${waitedAgain} ms after it went on, not 600`);
    const err = seen.caught[0].error;
    assert.equal(err.code, 'CONDITION_TIMEOUT');
    assert.match(err.message, /did not hold within 0\.54 s/);
  });

  it('a late answer to the step a hold cancelled goes to the core with its attempt, which ignores it once the restart sent the same step again', async function () {
    await start();
    // Each group command's answer (its onDone), in the order sent: step 1, the hold, the restore, step 1 again.
    const commands = helper.getNode('pl').runtime.commands;
    const sendCommand = commands.run;
    const answers = [];
    commands.run = function (args) {
      answers.push(args.onDone);
      return sendCommand.call(this, args);
    };
    send('op10', { topic: 'load' });
    await until(() => answers.length === 1, 'step 1 sent');
    // What reaches the run's core, and what it answers.
    const host = [...runtime().runs][0];
    const fed = [];
    for (const name of ['stepDone', 'stepFailed']) {
      const input = host.run[name];
      host.run[name] = function (attempt, ...rest) {
        const effects = input.call(this, attempt, ...rest);
        fed.push({ name, attempt, effects });
        return effects;
      };
    }
    await command('op10', 'hold');
    await runTill(() => runOf('10').state === 'held', 'held');
    await command('op10', 'restart');
    await until(() => answers.length === 4, 'step 1 sent again');
    assert.equal(host.run.step(), 0, 'in step 1 again, its new attempt in flight');
    const before = panel.commands.length;
    // The cancelled attempt answers now, done and then failed: the core ignores both.
    answers[0](null);
    answers[0](new Error('late'));
    assert.deepEqual(fed, [{ name: 'stepDone', attempt: 0, effects: [] }, { name: 'stepFailed', attempt: 0, effects: [] }]);
    assert.equal(host.run.step(), 0);
    assert.equal(panel.commands.length, before, 'no step 2 on the late answer');
    assert.equal(runOf('10').state, 'running');
    // The current attempt's answer moves the run on, and it completes with its normal result.
    await runTill(() => statusOf('op10').text === '3/5 wait', 'the wait');
    assert.deepEqual(fed[2], { name: 'stepDone', attempt: 3, effects: fed[2].effects });
    assert.deepEqual(fed[2].effects.map((e) => [e.kind, e.index, e.attempt]), [['startStep', 1, 4]]);
    sensor(150);
    await runTill(() => seen.out.length === 1, 'the return');
    assert.equal(seen.caught.length, 0, 'nothing faulted');
    assert.deepEqual(seen.out[0].operation.steps.map((s) => s.kind), ['command', 'command', 'wait', 'command', 'returnToIdle']);
  });

  it('a refused transition (restart of a running operation) reaches a Catch node as COMMAND_REFUSED and changes nothing', async function () {
    await start();
    await inWait();
    const before = panel.commands.length;
    const refused = await command('op10', 'restart', { by: 'ana' });
    assert.equal(refused.error.code, 'COMMAND_REFUSED');
    await until(() => seen.caught.length === 1, 'the Catch node');
    assert.equal(seen.caught[0].error.code, 'COMMAND_REFUSED');
    assert.ok(seen.caught[0].error.message.endsWith("restart refused: operation '10' is running; restart is for a held operation: hold it first"), seen.caught[0].error.message);
    assert.equal(runOf('10').state, 'running');
    assert.equal(panel.commands.length, before, 'nothing commanded');
    sensor(150);
    await runTill(() => seen.out.length === 1, 'the run completes as if nothing happened');
    assert.equal(seen.out[0].operation.heldMs, 0);
    // Nothing runs now: a command names nothing.
    const none = await command('op10', 'hold');
    assert.equal(none.error.code, 'UNKNOWN_RUN');
    await assert.rejects(operator.command(runtime(), { operation: '10' }, 'pause', {}), { code: 'INVALID_INPUT' });
    await assert.rejects(operator.command(runtime(), { routine: 'nope' }, 'hold', {}), { code: 'UNKNOWN_RUN' });
  });

  it('stop finishes the step, returns every commanded actuator to idle and releases: the msg goes on marked stopped, not as an error', async function () {
    await start();
    const msg = await inWait();
    const stopped = await command('op10', 'stop', { by: 'ana', reason: 'end of shift' });
    assert.equal(stopped.error, undefined);
    assert.deepEqual(statusOf('op10'), { fill: 'yellow', shape: 'ring', text: 'stopping 3/5' });
    assert.equal(runOf('10').state, 'stopping');
    assert.deepEqual(runOf('10').commands, ['abort']);
    const before = panel.commands.length;
    sensor(150); // the wait in progress finishes; step 4 (pump off) is skipped for the return to idle
    await runTill(() => seen.out.length === 1, 'the stopped run');
    assert.equal(seen.out[0], msg);
    assert.equal(seen.out[0].operation.stopped, true);
    assert.equal(seen.out[0].operation.step, 2);
    assert.deepEqual(seen.out[0].operation.steps.map((s) => s.kind), ['command', 'command', 'wait', 'returnToIdle']);
    assert.deepEqual(commandsSince(before).sort(), [['ctrl-1/pump/1/command', 'OFF'], ['ctrl-1/valve/1/command', '0'], ['ctrl-1/valve/2/command', '0']]);
    assert.equal(seen.caught.length, 0, 'a stop is not an error');
    assert.deepEqual(lineState('YEL'), { state: 'free' });
    assert.match(statusOf('op10').text, /^stopped /);
    await quiet();
    assert.equal(seen.events.filter((e) => e.payload.kind === 'faulted').length, 0);
  });

  it('abort sends the lockouts at once and refuses a new start until a reset', async function () {
    await start();
    await inWait();
    const aborted = await command('op10', 'abort', { by: 'ana', reason: 'leak at V101' });
    assert.equal(aborted.error, undefined, 'the abort msg itself completes');
    // The start msg fails: the run ended aborted, its lines locked out.
    await until(() => seen.caught.length === 1, 'the aborted run');
    const err = seen.caught[0].error;
    assert.equal(err.code, 'ABORTED');
    assert.match(err.message, /operation '10' was aborted at step 3 \(wait\): aborted by ana: leak at V101; YEL locked out until cleared/);
    assert.deepEqual(seen.caught[0].operation, { id: '10', step: 2, kind: 'wait', lockedOut: ['YEL'], aborted: true, state: 'aborted' });
    await until(() => seen.mqtt.filter((m) => m.retain).length === 3, 'the lockouts');
    assert.deepEqual(lineState('YEL').state, 'faulted');
    assert.deepEqual(statusOf('op10'), { fill: 'red', shape: 'ring', text: 'aborted' });
    const [waiting] = runtime().describe().aborted;
    assert.deepEqual({ ...waiting, sinceMs: 0 }, { operation: '10', sinceMs: 0, by: 'ana', reason: 'leak at V101', commands: ['reset'] });

    send('op10', { topic: 'load again' });
    await until(() => seen.caught.length === 2, 'the refused start');
    assert.equal(seen.caught[1].error.code, 'OPERATION_ABORTED');
    assert.ok(seen.caught[1].error.message.endsWith("start refused: operation '10' is aborted; an aborted operation starts again only after a reset"));
    const hold = await command('op10', 'hold');
    assert.equal(hold.error.code, 'COMMAND_REFUSED', 'an aborted operation takes only a reset');

    const reset = await operator.command(runtime(), { operation: '10' }, 'reset', { by: 'ben' });
    assert.deepEqual(reset, { operation: '10', command: 'reset', state: 'idle', by: 'ben' });
    assert.deepEqual(runtime().describe().aborted, []);
    await run(50); // the panel confirms the lockouts: the lines may be cleared
    send('clear', { by: 'ben' });
    await until(() => seen.clr.length === 1, 'the clear');
    send('op10', { topic: 'load' });
    await run(60);
    sensor(150);
    await runTill(() => seen.out.length === 1, 'a new run after the reset');
    assert.equal(seen.out[0].operation.id, '10');
  });

  it('the routine node: hold and restart reach its pending operation, a refused command is caught, abort and reset go to its operation too', async function () {
    await start();
    await until(() => statusOf('r') && statusOf('r').text === 'empty', 'the routine ready');
    send('r', { topic: 'load' });
    await run(100);
    const host = runtime().routines.get('truck');
    assert.deepEqual([host.describe().runState, host.describe().commands], ['running', ['hold', 'stop', 'abort']]);
    const hold = await command('r', 'hold', { by: 'ana' });
    assert.equal(hold.error, undefined);
    await runTill(() => runOf('10').state === 'held', 'its operation held');
    assert.deepEqual(runOf('10').routine, 'truck');
    assert.deepEqual(statusOf('r'), { fill: 'yellow', shape: 'ring', text: 'empty › held' });
    assert.deepEqual(host.describe().pending, { operation: '10', phase: 'running', state: 'held' });
    assert.deepEqual(seen.rt.map((m) => [m.payload.event, m.payload.runState]).slice(-1), [['hold', 'holding']]);
    await run(2000);
    assert.equal(seen.caught.length, 0);

    const refused = await command('r', 'hold');
    assert.equal(refused.error.code, 'COMMAND_REFUSED');
    assert.match(refused.error.message, /^hold refused: routine 'truck' is held; it is held already/);
    await until(() => seen.caught.length === 1, 'the Catch node');

    await command('r', 'restart', { by: 'ana' });
    sensor(150);
    await runTill(() => seen.rt.some((m) => m.payload.event === 'completed'), 'its operation completes');
    assert.deepEqual(seen.rt.find((m) => m.payload.event === 'completed').payload.state, 'full');

    // Abort: its operation's lockouts go out; a reset of the routine resets its operation too.
    send('r', { topic: 'unload' });
    await run(5);
    const abort = await command('r', 'abort', { by: 'ana', reason: 'spill' });
    assert.equal(abort.error, undefined);
    await runTill(() => seen.rt.some((m) => m.payload.event === 'aborted'), 'the routine aborted');
    assert.deepEqual(seen.rt.slice(-2).map((m) => [m.payload.event, m.payload.operation, m.payload.state]), [['abort', '12', 'full'], ['aborted', '12', 'full']]);
    assert.equal(seen.rt.at(-1).payload.runState, 'aborted');
    assert.deepEqual(runtime().describe().aborted.map((a) => a.operation), ['12']);
    assert.equal(lineState('YEL').state, 'faulted');
    assert.equal((await command('r', 'unload')).error.code, 'COMMAND_REFUSED', 'an aborted routine fires no trigger');
    const reset = await command('r', 'reset', { by: 'ben' });
    assert.equal(reset.error, undefined);
    assert.deepEqual(runtime().describe().aborted, [], 'its operation reset with it');
    // The command is answered when decided; the routine's msg is sent after it.
    await until(() => seen.rt.at(-1).payload.event === 'reset', 'the routine sends its reset');
    assert.equal(host.describe().state, 'empty');
  });

  it('a held run survives a crash held: saved before its hold command leaves, its line stays held, nothing is commanded, its node shows it, and a restart completes it', async function () {
    await start({ persist: true });
    await inWait();
    // What the state file says when the hold command reaches the broker.
    const onDisk = [];
    hooks.add('onReceive.sugarshack-isa88', (event) => {
      if (event.destination.id === 'mqtt' && event.msg.payload === 'OFF') onDisk.push(saved().runs);
    });
    await command('op10', 'hold', { by: 'ana' });
    await until(() => onDisk.length === 1, 'the hold command');
    hooks.remove('*.sugarshack-isa88');
    assert.deepEqual(onDisk[0].map((r) => [r.operation, r.held, r.owner]), [['10', false, { kind: 'node', id: 'op10' }]], 'saved holding first');
    await runTill(() => runOf('10').state === 'held', 'held');
    await quiet();
    const [held] = saved().runs;
    assert.deepEqual([held.operation, held.step, held.held, held.owner], ['10', 2, true, { kind: 'node', id: 'op10' }]);
    const delivered = trackDeliveries();
    await crashAndRestart();
    assert.deepEqual(lineState('YEL'), { state: 'held', operation: '10' }, 'held, not faulted');
    assert.equal(runOf('10').state, 'held');
    assert.deepEqual(statusOf('op10'), { fill: 'yellow', shape: 'ring', text: 'held 3/5' });
    await run(1000);
    assert.deepEqual(delivered.filter((d) => d.nodeId === 'mqtt').map((d) => d.msg.topic), [], 'nothing commanded, no lockout');
    assert.equal(seen.caught.length, 0);

    await command('op10', 'restart', { by: 'ana' });
    await runTill(() => statusOf('op10').text === '3/5 wait', 'the wait again');
    sensor(150);
    await runTill(() => seen.out.length === 1, 'the return, from the node that took the run over');
    assert.equal(seen.out[0].operation.id, '10');
    assert.equal(seen.out[0].topic, 'operation/10');
    assert.deepEqual(seen.out[0].operation.steps.map((s) => s.kind), ['command', 'command', 'wait', 'command', 'returnToIdle']);
    await quiet();
    assert.deepEqual(saved().runs, undefined, 'nothing held any more');
  });

  it('a routine\'s held operation survives a crash: the routine still waits for it, and it completes after a restart', async function () {
    await start({ persist: true });
    await until(() => statusOf('r') && statusOf('r').text === 'empty', 'the routine ready');
    send('r', { topic: 'load' });
    await run(100);
    await command('r', 'hold', { by: 'ana' });
    await runTill(() => runOf('10').state === 'held', 'held');
    await quiet();
    assert.deepEqual(saved().runs[0].owner, { kind: 'routine', id: 'truck' });
    await crashAndRestart();
    await quiet();
    await until(() => statusOf('r') && statusOf('r').text === 'empty › held', 'the routine shows its held operation');
    assert.deepEqual(runOf('10').routine, 'truck');
    assert.equal(lineState('YEL').state, 'held');
    assert.equal(seen.rt.filter((m) => m.payload.event === 'interrupted').length, 0, 'not interrupted');
    await command('r', 'restart');
    await runTill(() => statusOf('r').text === 'empty › run 10', 'running again');
    sensor(150);
    await runTill(() => seen.rt.some((m) => m.payload.event === 'completed'), 'its operation completes');
    assert.equal(seen.rt.find((m) => m.payload.event === 'completed').payload.state, 'full');
  });

  it('a wasm trap while a run is held: the interlock rebuilds from its saved state and the run comes back held to its node and msg', async function () {
    await start({ persist: true });
    const msg = await inWait();
    await command('op10', 'hold');
    await runTill(() => runOf('10').state === 'held', 'held');
    await quiet();
    const generation = wasm.currentGeneration();
    runtime().core.__wbg_ptr = 0x7ffffff0; // eslint-disable-line no-underscore-dangle
    await assert.rejects(operator.clear(runtime(), null, { by: 'ana' }), { code: 'INTERNAL' });
    await until(() => wasm.currentGeneration() === generation + 1, 'the new instance');
    await quiet();
    assert.deepEqual(lineState('YEL'), { state: 'held', operation: '10' }, 'held, not faulted');
    assert.equal(runOf('10').state, 'held');
    assert.deepEqual(statusOf('op10'), { fill: 'yellow', shape: 'ring', text: 'held 3/5' });
    assert.equal(seen.caught.length, 0, 'the held msg did not fail');
    await command('op10', 'restart');
    await runTill(() => statusOf('op10').text === '3/5 wait', 'the wait again');
    sensor(150);
    await runTill(() => seen.out.length === 1, 'the return');
    assert.equal(seen.out[0], msg, 'the start msg goes on');
  });

  it('a drain that waits for a running operation ends as an operator holds it, with no timer to look again', async function () {
    await start();
    await inWait();
    const doc = plantDocument();
    doc.operations[1].description = 'unload the truck';
    await helper.setFlows(flowOf({ doc }), 'full');
    await quiet();
    assert.equal(runtime().gateOpen, false, 'draining while op 10 runs');
    assert.deepEqual([...clock().timers.values()].filter((t) => t.every), [], 'no interval looks at the drain');
    await operator.command(runtime(), { operation: '10' }, 'hold', { by: 'ana' });
    await runTill(() => runOf('10').state === 'held', 'held');
    const heldAt = clock().now();
    await quiet();
    assert.equal(clock().now(), heldAt);
    assert.equal(runtime().gateOpen, true, 'the drain ended with the hold');
    assert.equal(runOf('10').state, 'held');
  });

  it('a deploy that changes the plant does not wait for a held run: it is handed over held, and restarts on the new nodes', async function () {
    await start();
    const msg = await inWait();
    await command('op10', 'hold');
    await runTill(() => runOf('10').state === 'held', 'held');
    const doc = plantDocument();
    doc.operations[1].description = 'unload the truck';
    await helper.setFlows(flowOf({ doc }), 'full');
    await quiet();
    await runTill(() => runtime().gateOpen, 'the drain over, though the run is held');
    assert.equal(runOf('10').state, 'held');
    assert.equal(lineState('YEL').state, 'held');
    for (const id of SINKS) seen[id] = collect(helper, id);
    await until(() => statusOf('op10') && statusOf('op10').text === 'held 3/5', 'the new node shows the held run');
    await command('op10', 'restart');
    await runTill(() => statusOf('op10').text === '3/5 wait', 'the wait again');
    sensor(150);
    await runTill(() => seen.out.length === 1, 'the return from the new node');
    assert.equal(seen.out[0]._msgid, msg._msgid);
    assert.equal(seen.out[0].operation.id, '10');
    assert.equal(seen.caught.length, 0);
  });
});
