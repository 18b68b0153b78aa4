// @ts-check
'use strict';
// The journal's tables: what each row of line protocol holds. Text goes in
// tags (QuestDB symbols) and numbers in fields, because that is what every
// line-protocol server keeps: VictoriaMetrics and InfluxDB index tags, and
// VictoriaMetrics drops string fields. Every row carries `plant` (which plant
// wrote it, for several plants in one database), `writer` (the journal that
// wrote it, an id kept across restarts) and `seq` (that writer's row number,
// going on across restarts): (writer, seq) names a row, so a reader can tell
// that none is missing, that order held, and which rows a retry sent twice.
// Times are milliseconds since the epoch; a row's own timestamp is when the
// palette saw it happen.

const WRITER = 'the journal writer\'s id (12 hex digits, kept with its spool or files)';

const TABLES = {
  datapoint: {
    name: 'sugarshack_datapoint',
    doc: 'every datapoint a device published, as received',
    tags: { plant: 'plant id', writer: WRITER, device: 'device name', entity: 'actuator or sensor id in the plant document' },
    fields: { value: 'float: the value', device_ts: 'float: the device timestamp (ms), when it sent one', seq: 'int' },
    time: 'reception time',
  },
  event: {
    name: 'sugarshack_event',
    doc: 'interlock, actuator, operation and routine events',
    tags: {
      plant: 'plant id',
      writer: WRITER,
      layer: '`interlock`, `actuator`, `operation` or `routine`',
      kind: 'the event: `granted`, `queued`, `released`, `faulted`, `cleared`, `completed`, `finished`, `dispatched`...',
      subject: 'the operation, actuator or routine',
      resources: 'lines concerned, space separated',
      note: 'fault note, failure code or routine state change (`from>to`)',
    },
    fields: {
      waited_ms: 'float', held_ms: 'float', priority: 'float', issue_to_motion_ms: 'float', completion_ms: 'float',
      run_ms: 'float', queued_ms: 'float', retries: 'float', seq: 'int',
    },
    time: 'event time',
  },
  action: {
    name: 'sugarshack_action',
    doc: 'operator actions: faults raised, lines cleared, operations cancelled, notes',
    tags: { plant: 'plant id', writer: WRITER, action: '`fault`, `clear`, `cancel` or `note`', who: 'msg.who (or msg.user)', why: 'msg.why (or msg.note)', target: 'operation or lines acted on' },
    fields: { seq: 'int' },
    time: 'action time',
  },
  timing: {
    name: 'sugarshack_timing',
    doc: "the paper's timing series (Figs. 11-15)",
    tags: {
      plant: 'plant id',
      writer: WRITER,
      series: '`tof`, `command/issueToMotion`, `command/completion`, `fault/lockout`, `lockout/confirm`, `operation/run`, `operation/queued`',
      subject: 'the device (`tof`) or operation (`operation/*`); empty otherwise',
    },
    fields: { value_ms: 'float', seq: 'int' },
    time: 'when the figure was measured',
  },
};

// Event details copied into fields: camelCase in msgs, snake_case in the database.
const EVENT_FIELDS = {
  waitedMs: 'waited_ms', heldMs: 'held_ms', priority: 'priority', issueToMotionMs: 'issue_to_motion_ms',
  completionMs: 'completion_ms', runMs: 'run_ms', queuedMs: 'queued_ms', retries: 'retries',
};

// Series named `<series>/<subject>` in lib/host/stats.js; the others have no subject.
const SERIES_WITH_SUBJECT = ['tof', 'operation/run', 'operation/queued'];

const INT_FIELDS = new Set(['seq']);

// A row is the same row when these match: a database that deduplicates on them keeps a resent row once.
const ROW_KEY = ['timestamp', 'writer', 'seq'];

/** Every column a query may name, per table name: the check the Grafana dashboards are tested with. */
function columns() {
  const out = {};
  for (const t of Object.values(TABLES)) out[t.name] = ['timestamp', ...Object.keys(t.tags), ...Object.keys(t.fields)];
  return out;
}

/**
 * QuestDB's statements for the tables, one per line: each created with its
 * columns, WAL and deduplication on ROW_KEY; one that the line protocol created
 * earlier gets the writer column and the deduplication. Run by deploy/ before
 * the journal writes (deploy/questdb/schema.sql, written by scripts/deploy-flows.js).
 */
function questdbStatements() {
  const keys = ROW_KEY.join(', ');
  return Object.values(TABLES).flatMap((t) => {
    const cols = [
      ...Object.keys(t.tags).map((c) => `${c} SYMBOL`),
      ...Object.keys(t.fields).map((c) => `${c} ${INT_FIELDS.has(c) ? 'LONG' : 'DOUBLE'}`),
      'timestamp TIMESTAMP',
    ];
    return [
      `CREATE TABLE IF NOT EXISTS ${t.name} (${cols.join(', ')}) TIMESTAMP(timestamp) PARTITION BY DAY WAL DEDUP UPSERT KEYS(${keys});`,
      `ALTER TABLE ${t.name} ADD COLUMN IF NOT EXISTS writer SYMBOL;`,
      `ALTER TABLE ${t.name} DEDUP ENABLE UPSERT KEYS(${keys});`,
    ];
  });
}

module.exports = { TABLES, EVENT_FIELDS, SERIES_WITH_SUBJECT, INT_FIELDS, ROW_KEY, columns, questdbStatements };
