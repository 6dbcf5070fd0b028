#!/usr/bin/env bash
# Time, peak memory and error of `glint convolve` (the whole set, the planner's own output sizes)
# against the input's size, 256x128 to 8192x4096; writes tests/bench/results/scaling.{md,csv} and
# images/convolution_scaling.png. Inputs and exact references are cached in
# build-native/bench-cache/scaling; the exact maps of the 1024x512 inputs are reused from
# build-native/bench-cache when run_convolution_bench.sh made them.
# Takes ~3 minutes on 2 cores (18 runs) once the inputs and exact references are cached; the first
# run also makes them (the references of the upsampled inputs from finer versions: ~30 minutes).
# Arguments are passed on (--help lists them; e.g. --preset issue, --run courtyard:256x128,1024x512).
set -euo pipefail
cd "$(dirname "$0")/../.."
# The benchmarks run in their own -march=native tree, build-native/ (bench_build.sh).
b=$(tests/bench/bench_build.sh glint_bench_scaling)
"$b/tests/bench/glint_bench_scaling" --cache "$b/bench-cache/scaling" --exact-cache "$b/bench-cache" \
    --out tests/bench/results --images images --glint "$b/appliance/app/glint" --threads 2 "$@"
