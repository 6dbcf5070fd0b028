#!/usr/bin/env bash
# Everything run-main.sh does, then every test (unit, CLI) through CTest.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/run-main.sh
ctest --test-dir build --output-on-failure -j"$(nproc)" --timeout 600
