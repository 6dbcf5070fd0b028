#!/usr/bin/env bash
# firmware_bridge: frame decoder throughput and firmware -> host sample latency over a pty;
# writes tests/bench/results/bridge.md. Takes about 20 s.
set -euo pipefail
cd "$(dirname "$0")/../.."
./scripts/build.sh
./build/tests/bench/glint_bench_bridge --out tests/bench/results/bridge.md "$@"
