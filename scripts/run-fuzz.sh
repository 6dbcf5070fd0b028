#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (ASan + UBSan) in build-fuzz/ and runs each for a
# bounded time on its seed corpus: the frame decoder (tests/bridge/protocol/corpus) and the
# recorded-sensor-file reader and player (tests/bridge/recording/corpus). New inputs the fuzzer
# finds go to a scratch copy, so the committed corpus only changes by hand. A crash leaves its
# input in build-fuzz/artifacts/ and fails the script.
#
#   scripts/run-fuzz.sh [SECONDS_PER_TARGET]     (default 30)
#
# Seeds: the protocol seeds are the raw received bytes of
#   glint-recording generate --duration-ms 400 --seed 3 --orientation-hz 100 --raw-imu-hz 100
# cut into pieces of 25 frames; the recording seeds are `glint-recording generate` files
# (--duration-ms 40; and --duration-ms 120 --seed 7 --orientation-hz 200 --raw-imu-hz 100).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-30}"

cmake -S . -B build-fuzz -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=RelWithDebInfo \
      -DGLINT_BUILD_BENCH=OFF -DGLINT_NATIVE=OFF >/dev/null
cmake --build build-fuzz -j"$(nproc)" --target glint_fuzz_protocol glint_fuzz_recording

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
