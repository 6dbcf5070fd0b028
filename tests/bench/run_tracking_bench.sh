#!/usr/bin/env bash
# Marker tracking against known poses (docs/tracking.md "Measured"); writes
# tests/bench/results/tracking.md. Takes several minutes on 2 cores (the rendering dominates).
set -euo pipefail
cd "$(dirname "$0")/../.."
# The benchmarks run in their own -march=native tree, build-native/ (bench_build.sh).
b=$(tests/bench/bench_build.sh glint_bench_tracking)
"$b/tests/bench/glint_bench_tracking" --out tests/bench/results/tracking.md "$@"
