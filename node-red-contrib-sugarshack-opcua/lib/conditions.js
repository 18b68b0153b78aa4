'use strict';
// The core's alarms as OPC UA Alarms & Conditions (OPC 10000-9): one
// AlarmConditionType per alarm id, its source the line or device it is about
// (else the plant), in the Alarms folder. Every state is the core's, mirrored
// on each change with an event: ActiveState, AckedState (with the Comment and
// ClientUserId of whoever acknowledged), ShelvingState (TimedShelved or
// OneShotShelved until the core's shelf ends), Retain (while active or
// unacknowledged), Message, and Severity (the core's priority of its kind).
// ConditionRefresh resends the retained ones.
//
// Acknowledge, TimedShelve, OneShotShelve and Unshelve do not move a condition
// themselves: they ask the core (api.acknowledge, shelve, unshelve) as the
// session's user, through the same path as the HMI and the state API, and the
// core's answer moves it. Disable, Enable and AddComment have no counterpart in
// the core's rules and are refused (BadNotSupported), so no state lives here.
//
// A condition is made the first time the core lists its alarm (one per turn of
// the event loop: node-opcua takes tens of ms each) and kept, never deleted
// (node-opcua frees a deleted condition only in part: a season of alarms
// coming and going must not grow the server), up to `limit`; past that an
// alarm is counted in Alarms/NotExposed and read through the state API.
const { DataType, StatusCodes, DataValue, NodeId, coerceLocalizedText } = require('node-opcua');
const { segment } = require('./model');

// The core's refusals, as OPC UA says them.
const STATUS_OF = {
  UNKNOWN_ALARM: StatusCodes.BadConditionBranchAlreadyAcked,
  INVALID_SHELF: StatusCodes.BadShelvingTimeOutOfRange,
  INVALID_INPUT: StatusCodes.BadInvalidArgument,
  NO_INTERLOCK: StatusCodes.BadInvalidState,
};

class Conditions {
  /** model: the PlantModel; users: who calls; limit: conditions at most; onError(err) logs. */
  constructor({ model, api, interlockId, users, limit, onError }) {
    this.model = model;
    this.api = api;
    this.interlockId = interlockId;
    this.users = users;
    this.limit = limit;
    this.onError = onError;
    /** @type {Map<string, { node: any, seen: string }>} */
    this.byId = new Map();
    /** @type {Map<string, string>} condition or shelving node id -> alarm id */
    this.byNode = new Map();
    this.waiting = new Map(); // alarm id -> alarm, waiting for its condition to be made
    this.making = false;
    this.alarms = new Map(); // the core's list, last seen
    this.prepared = new Map(); // alarm id -> { id, kind, subject }: made ahead, before any occurrence
    this.stopped = false;
    this.bindTypeMethods();
  }

  stop() {
    this.stopped = true;
  }

  /**
   * Conditions made ahead for alarms that may come (each line's fault), so
   * that their first event does not wait for node-opcua to make them.
   */
  prepare(alarms) {
    for (const a of alarms) {
      if (this.byId.has(a.id) || this.waiting.has(a.id) || this.byId.size + this.waiting.size >= this.limit) continue;
      this.prepared.set(a.id, a);
      this.waiting.set(a.id, a);
    }
    this.makeNext();
  }

  /** The core's alarm list now (api.interlock().alarms). */
  sync(alarms) {
    const listed = new Map(alarms.map((a) => [a.id, a]));
    for (const [id, entry] of this.byId) {
      if (!listed.has(id) && entry.seen !== 'gone') this.mirror(entry, null);
    }
    for (const alarm of alarms) {
      const entry = this.byId.get(alarm.id);
      if (entry) this.mirror(entry, alarm);
      else if (this.byId.size + this.waiting.size < this.limit || this.waiting.has(alarm.id)) this.waiting.set(alarm.id, alarm);
    }
    this.alarms = listed;
    const notExposed = alarms.filter((a) => !this.byId.has(a.id) && !this.waiting.has(a.id)).length;
    this.model.set('Alarms/Count', DataType.UInt32, alarms.length);
    this.model.set('Alarms/NotExposed', DataType.UInt32, notExposed);
    this.makeNext();
  }

