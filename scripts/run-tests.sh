#!/usr/bin/env bash
# The main job and every test: builds everything, then CTest (unit, GPU on Mesa llvmpipe, CLI,
# bridge, capture, tracking, kiosk...), whose `glint_replay_shipped` runs the main job itself
# (`glint replay data/sessions/kiosk`, the README's first command) and asserts its figures; then
# the libFuzzer targets for a bounded time.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/build.sh
ctest --test-dir build --output-on-failure -j"$(nproc)" --timeout 900
# The fuzz targets (frame decoder, recording reader), about 30 s each (scripts/run-fuzz.sh).
./scripts/run-fuzz.sh 30
