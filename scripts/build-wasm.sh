#!/usr/bin/env bash
# Builds the wasm facade crate and writes Node.js bindings into
# node-red-contrib-sugarshack/wasm/, and the plant document's JSON Schema
# (generated from the core's types) into node-red-contrib-sugarshack/schema/.
# Needs the tools from scripts/setup.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH="$HOME/.cargo/bin:$PATH"

out=node-red-contrib-sugarshack/wasm
want="$(sed -n 's/^wasm-bindgen *= *"=\([0-9.]*\)".*/\1/p' Cargo.toml)"
have="$(wasm-bindgen --version 2>/dev/null | cut -d' ' -f2 || true)"
if [ -n "$want" ] && [ "$have" != "$want" ]; then
  echo "build-wasm: need wasm-bindgen $want (found '${have:-none}'); run: bash scripts/setup.sh" >&2
  exit 1
fi

# opt-level 3 (the release profile): built for size ("z", "s", or "z" for the
# dependencies only), the case-study acquire+release through wasm took 1.4-1.8x
# longer for a module 7-18 % smaller after wasm-opt (tests/bench/footprint.js).
echo "build-wasm: cargo build (wasm32-unknown-unknown, release)"
cargo build -p sugarshack-wasm --target wasm32-unknown-unknown --release
built="${CARGO_TARGET_DIR:-target}/wasm32-unknown-unknown/release/sugarshack_wasm.wasm"

# Nothing to do when cargo's module is the one the bindings were last made from
# (wasm-opt alone takes a minute on a busy machine: every npm start would wait for it).
stamp="${CARGO_TARGET_DIR:-target}/wasm-bindings.sha"
source_sha="$( (sha256sum "$built"; wasm-bindgen --version; command -v wasm-opt || true) | sha256sum | cut -d' ' -f1)"
bind() {
  rm -f "$stamp"
  # wasm-opt runs before wasm-bindgen: Debian's binaryen (108) rewrites the
  # export of the externref table wasm-bindgen adds onto the function table, and
  # the module then fails to load. -Oz: size first; names and producers only
  # serve debuggers.
  if command -v wasm-opt >/dev/null; then
    # Recent rustc emits these post-MVP features by default; older binaryen rejects them unless enabled.
    if wasm-opt -Oz --strip-debug --strip-producers --enable-bulk-memory --enable-nontrapping-float-to-int \
         --enable-sign-ext --enable-mutable-globals --enable-reference-types --enable-multivalue \
         "$built" -o "$built.opt"; then
      built="$built.opt"
      echo "build-wasm: wasm-opt -Oz applied"
    else
      echo "build-wasm: wasm-opt failed; keeping the unoptimised module" >&2
    fi
  else
    echo "build-wasm: no wasm-opt on PATH (apt-get install -y binaryen, or bash scripts/setup.sh); module left unoptimised" >&2
  fi
  echo "build-wasm: wasm-bindgen --target nodejs -> $out/"
  wasm-bindgen --target nodejs --out-dir "$out" --out-name sugarshack_wasm "$built"
  local wasm="$out/sugarshack_wasm_bg.wasm"
  echo "$source_sha" >"$stamp"
  echo "build-wasm: $(du -h "$wasm" | cut -f1) $wasm"
}
if [ -f "$out/sugarshack_wasm_bg.wasm" ] && [ -f "$out/sugarshack_wasm.js" ] && [ "$(cat "$stamp" 2>/dev/null)" = "$source_sha" ]; then
  echo "build-wasm: $out/ is up to date"
else
  bind
fi

# A native build of the core with its `schema` feature, which the wasm leaves out.
schema=node-red-contrib-sugarshack/schema/plant.schema.json
echo "build-wasm: plant document schema -> $schema"
cargo run -q -p sugarshack-schema -- "$schema"
