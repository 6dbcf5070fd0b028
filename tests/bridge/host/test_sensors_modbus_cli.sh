#!/usr/bin/env bash
# `glint sensors --record` from a Modbus pan/tilt head (a source without a byte stream): the file
# holds the samples the driver published, `glint-recording verify` accepts it, and its replay
# prints the live run's samples again (times to the microsecond the file keeps, orientations to
# Q30).
# Usage: test_sensors_modbus_cli.sh GLINT GLINT_TEST_MODBUS_HEAD GLINT_RECORDING
set -u
glint=$1
head_sim=$2
recording_tool=$3
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
tmp=$(mktemp -d)
sim_pid=
cleanup() {
    [ -n "$sim_pid" ] && kill "$sim_pid" 2>/dev/null
    rm -rf "$tmp"
}
trap cleanup EXIT

mkfifo "$tmp/sim.out"
"$head_sim" --seconds 30 >"$tmp/sim.out" 2>"$tmp/sim.err" &
sim_pid=$!
exec 3<"$tmp/sim.out"
read -r -t 5 port <&3 || fail "the head simulator printed no port"

"$glint" sensors --source "modbus-tcp:127.0.0.1:$port" --print-csv --seconds 1.5 --latency-ms 5 \
    --record "$tmp/head.glrec" >"$tmp/live.csv" 2>"$tmp/live.err"
rc=$?
[ $rc -eq 0 ] || fail "glint sensors --record exited $rc: $(cat "$tmp/live.err")"
lines=$(($(wc -l <"$tmp/live.csv") - 1))
[ "$lines" -ge 20 ] || fail "only $lines samples in 1.5 s from the head"
"$recording_tool" verify "$tmp/head.glrec" >"$tmp/verify.txt" 2>&1 || fail "verify: $(cat "$tmp/verify.txt")"
grep -q "modbus: no byte stream" "$tmp/verify.txt" || fail "verify does not say the file has no byte stream: $(cat "$tmp/verify.txt")"
"$glint" sensors --source "replay:$tmp/head.glrec" --print-csv --latency-ms 5 >"$tmp/replay.csv" 2>"$tmp/replay.err" ||
    fail "replay exited $?: $(cat "$tmp/replay.err")"
python3 - "$tmp/live.csv" "$tmp/replay.csv" <<'PY' || fail "the replay differs from the live run"
import sys
live = [l.split(",") for l in open(sys.argv[1]).read().split()[1:]]
replay = [l.split(",") for l in open(sys.argv[2]).read().split()[1:]]
if len(live) != len(replay):
    sys.exit(f"{len(live)} live samples, {len(replay)} replayed")
turned = False
for a, b in zip(live, replay):
    if abs(int(a[0]) - int(b[0])) > 500:
        sys.exit(f"times {a[0]} and {b[0]} differ by more than the file's rounding")
    if max(abs(float(x) - float(y)) for x, y in zip(a[1:], b[1:])) > 1e-8:
        sys.exit(f"orientations differ: {a} | {b}")
    turned = turned or a[1:] != live[0][1:]
if not turned:
    sys.exit("the head did not move: nothing was compared")
PY

kill -INT "$sim_pid" 2>/dev/null
wait "$sim_pid" 2>/dev/null
sim_pid=
if [ $failures -eq 0 ]; then echo "sensors Modbus CLI: all checks passed"; else echo "sensors Modbus CLI: $failures failure(s)"; fi
[ $failures -eq 0 ]
