#!/usr/bin/env bash
# `glint sensors --record` from a Modbus pan/tilt head (a source without a byte stream): the file
# holds the samples the driver published, `glint-recording verify` accepts it, and its replay
# prints the live run's samples again (times to the microsecond the file keeps, orientations to
# Q30).
# Usage: test_sensors_modbus_cli.sh GLINT GLINT_TEST_MODBUS_HEAD GLINT_RECORDING
glint=$1
head_sim=$2
recording_tool=$3
source "$(dirname "$0")/served_cli_test.sh"

start_server "the head simulator" "$head_sim" --seconds 30
port=$served

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

stop_server
finish "sensors Modbus CLI"
