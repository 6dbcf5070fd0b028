#!/usr/bin/env bash
# Capture accuracy and speed on simulated sessions of courtyard, studio and sunset
# (docs/capture.md, "Benchmark"); writes tests/bench/results/capture.md. Takes a few minutes on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/../.."
./scripts/build.sh
./build/tests/bench/glint_bench_capture --out tests/bench/results/capture.md "$@"
