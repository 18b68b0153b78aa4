'use strict';
// Every text key the nodes and their editor dialogs use has its en-US text, in
// the catalog Node-RED loads for that node file (nodes/locales/en-US/<file>.json).
const assert = require('node:assert/strict');
const fs = require('fs');
const path = require('path');
const { PALETTE } = require('./support');

const NODES = path.join(PALETTE, 'nodes');
const catalogOf = (stem) => {
  const file = path.join(NODES, 'locales', 'en-US', `${stem}.json`);
  return fs.existsSync(file) ? JSON.parse(fs.readFileSync(file, 'utf8')) : {};
};
const textAt = (catalog, key) => key.split('.').reduce((v, part) => (v && typeof v === 'object' ? v[part] : undefined), catalog);
const stems = (ext) => fs.readdirSync(NODES).filter((f) => f.endsWith(ext)).map((f) => f.slice(0, -ext.length));

describe('i18n catalogs', function () {
  it('hold every key a node file reads through RED._', function () {
    const missing = [];
    let keys = 0;
    for (const stem of stems('.js')) {
      const source = fs.readFileSync(path.join(NODES, `${stem}.js`), 'utf8');
      const type = /translator\(RED, '([^']+)'\)/.exec(source);
      if (!type) continue;
      for (const [, key] of source.matchAll(/\bt\('([\w.]+)'/g)) {
        keys++;
        if (typeof textAt(catalogOf(stem), `${type[1]}.${key}`) !== 'string') missing.push(`${stem}.js: ${type[1]}.${key}`);
      }
    }
    assert.ok(keys > 30, `${keys} keys`);
    assert.deepEqual(missing, []);
  });

  it('hold every label and palette name an editor dialog reads', function () {
    const missing = [];
    let keys = 0;
    for (const stem of stems('.html')) {
      const source = fs.readFileSync(path.join(NODES, `${stem}.html`), 'utf8');
      // A node resources/editor.js registers with its dialog reads these for its type.
      const made = [...source.matchAll(/sugarshackEditor\.operationNode\('([\w-]+)'\)/g)]
        .flatMap(([, verb]) => ['paletteLabel', 'label.interlock', 'label.operation'].map((key) => `sugarshack-${verb}.${key}`));
      const read = [...source.matchAll(/data-i18n="([^"]+)"|this\._\('([^']+)'\)/g)].map((m) => m[1] || m[2]);
      for (const key of [...made, ...read]) {
        if (key.startsWith('node-red:')) continue;
        keys++;
        if (typeof textAt(catalogOf(stem), key) !== 'string') missing.push(`${stem}.html: ${key}`);
      }
    }
    assert.ok(keys > 80, `${keys} keys`);
    assert.deepEqual(missing, []);
  });
});
