#!/usr/bin/env bash
# Off-grid error of the auto planner's maps (its own output sizes) on courtyard, studio and
# sunset: bilinear lookup at random directions against exact_at. Writes
# tests/bench/results/offgrid.{md,csv}. Extra arguments go to the benchmark (see --help),
# e.g. --maps courtyard --targets irradiance,1,5120 for a short run.
set -euo pipefail
cd "$(dirname "$0")/../.."
# The benchmarks run in their own -march=native tree, build-native/ (bench_build.sh).
b=$(tests/bench/bench_build.sh glint_bench_offgrid)
# The same heap as `glint convolve`, which re-executes itself with huge pages (docs/convolution.md,
# "Large inputs: loading and memory").
export GLIBC_TUNABLES=glibc.malloc.hugetlb=1
"$b/tests/bench/glint_bench_offgrid" --out tests/bench/results --threads 2 --samples 4096 "$@"
