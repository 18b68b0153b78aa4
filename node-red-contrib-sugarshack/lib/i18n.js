// @ts-check
'use strict';
// Texts a person reads (status, errors built in JS), from the catalogs in
// nodes/locales/<lang>/<node file>.json, keyed by node type as Node-RED's own
// nodes are, through RED._ with its "__name__" placeholders. Where RED._ knows
// no catalog (node-red-node-test-helper's returns the key), the en-US text is used.
const fs = require('fs');
const path = require('path');

const EN_US = path.join(__dirname, '..', 'nodes', 'locales', 'en-US');
let english = null;

/** Every en-US catalog merged: node type -> its texts. */
function englishCatalog() {
  if (!english) {
    english = {};
    for (const file of fs.readdirSync(EN_US).filter((f) => f.endsWith('.json'))) {
      Object.assign(english, JSON.parse(fs.readFileSync(path.join(EN_US, file), 'utf8')));
    }
  }
  return english;
}

function lookup(key) {
  let value = englishCatalog();
  for (const part of key.split('.')) value = value && typeof value === 'object' ? value[part] : undefined;
  return typeof value === 'string' ? value : undefined;
}

function fill(text, subs = {}) {
  return text.replace(/__(\w+)__/g, (whole, name) => (name in subs ? String(subs[name]) : whole));
}

/** `t(key, subs)` for one node type: `t('status.waiting', { count: 2 })` reads "<type>.status.waiting". */
function translator(RED, type) {
  return (key, subs) => {
    const full = `${type}.${key}`;
    const text = RED && typeof RED._ === 'function' ? RED._(full, subs) : full;
    if (text !== full && !text.endsWith(`:${full}`)) return text;
    const en = lookup(full);
    return en === undefined ? full : fill(en, subs);
  };
}

module.exports = { translator, englishCatalog };
