#!/usr/bin/env bash
# Builds the benchmarks' own tree and prints its path. The benchmarks measure this machine's best
# (GLINT_NATIVE=ON: -march=native), while ./build stays portable (GLINT_NATIVE=OFF, the default,
# what the tests and the .deb use): two build directories, so neither flips the other's flags
# and neither rebuilds the other's objects.
#
# usage: tests/bench/bench_build.sh [TARGET...]   (prints the build directory on stdout)
#   BENCH_BUILD=DIR      another directory (default build-native)
#   BENCH_NATIVE=OFF     benchmark the portable code instead (e.g. to compare with the package)
# Without targets: glint and glint-vision (the scripts name their benchmark executable too).
set -euo pipefail
cd "$(dirname "$0")/../.."
dir=${BENCH_BUILD:-build-native}
native=${BENCH_NATIVE:-ON}
./scripts/install-deps.sh >&2
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=Release -DGLINT_NATIVE="$native" "${launcher[@]}" >/dev/null
cmake --build "$dir" -j"$(nproc)" --target glint glint-vision "$@" >&2
realpath "$dir"
