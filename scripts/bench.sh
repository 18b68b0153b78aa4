#!/usr/bin/env bash
# Benchmarks: builds the wasm package (release), then runs the interlock and
# the feedback ingest benchmarks, each beside its native example, and the cost
# of the interlock's durable state beside keeping it in memory. Prints
# figures; extra arguments go to tests/bench/interlock-bench.js (--quick,
# --no-native, --no-events).
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH="$HOME/.cargo/bin:$PATH"

bash scripts/build-wasm.sh
echo "bench: building the native examples (release)"
cargo build -q --release -p sugarshack-core --example interlock_bench --example tracker_bench
node tests/bench/interlock-bench.js "$@"
echo
node tests/bench/tracker-bench.js
echo
# What writing the interlock's state before every grant costs (fsync), against memory.
node tests/bench/durable-bench.js --quick
echo
# Node-RED cost per feedback msg through the actuators node (test helper, no broker).
node tests/bench/actuator-node-bench.js
echo
# CPU and memory of Node-RED on the full simulated plant, 30 s per run; the
# 3-minute run is opt-in: node tests/bench/plant-load.js (or --minutes N).
node tests/bench/plant-load.js --quick
