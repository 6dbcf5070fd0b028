#!/usr/bin/env bash
# Long fuzzing runs (tests/fuzz/README.md records their results): each named target of
# build-fuzz/tests/fuzz (built by scripts/run-fuzz.sh) for SECONDS, at most two at a time, under
# nice 19 (the machine is shared: below everyone's builds). Each run starts from a scratch copy of
# its committed corpus in
# build-fuzz/long/<target>/corpus; its log is build-fuzz/long/<target>.log, a crash's input
# build-fuzz/long/<target>-crash-*. Prints one line per target: executions, coverage, result.
#
#   tests/fuzz/run_long.sh SECONDS TARGET...     e.g. tests/fuzz/run_long.sh 600 config obj
set -uo pipefail
cd "$(dirname "$0")/../.."
if [ "$#" -lt 2 ] || [ "$1" = "--help" ]; then sed -n '2,9p' "$0"; exit 2; fi
seconds="$1"; shift
mkdir -p build-fuzz/long
run_one() {
  local t="$1" dir="build-fuzz/long/$1"
  rm -rf "$dir"; mkdir -p "$dir/corpus"
  cp "tests/fuzz/corpus/$t/"* "$dir/corpus/"
  local start; start=$(date +%s)
  nice -n 19 "build-fuzz/tests/fuzz/glint_fuzz_$t" -max_total_time="$seconds" -timeout="${FUZZ_TIMEOUT:-20}" -rss_limit_mb=2560 \
      -print_final_stats=1 -artifact_prefix="build-fuzz/long/$t-" "$dir/corpus" > "build-fuzz/long/$t.log" 2>&1
  local rc=$?
  local execs cov ft corp
  execs=$(grep -m1 '^stat::number_of_executed_units' "build-fuzz/long/$t.log" | awk '{print $2}')
  cov=$(grep -E '(DONE|NEW|REDUCE|pulse) +cov:' "build-fuzz/long/$t.log" | tail -1 | sed -E 's/.*cov: ([0-9]+) ft: ([0-9]+) corp: ([0-9]+)\/.*/cov \1 ft \2 corpus \3/')
  echo "$t: $(date -u +%H:%M) rc=$rc ${execs:-?} executions in $(( $(date +%s) - start )) s, $cov, findings: $(ls build-fuzz/long/$t-* 2>/dev/null | wc -l)"
}
running=0
for t in "$@"; do
  run_one "$t" &
  running=$((running + 1))
  if [ "$running" -ge 2 ]; then wait -n; running=$((running - 1)); fi
done
wait
