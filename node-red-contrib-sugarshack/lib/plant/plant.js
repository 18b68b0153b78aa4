// @ts-check
'use strict';
// The plant config node's document, and its validation and schema for the editor.
const fs = require('fs');
const path = require('path');
const { SugarshackError } = require('../host/errors');
const wasm = require('../wasm');

/** The plant document from the node's property: an object, or JSON text as typed in the editor. */
function plantDocument(value) {
  if (typeof value === 'string') {
    if (value.trim() === '') throw SugarshackError.of('INVALID_PLANT', 'plantEmpty');
    try {
      return JSON.parse(value);
    } catch (err) {
      throw SugarshackError.of('INVALID_PLANT', 'plantNotJson', { message: err.message });
    }
  }
  if (value && typeof value === 'object' && !Array.isArray(value)) return value;
  throw SugarshackError.of('INVALID_PLANT', 'plantNotObject');
}

/** 4000 -> "4 s", 300 -> "0.3 s". */
function seconds(ms) {
  return `${Number((ms / 1000).toFixed(3))} s`;
}

// "operations[0] (fill).steps[2]: unknown sensor 'x'" -> the path before the first ": ".
const PROBLEM = /^([A-Za-z_][\w.[\]-]*(?: \([^)]*\))?(?:[.[][\w.[\]-]*(?: \([^)]*\))?)*): ([\s\S]*)$/;

function problem(text) {
  const m = PROBLEM.exec(text);
  return m ? { path: m[1], message: m[2] } : { path: '', message: text };
}

/** The problems of an INVALID_PLANT refusal: one per line under the core's header, or the one it names. */
function problemsOf(err) {
  const text = String(err && err.message ? err.message : err);
  const lines = text.split('\n');
  if (/^invalid plant document \(\d+ problems?\):$/.test(lines[0])) return lines.slice(1).map((l) => problem(l.trim()));
  return [problem(text.replace(/^invalid plant document: /, ''))];
}

/**
 * Every problem of a plant document, as deploying it would find them: the same
 * reading as the plant node (JSON text or an object) and the core's own checks
 * (a throwaway Tracker). `{ valid, errors, warnings }`, each a list of { path, message }.
 */
function validatePlant(value) {
  let plant;
  try {
    plant = plantDocument(value);
  } catch (err) {
    return { valid: false, errors: problemsOf(err), warnings: [] };
  }
  const facade = wasm.load();
  const generation = wasm.currentGeneration();
  let tracker = null;
  try {
    tracker = new facade.Tracker(plant, 0);
    return { valid: true, errors: [], warnings: tracker.warnings().map(problem) };
  } catch (err) {
    if (wasm.isTrap(err)) {
      setImmediate(() => wasm.recover(err, generation));
      throw SugarshackError.of('INTERNAL', 'plantCheckTrapped', { message: err.message });
    }
    return { valid: false, errors: problemsOf(err), warnings: [] };
  } finally {
    wasm.release(tracker);
  }
}

/** The plant document's JSON Schema, generated from the core's types by the build; shipped in the package. */
const PLANT_SCHEMA = path.join(__dirname, '..', '..', 'schema', 'plant.schema.json');

const served = new WeakSet();

/**
 * POST /sugarshack/plant/validate { plant: JSON text or object }: what the
 * editor's plant dialog shows before a deploy (see validatePlant).
 * GET /sugarshack/plant/schema: the plant document's JSON Schema, for the
 * dialog's editor, from the package that runs (so it always matches the core).
 */
function servePlantValidation(RED) {
  if (!RED.httpAdmin || served.has(RED.httpAdmin)) return;
  served.add(RED.httpAdmin);
  const canRead = RED.auth.needsPermission('sugarshack.read');
  RED.httpAdmin.post('/sugarshack/plant/validate', canRead, (req, res) => {
    const body = req.body && typeof req.body === 'object' ? req.body : {};
    try {
      res.json(validatePlant(body.plant));
    } catch (err) {
      res.status(500).json({ code: err.code || 'INTERNAL', message: err.message });
    }
  });
  RED.httpAdmin.get('/sugarshack/plant/schema', canRead, (req, res) => {
    fs.readFile(PLANT_SCHEMA, 'utf8', (err, text) => {
      if (err) {
        const missing = SugarshackError.of('INTERNAL', 'noPlantSchema', { path: PLANT_SCHEMA });
        res.status(404).json({ code: missing.code, message: missing.message });
        return;
      }
      res.type('application/schema+json').send(text);
    });
  });
}

module.exports = { plantDocument, seconds, validatePlant, servePlantValidation, PLANT_SCHEMA };
