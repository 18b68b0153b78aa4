#!/usr/bin/env bash
# Builds the wasm facade crate and writes Node.js bindings into
# node-red-contrib-sugarshack/wasm/. Needs the tools from scripts/setup.sh.
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

echo "build-wasm: cargo build (wasm32-unknown-unknown, release)"
cargo build -p sugarshack-wasm --target wasm32-unknown-unknown --release

echo "build-wasm: wasm-bindgen --target nodejs -> $out/"
wasm-bindgen --target nodejs --out-dir "$out" \
  "${CARGO_TARGET_DIR:-target}/wasm32-unknown-unknown/release/sugarshack_wasm.wasm"

wasm="$out/sugarshack_wasm_bg.wasm"
# Debian bookworm's binaryen (108) rewrites this module into one that loads but
# misbehaves (the flow tests fail after even `wasm-opt -O0`): older ones are skipped.
WASM_OPT_MIN=117
wasm_opt_version() { wasm-opt --version 2>/dev/null | sed -nE 's/.*version ([0-9]+).*/\1/p'; }
if command -v wasm-opt >/dev/null && [ "$(wasm_opt_version)" -lt "$WASM_OPT_MIN" ] 2>/dev/null; then
  echo "build-wasm: wasm-opt $(wasm_opt_version) is older than $WASM_OPT_MIN; keeping the unoptimised module" >&2
elif command -v wasm-opt >/dev/null; then
  # Recent rustc emits these post-MVP features by default; older binaryen rejects them unless enabled.
  if wasm-opt -O --enable-bulk-memory --enable-nontrapping-float-to-int --enable-sign-ext \
       --enable-mutable-globals --enable-reference-types --enable-multivalue \
       "$wasm" -o "$wasm.opt"; then
    mv "$wasm.opt" "$wasm"
    echo "build-wasm: wasm-opt -O applied"
  else
    rm -f "$wasm.opt"
    echo "build-wasm: wasm-opt failed; keeping the unoptimised module" >&2
  fi
fi
echo "build-wasm: $(du -h "$wasm" | cut -f1) $wasm"
