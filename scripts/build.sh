#!/usr/bin/env bash
# Installs what is missing, configures and builds Glint in ./build (Release, portable:
# GLINT_NATIVE=OFF, also in a build/ configured before that was the default; the benchmarks'
# -march=native tree is build-native/, tests/bench/bench_build.sh).
# With target names (e.g. `glint glint-vision`), builds only those; without, everything
# (tests, benchmarks, fuzzers).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DGLINT_NATIVE=OFF >/dev/null
if [ "$#" -gt 0 ]; then
  cmake --build build -j"$(nproc)" --target "$@"
else
  cmake --build build -j"$(nproc)"
fi
