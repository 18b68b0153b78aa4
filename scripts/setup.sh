#!/usr/bin/env bash
# Installs what the build, tests and demo need; skips whatever is already there
# (the OPC UA package's node-opcua and Python's asyncua, its tests' client, among them).
# Run it (`bash scripts/setup.sh`) or source it (`. scripts/setup.sh`); when
# sourced it also leaves these variables in the caller's shell:
#   SUGARSHACK_CACHE  cache dir for the tools below (default ~/.cache/sugarshack)
#   NODE22            Node 22 binary (Node-RED 5 needs Node >= 22.9)
#   NR5_DIR           Node-RED 5.0.x install (red.js under node_modules/node-red)
#   WASM_BINDGEN_VERSION  wasm-bindgen version pinned in Cargo.toml

SUGARSHACK_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SUGARSHACK_CACHE="${SUGARSHACK_CACHE:-$HOME/.cache/sugarshack}"
NODE22="$SUGARSHACK_CACHE/node22/node_modules/node/bin/node"
NR5_DIR="$SUGARSHACK_CACHE/nr5"
# The CLI must match the crate's wasm-bindgen exactly; read the pin from Cargo.toml.
WASM_BINDGEN_VERSION="$(sed -n 's/^wasm-bindgen *= *"=\([0-9.]*\)".*/\1/p' "$SUGARSHACK_ROOT/Cargo.toml")"
WASM_BINDGEN_VERSION="${WASM_BINDGEN_VERSION:-0.2.130}"
case ":$PATH:" in *":$HOME/.cargo/bin:"*) ;; *) PATH="$HOME/.cargo/bin:$PATH" ;; esac
export SUGARSHACK_ROOT SUGARSHACK_CACHE NODE22 NR5_DIR WASM_BINDGEN_VERSION PATH

