'use strict';
// The shapes the wasm facade declares (the typescript_custom_section blocks of
// rust/sugarshack-wasm/src, in the generated wasm/sugarshack_wasm.d.ts) against
// what its calls really return: a field serde stops writing, starts writing
// or renames fails here, so the declarations the palette's JS is type-checked
// against cannot drift from the facade. Every declared shape must be met by
// at least one real value below.
const assert = require('node:assert/strict');
const fs = require('fs');
const path = require('path');
const ts = require('typescript');

const PALETTE = path.join(__dirname, '..', '..', 'node-red-contrib-sugarshack');
const DTS = path.join(PALETTE, 'wasm', 'sugarshack_wasm.d.ts');
const wasm = require(path.join(PALETTE, 'lib', 'wasm', 'index.js'));

/** Every exported interface and type alias of the .d.ts, by name. */
function declarations() {
  const source = ts.createSourceFile(DTS, fs.readFileSync(DTS, 'utf8'), ts.ScriptTarget.Latest, true);
  const decls = new Map();
  for (const statement of source.statements) {
    if (ts.isInterfaceDeclaration(statement) || ts.isTypeAliasDeclaration(statement) || ts.isClassDeclaration(statement)) decls.set(statement.name.text, statement);
  }
  return decls;
}

/** The attempt of the last effect of `kind` in `effects` (what an answer to it names). */
function attemptOf(effects, kind) {
  const effect = effects.filter((e) => e.kind === kind).pop();
  assert.ok(effect, `an effect of kind ${kind} in ${JSON.stringify(effects)}`);
  return effect.attempt;
}

const nameOf = (name) => (ts.isIdentifier(name) || ts.isStringLiteral(name) ? name.text : name.getText());

/**
 * Checks `value` against declared shapes: every required field present,
 * no field that is not declared, every field of its declared type.
 */
class ShapeChecker {
  constructor(decls) {
    this.decls = decls;
    this.met = new Set(); // declared names some value was checked against
  }

  /** Throws an AssertionError naming the first mismatch. */
  expect(typeText, value, where = typeText) {
    const problem = this.check(this.parseType(typeText), value, where);
    assert.equal(problem, null, problem || '');
  }

  parseType(text) {
    const source = ts.createSourceFile('t.ts', `type T = ${text};`, ts.ScriptTarget.Latest, true);
    return source.statements[0].type;
  }

  /** Null when `value` fits `type`, else what does not. */
  check(type, value, where) {
    switch (type.kind) {
      case ts.SyntaxKind.ParenthesizedType:
        return this.check(type.type, value, where);
      case ts.SyntaxKind.NumberKeyword:
        return typeof value === 'number' ? null : `${where}: a number expected, got ${JSON.stringify(value)}`;
      case ts.SyntaxKind.StringKeyword:
        return typeof value === 'string' ? null : `${where}: a string expected, got ${JSON.stringify(value)}`;
      case ts.SyntaxKind.BooleanKeyword:
        return typeof value === 'boolean' ? null : `${where}: a boolean expected, got ${JSON.stringify(value)}`;
      case ts.SyntaxKind.UndefinedKeyword:
        return value === undefined ? null : `${where}: undefined expected`;
      case ts.SyntaxKind.UnknownKeyword:
      case ts.SyntaxKind.AnyKeyword:
        return null;
      case ts.SyntaxKind.LiteralType: {
        const literal = type.literal;
        if (literal.kind === ts.SyntaxKind.NullKeyword) return value === null ? null : `${where}: null expected`;
        if (literal.kind === ts.SyntaxKind.TrueKeyword) return value === true ? null : `${where}: true expected`;
        if (literal.kind === ts.SyntaxKind.FalseKeyword) return value === false ? null : `${where}: false expected`;
        const expected = ts.isNumericLiteral(literal) ? Number(literal.text) : literal.text;
        return value === expected ? null : `${where}: ${JSON.stringify(expected)} expected, got ${JSON.stringify(value)}`;
      }
      case ts.SyntaxKind.ArrayType:
        if (!Array.isArray(value)) return `${where}: an array expected, got ${JSON.stringify(value)}`;
        for (const [i, item] of value.entries()) {
          const problem = this.check(type.elementType, item, `${where}[${i}]`);
          if (problem) return problem;
        }
        return null;
      case ts.SyntaxKind.UnionType:
        return this.checkUnion(type, value, where);
      case ts.SyntaxKind.TypeLiteral:
        return this.checkMembers(type.members, value, where);
      case ts.SyntaxKind.TypeReference:
        return this.checkReference(type, value, where);
      default:
        return `${where}: the checker does not read '${type.getText()}'; teach it`;
    }
  }

