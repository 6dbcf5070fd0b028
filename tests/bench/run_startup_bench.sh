#!/usr/bin/env bash
# Start-up of the glint commands as whole processes (median of 10); writes
# tests/bench/results/startup.md. Takes a few seconds after the build.
set -euo pipefail
cd "$(dirname "$0")/../.."
# The benchmarks run in their own -march=native tree, build-native/ (bench_build.sh).
b=$(tests/bench/bench_build.sh)
python3 tests/bench/startup_bench.py "$b" --out tests/bench/results/startup.md "$@"
