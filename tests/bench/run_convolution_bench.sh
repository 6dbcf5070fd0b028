#!/usr/bin/env bash
# Speed against error of every convolution method; writes tests/bench/results/convolution.{md,csv}
# and images/convolution_speed_error.png. Exact references are cached in build/bench-cache,
# except the timing map's (courtyard), which is recomputed every run for the headline ratio.
# Takes ~5 minutes on 2 cores the first time, ~2 minutes after.
set -euo pipefail
cd "$(dirname "$0")/../.."
./scripts/build.sh
# The same heap as `glint convolve`, which re-executes itself with huge pages (docs/convolution.md,
# "Large inputs: loading and memory").
export GLIBC_TUNABLES=glibc.malloc.hugetlb=1
./build/tests/bench/glint_bench_convolution --cache build/bench-cache --out tests/bench/results \
    --images images --threads 2 "$@"
