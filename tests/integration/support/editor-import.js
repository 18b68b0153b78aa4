'use strict';
// What Node-RED 4.1's editor does when a user imports a flow (Import >
// Examples, or pasted JSON) into the flows it shows (RED.view.importNodes and
// RED.nodes.import in @node-red/editor-client): nodes whose ids are all new go
// in as they are. When some id exists, the editor asks, and the one-click
// answer is "Import copy" (importNodes with generateIds): every tab and node
// gets a new id, and every reference follows, except that a config node whose
// id exists stays the existing one (the import uses it), and a subflow equal to
// an existing one (same name, same nodes) is not added again. The result is
// then deployed in full, as the Deploy button does.
const crypto = require('crypto');
const { isDeepStrictEqual } = require('util');

const CONTAINERS = new Set(['tab', 'subflow', 'group']);
/** A config node, as the editor's import dialog tells them apart: no tab and no place on one. */
const isConfig = (n) => !CONTAINERS.has(n.type) && !n.z && !('x' in n && 'y' in n);
const newId = () => crypto.randomBytes(8).toString('hex');

/** Every string in `value` equal to a key of `ids` replaced by its value (wires, links, scopes, config references). */
function remap(value, ids) {
  if (typeof value === 'string') {
    if (ids.has(value)) return ids.get(value);
    return value.startsWith('subflow:') && ids.has(value.slice(8)) ? `subflow:${ids.get(value.slice(8))}` : value;
  }
  if (Array.isArray(value)) return value.map((v) => remap(v, ids));
  if (value && typeof value === 'object') return Object.fromEntries(Object.entries(value).map(([k, v]) => [k, remap(v, ids)]));
  return value;
}

/**
 * The flows after importing `nodes` into `current`: `{ flows, ids, copied }`,
 * `ids` mapping each imported id to the id it has now (itself when kept),
 * `copied` whether the editor had to ask (some id existed).
 */
function importAsEditor(current, nodes) {
  const existing = new Map(current.map((n) => [n.id, n]));
  const copied = nodes.some((n) => existing.has(n.id));
  if (!copied) return { flows: [...current, ...nodes], ids: new Map(nodes.map((n) => [n.id, n.id])), copied };
  const inside = (flow, subflowId) => flow.filter((n) => n.z === subflowId);
  const sameSubflow = (sf) => existing.has(sf.id) && isDeepStrictEqual(existing.get(sf.id), sf)
    && isDeepStrictEqual(inside(current, sf.id), inside(nodes, sf.id));
  const kept = new Set();
  for (const n of nodes) {
    if (isConfig(n) && existing.has(n.id) && existing.get(n.id).type === n.type) kept.add(n.id);
    if (n.type === 'subflow' && sameSubflow(n)) {
      kept.add(n.id);
      for (const inner of inside(nodes, n.id)) kept.add(inner.id);
    }
  }
  const ids = new Map(nodes.map((n) => [n.id, kept.has(n.id) ? n.id : newId()]));
  const added = nodes.filter((n) => !kept.has(n.id)).map((n) => remap(n, ids));
  return { flows: [...current, ...added], ids, copied };
}

module.exports = { importAsEditor, isConfig };