  /** Makes one waiting condition per turn of the event loop, so the interlock keeps granting meanwhile. */
  makeNext() {
    if (this.making || this.waiting.size === 0 || this.stopped) return;
    this.making = true;
    setImmediate(() => {
      this.making = false;
      if (this.stopped) return;
      const [id] = this.waiting.keys();
      this.waiting.delete(id);
      const alarm = this.alarms.get(id);
      const prepared = this.prepared.get(id);
      this.prepared.delete(id);
      if (alarm || prepared) {
        try {
          // Made ahead and not listed: it starts as a condition back to normal, with no event.
          const entry = { node: this.make(alarm || prepared), seen: alarm ? '' : 'gone' };
          this.byId.set(id, entry);
          if (alarm) this.mirror(entry, alarm);
        } catch (err) {
          this.onError(err);
        }
      }
      this.makeNext();
    });
  }

  make(alarm) {
    const { model } = this;
    const source = sourceOf(model, alarm);
    const node = model.ns.instantiateAlarmCondition('AlarmConditionType', {
      browseName: alarm.id,
      nodeId: `s=Alarms/${segment(alarm.id)}`,
      componentOf: model.nodes.get('Alarms'),
      conditionSource: source,
      conditionName: alarm.id,
      inputNode: NodeId.nullNodeId,
      optionals: ['ShelvingState'],
      maxTimeShelved: this.api.maxShelveMs,
    });
    // What the alarm is about, by name (node-opcua would write the source's browse name with its namespace).
    node.sourceName.setValueFromSource({ dataType: DataType.String, value: alarm.subject });
    node.acknowledge.bindMethod(this.acknowledge.bind(this));
    const shelving = node.shelvingState;
    shelving.timedShelve.bindMethod(this.timedShelve.bind(this));
    shelving.oneShotShelve.bindMethod(this.oneShotShelve.bind(this));
    shelving.unshelve.bindMethod(this.unshelve.bind(this));
    for (const m of ['disable', 'enable', 'addComment']) if (node[m]) node[m].bindMethod(notSupported);
    // The time left on the core's shelf, not node-opcua's own timer.
    shelving.unshelveTime.bindVariable({ timestamped_get: () => this.timeLeft(alarm.id) }, true);
    this.byNode.set(node.nodeId.toString(), alarm.id);
    this.byNode.set(shelving.nodeId.toString(), alarm.id);
    return node;
  }

  /** The methods on the types answer too (clients call them with a condition's id as the object). */
  bindTypeMethods() {
    const as = this.model.addressSpace;
    const ackType = as.findEventType('AcknowledgeableConditionType');
    ackType.acknowledge.bindMethod(this.acknowledge.bind(this));
    if (ackType.confirm) ackType.confirm.bindMethod(notSupported);
    const conditionType = as.findEventType('ConditionType');
    for (const m of ['disable', 'enable', 'addComment']) if (conditionType[m]) conditionType[m].bindMethod(notSupported);
    const shelvedType = as.findObjectType('ShelvedStateMachineType');
    const bind = (name, fn) => {
      const method = shelvedType.getMethodByName(name);
      if (method) method.bindMethod(fn.bind(this));
    };
    bind('TimedShelve', this.timedShelve);
    bind('OneShotShelve', this.oneShotShelve);
    bind('Unshelve', this.unshelve);
  }

  /** Mirrors `alarm` (the core's, or null: it left the list) on its condition, with an event when anything changed. */
  mirror(entry, alarm) {
    const seen = alarm ? JSON.stringify([alarm.state, alarm.text, alarm.acked, alarm.shelved, alarm.activeSinceMs]) : 'gone';
    if (entry.seen === seen) return;
    entry.seen = seen;
    const { node } = entry;
    const branch = node.currentBranch();
    const state = alarm ? alarm.state : 'normal';
    const active = state === 'active-unacknowledged' || state === 'active-acknowledged';
    const acked = !state.endsWith('-unacknowledged');
    branch.setActiveState(active);
    if (branch.getAckedState() !== acked) branch.setAckedState(acked);
    if (alarm && alarm.acked) branch.setComment(coerceLocalizedText(alarm.acked.reason || ''));
    const last = alarm ? latestAction(alarm) : null;
    if (last) branch.setClientUserId(last.by);
    const shelf = alarm && alarm.shelved;
    const shelving = shelf ? (shelf.oneShot ? 'OneShotShelved' : 'TimedShelved') : 'Unshelved';
    if (node.shelvingState.getCurrentState() !== shelving) node.shelvingState.setState(shelving);
    const severity = alarm ? this.api.alarmSeverities[alarm.kind] || 500 : branch.getSeverity();
    node.raiseNewCondition({
      message: alarm ? alarm.text : branch.getMessage(),
      severity,
      retain: state !== 'normal',
      quality: StatusCodes.Good,
      time: new Date(alarm ? alarm.changedMs : Date.now()),
    });
  }

