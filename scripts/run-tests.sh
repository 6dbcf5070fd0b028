#!/usr/bin/env bash
# Everything run-main.sh does, then every test (unit, GPU, CLI, bridge) through CTest, then
# the libFuzzer targets for a bounded time.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/run-main.sh
ctest --test-dir build --output-on-failure -j"$(nproc)" --timeout 600
# The fuzz targets (frame decoder, recording reader), about 30 s each (scripts/run-fuzz.sh).
./scripts/run-fuzz.sh 30
