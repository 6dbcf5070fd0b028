#!/usr/bin/env bash
# Speed against error of every convolution method; writes tests/bench/results/convolution.{md,csv}
# and images/convolution_speed_error.png. Exact references are cached in build-native/bench-cache,
# except the timing map's (courtyard), which is recomputed every run for the headline ratio.
# Takes ~5 minutes on 2 cores the first time, ~2 minutes after.
set -euo pipefail
cd "$(dirname "$0")/../.."
# The benchmarks run in their own -march=native tree, build-native/ (bench_build.sh).
b=$(tests/bench/bench_build.sh glint_bench_convolution)
# The same heap as `glint convolve`, which re-executes itself with huge pages (docs/convolution.md,
# "Large inputs: loading and memory").
export GLIBC_TUNABLES=glibc.malloc.hugetlb=1
"$b/tests/bench/glint_bench_convolution" --cache "$b/bench-cache" --glint "$b/appliance/app/glint" \
    --out tests/bench/results --images images --threads 2 "$@"
