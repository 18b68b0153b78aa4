'use strict';
// The deployment recipe (deploy/), checked offline: no image is pulled or run.
// (a) every Compose file against the compose-spec JSON schema, plus what the
//     schema cannot see: volumes and networks declared, bind mounts and build
//     files present, every ${VAR} in .env.example (and nothing stale there),
//     no two services on one host port, every ${VAR} the flows and Grafana's
//     provisioning read set in their container's environment;
// (b) every SQL query of the Grafana dashboards names only tables and columns
//     of the journal (lib/journal/schema.js columns());
// (c) the committed mosquitto.conf run by the real mosquitto: anonymous
//     clients refused, the password file's user accepted;
// (d) QuestDB's tables deduplicate on (timestamp, writer, seq): the committed
//     statements are the journal's schema's, and deploy/questdb/schema.sh, run
//     by the real sh and curl against a stand-in for QuestDB's /exec, sends
//     every one of them once QuestDB answers.
const assert = require('assert');
const fs = require('fs');
const path = require('path');
const http = require('http');
const { execFile, execFileSync } = require('child_process');
const YAML = require('yaml');
const Ajv2019 = require('ajv/dist/2019').default;
const mqtt = require('mqtt');
const { columns, TABLES } = require('../../node-red-contrib-sugarshack/lib/journal/schema');
const deployFlows = require('../../scripts/deploy-flows');
const { startMosquitto, findMosquitto } = require('../integration/support/mosquitto');

const ROOT = path.resolve(__dirname, '..', '..');
const DEPLOY = path.join(ROOT, 'deploy');
const COMPOSE_FILES = ['compose.yaml', 'edge/compose.yaml', 'cloud/compose.yaml', 'standby/compose.yaml'].map((f) => path.join(DEPLOY, f));
const rel = (p) => path.relative(ROOT, p);

// ---- Compose interpolation (${VAR}, ${VAR:-default}, ${VAR:?error}, $VAR, $$) ----

const VAR_RE = /\$(?:\$|\{([A-Za-z_][A-Za-z0-9_]*)(?:(:?[-?])([^}]*))?\}|([A-Za-z_][A-Za-z0-9_]*))/g;

/** The variable names a Compose string refers to. */
function varsIn(text) {
  const out = new Set();
  for (const m of text.matchAll(VAR_RE)) if (m[1] || m[4]) out.add(m[1] || m[4]);
  return out;
}

/** Compose's substitution of `env` into `text` (unset and empty alike for the `:` forms). */
function interpolate(text, env) {
  return text.replace(VAR_RE, (whole, name, op, arg, bare) => {
    if (whole === '$$') return '$';
    const key = name || bare;
    const value = env[key];
    const unset = value === undefined || (op && op.startsWith(':') && value === '');
    if (op && op.endsWith('-')) return unset ? arg : value;
    if (op && op.endsWith('?') && unset) throw new Error(`${key} is required: ${arg}`);
    return value ?? '';
  });
}

function parseEnvFile(file) {
  const env = {};
  for (const line of fs.readFileSync(file, 'utf8').split('\n')) {
    const m = /^\s*([A-Za-z_][A-Za-z0-9_]*)=(.*)$/.exec(line);
    if (m) env[m[1]] = m[2];
  }
  return env;
}

/** A Compose file as Compose would use it with .env.example beside it as its .env. */
function loadCompose(file) {
  const text = fs.readFileSync(file, 'utf8');
  const env = parseEnvFile(path.join(path.dirname(file), '.env.example'));
  return { text, env, raw: YAML.parse(text), doc: YAML.parse(interpolate(text, env)) };
}

// ---- checks the schema cannot make ----

const isNamedVolume = (source) => source && !/^[./~]/.test(source) && !path.isAbsolute(source);

