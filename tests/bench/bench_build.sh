#!/usr/bin/env bash
# Builds the benchmarks' own tree and prints its path. The benchmarks measure this machine's best
# (GLINT_NATIVE=ON: -march=native), while ./build stays portable (GLINT_NATIVE=OFF, the default,
# what the tests and the .deb use): two build directories, so neither flips the other's flags
# and neither rebuilds the other's objects.
#
# usage: tests/bench/bench_build.sh [TARGET...]   (prints the build directory on stdout)
#   BENCH_NATIVE=OFF     benchmark the portable code instead (what the package runs): in build/,
#                        which is portable already, so no tree changes its flags
#   BENCH_BUILD=DIR      another directory
# Without targets: glint and glint-vision (the scripts name their benchmark executable too).
set -euo pipefail
cd "$(dirname "$0")/../.."
native=${BENCH_NATIVE:-ON}
if [ "$native" = ON ]; then dir=${BENCH_BUILD:-build-native}; else dir=${BENCH_BUILD:-build}; fi
./scripts/install-deps.sh >&2
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=Release -DGLINT_NATIVE="$native" "${launcher[@]}" >/dev/null
cmake --build "$dir" -j"$(nproc)" --target glint glint-vision "$@" >&2
realpath "$dir"
