#!/usr/bin/env bash
# Interlock benchmark: builds the wasm package (release), then runs the JS
# benchmark, which also builds and runs the native example. Prints figures;
# extra arguments go to tests/bench/interlock-bench.js (--quick, --no-native,
# --no-events).
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH="$HOME/.cargo/bin:$PATH"

bash scripts/build-wasm.sh
echo "bench: building the native example (release)"
cargo build -q --release -p sugarshack-core --example interlock_bench
node tests/bench/interlock-bench.js "$@"
