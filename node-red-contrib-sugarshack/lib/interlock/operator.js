// @ts-check
'use strict';
// A person's actions on an interlock, the same whoever carries them (the
// editor's admin endpoints, another package through the palette's API, the
// operation and routine nodes' command msgs):
// attributed to `who` ({ by, reason, force }), journalled like the clear and
// fault nodes journal theirs, and answered once the state is saved. Every rule
// is the core's: a refusal (CLEAR_REFUSED with every reason in `err.lines`,
// NOT_FAULTED, UNKNOWN_ALARM, INVALID_SHELF, ...) rejects unchanged.
const { SugarshackError } = require('../host/errors');
const { journal } = require('../journal/bus');
const wasm = require('../wasm');

/**
 * Runs `work(resolve)` on the runtime (a wasm trap becomes INTERNAL and a
 * rebuild); a refusal it throws rejects.
 * @template T
 * @param {any} runtime
 * @param {(resolve: (value: T) => void) => void} work
 * @returns {Promise<T>}
 */
function act(runtime, work) {
  return new Promise((resolve, reject) => {
    try {
      runtime.guard(() => work(resolve));
    } catch (err) {
      reject(err);
    }
  });
}

// Who the answer names: the core's words for it (trimmed, "unknown" when nobody said), as its event names them.
const byOf = (who) => wasm.load().attributedBy(who.by);

/** An emergency stop of `lines`; their lockouts go out. `note`: the fault's note when `who` gives no reason. */
function estop(runtime, lines, who, note) {
  if (runtime.operate) return runtime.operate({ kind: 'eStop', lines }, who); // the engine's note: the editor's e-stop
  return act(runtime, (resolve) => {
    if (!lines || lines.length === 0) throw SugarshackError.of('INVALID_RESOURCES', 'noLinesToStop');
    journal.action('e-stop', who, lines);
    runtime.faultResources(lines, who.reason || note, (lockouts) => {
      if (runtime.plant) runtime.plant.issueLockouts(lockouts, null);
      resolve({ stopped: lockouts.map((l) => l.resource), by: byOf(who) });
    }, who);
  });
}

/** Clears `lines` (every faulted one when null), by the core's clear rule, forced when `who.force`. */
function clear(runtime, lines, who) {
  if (runtime.operate) return runtime.operate({ kind: 'clear', lines }, who);
  const target = lines === null ? 'all' : lines;
  return act(runtime, (resolve) => {
    try {
      runtime.clear(lines, (cleared) => {
        journal.action(who.force ? 'clear-forced' : 'clear', who, target);
        resolve({ cleared, by: byOf(who) });
      }, who);
    } catch (err) {
      if (err.code === 'CLEAR_REFUSED') journal.action('clear-refused', who, target);
      throw err;
    }
  });
}

const alarmAnswer = (who, resolve) => (changes) => resolve({ changes, by: byOf(who) });

/** Acknowledges alarms `ids` (every unacknowledged one when null). */
function acknowledge(runtime, ids, who) {
  if (runtime.operate) return runtime.operate({ kind: 'ack', ids }, who);
  return act(runtime, (resolve) => runtime.acknowledgeAlarms(ids, who, alarmAnswer(who, resolve)));
}

/** Shelves alarm `id` until `untilMs`; `oneShot`: also until its condition next ends. */
function shelve(runtime, id, { untilMs, oneShot = false }, who) {
  if (runtime.operate) return runtime.operate({ kind: 'shelve', id, untilMs, oneShot }, who);
  return act(runtime, (resolve) => runtime.shelveAlarm(id, untilMs, who, alarmAnswer(who, resolve), { oneShot }));
}

function unshelve(runtime, id, who) {
  if (runtime.operate) return runtime.operate({ kind: 'unshelve', id }, who);
  return act(runtime, (resolve) => runtime.unshelveAlarm(id, who, alarmAnswer(who, resolve)));
}

/**
 * An operator's ISA-88 command (`hold`, `restart`, `stop`, `abort`, `reset`)
 * to the run of an operation (`target` `{ operation: id }`, also one waiting
 * for a reset after an abort) or to a routine (`{ routine: id }`), by `who`
 * ({ by, reason }). Resolves `{ operation | routine, command, state, by }`
 * once the state it entered is saved; rejects unchanged with the core's
 * refusal (COMMAND_REFUSED, naming the state and what it allows), UNKNOWN_RUN
 * (nothing of that id runs or waits for a reset here), INVALID_INPUT (not a command).
 * @param {any} runtime
 * @param {{ operation?: string, routine?: string }} target
 * @param {string} name
 * @param {{ by?: string, reason?: string }} who
 * @returns {Promise<{ operation?: string, routine?: string, command: string, state: string | null, by: string }>}
 */
function command(runtime, target, name, who) {
  // Runs and routines of a plant are supervised beside the engine: their commands go to them.
  if (runtime.operate && !runtime.plant) return runtime.operate({ kind: 'command', command: name, operation: target?.operation, routine: target?.routine }, who);
  return act(runtime, (resolve) => {
    runtime.command(target, name, who, (state) => {
      const [kind, id] = target.routine !== undefined ? ['routine', target.routine] : ['operation', target.operation];
      journal.action(name, who, id);
      resolve({ [kind]: id, command: name, state, by: byOf(who) });
    });
  });
}

module.exports = { estop, clear, acknowledge, shelve, unshelve, command };
