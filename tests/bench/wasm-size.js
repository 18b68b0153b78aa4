#!/usr/bin/env node
'use strict';
// Where the wasm module's bytes go: the code size of every function of the
// release build (before wasm-opt, which keeps the function names), summed by
// the crate its Rust name starts with, and the largest functions. The
// shipped module is smaller (wasm-opt -Oz, no names); the shares are what
// this is for. Reads the binary itself: the code section for sizes, the
// "name" custom section for names.
//
// usage: node tests/bench/wasm-size.js [module.wasm] [--top N]

const fs = require('fs');
const path = require('path');

const ROOT = path.resolve(__dirname, '../..');
const args = process.argv.slice(2);
const topAt = args.indexOf('--top');
const TOP = topAt >= 0 ? Number(args[topAt + 1]) : 12;
const file = args.find((a, i) => !a.startsWith('--') && i !== topAt + 1)
  || path.join(process.env.CARGO_TARGET_DIR || path.join(ROOT, 'target'), 'wasm32-unknown-unknown/release/sugarshack_wasm.wasm');

class Reader {
  constructor(bytes, at = 0) {
    this.bytes = bytes;
    this.at = at;
  }
  u32() {
    let result = 0;
    let shift = 0;
    for (;;) {
      const byte = this.bytes[this.at++];
      result += (byte & 0x7f) * 2 ** shift;
      if (byte < 0x80) return result;
      shift += 7;
    }
  }
  name() {
    const length = this.u32();
    const text = this.bytes.toString('utf8', this.at, this.at + length);
    this.at += length;
    return text;
  }
}

/** Imported functions (they come first in the function index space), code sizes, and names. */
function parse(bytes) {
  if (bytes.readUInt32LE(0) !== 0x6d736100) throw new Error(`${file} is not a wasm module`);
  const r = new Reader(bytes, 8);
  let imported = 0;
  const sizes = [];
  const names = new Map();
  while (r.at < bytes.length) {
    const id = bytes[r.at++];
    const size = r.u32();
    const end = r.at + size;
    if (id === 2) {
      for (let n = r.u32(); n > 0; n--) {
        r.name();
        r.name();
        const kind = bytes[r.at++];
        if (kind === 0) { imported++; r.u32(); }
        else if (kind === 1) { r.at++; const flags = r.u32(); r.u32(); if (flags & 1) r.u32(); }
        else if (kind === 2) { const flags = r.u32(); r.u32(); if (flags & 1) r.u32(); }
        else if (kind === 3) { r.at += 2; }
        else if (kind === 4) { r.at++; r.u32(); }
      }
    } else if (id === 10) {
      for (let n = r.u32(); n > 0; n--) {
        const length = r.u32();
        sizes.push(length);
        r.at += length;
      }
    } else if (id === 0 && r.name() === 'name') {
      while (r.at < end) {
        const sub = bytes[r.at++];
        const subEnd = r.u32() + r.at;
        if (sub === 1) {
          for (let n = r.u32(); n > 0; n--) {
            const index = r.u32();
            names.set(index, r.name());
          }
        }
        r.at = subEnd;
      }
    }
    r.at = end;
  }
  return { imported, sizes, names };
}

/** The path segments of a legacy-mangled Rust symbol (`_ZN3foo3bar17h...E`), or the name as it is. */
function segments(symbol) {
  if (!symbol.startsWith('_ZN')) return [symbol];
  const out = [];
  const r = /^(\d+)/;
  let rest = symbol.slice(3);
  for (;;) {
    const m = r.exec(rest);
    if (!m) break;
    const length = Number(m[1]);
    out.push(rest.slice(m[1].length, m[1].length + length));
    rest = rest.slice(m[1].length + length);
  }
  if (out.length > 1 && /^h[0-9a-f]{16}$/.test(out[out.length - 1])) out.pop();
  return out.length ? out : [symbol];
}

/** The crate a function belongs to; generic code instantiated for a type counts for the crate it comes from. */
function crateOf(symbol) {
  if (symbol.startsWith('_R')) {
    // v0 mangling: the first crate root is `C`, an optional `s<hash>_`, then <length><name>.
    const m = /C(?:s[0-9A-Za-z]*_)?(\d+)/.exec(symbol);
    return m ? symbol.substr(m.index + m[0].length, Number(m[1])) : '(unnamed)';
  }
  // Legacy mangling writes `::` as `..` and `<` as `$LT$`.
  const first = segments(symbol)[0].replace(/^_?\$LT\$/, '');
  return first.split(/\.\.|\$/)[0] || '(unnamed)';
}

function kb(n) {
  return `${(n / 1024).toFixed(1)} KB`;
}

function main() {
  if (!fs.existsSync(file)) {
    console.error(`wasm-size: no ${file} (build it: bash scripts/build-wasm.sh)`);
    process.exit(1);
  }
  const bytes = fs.readFileSync(file);
  const { imported, sizes, names } = parse(bytes);
  const code = sizes.reduce((a, b) => a + b, 0);
  const byCrate = new Map();
  const functions = sizes.map((size, i) => {
    const name = names.get(imported + i) || `#${imported + i}`;
    const crate = crateOf(name);
    byCrate.set(crate, (byCrate.get(crate) || 0) + size);
    return { name: segments(name).join('::'), size };
  });
  console.log(`wasm size by crate: ${path.relative(ROOT, file)}, ${kb(bytes.length)} (release, before wasm-opt), of which code ${kb(code)} in ${sizes.length} functions`);
  for (const [crate, size] of [...byCrate].sort((a, b) => b[1] - a[1]).slice(0, TOP)) {
    console.log(`  ${crate.padEnd(28)} ${kb(size).padStart(10)}  ${((100 * size) / code).toFixed(1).padStart(5)} % of the code`);
  }
  console.log('  largest functions:');
  for (const f of functions.sort((a, b) => b.size - a.size).slice(0, TOP)) {
    console.log(`  ${kb(f.size).padStart(10)}  ${f.name.slice(0, 110)}`);
  }
}

main();