  checkUnion(type, value, where) {
    // An object with a `kind` is checked against the member of that kind alone, for a clear message.
    const members = type.types.map((t) => this.resolveAlias(t));
    if (value && typeof value === 'object' && typeof value.kind === 'string') {
      const tagged = members.filter((t) => this.kindOf(t) !== undefined);
      if (tagged.length > 0) {
        const member = tagged.find((t) => this.kindOf(t) === value.kind);
        if (!member) return `${where}: kind ${JSON.stringify(value.kind)} is not declared`;
        return this.check(member, value, `${where}<${value.kind}>`);
      }
    }
    const problems = [];
    for (const member of type.types) {
      const problem = this.check(member, value, where);
      if (!problem) return null;
      problems.push(problem);
    }
    return problems.join(' | ');
  }

  resolveAlias(type) {
    if (ts.isTypeReferenceNode(type)) {
      const decl = this.decls.get(nameOf(type.typeName));
      if (decl && ts.isTypeAliasDeclaration(decl)) return decl.type;
    }
    return type;
  }

  /** The `kind` literal of an object-literal type, if it has one. */
  kindOf(type) {
    if (!ts.isTypeLiteralNode(type)) return undefined;
    const member = type.members.find((m) => m.name && nameOf(m.name) === 'kind');
    return member && member.type && ts.isLiteralTypeNode(member.type) && ts.isStringLiteral(member.type.literal) ? member.type.literal.text : undefined;
  }

  checkReference(type, value, where) {
    const name = nameOf(type.typeName);
    if (name === 'Record') {
      if (!value || typeof value !== 'object' || Array.isArray(value)) return `${where}: an object expected`;
      for (const [key, item] of Object.entries(value)) {
        const problem = this.check(type.typeArguments[1], item, `${where}.${key}`);
        if (problem) return problem;
      }
      return null;
    }
    const decl = this.decls.get(name);
    if (!decl) return `${where}: ${name} is not declared in the .d.ts`;
    this.met.add(name);
    // A facade class: an instance of it, its fields wasm's own.
    if (ts.isClassDeclaration(decl)) return value instanceof wasm.load()[name] ? null : `${where}: an instance of ${name} expected`;
    if (ts.isTypeAliasDeclaration(decl)) return this.check(decl.type, value, `${where}:${name}`);
    return this.checkMembers(this.interfaceMembers(decl), value, `${where}:${name}`, name);
  }

  /** An interface's members with those it extends (an Error's own fields are not listed). */
  interfaceMembers(decl) {
    const members = [...decl.members];
    for (const clause of decl.heritageClauses || []) {
      for (const base of clause.types) {
        const parent = this.decls.get(base.expression.getText());
        if (parent) members.push(...this.interfaceMembers(parent));
      }
    }
    return members;
  }

  checkMembers(members, value, where, name) {
    if (!value || typeof value !== 'object' || Array.isArray(value)) return `${where}: an object expected, got ${JSON.stringify(value)}`;
    const declared = new Set();
    for (const member of members) {
      if (!ts.isPropertySignature(member)) continue;
      const key = nameOf(member.name);
      declared.add(key);
      if (!(key in value)) {
        if (member.questionToken) continue;
        return `${where}: field '${key}' is declared but missing`;
      }
      const problem = this.check(member.type, value[key], `${where}.${key}`);
      if (problem) return problem;
    }
    // An Error's message, name and stack are its own; only the declared extras are compared.
    if (value instanceof Error) return null;
    const extra = Object.keys(value).filter((key) => !declared.has(key));
    return extra.length ? `${where}: field(s) ${extra.join(', ')} not declared${name ? ` in ${name}` : ''}` : null;
  }
}

const PLANT = wasm.SAMPLE_PLANT;