/** Named volumes, networks and bind-mount sources of every service. */
function checkReferences(doc, dir) {
  const problems = [];
  const volumes = new Set(Object.keys(doc.volumes || {}));
  const networks = new Set(['default', ...Object.keys(doc.networks || {})]);
  for (const [name, svc] of Object.entries(doc.services || {})) {
    for (const v of svc.volumes || []) {
      const source = typeof v === 'string' ? (v.includes(':') ? v.split(':')[0] : null) : v.source;
      if (isNamedVolume(source) && !volumes.has(source)) problems.push(`${name}: volume '${source}' is not declared under volumes:`);
      if (source && !isNamedVolume(source) && !fs.existsSync(path.resolve(dir, source))) problems.push(`${name}: bind mount source ${source} does not exist`);
    }
    const nets = Array.isArray(svc.networks) ? svc.networks : Object.keys(svc.networks || {});
    for (const n of nets) if (!networks.has(n)) problems.push(`${name}: network '${n}' is not declared under networks:`);
    if (svc.build) {
      const context = path.resolve(dir, typeof svc.build === 'string' ? svc.build : svc.build.context);
      if (!fs.existsSync(context)) problems.push(`${name}: build context ${context} does not exist`);
      const dockerfile = path.resolve(context, svc.build.dockerfile || 'Dockerfile');
      if (!fs.existsSync(dockerfile)) problems.push(`${name}: ${dockerfile} does not exist`);
    }
    for (const dep of Array.isArray(svc.depends_on) ? svc.depends_on : Object.keys(svc.depends_on || {})) {
      if (!doc.services[dep]) problems.push(`${name}: depends on unknown service '${dep}'`);
    }
  }
  return problems;
}

/** Host ports: `[ip:]published:target[/proto]` strings or long syntax; two services may not share one. */
function hostPorts(doc) {
  const out = [];
  for (const [name, svc] of Object.entries(doc.services || {})) {
    for (const p of svc.ports || []) {
      let ip = '0.0.0.0';
      let published;
      let protocol = 'tcp';
      if (typeof p === 'object') {
        ip = p.host_ip || ip;
        published = p.published;
        protocol = p.protocol || protocol;
      } else {
        const [spec, proto] = String(p).split('/');
        protocol = proto || protocol;
        const parts = spec.split(':');
        if (parts.length === 3) [ip, published] = parts;
        else if (parts.length === 2) [published] = parts;
      }
      if (published === undefined) continue; // a container port only: Docker picks the host port
      out.push({ service: name, ip, port: Number(published), protocol });
    }
  }
  return out;
}

function portClashes(doc) {
  const problems = [];
  const ports = hostPorts(doc);
  ports.forEach((a, i) => {
    for (const b of ports.slice(i + 1)) {
      const sameIp = a.ip === b.ip || a.ip === '0.0.0.0' || b.ip === '0.0.0.0';
      if (sameIp && a.port === b.port && a.protocol === b.protocol) problems.push(`${a.service} and ${b.service} both publish ${a.protocol} port ${a.port}`);
    }
    if (!Number.isInteger(a.port) || a.port < 1 || a.port > 65535) problems.push(`${a.service}: host port '${a.port}' is not a port`);
  });
  return problems;
}

/** Every ${VAR} that files read inside the container must be in that service's environment (a script's own variables apart). */
function unsetInContainer(svc, files) {
  const env = svc.environment || {};
  const names = Array.isArray(env) ? env.map((e) => e.split('=')[0]) : Object.keys(env);
  const missing = new Set();
  for (const file of files) {
    const text = fs.readFileSync(file, 'utf8');
    const own = new Set([...text.matchAll(/(?:^|[\s;])(?:for\s+)?([A-Za-z_][A-Za-z0-9_]*)(?:=|\s+in\s)/gm)].map((m) => m[1]));
    for (const v of varsIn(text)) if (!names.includes(v) && !own.has(v)) missing.add(`${v} (${rel(file)})`);
  }
  return [...missing];
}

// ---- SQL identifiers of the dashboards ----

const SQL_KEYWORDS = new Set(`select from where and or not in as order by group desc asc limit sample align to calendar fill
  null prev linear none case when then else end is like ilike between distinct latest on partition true false cast
  join left inner cross asof lt splice with union all having offset timestamp`.split(/\s+/));

/**
 * Tables and columns a QuestDB query names, by a plain tokenizer rather than a
 * parser: Grafana's macros are replaced first ($__timeFilter(col) keeps its
 * column), then strings and Grafana's variables by empty strings; numbers (1h, 1000) are
 * dropped, a word before `(` is a function, a word after AS an alias, a word
 * after FROM/JOIN a table, a keyword nothing; every other word is a column.
 * `timestamp` is both a keyword (CAST ... AS timestamp) and QuestDB's
 * designated timestamp column: it is counted as a column unless after AS.
 */
