#!/usr/bin/env bash
# firmware_bridge: frame decoder throughput and firmware -> host sample latency over a pty;
# writes tests/bench/results/bridge.md. Takes about 20 s.
set -euo pipefail
cd "$(dirname "$0")/../.."
# The benchmarks run in their own -march=native tree, build-native/ (bench_build.sh).
b=$(tests/bench/bench_build.sh glint_bench_bridge)
"$b/tests/bench/glint_bench_bridge" --out tests/bench/results/bridge.md "$@"
