#!/usr/bin/env bash
# Full test run: setup, rustfmt and clippy gates, Rust tests (native, doctests
# and wasm under Node), the control report, wasm build, the JS type check,
# the docs (links, site, snippets), Node-RED flow tests, integration tests
# against a real Mosquitto (and the OPC UA server against asyncua), then the
# install tests of the palette and of the OPC UA package on Node-RED 4.1 and 5.0.
# Stops at the first failing stage and prints a summary either way.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT="$PWD"
PALETTE="${PALETTE_DIR:-$ROOT/node-red-contrib-sugarshack}"

STAGES=() CURRENT="" STARTED=0 TMP=""
# Every runner's output is kept here so the summary can add up their counts.
RESULTS="$(mktemp)"
counted() { "$@" 2>&1 | tee -a "$RESULTS"; }
stage() {
  [ -n "$CURRENT" ] && STAGES+=("ok|$(( SECONDS - STARTED ))s|$CURRENT")
  CURRENT="$1" STARTED=$SECONDS
  printf '\n==== %s ====\n' "$1"
}
finish() {
  local rc=$?
  if [ -n "$CURRENT" ]; then
    if [ $rc -eq 0 ]; then STAGES+=("ok|$(( SECONDS - STARTED ))s|$CURRENT")
    else STAGES+=("FAILED|$(( SECONDS - STARTED ))s|$CURRENT"); fi
  fi
  [ -n "$TMP" ] && rm -rf "$TMP"
  local passed failed
  passed=$(sed -nE 's/^test result: .* ([0-9]+) passed.*/\1/p; s/^ *([0-9]+) passing.*/\1/p; s/^ +PASS \[.*/1/p' "$RESULTS" | awk '{ n += $1 } END { print n + 0 }')
  failed=$(sed -nE 's/^test result: .* ([0-9]+) failed.*/\1/p; s/^ *([0-9]+) failing.*/\1/p; s/^ *FAIL \[.*/1/p' "$RESULTS" | awk '{ n += $1 } END { print n + 0 }')
  rm -f "$RESULTS"
  printf '\n==== summary ====\n'
  local line
  for line in "${STAGES[@]}"; do
    IFS='|' read -r status secs name <<<"$line"
    printf '  %-8s %5s  %s\n' "$status" "$secs" "$name"
  done
  [ $rc -eq 0 ] && echo "all stages passed (${SECONDS}s)" || echo "test run FAILED (exit $rc)"
  echo "tests: ${passed:-0} passed, ${failed:-0} failed"
}
trap finish EXIT
# A run stopped by a signal failed: without these, finish sees the last command's status (0) and says all passed.
trap 'exit 143' TERM
trap 'exit 130' INT
trap 'exit 129' HUP

# Packs the palette (and the OPC UA package) once, then installs the tarballs into a fresh user dir per Node-RED version.
pack() { # <package dir>: prints the tarball's path
  local dir="$1" tarball
  [ -f "$dir/package.json" ] || { echo "no $dir/package.json" >&2; return 1; }
  tarball="$TMP/$(cd "$TMP" && npm pack --loglevel=error "$dir" | tail -n1)"
  echo "packed $(basename "$tarball") ($(tar tzf "$tarball" | wc -l) files)" >&2
  echo "$tarball"
}
palette_test() { # <label> <node binary> <node-red dir>
  local label="$1" node="$2" nrdir="$3" userdir
  [ -n "$TMP" ] || TMP="$(mktemp -d)"
  [ -n "${TARBALL:-}" ] || TARBALL="$(pack "$PALETTE")"
  userdir="$TMP/userdir-$label"
  mkdir -p "$userdir"
  echo '{"name":"node-red-project","private":true}' >"$userdir/package.json"
  (cd "$userdir" && npm install --no-audit --no-fund --loglevel=error "$TARBALL")
  # The HMI example needs FlowFuse Dashboard 2: the workspace's copy, linked (offline), as a user who installed it has it.
  [ -d "$ROOT/node_modules/@flowfuse/node-red-dashboard" ] || { echo "no @flowfuse/node-red-dashboard in $ROOT/node_modules (npm install)" >&2; return 1; }
  mkdir -p "$userdir/node_modules/@flowfuse"
  ln -s "$ROOT/node_modules/@flowfuse/node-red-dashboard" "$userdir/node_modules/@flowfuse/node-red-dashboard"
  counted node tests/palette/install-test.js --label "$label" --node "$node" \
    --red "$nrdir/red.js" --userdir "$userdir" --pkg "$PALETTE/package.json" --examples "$PALETTE/examples"
}