describe('the facade\'s declared shapes (wasm/sugarshack_wasm.d.ts)', function () {
  let facade;
  let shapes;
  const freed = [];
  const keep = (object) => {
    freed.push(object);
    return object;
  };

  before(function () {
    facade = wasm.load();
    shapes = new ShapeChecker(declarations());
  });

  after(function () {
    for (const object of freed) wasm.release(object);
  });

  it('every file of lib/ (sub-folders too) and nodes/ is type-checked against these declarations (// @ts-check)', function () {
    const js = (dir, recursive) => fs.readdirSync(path.join(PALETTE, dir), { recursive })
      .map(String).filter((f) => f.endsWith('.js')).map((f) => path.join(dir, f));
    const files = [...js('lib', true), ...js('nodes', false)];
    const unchecked = files.filter((f) => !fs.readFileSync(path.join(PALETTE, f), 'utf8').startsWith('// @ts-check'));
    assert.deepEqual(unchecked, []);
    assert.ok(files.includes(path.join('lib', 'journal', 'spool.js')), 'lib/journal/ is covered');
    assert.ok(files.length > 45, `${files.length} files`);
  });

  it('no method of the facade returns or takes `any`', function () {
    const text = fs.readFileSync(DTS, 'utf8');
    const anys = text.split('\n').filter((line) => /\bany\b/.test(line) && !/^\s*(\*|\/\*\*)/.test(line));
    assert.deepEqual(anys, []);
  });

  it('the contract: codes and abnormal event kinds', function () {
    shapes.expect('CodeEntry[]', facade.codes());
    shapes.expect('EventKind[]', facade.abnormalEventKinds());
  });

  it('the interlock: counts, fault outcomes, event records, snapshot, alarm conditions, errors', function () {
    const config = { resources: [{ name: 'A', lockout: { valves: { V: 0 } } }, { name: 'B' }], policy: 'greedy', warnQueuedMs: 1, warnHeldMs: 1, recordEvents: true };
    shapes.expect('InterlockConfig', config);
    const il = keep(new facade.Interlock(config));
    const [a, b, c] = [il.operation('a'), il.operation('b'), il.operation('c')];
    const setA = il.resourceSet(['A']);
    il.acquire(a, 1, setA, 0);
    il.acquire(b, 2, setA, 1);
    shapes.expect('EventRecord[]', il.tick(10));
    shapes.expect('InterlockCounts', il.counts());
    const snapshot = il.snapshot(11);
    shapes.expect('InterlockSnapshot', snapshot);
    assert.ok(snapshot.queue.length > 0 && snapshot.holds.length > 0, 'a snapshot with a queue and a hold');
    const faulted = il.fault(a, 'note', 12);
    shapes.expect('FaultOutcome', faulted);
    assert.ok(faulted.lockouts.length > 0);
    shapes.expect('FaultOutcome', il.faultResources(il.resourceSet(['B']), 'stop', 'Ann', 'leak', 13));
    il.acquire(c, 1, il.resourceSet(['B']), 14);
    shapes.expect('AlarmCondition[]', il.alarmConditions(20));
    const faultedSnapshot = il.snapshot(21);
    shapes.expect('InterlockSnapshot', faultedSnapshot);
    il.clear(il.resourceSet(['A', 'B']), 'Ann', 'fixed', true, 22);
    const events = il.drainEvents();
    shapes.expect('EventRecord[]', events);
    assert.ok(events.some((e) => e.kind === 'cleared' && e.by === 'Ann'), 'an attributed clear');
    assert.equal(il.acquireCode(il.operation('d'), 1, 999, 23), -1);
    shapes.expect('SugarshackError', il.takeError());
    shapes.expect('ResourceConfig[]', config.resources);
  });

  it('the state document: sealed with routines, alarms, held runs and aborted operations, opened restored or lost', function () {
    const plant = keep(new facade.Tracker(PLANT, 0));
    const config = { resources: plant.interlockResources() };
    const il = keep(new facade.Interlock(config));
    il.acquire(il.operation('o'), 1, il.resourceSet(['A']), 1);
    const routine = keep(plant.routine('r'));
    shapes.expect('RoutineSnapshot', routine.snapshot());
    const alarms = keep(new facade.Alarms());
    alarms.observe([{ kind: 'line-faulted', subject: 'A', text: 'faulted', sinceMs: 1 }], 2);
    const run = keep(plant.operationRun('o'));
    run.start(1);
    run.granted(1);
    run.holdDone(attemptOf(run.command('hold', 'Ann', 'gasket', 2), 'hold'), 2);
    const held = run.snapshot({ kind: 'node', id: 'op' });
    shapes.expect('RunSnapshot', held);
    shapes.expect('RunOwner', held.owner);
    const aborted = keep(new facade.AbortedOperations(undefined));
    aborted.ended('x', 'aborted', 'Ann', 'leak', 2);
    shapes.expect('AbortedOperation[]', aborted.list());
    const beside = { routines: { r: routine.snapshot() }, alarms: alarms.snapshot(), runs: [held], aborted: aborted.snapshot() };
    shapes.expect('SavedBeside', beside);
    const text = il.seal('il', 'pl', beside, 3);
    const restored = facade.Interlock.openBound(config, 'il', 'pl', 'test', text, 4, plant);
    keep(restored.interlock);
    shapes.expect('OpenedInterlock', restored);
    assert.equal(restored.lost, null);
    assert.deepEqual(Object.keys(restored.routines), ['r']);
    assert.deepEqual(restored.runs.map((r) => r.operation), ['o'], 'the held run came back held');
    const back = plant.restoreRun(restored.runs[0]);
    shapes.expect('RestoredRun', back);
    keep(back.run);
    assert.equal(back.run.state(), 'held');
    const unbound = facade.Interlock.open(config, 'il', 'pl', 'test', text, 4);
    keep(unbound.interlock);
    assert.equal(unbound.runsInterrupted.length, 1, 'without a plant no run comes back held');
    const lost = facade.Interlock.open(config, 'other', 'pl', 'test', text, 4);
    keep(lost.interlock);
    shapes.expect('OpenedInterlock', lost);
    assert.match(lost.lost, /^test: it is the state of node 'il'/);
    const pid = { loop: { pid: { kp: 1, tiS: 10, tdS: 1, outMin: 0, outMax: 100, action: 'reverse', fallback: null, proportionalOn: 'error' }, smith: null }, tsS: 1, setpoint: 50 };
    shapes.expect('StationConfig', pid);
    const saved = { integral: 1, setpoint: 50, mode: 'manual', manual: 3 };
    shapes.expect('StationSaved', facade.openPidState('test', facade.sealPidState('p', pid, saved, 5), 'p'));
    shapes.expect('PidDefaults', facade.pidDefaults());
  });

  it('a group command msg read in one call: lockout, lines held, payload; or the refusal', function () {
    const read = facade.readGroupMsg('plant/command', undefined, { resources: ['A'] }, '{"valves": {"V1": 5}}');
    shapes.expect('GroupMsgRead', read);
    assert.deepEqual(read, { lockout: false, within: ['A'], payload: { valves: { V1: 5 } } });
    const refused = facade.readGroupMsg('plant/command', undefined, 'A', {});
    shapes.expect('GroupMsgRead', refused);
    assert.deepEqual(refused, { refusal: { code: 'INVALID_RESOURCES', key: 'errors.heldNotListed', params: { got: '"A"' } } });
    assert.equal(facade.isLockoutMsg('lockout/A', undefined), true);
  });

  it('clear blockers against a plant', function () {
    const plant = keep(new facade.Tracker(PLANT, 0));
    const il = keep(new facade.Interlock({ resources: plant.interlockResources() }));
    shapes.expect('ResourceConfig[]', plant.interlockResources());
    il.faultResources(il.resourceSet(['A']), null, null, null, 1);
    const lines = il.clearBlockers(il.resourceSet(['A', 'B']), plant);
    shapes.expect('LineBlockers[]', lines);
    assert.ok(lines.some((l) => l.reasons.length > 0), 'some line has reasons');
    try {
      il.clearAgainst(il.resourceSet(['A']), plant, 'Ann', null, false, 2);
      assert.fail('the clear should be refused');
    } catch (err) {
      shapes.expect('SugarshackError', err);
      assert.ok(err.lines, 'a refused clear lists its lines');
    }
    il.clearAgainst(il.resourceSet(['A']), plant, 'Ann', 'override', true, 3);
    const events = il.drainEvents();
    shapes.expect('EventRecord[]', events);
    assert.ok(events.some((e) => e.forced), 'a forced clear');
  });

  it('the alarms: changes, list, snapshot', function () {
    const alarms = keep(new facade.Alarms());
    const conditions = [{ kind: 'line-faulted', subject: 'A', text: 'faulted', sinceMs: 1 }, { kind: 'device-offline', subject: 'p' }];
    shapes.expect('AlarmConditionInput[]', conditions);
    shapes.expect('AlarmChange[]', alarms.observe(conditions, 10));
    shapes.expect('AlarmChange[]', alarms.acknowledge(['line-faulted:A'], 'Ann', 'seen', 11));
    shapes.expect('AlarmChange[]', alarms.shelve('device-offline:p', 100000, 'Ann', 'maintenance', 12));
    shapes.expect('Alarm[]', alarms.list());
    const saved = alarms.snapshot();
    shapes.expect('AlarmsSnapshot', saved);
    assert.ok(saved.alarms.some((x) => x.acked) && saved.alarms.some((x) => x.shelved), 'an acknowledged and a shelved alarm');
    shapes.expect('AlarmChange[]', alarms.unshelve('device-offline:p', 'Ann', null, 13));
    shapes.expect('AlarmChange[]', alarms.shelveOneShot('line-faulted:A', 14 + facade.maxShelveMs(), 'Ann', null, 14));
    assert.ok(alarms.list().find((x) => x.id === 'line-faulted:A').shelved.oneShot, 'a one-shot shelf');
    shapes.expect('AlarmChange[]', alarms.observe([], 15));
  });

  it('the tracker: views, counts, effects, health, plans', function () {
    shapes.expect('PlantDocument', PLANT);
    const t = keep(new facade.Tracker(PLANT, 0));
    shapes.expect('PlantActuator[]', t.actuators());
    const v = t.actuator('V');
    const p = t.actuator('P');
    t.deviceStatus(t.device('p'), true, 0);
    const command = { valves: { V: 100 }, pumps: { P: true } };
    shapes.expect('GroupCommand', command);
    t.command(command, 1, false, 0, ['A', 'B']);
    t.feedback(v, 50, null, 100);
    t.feedback(v, 100, null, 200);
    t.feedback(p, 1, null, 200);
    t.command({ pumps: { P: false } }, 2, true, 300);
    t.tick(5000);
    t.ingest('p/status', 'offline', 5100);
    t.ingest('p/status', 'online', 5200);
    t.ingest('p/valve/1/state', 'not a number', 5300);
    t.feedbackBatch(Uint32Array.of(v), Float64Array.of(-5), null, 5400);
    shapes.expect('PendingLockout[]', t.pendingLockouts());
    const effects = t.takeEffects();
    shapes.expect('TrackerEffect[]', effects);
    const kinds = new Set(effects.map((e) => e.kind));
    for (const kind of ['publish', 'moving', 'completed', 'groupCompleted', 'changed', 'deviceStatus']) assert.ok(kinds.has(kind), `an effect of kind ${kind} (got ${[...kinds]})`);
    shapes.expect('TrackerCounts', t.counts());
    shapes.expect('TrackerCounts', t.countsOn(Uint32Array.of(t.device('p'))));
    shapes.expect('FaultDescription', t.describeFault(v, 'no-motion', 1, 100));
    t.recordSensor(t.sensor('L'), 2, null, 5500);
    shapes.expect('PlantHealth', t.health(5600));
    shapes.expect('DeviceHealth', t.deviceHealth(t.device('p')));
    assert.equal(t.target(v), 100, 'the last commanded position');
    t.ingest('p/status', 'offline', 5700);
    const offline = t.alarmConditions();
    assert.equal(offline.length, 1, 'device p offline');
    shapes.expect('AlarmCondition[]', offline);
    shapes.expect('OperationPlan', t.operationPlan('o'));
  });

  it('an operation run: every effect', function () {
    const t = keep(new facade.Tracker(PLANT, 0));
    const ok = keep(t.operationRun('o'));
    shapes.expect('OperationPlan', ok.plan());
    const effects = [...ok.start(0), ...ok.granted(1), ...ok.stepDone(0, 2), ...ok.stepDone(1, 3), ...ok.stepDone(2, 4), ...ok.released(5)];
    const failing = keep(t.operationRun('o'));
    effects.push(...failing.start(10), ...failing.granted(11), ...failing.stepFailed(0, 'STEP_TIMEOUT', 'no', 12), ...failing.faultApplied(['A'], 13));
    const withdrawn = keep(t.operationRun('o'));
    effects.push(...withdrawn.start(20), ...withdrawn.interrupt('stop', 21), ...withdrawn.withdrawn(22));
    const commanded = keep(t.operationRun('o'));
    shapes.expect('RunCommand[]', commanded.commands());
    // Held in the wait: the restart puts V back before the wait goes on (a command step of V would command it itself).
    // Each answer names the attempt of the effect it answers.
    const step = commanded.start(30).concat(commanded.granted(31), commanded.stepDone(0, 31));
    const hold = commanded.command('hold', 'Ann', null, 32);
    effects.push(...step, ...hold, ...commanded.holdDone(attemptOf(hold, 'hold'), 33));
    shapes.expect('RunState', commanded.state());
    const restore = commanded.command('restart', 'Ann', null, 34);
    const again = commanded.restartDone(attemptOf(restore, 'restore'), 35);
    effects.push(...restore, ...again, ...commanded.command('stop', 'Ann', null, 36));
    const toIdle = commanded.stepDone(attemptOf(again, 'startStep'), 37);
    effects.push(...toIdle, ...commanded.stepDone(attemptOf(toIdle, 'startStep'), 38), ...commanded.released(39));
    shapes.expect('RunEffect[]', effects);
    const kinds = new Set(effects.map((e) => e.kind));
    for (const kind of ['acquire', 'startStep', 'release', 'finished', 'fault', 'failed', 'hold', 'restore', 'entered', 'cancelStep', 'stopped']) {
      assert.ok(kinds.has(kind), `an effect of kind ${kind} (got ${[...kinds]})`);
    }
  });

  it('a condition checked: no value yet, held, not held', function () {
    const t = keep(new facade.Tracker(PLANT, 0));
    const sensor = t.sensor('L');
    const handles = Uint32Array.of(sensor);
    const condition = t.condition('L > 1', ['L']);
    shapes.expect('ConditionCheck', t.checkCondition(condition, handles, 0));
    t.recordSensor(sensor, 2, null, 10);
    shapes.expect('ConditionCheck', t.checkCondition(condition, handles, 20));
    t.recordSensor(sensor, 0, null, 30);
    const notMet = t.checkCondition(condition, handles, 40);
    shapes.expect('ConditionCheck', notMet);
    assert.deepEqual(notMet, { met: false, values: { L: 0 }, reason: 'values {"L":0}' });
  });

  it('a wait on a condition: checked, timed out at the tracker\'s deadline', function () {
    const t = keep(new facade.Tracker(PLANT, 0));
    const a = t.waitStart(1000, 0, 'L > 1');
    const b = t.waitUntil(5000, 1000, 'L > 1');
    assert.equal(t.nextDeadline(), 1000);
    shapes.expect('WaitChecked', t.waitChecked(a, 'stale', 10));
    shapes.expect('WaitTimedOut[]', t.expireWaits(1000));
    shapes.expect('WaitChecked', t.waitChecked(a, undefined, 1100));
    shapes.expect('WaitChecked', t.waitChecked(b, undefined, 6000));
  });

  it('a routine: dispatches, moves, conditions, snapshot', function () {
    const t = keep(new facade.Tracker(PLANT, 0));
    const r = keep(t.routine('r'));
    shapes.expect('RoutineTransitionCondition[]', r.conditions());
    shapes.expect('RoutineCondition', r.condition(1));
    shapes.expect('RoutineDispatch', r.onMsg('go'));
    shapes.expect('RoutineSnapshot', r.snapshot());
    shapes.expect('RoutineMove', r.completed());
    shapes.expect('RoutineDispatch | undefined', r.conditionMet(1));
    shapes.expect('RoutineMove', r.faulted());
    shapes.expect('RoutineMove', r.reset());
    r.onMsg('go');
    shapes.expect('RoutineCommanded', r.command('hold', 'running'));
    shapes.expect('RunState', r.runState('held'));
    const saved = r.snapshot();
    shapes.expect('RoutineSnapshot', saved);
    shapes.expect('RoutineMove | null', r.restore(saved, ['o']));
    shapes.expect('RoutineMove', r.operationStopped());
    r.reset();
    r.onMsg('go');
    shapes.expect('RoutineFailed', r.runFailed('faulted'));
  });

  it('a msg\'s request read by the core: its values, or the refusal', function () {
    shapes.expect('RequestRead', facade.readRequest({ kind: 'acquire' }, { operation: ' 12 ', resources: 'A,B' }, { priority: '5' }));
    shapes.expect('RequestRead', facade.readRequest({ kind: 'who' }, { user: { username: 'ann' }, by: 'bo', reason: 'fix' }, {}));
    shapes.expect('RequestRead', facade.readRequest({ kind: 'acquire' }, { operation: 'x', priority: 'soon' }, {}));
    shapes.expect('NamesRead', facade.namesOf(' a, b', 'sensors'));
    shapes.expect('NamesRead', facade.namesOf(7, 'sensors'));
    shapes.expect('ConfigRead', facade.nodeConfig('wait', { timeout: '60', sensors: 'LT-3' }));
    shapes.expect('ConfigRead', facade.nodeConfig('operation', { operation: ' 10 ' }));
    shapes.expect('ConfigRead', facade.nodeConfig('acquire', { timeout: -1 }));
  });

  it('the device side: messages and commands', function () {
    const d = keep(new facade.DeviceSide(PLANT));
    const panel = d.device('p');
    shapes.expect('DeviceMessage | null', d.status(panel, true));
    shapes.expect('DeviceMessage[]', d.actuatorMessages(panel, Uint32Array.of(0, 1), Float64Array.of(50, 1)));
    shapes.expect('DeviceMessage[]', d.sensorMessages(d.device('s'), Uint32Array.of(0), Float64Array.of(1.5)));
    for (const topic of d.commandTopics(panel)) {
      shapes.expect('DeviceCommand | undefined', d.parseCommand(topic, Buffer.from('50')));
      shapes.expect('DeviceCommand | undefined', d.parseCommand(topic, Buffer.from('nonsense')));
      shapes.expect('DeviceCommand | undefined', d.parseCommand(topic, Buffer.alloc(0)));
    }
  });

  it('Modbus: connections, the device side, a modbusSend effect', function () {
    const scale = { raw: [4000, 20000], value: [0, 100] };
    const doc = {
      actuatorTypes: { valve: { signal: 'analog', tolerance: 2, noMotionMs: 1000, completionMs: 5000, staleMs: 5000 } },
      devices: [
        { id: 'io', kind: 'actuator-panel', profile: 'modbus', modbus: { host: '127.0.0.1', port: 5020, unit: 1 } },
        { id: 'rs', kind: 'sensor-station', profile: 'modbus', modbus: { serial: { path: '/dev/ttyUSB0' }, unit: 2 } },
      ],
      actuators: [{ id: 'V', type: 'valve', device: 'io', lockout: 0, modbus: { command: { kind: 'holding', address: 0, scale } } }],
      sensors: [{ id: 'T', device: 'rs', name: 't', modbus: { kind: 'input', address: 0, type: 'f32' } }],
    };
    const t = keep(new facade.Tracker(doc, 0));
    const connections = t.modbusConnections();
    shapes.expect('ModbusConnection[]', connections);
    assert.deepEqual(connections.map((c) => c.endpoint.kind), ['tcp', 'serial']);
    shapes.expect('ModbusEndpoint', connections[1].endpoint);
    t.modbusOpened(0, 0);
    t.command({ valves: { V: 50 } }, 1, false, 0);
    const effects = t.takeEffects();
    shapes.expect('TrackerEffect[]', effects);
    assert.deepEqual(effects, [{ kind: 'modbusSend', connection: 0 }]);
    const d = keep(new facade.DeviceSide(doc));
    shapes.expect('ModbusDeviceEndpoint | null', d.modbusEndpoint(0));
    const frame = t.modbusNext(0, 1);
    const request = d.modbusRequest('tcp', frame);
    shapes.expect('ModbusServedRequest', request);
    shapes.expect('ModbusWritten[]', d.modbusWritten(0, request.kind, request.address, Uint16Array.from(request.write)));
    shapes.expect('ModbusImage[]', d.modbusImage(1, new Uint32Array(0), new Float64Array(0), Uint32Array.of(0), Float64Array.of(21.5)));
  });

  it('the control facade: steps, decisions, states, configurations', function () {
    const pid = { kp: 1, tiS: 10, tdS: 1, outMin: 0, outMax: 100, action: 'reverse', fallback: 5, proportionalOn: 'error' };
    const smith = { model: { gain: 1, tauS: 10 }, tsS: 1, deadTime: { mode: 'adaptive', alpha: 0.2, h: 3 }, maxSamples: 10 };
    shapes.expect('PidLoopConfig', { pid, smith });
    const loop = keep(new facade.PidLoop({ pid, smith }));
    loop.observeRoundTrip(1500);
    shapes.expect('DelayEstimate | undefined', loop.delayEstimate());
    shapes.expect('PidLoopStep', loop.step(50, 40, 1, undefined));
    shapes.expect('PidLoopStep', loop.step(50, undefined, 1, undefined));
    shapes.expect('PidConfig', loop.config());
    const rccConfig = { id: 2, thresholdsMs: [1000, 2000], tsMs: 500, smoothHandover: true };
    shapes.expect('RccConfig', rccConfig);
    const rcc = keep(new facade.Rcc(rccConfig));
    const io = keep(new facade.IoModule(2, 10));
    io.write(1, 20, 0);
    const state = io.state(100);
    shapes.expect('IoState', state);
    const decision = rcc.decide(state, 100);
    shapes.expect('RccDecision', decision);
    shapes.expect('PidLoopScan', loop.stepDecided(decision, 50, 42, 0.5));
    const plain = keep(new facade.PidLoop({ pid, smith: null }));
    shapes.expect('RccScan', rcc.scan(plain, io.state(3000), 50, 42, 0.5));
    const stationConfig = { loop: { pid, smith }, tsS: 1, staleMs: 100, setpoint: 50, mode: 'auto', manual: null };
    shapes.expect('StationConfig', stationConfig);
    const station = keep(new facade.PidStation(stationConfig));
    shapes.expect('StationOutcome', station.measure(40, 0, 0, undefined, undefined));
    shapes.expect('StationOutcome', station.measure(41, 1000, 1000, undefined, rcc.decide(io.state(1000), 1000)));
    const change = { setpoint: 55, tunings: { kp: 2 }, limits: { max: 90 } };
    shapes.expect('StationChange', change);
    station.change(change);
    const saved = { integral: 1, setpoint: 55, mode: 'manual', manual: 20 };
    shapes.expect('StationSaved', saved);
    station.restore(saved);
    shapes.expect('StationState', station.state());
    shapes.expect('DelayEstimate | undefined', station.delayEstimate());
    shapes.expect('PidConfig', station.config());
    shapes.expect('StationStale | undefined', station.tick(5000));
    shapes.expect('PidConfigInput', pid);
    shapes.expect('SmithConfig', smith);
  });

  it('the engine: options, nodes, msg fields, operator requests, its view', function () {
    const t = keep(new facade.Tracker(PLANT, 0));
    const config = { resources: t.interlockResources() };
    const options = { plantBound: true, wire: 'typed' };
    shapes.expect('EngineOptions', options);
    const e = keep(new facade.Engine(config, options));
    const nodes = [
      { kind: 'acquire', timeoutMs: 1000, operation: 'o', priority: 2, resources: 'A' },
      { kind: 'release', operation: 'o' },
      { kind: 'fault', byResources: true, failMsg: false, resources: 'B' },
      { kind: 'clear', allFaulted: true, refusalsWired: false },
    ];
    nodes.forEach((node, i) => {
      shapes.expect('EngineNode', node);
      e.addNode(i + 1, node, 0);
    });
    e.start(null, undefined, 0);
    e.acquire(1, 1, 1);
    e.acquireNamed(1, 9, 'p', 1, undefined, 1);
    const fields = { reason: 'leak', user: 'Ann', force: false };
    shapes.expect('EngineFields', fields);
    e.fault(3, 2, fields, 2);
    for (const request of [{ kind: 'clear', lines: ['B'] }, { kind: 'ack' }, { kind: 'shelve', id: 'line-faulted:B', forMs: 1000 }]) {
      shapes.expect('OperatorRequest', request);
      e.operatorAgainst(3, request, fields, 3, t);
    }
    e.fault(3, 4, fields, 4);
    shapes.expect('EngineView', e.viewAgainst(5, t));
    shapes.expect('InterlockCounts', e.counts());
    shapes.expect('InterlockSnapshot', e.snapshot(5));
  });

  it('the engine\'s sealed document: the interlock reads it, a restart faults its held line, another owner\'s is lost', function () {
    const t = keep(new facade.Tracker(PLANT, 0));
    const config = { resources: t.interlockResources() };
    const e = keep(new facade.Engine(config, {}));
    e.addNode(1, { kind: 'acquire', timeoutMs: 1000, operation: 'o', priority: 2, resources: 'A' }, 0);
    e.start(null, undefined, 0);
    e.acquire(1, 1, 1);
    assert.equal(e.counts().faulted, 0);
    const text = e.seal('il-1', 'plant-1', {}, 2);
    const opened = facade.Interlock.open(config, 'il-1', 'plant-1', 'state.json', text, 3);
    keep(opened.interlock);
    shapes.expect('OpenedInterlock', opened);
    assert.equal(opened.lost, null);
    const restarted = keep(new facade.Engine(config, {}));
    restarted.startSealed('il-1', 'plant-1', 'state.json', text, 3);
    assert.deepEqual([restarted.counts().faulted, restarted.lost()], [1, undefined]);
    const foreign = keep(new facade.Engine(config, {}));
    foreign.startSealedAgainst('il-2', 'plant-1', 'state.json', text, 3, t);
    assert.equal(foreign.counts().faulted, config.resources.length);
    assert.match(foreign.lost(), /^state\.json: /);
  });

  it('a runtime\'s life: the view of each stage a step leads to', function () {
    let view = facade.lifeView('starting');
    shapes.expect('LifeView', view);
    for (const step of ['drain-begin', 'fail', 'restart', 'stand-down', 'activate', 'started', 'drain-end', 'retire']) {
      shapes.expect('LifeStep', step);
      view = facade.lifeStep(view.stage, step);
      shapes.expect('LifeView', view);
      for (const admit of view.admit) shapes.expect('LifeAdmit', admit);
    }
    assert.equal(view.stage, 'stopped');
  });

  it('every declared shape was met by a real value', function () {
    // Classes are wasm's own; a class is checked only where a declared shape names it.
    const unmet = [...declarations()].filter(([name, decl]) => !ts.isClassDeclaration(decl) && !shapes.met.has(name)).map(([name]) => name);
    assert.deepEqual(unmet, []);
  });
});