function sqlIdentifiers(sql) {
  const text = sql
    .replace(/\$__timeFilter\(\s*([A-Za-z_][A-Za-z0-9_]*)\s*\)/g, '$1 >= 0')
    .replace(/\$__(sampleByInterval|fromTime|toTime)\b/g, (m, k) => (k === 'sampleByInterval' ? '1h' : '0'))
    .replace(/'(?:[^']|'')*'/g, "''") // a variable inside a string stays in the string
    .replace(/\$\{[^}]+\}|\$[A-Za-z_][A-Za-z0-9_]*/g, "''");
  const tokens = [...text.matchAll(/'(?:[^']|'')*'|"[^"]*"|\d[\w.]*|[A-Za-z_][A-Za-z0-9_]*|\S/g)].map((m) => m[0]);
  const tables = [];
  const columnsNamed = [];
  const aliases = new Set();
  tokens.forEach((tok, i) => {
    const prev = (tokens[i - 1] || '').toLowerCase();
    if (/^["']/.test(tok) || /^\d/.test(tok) || !/^[A-Za-z_]/.test(tok)) {
      if (tok.startsWith('"') && prev === 'as') aliases.add(tok.slice(1, -1));
      return;
    }
    const lower = tok.toLowerCase();
    if (prev === 'as') aliases.add(tok);
    else if (prev === 'from' || prev === 'join') tables.push(tok);
    else if (tokens[i + 1] === '(') return; // a function
    else if (lower === 'timestamp' || !SQL_KEYWORDS.has(lower)) columnsNamed.push(tok);
  });
  return { tables, columns: columnsNamed.filter((c) => !aliases.has(c)) };
}

/** What is wrong with a query against the journal's columns(): unknown tables or columns. */
function checkQuery(sql, schema = columns()) {
  const { tables, columns: named } = sqlIdentifiers(sql);
  const problems = [];
  if (tables.length === 0) problems.push('names no table');
  for (const t of tables) if (!schema[t]) problems.push(`unknown table ${t}`);
  const known = new Set(tables.flatMap((t) => schema[t] || []));
  for (const c of named) if (!known.has(c)) problems.push(`unknown column ${c} (tables: ${tables.join(', ')})`);
  return problems;
}

function dashboardQueries(dashboard) {
  const out = [];
  const walk = (panels) => {
    for (const p of panels || []) {
      for (const t of p.targets || []) out.push({ where: `panel '${p.title}' ${t.refId}`, sql: t.rawSql, datasource: t.datasource || p.datasource });
      walk(p.panels);
    }
  };
  walk(dashboard.panels);
  for (const v of (dashboard.templating && dashboard.templating.list) || []) {
    if (v.type === 'query') out.push({ where: `variable ${v.name}`, sql: v.query.rawSql || v.query, datasource: v.datasource });
  }
  return out;
}

// ---- the tests ----

