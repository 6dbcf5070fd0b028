#!/usr/bin/env bash
# Capture accuracy and speed on simulated sessions of courtyard, studio and sunset
# (docs/capture.md, "Benchmark"); writes tests/bench/results/capture.md. Takes a few minutes on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/../.."
# The benchmarks run in their own -march=native tree, build-native/ (bench_build.sh).
b=$(tests/bench/bench_build.sh glint_bench_capture)
"$b/tests/bench/glint_bench_capture" --out tests/bench/results/capture.md "$@"
