// @ts-check
'use strict';
// Texts a person reads (status, errors, logs built in JS), from the catalogs in
// nodes/locales/<lang>/<node file>.json, keyed by node type as Node-RED's own
// nodes are, through RED._ with its "__name__" placeholders. Where RED._ knows
// no catalog (node-red-node-test-helper's returns the key), the en-US text is used.
//
// lib/ has no RED of its own: its texts sit under "sugarshack" in the interlock
// node set's catalog, read by namespace ("<module>/interlock:sugarshack.<key>"),
// through the RED that every node file hands to `useRED` when Node-RED loads it.
// Node-RED registers every set's catalog, enabled or not, so any node file's RED reads it.
const fs = require('fs');
const path = require('path');

const EN_US = path.join(__dirname, '..', '..', 'nodes', 'locales', 'en-US');
const SHARED_NAMESPACE = `${require('../../package.json').name}/interlock`;
const SHARED_PREFIX = 'sugarshack';
/** @type {Record<string, any> | null} */
let english = null;
/** @type {{ _?: (key: string, subs?: object) => string } | null} */
let sharedRED = null;
// Texts without placeholders, as read through sharedRED: a status reads a dozen words on every
// change, and i18next takes some 20 µs a lookup. The runtime's language is fixed once it runs.
/** @type {Map<string, string>} */
const plainTexts = new Map();

/** Every en-US catalog merged: node type (and "sugarshack" for lib/) -> its texts. */
function englishCatalog() {
  if (!english) {
    english = {};
    for (const file of fs.readdirSync(EN_US).filter((f) => f.endsWith('.json'))) {
      Object.assign(english, JSON.parse(fs.readFileSync(path.join(EN_US, file), 'utf8')));
    }
  }
  return english;
}

/** @param {string} key */
function lookup(key) {
  /** @type {any} */
  let value = englishCatalog();
  for (const part of key.split('.')) value = value && typeof value === 'object' ? value[part] : undefined;
  return typeof value === 'string' ? value : undefined;
}

/** @param {string} text @param {Record<string, any>} [subs] */
function fill(text, subs = {}) {
  // Non-greedy as i18next's, so that two placeholders may touch ("__a____b__").
  return text.replace(/__(\w+?)__/g, (whole, name) => (name in subs ? String(subs[name]) : whole));
}

/**
 * RED._ on `asked` (a full key, or "<namespace>:<full key>"); the en-US text when RED has no catalog for it.
 * @param {{ _?: (key: string, subs?: object) => string } | null | undefined} RED
 * @param {string} asked @param {string} full @param {Record<string, any>} [subs]
 */
function translate(RED, asked, full, subs) {
  const text = RED && typeof RED._ === 'function' ? RED._(asked, subs) : asked;
  if (typeof text === 'string' && text !== asked && text !== full && !text.endsWith(`:${full}`)) return text;
  const en = lookup(full);
  return en === undefined ? full : fill(en, subs);
}

/**
 * `t(key, subs)` for one node type: `t('status.waiting', { count: 2 })` reads "<type>.status.waiting".
 * @param {any} RED @param {string} type
 * @returns {(key: string, subs?: Record<string, any>) => string}
 */
function translator(RED, type) {
  return (key, subs) => translate(RED, `${type}.${key}`, `${type}.${key}`, subs);
}

/**
 * Called by every node file with its RED, so that lib/ reads its texts in the runtime's language.
 * @param {any} RED
 */
function useRED(RED) {
  if (RED !== sharedRED) plainTexts.clear();
  sharedRED = RED;
}

/**
 * A text of lib/: `text('errors.noPlant')` reads "sugarshack.errors.noPlant".
 * @param {string} key @param {Record<string, any>} [subs]
 */
function text(key, subs) {
  const known = subs === undefined ? plainTexts.get(key) : undefined;
  if (known !== undefined) return known;
  const full = `${SHARED_PREFIX}.${key}`;
  const read = translate(sharedRED, `${SHARED_NAMESPACE}:${full}`, full, subs);
  if (subs === undefined) plainTexts.set(key, read);
  return read;
}

/**
 * A text of lib/ whose key the core named (`errors.acquireTimeout`...): the
 * core lists every such key with its placeholders (the facade's
 * catalogTexts()), and the catalog tests check that list.
 * @param {string} key @param {Record<string, any>} [subs]
 */
function textOf(key, subs) {
  return text(key, subs);
}

/** A text of node type `type`'s catalog, in the runtime's language. @param {string} type @param {string} key @param {Record<string, any>} [subs] */
function typeText(type, key, subs) {
  return translator(sharedRED, type)(key, subs);
}

module.exports = { typeText, translator, useRED, text, textOf, englishCatalog, SHARED_NAMESPACE };