# The OPC UA package beside the palette, from its own tarball (node-opcua comes from the registry),
# as a user installs both from the palette manager; its example's server must start.
OPCUA="$ROOT/node-red-contrib-sugarshack-opcua"
opcua_test() { # <label> <node binary> <node-red dir>
  local label="$1" node="$2" nrdir="$3" userdir
  [ -n "$TMP" ] || TMP="$(mktemp -d)"
  [ -n "${TARBALL:-}" ] || TARBALL="$(pack "$PALETTE")"
  [ -n "${OPCUA_TARBALL:-}" ] || OPCUA_TARBALL="$(pack "$OPCUA")"
  userdir="$TMP/userdir-$label"
  mkdir -p "$userdir"
  echo '{"name":"node-red-project","private":true}' >"$userdir/package.json"
  (cd "$userdir" && npm install --no-audit --no-fund --loglevel=error "$TARBALL" "$OPCUA_TARBALL")
  counted node tests/palette/install-test.js --label "$label" --node "$node" \
    --red "$nrdir/red.js" --userdir "$userdir" --pkg "$OPCUA/package.json" --examples "$OPCUA/examples" \
    --subflows no --config-nodes no --expect-log "OPC UA server on"
}

stage "setup"
# shellcheck source=scripts/setup.sh
. scripts/setup.sh

stage "rustfmt (cargo fmt --check)"
cargo fmt --all -- --check

stage "clippy, native and wasm (warnings are errors)"
cargo clippy --workspace --all-targets -- -D warnings
cargo clippy -p sugarshack-wasm --target wasm32-unknown-unknown --all-targets -- -D warnings

stage "repetition (jscpd: no code written twice in the Rust and JS, tests included)"
npx jscpd .

stage "cargo test (sugarshack-core, plant schema, control experiments)"
counted cargo test -p sugarshack-core -p sugarshack-schema -p sugarshack-experiments

stage "doctests (the core's documented entry points)"
counted cargo test --workspace --doc

stage "control report (the paper's Tables 2-3, Figs. 11-12)"
REPORT_DIR="$(mktemp -d)"
cargo run --release -q -p sugarshack-experiments --bin control-report -- --out "$REPORT_DIR"
for figure in fig11a fig11b fig12a fig12b fig12c fig12d; do
  [ -s "$REPORT_DIR/$figure.svg" ] || { echo "control report wrote no $figure.svg" >&2; exit 1; }
done
rm -rf "$REPORT_DIR"

stage "wasm-bindgen tests under Node"
CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUNNER=wasm-bindgen-test-runner \
  counted cargo test -p sugarshack-wasm --target wasm32-unknown-unknown

stage "build wasm package"
bash scripts/build-wasm.sh

# After the build: the palette's JS is checked against the facade's generated .d.ts.
stage "typecheck (tsc --noEmit)"
npx tsc -p tsconfig.json --noEmit

# After the build: the code table is compared with the facade's, and plant snippets go through its check.
stage "docs: links and anchors, the generated code table, the site (VitePress), every snippet"
node scripts/docs/links.js
node scripts/docs/codes.js --check
node scripts/docs/plant-reference.js --check
node scripts/docs/site.js
counted npx mocha --timeout 10000 --exit 'tests/docs/**/*.spec.js'

stage "Node-RED flow tests (mocha)"
[ -n "$(find tests/flow -name '*.spec.js' 2>/dev/null | head -n1)" ] || { echo "no tests/flow/*.spec.js found" >&2; exit 1; }
counted npx mocha --timeout 10000 --exit 'tests/flow/**/*.spec.js'

stage "integration tests (Mosquitto, simulator, the OPC UA server with Python's asyncua)"
counted npx mocha --timeout 30000 --exit 'tests/integration/**/*.spec.js'

stage "browser tests (the HMI at /dashboard and the editor, in headless Chromium)"
counted npx mocha --timeout 180000 --exit 'tests/browser/**/*.spec.js'

stage "palette install: Node-RED 4.1 on Node $(node --version)"
palette_test nr4 "$(command -v node)" "$ROOT/node_modules/node-red"

stage "palette install: Node-RED 5.0 on Node $("$NODE22" --version)"
palette_test nr5 "$NODE22" "$NR5_DIR/node_modules/node-red"

stage "OPC UA package install: Node-RED 4.1 on Node $(node --version)"
opcua_test opcua-nr4 "$(command -v node)" "$ROOT/node_modules/node-red"

stage "OPC UA package install: Node-RED 5.0 on Node $("$NODE22" --version)"
opcua_test opcua-nr5 "$NODE22" "$NR5_DIR/node_modules/node-red"
