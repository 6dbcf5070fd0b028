#!/usr/bin/env bash
# The soak benchmark (issue 18, part 3; not CI): the shipped session replayed pass after pass in
# ONE process for at least SECONDS (default 1800) with `glint replay --loop-for`, on one headless
# display and GL context. Writes tests/bench/results/soak.md: resident memory, the heap in use,
# open descriptors, threads and live GL objects after the first pass (the warm-up) and after the
# last, their growth against the target (< 2 MiB, no new descriptors or GL objects), and each
# pass's frame-time median and p99.
# usage: tests/bench/run_soak_bench.sh [BUILD_DIR] [OUT_MD] [SECONDS]
#   the raw samples stay in $SOAK_KEEP/soak.csv when SOAK_KEEP is set (else a temporary directory).
set -euo pipefail
cd "$(dirname "$0")/../.."
build=${1:-build}
out_md=${2:-tests/bench/results/soak.md}
seconds=${3:-1800}
if [[ -n "${SOAK_KEEP:-}" ]]; then
    work=$SOAK_KEEP
    mkdir -p "$work"
else
    work=$(mktemp -d)
    trap 'rm -rf "$work"' EXIT
fi
glint="$build/appliance/app/glint"
[[ -x "$glint" ]] || { echo "run_soak_bench.sh: $glint: not built (cmake --build $build --target glint)" >&2; exit 2; }
load_before=$(cut -d' ' -f1-3 /proc/loadavg)
started=$(date -u +%Y-%m-%dT%H:%MZ)
cmd=(nice -n 5 "$glint" replay data/sessions/kiosk --out "$work/replay" --snapshot-every 0 --loop-for "$seconds")
echo "soak: ${cmd[*]} (log: $work/log)"
"${cmd[@]}" > "$work/log" 2>&1 || { echo "run_soak_bench.sh: glint replay failed:" >&2; tail -20 "$work/log" >&2; exit 1; }
load_after=$(cut -d' ' -f1-3 /proc/loadavg)
python3 tests/bench/soak_report.py "$work/replay/soak.csv" "$out_md" "$started" "$load_before" "$load_after" "$seconds"