  timeLeft(id) {
    const alarm = this.alarms.get(id);
    const shelf = alarm && alarm.shelved;
    if (!shelf) return new DataValue({ statusCode: StatusCodes.BadConditionNotShelved, value: { dataType: DataType.Double, value: 0 } });
    return new DataValue({ value: { dataType: DataType.Double, value: Math.max(0, shelf.untilMs - Date.now()) } });
  }

  // ---- methods: the core decides --------------------------------------------------

  /** The alarm a call is on (`context.object`: the condition or its ShelvingState), and who calls. */
  callOf(context) {
    const object = context && context.object;
    const id = object ? this.byNode.get(object.nodeId.toString()) : undefined;
    return { id, who: this.users.caller(context), node: id ? this.byId.get(id).node : null };
  }

  /** Runs `act(id, who)` (a promise of the core's changes) for an allowed caller; `done(changes)` says the status. */
  call(context, callback, act, done) {
    const { id, who } = this.callOf(context);
    if (!id) return callback(null, { statusCode: StatusCodes.BadNodeIdInvalid });
    if (!who.write) return callback(null, { statusCode: StatusCodes.BadUserAccessDenied });
    act(id, who).then((answer) => callback(null, { statusCode: done(answer.changes.filter((c) => c.id === id)) }), (err) => {
      if (!STATUS_OF[err.code]) this.onError(err);
      callback(null, { statusCode: STATUS_OF[err.code] || StatusCodes.BadInternalError });
    });
    return undefined;
  }

  acknowledge(inputArguments, context, callback) {
    const { node } = this.callOf(context);
    const eventId = inputArguments[0] && inputArguments[0].value;
    // The client acknowledges what it saw: the condition's latest event.
    if (node && !(Buffer.isBuffer(eventId) && eventId.equals(node.eventId.readValue().value.value))) {
      return callback(null, { statusCode: StatusCodes.BadEventIdUnknown });
    }
    const comment = inputArguments[1] && inputArguments[1].value ? coerceLocalizedText(inputArguments[1].value).text || null : null;
    return this.call(context, callback, (id, who) => this.api.acknowledge(this.interlockId, [id], { by: who.by, reason: comment }),
      (changes) => (changes.some((c) => c.action === 'acknowledge') ? StatusCodes.Good : StatusCodes.BadConditionBranchAlreadyAcked));
  }

  timedShelve(inputArguments, context, callback) {
    const forMs = inputArguments[0] ? Number(inputArguments[0].value) : NaN;
    if (!Number.isFinite(forMs) || forMs <= 0) return callback(null, { statusCode: StatusCodes.BadShelvingTimeOutOfRange });
    return this.call(context, callback, (id, who) => this.api.shelve(this.interlockId, id, { untilMs: Date.now() + forMs }, { by: who.by }),
      () => StatusCodes.Good);
  }

  oneShotShelve(inputArguments, context, callback) {
    return this.call(context, callback, (id, who) => this.api.shelve(this.interlockId, id, { untilMs: Date.now() + this.api.maxShelveMs, oneShot: true }, { by: who.by }),
      () => StatusCodes.Good);
  }

  unshelve(inputArguments, context, callback) {
    return this.call(context, callback, (id, who) => this.api.unshelve(this.interlockId, id, { by: who.by }),
      (changes) => (changes.some((c) => c.action === 'unshelve') ? StatusCodes.Good : StatusCodes.BadConditionNotShelved));
  }
}

function notSupported(inputArguments, context, callback) {
  callback(null, { statusCode: StatusCodes.BadNotSupported });
}

/** Who last acted on the alarm: its acknowledgement or its shelving, whichever came later. */
function latestAction(alarm) {
  const stamps = [alarm.acked, alarm.shelved].filter(Boolean);
  return stamps.sort((a, b) => b.atMs - a.atMs)[0] || null;
}

/** An alarm's source: its line or device when the address space has it, else the plant. */
function sourceOf(model, alarm) {
  const folder = alarm.kind === 'line-faulted' ? 'Lines' : alarm.kind.startsWith('device-') ? 'Devices' : null;
  return (folder && model.nodes.get(`${folder}/${segment(alarm.subject)}`)) || model.root;
}

module.exports = { Conditions };
