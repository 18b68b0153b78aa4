#!/usr/bin/env bash
# Runs the palette in a local Node-RED 4.1 with an MQTT broker and the plant simulator.
set -euo pipefail

usage() {
  cat <<'EOF'
usage: npm start [-- options]        (or: bash scripts/start.sh [options])

Runs an MQTT broker (aedes), the plant simulator and Node-RED with the palette:
the editor at http://127.0.0.1:1880/, the HMI at http://127.0.0.1:1880/dashboard.

Which plant:
  (none)              the case study: the simulator plays flows/plant.json, Node-RED
                      runs the flows of flows/*.json and the control examples
                      (pid-loop, rcc-failover, modbus-pid-loop); its run directory is .run/
  --plant FILE        your own plant, FILE its plant document (JSON): checked first (as a
                      deploy would; nothing starts while it has a problem), the simulator
                      plays its devices, Node-RED runs its flows; its run directory is
                      .run/plants/<name>/ (<name>: FILE's name without .json), so the case
                      study and each plant keep their own flows. A plant without flows
                      there gets starter flows made from FILE: its field bus, the interlock
                      on its lines, a start for every operation, its routines, simulator
                      faults and clears, and the HMI. Later changes to FILE reach the flows'
                      plant node at the next start unless it was changed in the editor.
                      Same as SUGARSHACK_PLANT=FILE.
  --check             check the plant document (FILE, or flows/plant.json) and exit:
                      every problem with its path, exit status 1 if a deploy would refuse it

Flows and state (in the run directory):
  --reset-flows       replace the user dir's flows.json: from flows/*.json for the case
                      study, starter flows from FILE for --plant
  --fresh             start from a clean state: flows reset, the saved interlock state
                      (faulted lines, routines) and context removed

Beside either plant the simulator also plays the example rig (flows/example-rig.json),
the devices the palette's examples drive, and the Modbus/TCP flow loop of the
modbus-pid-loop example (127.0.0.1:5502): import an example, it works.

A run directory holds userdir/ (Node-RED's: flows.json, settings.js, context, saved
interlock state), logs/ (broker.log, simulator.log, simulator-rig.log) and journal/.

Environment:
  PORT                Node-RED's port (default 1880)
  HOST                its interface (default 127.0.0.1; 0.0.0.0 for every interface)
  MQTT_PORT           the embedded broker's port (default 1883); seeded flows use it
  MQTT_URL            a broker of your own instead of the embedded one
  SIM=0               no simulator (real devices on the broker)
  SIM_ARGS            extra simulator flags, e.g. "--sweep-s 1 --fault stuck:V101"
  PROFILE             the case study's devices and its plant node all speak this profile:
                      esphome, tasmota, shelly-gen2, sugarshack or modbus (default: each
                      device's own in flows/plant.json, ESPHome); not with --plant
  JOURNAL=0           no journal; SUGARSHACK_JOURNAL_DIR to put it elsewhere
  SUGARSHACK_PLANT    the plant document, as --plant
  SUGARSHACK_RUN_DIR  where run directories go (default .run)
EOF
}

# A relative --plant is the caller's: npm runs this script from the package root
# and leaves the directory it was called from in INIT_CWD.
CALLER_DIR="${INIT_CWD:-$PWD}"
cd "$(dirname "$0")/.."
ROOT="$PWD"
PALETTE="$ROOT/node-red-contrib-sugarshack"
PORT="${PORT:-1880}"
HOST="${HOST:-127.0.0.1}"
PLANT_FILE="${SUGARSHACK_PLANT:-}"
RESET_FLOWS=0
FRESH=0
CHECK=0
say() { printf 'start: %s\n' "$*"; }
die() { printf 'start: %s\n' "$*" >&2; exit 2; }
while [ $# -gt 0 ]; do
  case "$1" in
    --reset-flows) RESET_FLOWS=1 ;;
    --fresh) FRESH=1 RESET_FLOWS=1 ;;
    --check) CHECK=1 ;;
    --plant) [ $# -ge 2 ] || die "--plant needs a file"; PLANT_FILE="$2"; shift ;;
    --plant=*) PLANT_FILE="${1#--plant=}" ;;
    -h|--help) usage; exit 0 ;;
    *) die "unknown option $1 (npm start -- --help)" ;;
  esac
  shift
done

RUN_BASE="${SUGARSHACK_RUN_DIR:-$ROOT/.run}"
if [ -n "$PLANT_FILE" ]; then
  case "$PLANT_FILE" in /*) ;; *) PLANT_FILE="$CALLER_DIR/$PLANT_FILE" ;; esac
  [ -f "$PLANT_FILE" ] || die "no plant document at $PLANT_FILE"
  PLANT_NAME="$(basename "$PLANT_FILE" .json | tr -c 'A-Za-z0-9._\n-' '-')"
  RUN="$RUN_BASE/plants/$PLANT_NAME"
else
  PLANT_FILE="$ROOT/flows/plant.json"
  PLANT_NAME=""
  RUN="$RUN_BASE"
fi
USERDIR="$RUN/userdir"
LOGS="$RUN/logs"

# Background processes started before Node-RED; stopped when Node-RED exits.
PIDS=()

# Local path install: npm links the package, so edits to its files are live;
# reinstall only when its package.json changes.
install_palette() {
  mkdir -p "$USERDIR"
  [ -f "$USERDIR/package.json" ] || echo '{"name":"node-red-project","private":true}' >"$USERDIR/package.json"
  local stamp="$USERDIR/.palette-install.sha" want
  want="$( (echo "$PALETTE"; cat "$PALETTE/package.json" "$ROOT/node_modules/@flowfuse/node-red-dashboard/package.json") | sha256sum | cut -d' ' -f1)"
  if [ -e "$USERDIR/node_modules/node-red-contrib-sugarshack/package.json" ] &&
     [ "$want" = "$(cat "$stamp" 2>/dev/null)" ]; then
    say "palette: installed"
  else
    say "palette: npm install $PALETTE and the dashboard"
    (cd "$USERDIR" && npm install --no-audit --no-fund "$PALETTE" "$ROOT/node_modules/@flowfuse/node-red-dashboard")
    echo "$want" >"$stamp"
  fi
}

# Regenerated on every start; put local changes in this script, not in the user dir.
write_settings() {
  cat >"$USERDIR/settings.js" <<'EOF'
// Generated by scripts/start.sh on every start.
module.exports = {
  uiHost: process.env.SUGARSHACK_UI_HOST || '127.0.0.1',
  flowFile: 'flows.json',
  flowFilePretty: true,
  credentialSecret: false,
  // The default store is on disk so a persisted interlock keeps its faults across restarts.
  contextStorage: {
    default: { module: 'localfilesystem' },
    memory: { module: 'memory' },
  },
  logging: { console: { level: 'info', metrics: false, audit: false } },
  // A plant's edge server: no prompt about update checks, no calls home.
  telemetry: { enabled: false },
  // With no database configured, the journal goes to rotated local files (npm run season-report reads them).
  sugarshackJournal: { dir: process.env.SUGARSHACK_JOURNAL_DIR, plant: process.env.SUGARSHACK_PLANT_ID || 'local' },
  // No welcome tour over the canvas of the demo.
  editorTheme: { tours: false },
};
EOF
}

# The plant document, checked as a deploy would: nothing starts on one it would refuse.
check_plant() {
  if [ "$CHECK" = 1 ]; then
    node scripts/check-plant.js "$PLANT_FILE"
    exit $?
  fi
  [ -n "$PLANT_NAME" ] || return 0
  node scripts/check-plant.js "$PLANT_FILE" || { say "fix the plant document and start again (npm start -- --plant FILE --check checks it alone)" >&2; exit 1; }
}

# --fresh: what a previous run left (saved interlock state, context) goes.
clean_state() {
  [ "$FRESH" = 1 ] || return 0
  say "fresh: removing saved state and context from $USERDIR"
  rm -rf "$USERDIR/sugarshack" "$USERDIR/context"
}

port_open() { (exec 3<>"/dev/tcp/$1/$2") 2>/dev/null; }

# The broker everything uses: MQTT_URL when set, else the embedded one on MQTT_PORT.
choose_broker() {
  if [ -z "${MQTT_URL:-}" ]; then
    MQTT_PORT="${MQTT_PORT:-1883}"
    MQTT_URL="mqtt://127.0.0.1:$MQTT_PORT"
    EMBEDDED_BROKER=1
  else
    EMBEDDED_BROKER=0
  fi
  # Node-RED's flows can read these (${MQTT_URL} in a config node's fields).
  export MQTT_URL MQTT_PORT
}

seed_flows() {
  local target="$USERDIR/flows.json" sources=()
  if [ -n "$PLANT_NAME" ]; then
    local reset=()
    [ "$RESET_FLOWS" = 1 ] && reset=(--reset)
    node scripts/starter-flows.js "${reset[@]}" --broker "$MQTT_URL" "$PLANT_FILE" "$target"
    return
  fi
  if [ -f "$target" ] && [ "$RESET_FLOWS" = 0 ]; then
    say "flows: keeping $target (--reset-flows to replace)"
    return
  fi
  shopt -s nullglob
  local file
  for file in "$ROOT"/flows/*.json; do
    # Plant documents (flows/plant.json, flows/example-rig.json) are objects; flows are arrays.
    if [ "$(head -c 1 "$file")" = "[" ]; then sources+=("$file"); fi
  done
  if [ ${#sources[@]} -gt 0 ]; then
    # The control examples stand beside the plant: a PID loop, RCC over the same broker,
    # and the PID over Modbus/TCP against the simulator's flow loop.
    sources+=("$PALETTE"/examples/pid-loop.json "$PALETTE"/examples/rcc-failover.json "$PALETTE"/examples/modbus-pid-loop.json)
  else
    sources=("$PALETTE"/examples/*.json)
  fi
  shopt -u nullglob
  if [ ${#sources[@]} -eq 0 ]; then
    say "flows: nothing to seed (no flows/*.json or examples)"
    return
  fi
  node scripts/merge-flows.js --broker "$MQTT_URL" "$target" "${sources[@]}"
}

# PROFILE: the case-study plant node gets the document the simulator's devices speak.
profile_flows() {
  [ -n "${PROFILE:-}" ] && [ -z "$PLANT_NAME" ] && [ -f "$USERDIR/flows.json" ] && [ -f "$PLANT_FILE" ] || return 0
  node scripts/profile-flows.js "$USERDIR/flows.json" "$PLANT_FILE" "$PROFILE"
}

# Extra services (each started in the background with its pid appended to PIDS):
# the MQTT broker (aedes, scripts/broker.js), and the simulator on the plant and
# on the example rig. Their output goes to the run directory's logs/.
start_services() {
  mkdir -p "$LOGS"
  if [ "$EMBEDDED_BROKER" = 0 ]; then
    say "MQTT broker: $MQTT_URL (MQTT_URL set; not starting one)"
  else
    if port_open 127.0.0.1 "$MQTT_PORT"; then
      say "MQTT broker: 127.0.0.1:$MQTT_PORT is already taken; set MQTT_PORT, or MQTT_URL=mqtt://127.0.0.1:$MQTT_PORT to use that broker" >&2
      exit 1
    fi
    MQTT_PORT="$MQTT_PORT" node scripts/broker.js >"$LOGS/broker.log" 2>&1 &
    PIDS+=($!)
    local i
    for i in $(seq 50); do
      port_open 127.0.0.1 "$MQTT_PORT" && break
      kill -0 "${PIDS[-1]}" 2>/dev/null || break
      sleep 0.1
    done
    port_open 127.0.0.1 "$MQTT_PORT" || { cat "$LOGS/broker.log" >&2; say "MQTT broker did not start" >&2; exit 1; }
    say "MQTT broker: listening on $MQTT_URL (aedes; log ${LOGS#"$ROOT"/}/broker.log)"
  fi
  if [ "${SIM:-1}" = 0 ]; then
    say "plant simulator: off (SIM=0)"
    return
  fi
  local profile=()
  if [ -n "${PROFILE:-}" ]; then
    if [ -n "$PLANT_NAME" ]; then say "PROFILE=$PROFILE left out: with --plant, each device speaks the profile its plant document gives"
    else profile=(--profile "$PROFILE"); fi
  fi
  # shellcheck disable=SC2086  # SIM_ARGS is a list of flags
  node scripts/simulator/cli.js --broker "$MQTT_URL" --plant "$PLANT_FILE" "${profile[@]}" ${SIM_ARGS:-} >"$LOGS/simulator.log" 2>&1 &
  PIDS+=($!)
  say "plant simulator: ${PLANT_FILE#"$ROOT"/} on $MQTT_URL${profile[1]:+, profile ${profile[1]}} (log ${LOGS#"$ROOT"/}/simulator.log; faults via sim/control)"
  node scripts/simulator/cli.js --broker "$MQTT_URL" --plant flows/example-rig.json --control-topic sim/rig/control \
    --loop "$PALETTE/examples/modbus-pid-loop.json" --quiet >"$LOGS/simulator-rig.log" 2>&1 &
  PIDS+=($!)
  say "example rig: flows/example-rig.json and the Modbus flow loop on $MQTT_URL, for the palette's examples (faults via sim/rig/control)"
}

run_node_red() {
  local url_host="$HOST"
  [ "$HOST" = 0.0.0.0 ] && url_host=127.0.0.1
  local cmd=(node "$ROOT/node_modules/node-red/red.js" -u "$USERDIR" -s "$USERDIR/settings.js" -p "$PORT")
  say "Node-RED editor: http://$url_host:$PORT/  (flows: ${USERDIR#"$ROOT"/}/flows.json)"
  say "HMI: http://$url_host:$PORT/dashboard"
  export SUGARSHACK_UI_HOST="$HOST"
  # The embedded journal (settings.js: sugarshackJournal); JOURNAL=0 turns it off.
  [ "${JOURNAL:-1}" = 0 ] || export SUGARSHACK_JOURNAL_DIR="${SUGARSHACK_JOURNAL_DIR:-$RUN/journal}"
  [ -z "$PLANT_NAME" ] || export SUGARSHACK_PLANT_ID="${SUGARSHACK_PLANT_ID:-$PLANT_NAME}"
  say "journal: ${SUGARSHACK_JOURNAL_DIR:-off} (npm run season-report -- --from ... --to ...)"
  if [ ${#PIDS[@]} -eq 0 ]; then
    exec "${cmd[@]}"
  fi
  trap 'kill "${PIDS[@]}" 2>/dev/null || true' EXIT
  trap 'exit 130' INT TERM
  "${cmd[@]}"
}

# shellcheck source=scripts/setup.sh
. scripts/setup.sh
bash scripts/build-wasm.sh
check_plant
install_palette
write_settings
clean_state
choose_broker
seed_flows
profile_flows
start_services
run_node_red
