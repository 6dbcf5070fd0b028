#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (ASan + UBSan) in build-fuzz/ and runs each for a
# bounded time on its seed corpus: the frame decoder (tests/bridge/protocol/corpus), the
# recorded-sensor-file reader and player (tests/bridge/recording/corpus), and the parsers of
# outside data in tests/fuzz (config, strings, calibration, board, session, exr, obj, gltf, ao,
# material; seeds in tests/fuzz/corpus/<target>, see tests/fuzz/README.md). New inputs the fuzzer
# finds go to a scratch copy, so the committed corpus only changes by hand. A crash leaves its
# input in build-fuzz/artifacts/ and fails the script.
#
#   scripts/run-fuzz.sh [BRIDGE_SECONDS [PARSER_SECONDS]]     (defaults 30 and 12)
#
# The bridge targets run one after the other for BRIDGE_SECONDS each; the parser targets two at
# a time (the CI machine has 2 cores; each fuzzer is one thread) for PARSER_SECONDS each.
# What the parser targets add to CI, measured 2026-12-03 on this 2-core machine (shared, load
# about 10): their build from cold (30 instrumented sources, no ccache) is 175 s of CPU (user),
# so about 90 s on two idle cores (8.5 min wall under that load); running the ten of them took
# 98 s at 15 s each (five pairs plus start-up) and 75 s at the default 12 s. About 2.8 min
# in all, beside the bridge targets' 60 s and their small build.
#
# Seeds: the protocol seeds are the raw received bytes of
#   glint-recording generate --duration-ms 400 --seed 3 --orientation-hz 100 --raw-imu-hz 100
# cut into pieces of 25 frames; the recording seeds are `glint-recording generate` files
# (--duration-ms 40; and --duration-ms 120 --seed 7 --orientation-hz 200 --raw-imu-hz 100).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-30}"
parser_seconds="${2:-12}"
parsers=(config strings calibration board session exr obj gltf ao material)

launcher=()
if command -v ccache >/dev/null; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi
start=$(date +%s)
cmake -S . -B build-fuzz -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=RelWithDebInfo \
      -DGLINT_BUILD_BENCH=OFF -DGLINT_NATIVE=OFF "${launcher[@]}" >/dev/null
cmake --build build-fuzz -j"$(nproc)" --target glint_fuzz_protocol glint_fuzz_recording glint_fuzz_parsers
echo "run-fuzz: build took $(( $(date +%s) - start )) s"

mkdir -p build-fuzz/artifacts
for target in protocol recording; do
  scratch="build-fuzz/corpus-$target"
  rm -rf "$scratch"
  mkdir -p "$scratch"
  cp "tests/bridge/$target/corpus/"* "$scratch/"
  echo "run-fuzz: glint_fuzz_$target for ${seconds} s"
  "build-fuzz/tests/bridge/$target/glint_fuzz_$target" -max_total_time="$seconds" \
      -print_final_stats=1 -artifact_prefix=build-fuzz/artifacts/ "$scratch" \
      2> "build-fuzz/fuzz-$target.log" || { tail -40 "build-fuzz/fuzz-$target.log"; exit 1; }
  grep -E "^stat::number_of_executed_units|^Done" "build-fuzz/fuzz-$target.log" | sed "s/^/  /"
done

# One parser target: its corpus copied to scratch, -timeout catches a hang (an input that takes
# more than 10 s), the default -rss_limit_mb (2 GiB) an input that makes the parser allocate
# without bound.
run_parser() {
  local target="$1" scratch="build-fuzz/corpus-$1"
  rm -rf "$scratch"
  mkdir -p "$scratch"
  cp "tests/fuzz/corpus/$target/"* "$scratch/"
  if "build-fuzz/tests/fuzz/glint_fuzz_$target" -max_total_time="$parser_seconds" -timeout=10 \
        -print_final_stats=1 -artifact_prefix="build-fuzz/artifacts/$target-" "$scratch" \
        2> "build-fuzz/fuzz-$target.log"; then
    echo "run-fuzz: glint_fuzz_$target for ${parser_seconds} s: $(grep -m1 '^stat::number_of_executed_units' "build-fuzz/fuzz-$target.log" | awk '{print $2}') executions"
  else
    echo "run-fuzz: glint_fuzz_$target FAILED (build-fuzz/fuzz-$target.log):"
    tail -40 "build-fuzz/fuzz-$target.log"
    return 1
  fi
}
start=$(date +%s)
status=0
for ((i = 0; i < ${#parsers[@]}; i += 2)); do
  pids=()
  for target in "${parsers[@]:i:2}"; do
    run_parser "$target" & pids+=($!)
  done
  for pid in "${pids[@]}"; do wait "$pid" || status=1; done
done
echo "run-fuzz: parser targets took $(( $(date +%s) - start )) s"
exit "$status"
