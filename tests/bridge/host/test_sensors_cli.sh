#!/usr/bin/env bash
# `glint sensors` on the committed session (replay, virtual clock: instant) and on bad input.
# Usage: test_sensors_cli.sh GLINT GLINT_RECORDING SESSIONS_DIR
set -u
glint=$1
recording_tool=$2
session=$3/synthetic-rotation-4s.glrec
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# Reference: the orientation messages the live decoder accepted when the session was recorded.
expected=$("$recording_tool" info "$session" | awk '$1 == "messages" && $2 == "orientation" { print $3 }')
[ -n "$expected" ] || fail "glint-recording info gave no orientation count"

"$glint" sensors --source "replay:$session" --print-csv >"$tmp/out.csv" 2>"$tmp/err.txt"
rc=$?
[ $rc -eq 0 ] || fail "replay exited $rc: $(cat "$tmp/err.txt")"
# A header row like every other CSV Glint writes, then one line per sample.
[ "$(head -1 "$tmp/out.csv")" = "t_ns,w,x,y,z" ] || fail "first line is not the header t_ns,w,x,y,z: $(head -1 "$tmp/out.csv")"
tail -n +2 "$tmp/out.csv" >"$tmp/samples.csv"
mv "$tmp/samples.csv" "$tmp/out.csv"
lines=$(wc -l <"$tmp/out.csv")
[ "$lines" -eq "$expected" ] || fail "replay printed $lines samples, the recording holds $expected"
bad=$(grep -cvE '^[0-9]+(,-?[0-9]\.[0-9]{9}){4}$' "$tmp/out.csv")
[ "$bad" -eq 0 ] || fail "$bad lines are not t_ns,w,x,y,z with 9 decimals: $(grep -vE '^[0-9]+(,-?[0-9]\.[0-9]{9}){4}$' "$tmp/out.csv" | head -1)"
awk -F, 'NR > 1 && $1 <= prev { print "not increasing at line " NR; exit 1 } { prev = $1 }' "$tmp/out.csv" ||
    fail "sample times are not strictly increasing"
# Unit quaternions.
awk -F, '{ n = $2*$2 + $3*$3 + $4*$4 + $5*$5; if (n < 0.999999 || n > 1.000001) { print "norm " n " at line " NR; exit 1 } }' \
    "$tmp/out.csv" || fail "a quaternion is not normalised"
grep -q '^health: finished, ' "$tmp/err.txt" || fail "no final health line in state finished on stderr"
grep -qE 'crc errors 0, frame errors [0-9]+, lost [0-9]+, untimed [0-9]+, reconnects 0, stalls 0, timeouts 0, drift ' "$tmp/err.txt" ||
    fail "health line lacks its counters: $(tail -1 "$tmp/err.txt")"

# --seconds counts recorded time: one second of a 100 Hz stream.
n=$("$glint" sensors --source "replay:$session" --print-csv --seconds 1 2>/dev/null | tail -n +2 | wc -l)
{ [ "$n" -ge 90 ] && [ "$n" -le 110 ]; } || fail "--seconds 1 printed $n samples (expected ~100)"

# Human form: time and yaw/pitch/roll in degrees.
"$glint" sensors --source "replay:$session" --seconds 0.5 >"$tmp/human.txt" 2>/dev/null || fail "human form exited $?"
head -1 "$tmp/human.txt" | grep -qE '^t=[0-9]+\.[0-9]{6} s  yaw +-?[0-9]+\.[0-9]{3}  pitch +-?[0-9]+\.[0-9]{3}  roll +-?[0-9]+\.[0-9]{3} deg$' ||
    fail "human line format: $(head -1 "$tmp/human.txt")"

# --latency-ms moves every sample earlier by exactly that much.
first=$(head -1 "$tmp/out.csv" | cut -d, -f1)
shifted=$("$glint" sensors --source "replay:$session" --print-csv --latency-ms 30 2>/dev/null | sed -n 2p | cut -d, -f1)
[ $((first - shifted)) -eq 30000000 ] || fail "--latency-ms 30 moved the first sample by $((first - shifted)) ns"

expect_exit() {
    local want=$1 what=$2
    shift 2
    "$glint" "$@" >"$tmp/o.txt" 2>"$tmp/e.txt"
    local got=$?
    [ $got -eq "$want" ] || fail "$what: exit $got, expected $want"
    [ "$want" -eq 0 ] || [ -s "$tmp/e.txt" ] || fail "$what: no message on stderr"
}
expect_exit 2 "bad spec" sensors --source bogus:x
grep -q "bogus:x" "$tmp/e.txt" || fail "bad spec message does not name the spec: $(cat "$tmp/e.txt")"
expect_exit 2 "bad baud" sensors --source serial:/dev/ttyACM0:12345
grep -q "12345" "$tmp/e.txt" || fail "bad baud message does not name it: $(cat "$tmp/e.txt")"
expect_exit 2 "missing recording" sensors --source "replay:$tmp/none.glrec"
grep -q "none.glrec" "$tmp/e.txt" || fail "missing file not named: $(cat "$tmp/e.txt")"
expect_exit 2 "record a replay" sensors --source "replay:$session" --record "$tmp/x.glrec"
[ ! -e "$tmp/x.glrec" ] || fail "--record with replay created a file"
expect_exit 2 "an i2c address that is no BNO055's" sensors --source i2c:/dev/i2c-1:0x30
grep -q "0x30" "$tmp/e.txt" || fail "bad I2C address not named: $(cat "$tmp/e.txt")"
expect_exit 2 "no --source" sensors

if [ $failures -eq 0 ]; then echo "sensors CLI: all checks passed"; else echo "sensors CLI: $failures failure(s)"; fi
[ $failures -eq 0 ]
