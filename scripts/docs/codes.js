'use strict';
// The error code table of docs/reference/errors.md, written from the core's
// table (rust/sugarshack-core/src/code.rs: each code's doc comment, name,
// status text and message stem, under its section), never by hand. With the
// wasm package built, the rows must equal what the facade's codes() returns.
//   node scripts/docs/codes.js          rewrites the table in the page
//   node scripts/docs/codes.js --check  exits 1 when the page differs
const fs = require('fs');
const path = require('path');
const { ROOT, read } = require('./markdown');

const SOURCE = 'rust/sugarshack-core/src/code.rs';
const PAGE = 'docs/reference/errors.md';
const BEGIN = `<!-- codes: written by scripts/docs/codes.js from ${SOURCE}; do not edit -->`;
const END = '<!-- codes: end -->';

/** The table's rows in order: `{ section, code, status, stem, means }`. */
function parseCodes(text = read(SOURCE)) {
  const body = /codes! \{\n([\s\S]*?)\n\}/.exec(text);
  if (!body) throw new Error(`${SOURCE}: no codes! { ... } table`);
  const rows = [];
  let section = '';
  let doc = [];
  for (const raw of body[1].split('\n')) {
    const line = raw.trim();
    const head = /^\/\/ -+ (.*)$/.exec(line);
    const comment = /^\/\/\/ ?(.*)$/.exec(line);
    const row = /^(\w+) = "([A-Z_]+)", "([^"]*)", "([^"]*)";$/.exec(line);
    if (head) section = head[1];
    else if (comment) doc.push(comment[1]);
    else if (row) {
      rows.push({ section, code: row[2], status: row[3], stem: row[4], means: doc.join(' ') });
      doc = [];
    } else if (line) {
      throw new Error(`${SOURCE}: cannot read this line of the code table: ${line}`);
    }
  }
  return rows;
}

const cell = (text) => text.replace(/\|/g, '\\|');

/** The markdown of the table, one part per section of the core's table. */
function codesMarkdown(rows = parseCodes()) {
  const out = [BEGIN];
  let section = null;
  for (const r of rows) {
    if (r.section !== section) {
      section = r.section;
      out.push('', `### ${section[0].toUpperCase()}${section.slice(1)}`, '', '| code | status | message stem | when |', '|---|---|---|---|');
    }
    out.push(`| \`${r.code}\` | \`${cell(r.status)}\` | ${cell(r.stem)} | ${cell(r.means)} |`);
  }
  out.push('', END);
  return out.join('\n');
}

/** The page with its table replaced by `table`. */
function withTable(page, table) {
  const from = page.indexOf(BEGIN);
  const to = page.indexOf(END);
  if (from < 0 || to < from) throw new Error(`${PAGE} has no ${BEGIN} ... ${END} block for the table`);
  return page.slice(0, from) + table + page.slice(to + END.length);
}

/** The rows against the built facade's codes(), when the wasm package is there. */
function facadeDisagreement(rows) {
  const wasm = path.join(ROOT, 'node-red-contrib-sugarshack', 'wasm', 'sugarshack_wasm.js');
  if (!fs.existsSync(wasm)) return null;
  const facade = require(wasm).codes().map((c) => `${c.code}|${c.status}|${c.stem}`);
  const parsed = rows.map((r) => `${r.code}|${r.status}|${r.stem}`);
  return JSON.stringify(facade) === JSON.stringify(parsed) ? null
    : `the rows read from ${SOURCE} differ from the facade's codes(): rebuild the wasm (npm run build) or fix scripts/docs/codes.js`;
}

if (require.main === module) {
  const rows = parseCodes();
  const disagreement = facadeDisagreement(rows);
  if (disagreement) {
    console.error(`codes: ${disagreement}`);
    process.exit(1);
  }
  const page = read(PAGE);
  const want = withTable(page, codesMarkdown(rows));
  if (process.argv.includes('--check')) {
    if (want !== page) {
      console.error(`codes: ${PAGE} does not hold the core's code table as written now: run node scripts/docs/codes.js`);
      process.exit(1);
    }
    console.log(`codes: ${PAGE} holds the core's ${rows.length} codes`);
  } else {
    fs.writeFileSync(path.join(ROOT, PAGE), want);
    console.log(`codes: wrote ${rows.length} codes into ${PAGE}`);
  }
}

module.exports = { parseCodes, codesMarkdown, withTable };