describe('deployment recipe (deploy/)', function () {
  describe('(a) Compose files', function () {
    // The schema is draft 2019-09 with draft-04 style `id`s, which Ajv reserves: they only
    // name their own place (every $ref is from the root), so they are dropped. `expose` is
    // a format of Compose's own.
    const schema = JSON.parse(fs.readFileSync(path.join(ROOT, 'tests', 'fixtures', 'compose-spec.json'), 'utf8'), (k, v) => (k === 'id' && typeof v === 'string' ? undefined : v));
    const ajv = new Ajv2019({ strict: false, allErrors: true, formats: { expose: true } });
    const validate = ajv.compile(schema);

    it('the schema refuses what Compose refuses (an unknown service key, a service with neither image nor build)', function () {
      assert.strictEqual(validate({ services: { a: { image: 'x', imagee: 'y' } } }), false);
      assert.strictEqual(validate({ services: { a: { image: 'x' } } }), true);
      assert.strictEqual(validate({ services: { a: { image: 'x', ports: [{ target: 80, published: 8080, hostip: '1' }] } } }), false);
    });

    for (const file of COMPOSE_FILES) {
      describe(rel(file), function () {
        const { text, env, raw, doc } = loadCompose(file);

        it('is valid against the compose-spec schema, before and after interpolation', function () {
          for (const d of [raw, doc]) assert.ok(validate(d), ajv.errorsText(validate.errors, { separator: '\n' }));
        });

        it('declares every named volume and network its services use; its bind mounts and build files exist', function () {
          assert.deepStrictEqual(checkReferences(doc, path.dirname(file)), []);
        });

        it('names in .env.example every variable it uses, and nothing it does not', function () {
          const used = varsIn(text);
          const missing = [...used].filter((v) => !(v in env));
          const stale = Object.keys(env).filter((v) => !used.has(v));
          assert.deepStrictEqual({ missing, stale }, { missing: [], stale: [] });
        });

        it('publishes no host port twice, every one a port number', function () {
          assert.ok(hostPorts(doc).length > 0);
          assert.deepStrictEqual(portClashes(doc), []);
        });

        it('keeps its data in named volumes (the broker, the database, Node-RED\'s user dir, Grafana)', function () {
          const wants = {
            'node-red': '/data', 'node-red-a': '/data', 'node-red-b': '/data', mosquitto: '/mosquitto/data', questdb: '/var/lib/questdb', grafana: '/var/lib/grafana',
          };
          for (const [svc, target] of Object.entries(wants)) {
            if (!doc.services[svc]) continue;
            const vol = doc.services[svc].volumes.find((v) => v.split(':')[1] === target);
            assert.ok(vol && isNamedVolume(vol.split(':')[0]), `${svc} keeps ${target} in a named volume`);
          }
        });

        it('sets in each container every ${VAR} its flows and provisioning files read', function () {
          const s = doc.services;
          for (const name of ['node-red', 'node-red-a', 'node-red-b'].filter((n) => s[n])) {
            assert.deepStrictEqual(unsetInContainer(s[name], [deployFlows.OUT.flows, deployFlows.OUT.credentials]), []);
          }
          if (s.grafana) {
            const prov = path.join(DEPLOY, 'grafana', 'provisioning');
            const files = fs.readdirSync(prov, { recursive: true }).map((f) => path.join(prov, f)).filter((f) => f.endsWith('.yaml'));
            assert.deepStrictEqual(unsetInContainer(s.grafana, files), []);
          }
          const entrypoint = fs.existsSync(path.join(path.dirname(file), 'mosquitto-entrypoint.sh')) ? path.join(path.dirname(file), 'mosquitto-entrypoint.sh') : path.join(DEPLOY, 'mosquitto', 'entrypoint.sh');
          if (s.mosquitto) assert.deepStrictEqual(unsetInContainer(s.mosquitto, [entrypoint]).filter((v) => !v.startsWith('passwd')), []);
        });
      });
    }

    it('the checks find an undeclared volume, a missing bind mount, an unknown network and a port clash', function () {
      const doc = {
        services: {
          a: { image: 'x', volumes: ['data:/d', './nowhere.conf:/c'], networks: ['back'], ports: ['1883:1883'] },
          b: { image: 'y', ports: ['127.0.0.1:1883:1884'] },
        },
      };
      assert.deepStrictEqual(checkReferences(doc, DEPLOY), [
        "a: volume 'data' is not declared under volumes:",
        'a: bind mount source ./nowhere.conf does not exist',
        "a: network 'back' is not declared under networks:",
      ]);
      assert.deepStrictEqual(portClashes(doc), ['a and b both publish tcp port 1883']);
      assert.deepStrictEqual(portClashes({ services: { a: { ports: ['127.0.0.1:9000:9000'] }, b: { ports: ['10.0.0.1:9000:9000'] } } }), []);
    });

    it('interpolates as Compose does: defaults, required variables, $$', function () {
      assert.strictEqual(interpolate('${A:-x} ${B-y} $$C ${D}', { B: '', D: 'd' }), 'x  $C d');
      assert.throws(() => interpolate('${A:?set A}', { A: '' }), /A is required: set A/);
      assert.deepStrictEqual([...varsIn('$$X ${Y:?e} $Z')], ['Y', 'Z']);
    });

    it('the edge sends the journal where its environment says, the single host to its own QuestDB', function () {
      const single = loadCompose(COMPOSE_FILES[0]).doc.services['node-red'].environment;
      assert.strictEqual(single.SUGARSHACK_DB_HOST, 'questdb');
      const edge = loadCompose(COMPOSE_FILES[1]);
      assert.strictEqual(edge.doc.services['node-red'].environment.SUGARSHACK_DB_HOST, edge.env.SUGARSHACK_DB_HOST);
      assert.ok(!edge.doc.services.questdb, 'the edge runs no database');
      assert.throws(() => interpolate(edge.text, { ...edge.env, SUGARSHACK_PLANT_ID: '' }), /SUGARSHACK_PLANT_ID is required/);
      const cloud = loadCompose(COMPOSE_FILES[2]).doc.services;
      assert.deepStrictEqual(Object.keys(cloud).sort(), ['grafana', 'questdb', 'questdb-schema']);
    });

    it('the container flows are the case study with a journal to ${SUGARSHACK_DB_HOST}, tagged ${SUGARSHACK_PLANT_ID}', function () {
      const source = JSON.parse(fs.readFileSync(path.join(ROOT, 'flows', 'case-study.json'), 'utf8'));
      const built = deployFlows.build(source);
      assert.deepStrictEqual(JSON.parse(fs.readFileSync(deployFlows.OUT.flows, 'utf8')), built.flows, 'run node scripts/deploy-flows.js');
      assert.deepStrictEqual(JSON.parse(fs.readFileSync(deployFlows.OUT.credentials, 'utf8')), built.credentials, 'run node scripts/deploy-flows.js');
      const journal = built.flows.filter((n) => n.type === 'sugarshack-journal');
      assert.strictEqual(journal.length, 1);
      assert.strictEqual(journal[0].target, 'http');
      assert.strictEqual(journal[0].host, '${SUGARSHACK_DB_HOST}');
      assert.strictEqual(journal[0].plantId, '${SUGARSHACK_PLANT_ID}');
      assert.strictEqual(built.flows.length, source.length + 4);
      for (const b of built.flows.filter((n) => n.type === 'mqtt-broker')) assert.strictEqual(built.credentials[b.id].user, '${MQTT_USER}');
    });
  });

  describe('(b) Grafana dashboards against the journal\'s schema', function () {
    const dir = path.join(DEPLOY, 'grafana', 'dashboards');
    const dashboards = fs.readdirSync(dir).filter((f) => f.endsWith('.json')).map((f) => ({ file: f, json: JSON.parse(fs.readFileSync(path.join(dir, f), 'utf8')) }));
    const provisioned = YAML.parse(fs.readFileSync(path.join(DEPLOY, 'grafana', 'provisioning', 'datasources', 'questdb.yaml'), 'utf8')).datasources[0];

    it('the extraction finds tables, columns, functions, aliases and macros as documented', function () {
      const got = sqlIdentifiers(`SELECT timestamp AS time, subject AS device, avg(value_ms) AS "tof"
        FROM sugarshack_timing WHERE $__timeFilter(timestamp) AND plant IN (\${plant:singlequote}) AND series = 'tof'
        SAMPLE BY $__sampleByInterval ALIGN TO CALENDAR ORDER BY device`);
      assert.deepStrictEqual(got, { tables: ['sugarshack_timing'], columns: ['timestamp', 'subject', 'value_ms', 'timestamp', 'plant', 'series'] });
      assert.deepStrictEqual(checkQuery('SELECT timestamp, valu FROM sugarshack_datapoint'), ['unknown column valu (tables: sugarshack_datapoint)']);
      assert.deepStrictEqual(checkQuery('SELECT kind FROM sugarshack_events'), ['unknown table sugarshack_events', 'unknown column kind (tables: sugarshack_events)']);
      assert.deepStrictEqual(checkQuery("SELECT value_ms FROM sugarshack_event WHERE layer = 'x'"), ['unknown column value_ms (tables: sugarshack_event)']);
    });

    it('there are dashboards for the lines, the alarms and Figs. 11-15, with distinct uids', function () {
      assert.deepStrictEqual(dashboards.map((d) => d.json.uid).sort(), ['sugarshack-alarms', 'sugarshack-lines', 'sugarshack-timing']);
      const titles = dashboards.flatMap((d) => d.json.panels.map((p) => p.title)).join('\n');
      for (const fig of [11, 12, 13, 14, 15]) assert.match(titles, new RegExp(`Fig\\. ${fig}:`));
      const timing = dashboards.find((d) => d.json.uid === 'sugarshack-timing').json;
      for (const p of timing.panels.filter((x) => /^Fig\./.test(x.title))) assert.match(p.targets[0].rawSql, /FROM sugarshack_timing/);
    });

    for (const { file, json } of dashboards) {
      it(`${file}: every query names only the journal's tables and columns, on the provisioned datasource, filtered by plant`, function () {
        const queries = dashboardQueries(json);
        assert.ok(queries.length >= 4, `${file} has ${queries.length} queries`);
        const problems = [];
        for (const q of queries) {
          for (const p of checkQuery(q.sql)) problems.push(`${q.where}: ${p}`);
          if (!q.datasource || q.datasource.uid !== provisioned.uid || q.datasource.type !== provisioned.type) problems.push(`${q.where}: not on datasource ${provisioned.uid}`);
          if (!q.where.startsWith('variable') && !/plant IN \(\$\{plant:singlequote\}\)/.test(q.sql)) problems.push(`${q.where}: not filtered by the plant variable`);
          if (!q.where.startsWith('variable') && !/\$__timeFilter\(timestamp\)/.test(q.sql)) problems.push(`${q.where}: not limited to the dashboard's time range`);
        }
        assert.deepStrictEqual(problems, []);
      });
    }
  });

  describe('(d) QuestDB\'s tables deduplicate on (timestamp, writer, seq)', function () {
    const SCHEMA_SH = path.join(DEPLOY, 'questdb', 'schema.sh');
    const statements = () => fs.readFileSync(deployFlows.OUT.schema, 'utf8').split('\n').filter((l) => l && !l.startsWith('--'));

    it('the committed statements are the journal\'s schema\'s: every table with every column, deduplicated', function () {
      assert.strictEqual(fs.readFileSync(deployFlows.OUT.schema, 'utf8'), deployFlows.schemaSql(), 'run node scripts/deploy-flows.js');
      const all = statements();
      for (const table of Object.values(TABLES)) {
        const create = all.find((st) => st.startsWith(`CREATE TABLE IF NOT EXISTS ${table.name} (`));
        assert.ok(create, table.name);
        const cols = /\((.*)\) TIMESTAMP\(timestamp\)/.exec(create)[1].split(', ').map((c) => c.split(' ')[0]);
        assert.deepStrictEqual(cols.sort(), [...columns()[table.name]].sort());
        assert.match(create, / WAL DEDUP UPSERT KEYS\(timestamp, writer, seq\);$/);
        // A table the line protocol created before (no writer column, no deduplication) is brought up to it.
        assert.ok(all.includes(`ALTER TABLE ${table.name} ADD COLUMN IF NOT EXISTS writer SYMBOL;`));
        assert.ok(all.includes(`ALTER TABLE ${table.name} DEDUP ENABLE UPSERT KEYS(timestamp, writer, seq);`));
      }
    });

    it('every Compose file with QuestDB runs schema.sh with what it reads, and the single host\'s journal starts after it', function () {
      // What it reads without a default must come from the service's environment.
      const needed = [...fs.readFileSync(SCHEMA_SH, 'utf8').matchAll(/\$\{([A-Z_][A-Z0-9_]*)\}/g)].map((m) => m[1]);
      assert.deepStrictEqual([...new Set(needed)], ['QUESTDB_HOST']);
      for (const file of [COMPOSE_FILES[0], COMPOSE_FILES[2]]) {
        const svc = loadCompose(file).doc.services['questdb-schema'];
        assert.ok(svc, rel(file));
        assert.strictEqual(svc.environment.QUESTDB_HOST, 'questdb');
        assert.ok(svc.environment.QDB_HTTP_USER && svc.environment.QDB_HTTP_PASSWORD, 'QuestDB\'s HTTP login');
        assert.deepStrictEqual(svc.entrypoint, ['/bin/sh', '/schema/schema.sh']);
      }
      assert.deepStrictEqual(loadCompose(COMPOSE_FILES[0]).doc.services['node-red'].depends_on['questdb-schema'], { condition: 'service_completed_successfully' });
    });

    /** Runs schema.sh against a stand-in for QuestDB's /exec that answers 503 `downFor` times, then as `answer(query)` says. */
    async function runSchema({ downFor, answer = () => 200 }) {
      const seen = [];
      let calls = 0;
      const server = http.createServer((req, res) => {
        calls += 1;
        const query = new URL(req.url, 'http://x').searchParams.get('query');
        if (calls <= downFor) {
          res.writeHead(503).end();
          return;
        }
        seen.push({ path: new URL(req.url, 'http://x').pathname, query, auth: Buffer.from((req.headers.authorization || '').replace(/^Basic /, ''), 'base64').toString() });
        res.writeHead(answer(query), { 'Content-Type': 'application/json' }).end('{}');
      });
      await new Promise((resolve) => server.listen(0, '127.0.0.1', resolve));
      const env = {
        PATH: process.env.PATH, QUESTDB_HOST: '127.0.0.1', QUESTDB_PORT: String(server.address().port), QDB_HTTP_USER: 'journal', QDB_HTTP_PASSWORD: 'pw', QUESTDB_WAIT_S: '0',
      };
      try {
        return await new Promise((resolve) => {
          execFile('sh', [SCHEMA_SH], { env, timeout: 20000 }, (err, stdout, stderr) => resolve({ code: err ? err.code : 0, stdout, stderr, seen }));
        });
      } finally {
        server.close();
      }
    }

    it('schema.sh waits for QuestDB, then sends every statement in order as the HTTP user', async function () {
      this.timeout(30000);
      const run = await runSchema({ downFor: 2 });
      assert.strictEqual(run.code, 0, run.stderr);
      assert.deepStrictEqual(run.seen.map((q) => q.query), ['SELECT 1', ...statements()]);
      assert.ok(run.seen.every((q) => q.path === '/exec' && q.auth === 'journal:pw'));
      assert.match(run.stdout, /deduplicate on \(timestamp, writer, seq\)/);
    });

    it('schema.sh fails, naming the statement, when QuestDB refuses one', async function () {
      this.timeout(30000);
      const run = await runSchema({ downFor: 0, answer: (q) => (q.startsWith('ALTER TABLE sugarshack_event DEDUP') ? 400 : 200) });
      assert.notStrictEqual(run.code, 0);
      assert.match(run.stderr, /refused: ALTER TABLE sugarshack_event DEDUP ENABLE/);
    });
  });

  describe('(c) mosquitto.conf run by the real mosquitto', function () {
    this.timeout(20000);
    const passwd = (() => {
      try {
        return execFileSync('sh', ['-c', 'command -v mosquitto_passwd'], { encoding: 'utf8' }).trim();
      } catch {
        return '';
      }
    })();
    let broker;

    before(async function () {
      if (!findMosquitto() || !passwd) throw new Error('mosquitto and mosquitto_passwd are needed (bash scripts/setup.sh installs them)');
      const committed = fs.readFileSync(path.join(DEPLOY, 'mosquitto', 'mosquitto.conf'), 'utf8');
      broker = await startMosquitto({
        config: (port, dir) => {
          // The container's paths moved to a temporary dir, the listener to a free loopback port.
          execFileSync(passwd, ['-c', '-b', path.join(dir, 'passwd'), 'nodered', 's3cret']);
          const text = committed
            .replace(/\/mosquitto\/data\//g, `${dir}/`)
            .replace(/^listener 1883$/m, `listener ${port} 127.0.0.1`)
            .replace(/^log_dest stdout$/m, 'log_dest stderr'); // unbuffered, so the start is seen at once
          assert.notStrictEqual(text, committed);
          // Run as whoever runs the test (as root mosquitto would drop to a user that cannot read the temp dir).
          return `${text}\nuser ${require('os').userInfo().username}\n`;
        },
      });
    });

    after(async function () {
      if (broker) await broker.stop();
    });

    const connect = (opts) => new Promise((resolve) => {
      const client = mqtt.connect(broker.url, { reconnectPeriod: 0, connectTimeout: 5000, ...opts });
      client.once('connect', () => {
        client.end(true);
        resolve({ ok: true });
      });
      client.once('error', (err) => {
        client.end(true);
        resolve({ ok: false, code: err.code });
      });
    });

    it('refuses an anonymous client', async function () {
      const r = await connect({});
      assert.strictEqual(r.ok, false);
      assert.strictEqual(r.code, 5); // CONNACK 5: not authorized
    });

    it('refuses a wrong password', async function () {
      const r = await connect({ username: 'nodered', password: 'wrong' });
      assert.strictEqual(r.ok, false);
      assert.ok([4, 5].includes(r.code), `code ${r.code}`);
    });

    it('accepts the user of the password file', async function () {
      assert.deepStrictEqual(await connect({ username: 'nodered', password: 's3cret' }), { ok: true });
    });
  });
});
