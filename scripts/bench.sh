#!/usr/bin/env bash
# Benchmarks: builds the wasm package (release, wasm-opt), then runs every
# benchmark and ends with each target's PASS or MISS line gathered in one list.
# Quick variants by default (about 10 minutes on 2 cores); `--full` runs the
# long variants and the scaling run up to the cloud paper's 95,200-I/O plant.
# Other arguments go to tests/bench/interlock-bench.js (--no-native, --no-events).
#
#   footprint      wasm size, palette's added RSS and start-up (tests/bench/footprint.js)
#   wasm size      where the module's bytes go, by crate and function (tests/bench/wasm-size.js)
#   interlock      case and large scale, wasm against a JS baseline and native
#   tracker        feedback ingest through wasm as the nodes call it
#   durable        what writing the interlock's state before a grant costs
#   actuator node  Node-RED cost per feedback msg (test helper, no broker)
#   crossings      calls into wasm per msg through the nodes: acquire, release, feedback, group command
#   peers          against node-red-contrib-simple-message-queue, -queue-gate and a function-node PID; durable grants/s
#   layers         per-layer overhead p99 on the case-study plant, GC pauses apart (scripts/measure.js)
#   plant load     CPU and memory of Node-RED on the simulated case-study plant
#   scaling        1x, 10x, 100x (and --full: 95,200 I/O) end to end on Mosquitto
#   OPC UA         the OPC UA server's CPU and memory, every value subscribed (--full: and at 95,200 I/O)
#   standby        hot standby on a real etcd: commit cost, grants/s through the nodes, failover times
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH="$HOME/.cargo/bin:$PATH"

full=0
rest=()
for a in "$@"; do
  if [ "$a" = --full ]; then full=1; else rest+=("$a"); fi
done
quick=(--quick)
[ "$full" = 1 ] && quick=()

log="$(mktemp -t sugarshack-bench.XXXXXX)"
trap 'rm -f "$log"' EXIT
failed=()
# One benchmark failing does not stop the others; the run exits 1 at the end.
run() {
  local name="$1"
  echo
  echo "== $name"
  shift
  "$@" 2>&1 | tee -a "$log" || failed+=("$name")
}

# What the benchmarks need (npm packages, the peers' packages, Mosquitto, binaryen), skipping what is there.
# shellcheck source=scripts/setup.sh
. scripts/setup.sh
bash scripts/build-wasm.sh
echo "bench: building the native examples (release)"
cargo build -q --release -p sugarshack-core --example interlock_bench --example tracker_bench
echo "bench: load average $(cut -d' ' -f1-3 /proc/loadavg) on $(nproc) cores at start"

run footprint node tests/bench/footprint.js --runs "$([ "$full" = 1 ] && echo 5 || echo 3)"
run "wasm size" node tests/bench/wasm-size.js
run interlock node tests/bench/interlock-bench.js "${quick[@]}" ${rest[@]+"${rest[@]}"}
run tracker node tests/bench/tracker-bench.js
run durable node tests/bench/durable-bench.js "${quick[@]}"
run "actuator node" node tests/bench/actuator-node-bench.js
run crossings node tests/bench/crossings.js
run peers node tests/bench/peers-bench.js "${quick[@]}"
if [ "$full" = 1 ]; then
  run layers node scripts/measure.js --minutes 10
  run "plant load" node tests/bench/plant-load.js
  run scaling node tests/bench/scaling.js --full
  run "OPC UA" node tests/bench/opcua-load.js
else
  run layers node scripts/measure.js --minutes 1 --speed 4 --warmup-s 10 --fault-every-min 0.5
  run "plant load" node tests/bench/plant-load.js --quick
  run scaling node tests/bench/scaling.js
  run "OPC UA" node tests/bench/opcua-load.js --quick --skip-large
fi

run standby node tests/bench/standby-bench.js "${quick[@]}"

echo
echo "== every target (load average $(cut -d' ' -f1-3 /proc/loadavg) at the end)"
grep -E '^ *(PASS|MISS|----) ' "$log" | sed -E 's/^ */  /'
if [ "${#failed[@]}" -gt 0 ]; then
  echo "bench: failed to run: ${failed[*]}" >&2
  exit 1
fi
