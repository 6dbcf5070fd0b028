#!/usr/bin/env bash
# The whole CTest suite under AddressSanitizer (with LeakSanitizer) and UndefinedBehaviorSanitizer:
# configures build-asan/ (GCC, RelWithDebInfo, -fsanitize=address,undefined), builds everything
# the tests use and runs CTest with every report fatal. See docs/testing.md, "Sanitizers".
#
#   scripts/run-sanitizers.sh                 build, then the whole suite
#   scripts/run-sanitizers.sh --build-only    build only
#   scripts/run-sanitizers.sh -R REGEX ...    build, then ctest with these arguments
#
# Not part of .ci/run: a cold build and the suite take far longer than CI's budget (the measured
# times are in docs/testing.md). ccache makes a warm rebuild quick.
#
# -fno-sanitize=vptr: the sensor-protocol and firmware libraries are built without RTTI (they
# must run on a microcontroller), and vptr checks need the type information of every class.
set -euo pipefail
cd "$(dirname "$0")/.."
build_only=0
if [ "${1:-}" = "--build-only" ]; then build_only=1; shift; fi
if [ "${1:-}" = "--help" ] || [ "${1:-}" = "-h" ]; then sed -n '2,14p' "$0"; exit 0; fi

flags="-fsanitize=address,undefined -fno-sanitize=vptr -fno-omit-frame-pointer"
# The instrumented programs run several times slower: the tests' time limits (CTest TIMEOUTs and
# the Python tests' waits) are multiplied by this; what the tests check does not change.
time_scale=4
launcher=()
if command -v ccache >/dev/null; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi
start=$(date +%s)
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo "${launcher[@]}" \
      -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS="$flags" -DCMAKE_SHARED_LINKER_FLAGS="$flags" \
      -DGLINT_BUILD_BENCH=OFF -DGLINT_FUZZ_REPLAY=ON -DGLINT_TEST_TIME_SCALE="$time_scale" >/dev/null
cmake --build build-asan -j"$(nproc)"
echo "run-sanitizers: build took $(( $(date +%s) - start )) s"
[ "$build_only" = 1 ] && exit 0

# Every report is fatal: ASan and UBSan stop the process at the first report (non-zero exit, so
# the test fails), LeakSanitizer's leak report at exit fails it too. The suppressions name only
# the GL driver's libraries (tests/sanitizers/lsan.supp says why).
supp="$PWD/tests/sanitizers/lsan.supp"
# Shared libraries stay loaded to the end (tests/sanitizers/keep_loaded.c says why); the preload
# comes before the ASan runtime, hence verify_asan_link_order=0.
cc -shared -fPIC -O2 -o build-asan/libglint_keep_loaded.so tests/sanitizers/keep_loaded.c
export LD_PRELOAD="$PWD/build-asan/libglint_keep_loaded.so${LD_PRELOAD:+ $LD_PRELOAD}"
export ASAN_OPTIONS="halt_on_error=1:abort_on_error=0:detect_leaks=1:strict_string_checks=1:detect_stack_use_after_return=0:check_initialization_order=1:verify_asan_link_order=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
export LSAN_OPTIONS="suppressions=$supp:print_suppressions=0"
export GLINT_TEST_TIME_SCALE="$time_scale"
start=$(date +%s)
status=0
ctest --test-dir build-asan --output-on-failure -j"$(nproc)" --timeout 1800 "$@" || status=$?
echo "run-sanitizers: ctest took $(( $(date +%s) - start )) s, status $status"
exit "$status"
