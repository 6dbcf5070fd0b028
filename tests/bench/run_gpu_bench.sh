#!/usr/bin/env bash
# GPU engine benchmark: whole set GPU vs CPU, and a 30 Hz 1280x720 render loop with and
# without the convolution. Writes tests/bench/results/gpu.md (+ gpu_frames.csv) and
# images/gpu_frame_times.png. Run tests/bench/run_convolution_bench.sh first for the
# exact references it compares against (build-native/bench-cache). A few minutes on llvmpipe.
set -euo pipefail
cd "$(dirname "$0")/../.."
# The benchmarks run in their own -march=native tree, build-native/ (bench_build.sh).
b=$(tests/bench/bench_build.sh glint_bench_gpu)
"$b/tests/bench/glint_bench_gpu" --cache "$b/bench-cache" --out tests/bench/results --images images "$@"