# Runs in a subshell so that `set -e` and `exit` never leak into a sourcing shell.
_sugarshack_setup() (
  set -euo pipefail
  say() { printf 'setup: %s\n' "$*"; }
  cd "$SUGARSHACK_ROOT"

  command -v cargo >/dev/null || { say "cargo not found (install rustup first)"; exit 1; }

  if rustup target list --installed | grep -qx wasm32-unknown-unknown; then
    say "rust target wasm32-unknown-unknown: present"
  else
    say "rust target wasm32-unknown-unknown: installing"
    rustup target add wasm32-unknown-unknown
  fi

  if [ "$(wasm-bindgen --version 2>/dev/null)" = "wasm-bindgen $WASM_BINDGEN_VERSION" ] &&
     command -v wasm-bindgen-test-runner >/dev/null; then
    say "wasm-bindgen-cli $WASM_BINDGEN_VERSION: present"
  else
    # No --locked: the CLI's own lockfile names crate versions the registry may lack.
    say "wasm-bindgen-cli $WASM_BINDGEN_VERSION: installing (takes a few minutes)"
    cargo install wasm-bindgen-cli --version "$WASM_BINDGEN_VERSION"
  fi

  # Root node_modules: reinstall only when the lockfile (or, without one, package.json) changed.
  local stamp=node_modules/.sugarshack-install.sha want have=""
  lockhash() { if [ -f package-lock.json ]; then sha256sum package-lock.json; else sha256sum package.json; fi | cut -d' ' -f1; }
  want="$(lockhash)"
  [ -f "$stamp" ] && have="$(cat "$stamp")"
  if [ -d node_modules ] && [ "$want" = "$have" ]; then
    say "root node_modules: up to date"
  elif [ -f package-lock.json ]; then
    say "root node_modules: npm ci"
    npm ci --no-audit --no-fund
  else
    say "root node_modules: npm install (no lockfile)"
    npm install --no-audit --no-fund
  fi
  # npm install may have written the lockfile: stamp what is on disk now.
  lockhash >"$stamp"

  # The OPC UA package's own node_modules (node-opcua), from its lockfile. Its peer, the palette,
  # is this repository's: npm would look for it in the registry, so peers are left out.
  local opcua=node-red-contrib-sugarshack-opcua ostamp ohave=""
  ostamp="$opcua/node_modules/.sugarshack-install.sha"
  want="$(sha256sum "$opcua/package-lock.json" | cut -d' ' -f1)"
  [ -f "$ostamp" ] && ohave="$(cat "$ostamp")"
  if [ -d "$opcua/node_modules" ] && [ "$want" = "$ohave" ]; then
    say "$opcua node_modules: up to date"
  else
    say "$opcua node_modules: npm ci"
    (cd "$opcua" && npm ci --no-audit --no-fund --legacy-peer-deps)
    echo "$want" >"$ostamp"
  fi

  # Python's asyncua: the independent client of the OPC UA tests.
  if python3 -c 'import asyncua' 2>/dev/null; then
    say "python asyncua: present"
  else
    say "python asyncua: pip install"
    python3 -m pip install --quiet asyncua 2>/dev/null || python3 -m pip install --quiet --break-system-packages asyncua
    python3 -c 'import asyncua' || { say "asyncua install failed"; exit 1; }
  fi

  if [[ "$("$NODE22" --version 2>/dev/null)" == v22.* ]]; then
    say "node 22: present ($("$NODE22" --version))"
  else
    say "node 22: installing npm package node@22 into $SUGARSHACK_CACHE/node22"
    mkdir -p "$SUGARSHACK_CACHE/node22"
    # The package's preinstall script fetches the platform binary; allow it explicitly.
    printf '%s\n' '{"private":true,"dependencies":{"node":"22"},"allowScripts":{"node":true}}' \
      >"$SUGARSHACK_CACHE/node22/package.json"
    (cd "$SUGARSHACK_CACHE/node22" && npm install --no-audit --no-fund)
    [[ "$("$NODE22" --version)" == v22.* ]] || { say "node 22 install failed"; exit 1; }
  fi

  local nr5ver
  nr5ver="$("$NODE22" -p 'require(process.argv[1]).version' "$NR5_DIR/node_modules/node-red/package.json" 2>/dev/null || true)"
  if [[ "$nr5ver" == 5.* ]]; then
    say "node-red 5: present ($nr5ver)"
  else
    say "node-red 5: installing node-red@~5.0.0 into $NR5_DIR"
    mkdir -p "$NR5_DIR"
    printf '%s\n' '{"private":true,"dependencies":{"node-red":"~5.0.0"}}' >"$NR5_DIR/package.json"
    # npm runs under whichever `node` is first on PATH: use Node 22 for Node-RED 5.
    (cd "$NR5_DIR" && PATH="$(dirname "$NODE22"):$PATH" npm install --no-audit --no-fund)
  fi
  # Test servers and tools from Debian, each skipped when present: Mosquitto,
  # VictoriaMetrics and etcd (the integration tests run their own; only the
  # binaries are needed), binaryen's wasm-opt (scripts/build-wasm.sh), chromium
  # (tests/browser) and socat (a pty pair stands for a Modbus RTU serial line).
  local needed=(mosquitto:mosquitto wasm-opt:binaryen victoria-metrics:victoria-metrics chromium:chromium etcd:etcd-server etcdctl:etcd-client socat:socat)
  have() { command -v "$1" >/dev/null || [ -x "/usr/sbin/$1" ] || [ -x "/usr/bin/$1" ] || { [ "$1" = chromium ] && [ -n "${CHROMIUM_BIN:-}" ]; }; }
  local missing=() entry
  for entry in "${needed[@]}"; do
    if have "${entry%%:*}"; then say "${entry%%:*}: present"; else missing+=("${entry#*:}"); fi
  done
  if [ ${#missing[@]} -gt 0 ]; then
    say "apt-get install -y ${missing[*]}"
    local sudo=()
    [ "$(id -u)" = 0 ] || sudo=(sudo)
    "${sudo[@]}" apt-get update
    "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y "${missing[@]}"
    for entry in "${needed[@]}"; do
      have "${entry%%:*}" || { say "${entry#*:} install failed"; exit 1; }
    done
  fi
  # pymodbus from PyPI (with pyserial): the independent Modbus device of tests/integration/modbus.spec.js.
  if python3 -c 'import pymodbus, serial' 2>/dev/null; then
    say "pymodbus: present ($(python3 -c 'import pymodbus; print(pymodbus.__version__)'))"
  else
    command -v python3 >/dev/null || { say "python3 not found (the Modbus tests need it)"; exit 1; }
    say "pymodbus: pip install 'pymodbus[serial]~=3.16.1'"
    python3 -m pip install --quiet 'pymodbus[serial]~=3.16.1' ||
      python3 -m pip install --quiet --user --break-system-packages 'pymodbus[serial]~=3.16.1'
  fi
  say "done"
)

# Sourced: the status of the last command becomes the status of `.`.
if [[ "${BASH_SOURCE[0]}" == "$0" ]]; then _sugarshack_setup; exit; fi
_sugarshack_setup
