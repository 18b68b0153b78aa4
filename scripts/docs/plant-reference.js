#!/usr/bin/env node
'use strict';
// Writes the plant document's reference (Markdown) from its JSON Schema, which
// the build generates from the core's types (their doc comments are its
// descriptions): one table of the document's keys, then one section per part
// (actuator type, device, actuator...) in the order the document uses them.
// Nothing in it is written by hand, so it cannot drift from what the core reads.
//
// usage: node scripts/docs/plant-reference.js [<out.md>] [--schema <plant.schema.json>] [--check]
//        (out defaults to docs/reference/plant-keys.md; the schema to the
//        palette's, written by scripts/build-wasm.sh; --check exits 1 when the
//        page differs from what the schema gives, as in npm test)

const fs = require('fs');
const path = require('path');

const ROOT = path.join(__dirname, '..', '..');
const DEFAULT_SCHEMA = path.join(ROOT, 'node-red-contrib-sugarshack', 'schema', 'plant.schema.json');
const DEFAULT_PAGE = path.join(ROOT, 'docs', 'reference', 'plant-keys.md');

/** The definition a schema names by $ref (directly, or as its one allOf), or null. */
function refName(schema) {
  const ref = schema.$ref || (Array.isArray(schema.allOf) && schema.allOf.length === 1 && schema.allOf[0].$ref);
  return ref ? ref.split('/').pop() : null;
}

/** The schemas of a value besides null (null reads as the key left out). */
function nonNull(schema) {
  const options = schema.anyOf || schema.oneOf;
  if (options && options.some((o) => o.type === 'null')) return options.filter((o) => o.type !== 'null');
  return [schema];
}

const anchor = (name) => name.toLowerCase();

/** A value's type in words, with links to the parts it is made of. */
function typeOf(schema) {
  const name = refName(schema);
  if (name) return `[${name}](#${anchor(name)})`;
  const options = nonNull(schema);
  if (options.length !== 1 || options[0] !== schema) return options.map(typeOf).join(' or ');
  if (schema.const !== undefined) return `\`${JSON.stringify(schema.const)}\``;
  const types = [].concat(schema.type || []).filter((t) => t !== 'null');
  if (types.length === 0) return 'any';
  return types.map((type) => {
    if (type === 'array') return `list of ${typeOf(schema.items || {})}`;
    if (type === 'object' && schema.additionalProperties && typeof schema.additionalProperties === 'object') {
      return `object: name → ${typeOf(schema.additionalProperties)}`;
    }
    if ((type === 'number' || type === 'integer') && schema.minimum === 0) return `${type} ≥ 0`;
    return type;
  }).join(' or ');
}

/** Text for a table cell: one line, its pipes escaped. */
const cell = (text) => String(text || '').replace(/\n+/g, ' ').replace(/\|/g, '\\|');
const describe = (schema) => schema.markdownDescription || schema.description || '';

/** The table of an object's keys: key, type, required or default, meaning. */
function keyTable(schema) {
  const required = new Set(schema.required || []);
  const rows = Object.entries(schema.properties || {}).map(([key, value]) => {
    const need = required.has(key) ? 'required' : (value.default !== undefined ? `default \`${JSON.stringify(value.default)}\`` : 'optional');
    return `| \`${key}\` | ${cell(typeOf(value))} | ${need} | ${cell(describe(value))} |`;
  });
  const extra = schema.additionalProperties === false ? '' : '\n\nOther keys are allowed.';
  return ['| Key | Type | | Meaning |', '| --- | --- | --- | --- |', ...rows].join('\n') + extra;
}

/** The Markdown of one part: its description, then its keys, its forms or its values. */
function section(name, schema) {
  const lines = [`## ${name}`, '', describe(schema)];
  const forms = schema.anyOf || schema.oneOf;
  if (forms && forms.every((f) => f.const !== undefined)) {
    lines.push('', 'One of:', '', ...forms.map((f) => `- \`${JSON.stringify(f.const)}\`: ${describe(f)}`));
  } else if (forms) {
    lines.push('', 'It takes one of these forms (and no other key):');
    forms.forEach((form) => lines.push('', `- ${describe(form)}`, '', keyTable(form).replace(/^/gm, '  ')));
  } else if (schema.properties) {
    lines.push('', keyTable(schema));
  } else {
    lines.push('', `Type: ${typeOf(schema)}.`);
  }
  return lines.join('\n');
}

/** The definitions in the order the document first uses them (depth first). */
function definitionOrder(schema) {
  const order = [];
  const visit = (node) => {
    if (!node || typeof node !== 'object') return;
    if (Array.isArray(node)) { node.forEach(visit); return; }
    const name = node.$ref && node.$ref.split('/').pop();
    if (name && !order.includes(name)) {
      order.push(name);
      visit(schema.definitions[name]);
    }
    for (const [key, value] of Object.entries(node)) if (key !== 'definitions') visit(value);
  };
  visit(schema);
  return order.concat(Object.keys(schema.definitions || {}).filter((name) => !order.includes(name)));
}

/** The reference as Markdown. */
function plantReference(schema) {
  const parts = [
    '# The plant document, key by key',
    '',
    '<!-- Generated by scripts/docs/plant-reference.js from the JSON Schema the build generates from the core\'s types (rust/sugarshack-core/src/plant/). Do not edit. -->',
    '',
    describe(schema),
    '',
    'An editor that reads JSON Schema (VS Code, the plant dialog) proposes these keys and values and marks a wrong one as you type; '
      + 'the schema ships in the palette as `schema/plant.schema.json`. The plant check then checks what a schema cannot: '
      + 'that names refer to things the document defines, ranges, timings and the interlock\'s rules.',
    '',
    '## The document',
    '',
    keyTable(schema),
  ];
  for (const name of definitionOrder(schema)) parts.push('', section(name, schema.definitions[name]));
  return `${parts.join('\n')}\n`;
}

function main(argv) {
  const args = argv.slice(2);
  const check = args.includes('--check');
  if (check) args.splice(args.indexOf('--check'), 1);
  const at = args.indexOf('--schema');
  const schemaFile = at === -1 ? DEFAULT_SCHEMA : args.splice(at, 2)[1];
  const [out = DEFAULT_PAGE] = args;
  if (!schemaFile) {
    console.error('usage: node scripts/docs/plant-reference.js [<out.md>] [--schema <plant.schema.json>] [--check]');
    return 2;
  }
  if (!fs.existsSync(schemaFile)) {
    console.error(`plant-reference: no schema at ${schemaFile} (it is built by: npm run build)`);
    return 1;
  }
  const markdown = plantReference(JSON.parse(fs.readFileSync(schemaFile, 'utf8')));
  if (check) {
    const written = fs.existsSync(out) ? fs.readFileSync(out, 'utf8') : null;
    if (written !== markdown) {
      console.error(`plant-reference: ${path.relative(ROOT, path.resolve(out))} is not what the plant schema gives now: run node scripts/docs/plant-reference.js`);
      return 1;
    }
    console.log(`plant-reference: ${path.relative(ROOT, path.resolve(out))} matches the plant schema`);
    return 0;
  }
  fs.mkdirSync(path.dirname(path.resolve(out)), { recursive: true });
  fs.writeFileSync(out, markdown);
  console.log(`plant-reference: ${out} (${markdown.length} characters)`);
  return 0;
}

if (require.main === module) process.exitCode = main(process.argv);

module.exports = { plantReference };
