#!/usr/bin/env bash
# Start-up of the glint commands as whole processes (median of 10); writes
# tests/bench/results/startup.md. Takes a few seconds after the build.
set -euo pipefail
cd "$(dirname "$0")/../.."
./scripts/build.sh
python3 tests/bench/startup_bench.py build --out tests/bench/results/startup.md "$@"
