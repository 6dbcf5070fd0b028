#!/usr/bin/env bash
# `glint sensors` live: glint-sensor-sim --port pty serves the board on a pseudo-terminal (its
# path on stdout's first line), glint reads it, records the session, stops on SIGINT; the
# recording then replays to exactly the same CSV lines.
# Usage: test_sensors_live_cli.sh GLINT GLINT_SENSOR_SIM GLINT_RECORDING
glint=$1
sim=$2
recording_tool=$3
source "$(dirname "$0")/served_cli_test.sh"

start_server glint-sensor-sim "$sim" --port pty --trajectory tumble --duration 6
port=$served
case "$port" in /dev/pts/*) ;; *) fail "first line is not a pty path: '$port'" ;; esac

# Until SIGINT: it must stop cleanly (exit 0) and close the recording.
"$glint" sensors --source "serial:$port" --print-csv --record "$tmp/live.glrec" >"$tmp/live.csv" 2>"$tmp/live.err" &
glint_pid=$!
# Wait for the event (>= 50 samples in the CSV, plus its header row), not for a fixed time: a
# loaded machine may take longer than any guess, and an idle one need not wait. The 20 s limit
# only ends a run whose board never streams (the sim's --duration is 6 s, the board boots in
# 0.65 s and sends 100 Hz). Polled every 50 ms.
want=50
deadline=$(($(date +%s) + 20))
while [ "$(($(wc -l <"$tmp/live.csv") - 1))" -lt "$want" ]; do
    if ! kill -0 "$glint_pid" 2>/dev/null; then fail "glint sensors ended before $want samples"; break; fi
    if [ "$(date +%s)" -ge "$deadline" ]; then fail "fewer than $want samples after 20 s"; break; fi
    sleep 0.05
done
kill -INT "$glint_pid"
wait "$glint_pid"
rc=$?
[ $rc -eq 0 ] || fail "glint sensors exited $rc after SIGINT: $(cat "$tmp/live.err")"
lines=$(($(wc -l <"$tmp/live.csv") - 1))  # after the header row
[ "$lines" -ge "$want" ] || fail "only $lines samples, SIGINT was sent after $want"
grep -q "^health: streaming, " "$tmp/live.err" || fail "no streaming health line: $(cat "$tmp/live.err")"
grep -q "crc errors 0, frame errors 0, lost 0" "$tmp/live.err" || fail "errors on a clean link: $(tail -1 "$tmp/live.err")"
"$recording_tool" verify "$tmp/live.glrec" >/dev/null || fail "the recording does not verify"
"$glint" sensors --source "replay:$tmp/live.glrec" --print-csv >"$tmp/replay.csv" 2>/dev/null || fail "replay exited $?"
cmp -s "$tmp/live.csv" "$tmp/replay.csv" || fail "the replay differs from the live run ($(wc -l <"$tmp/replay.csv") vs $lines lines)"

# An existing recording is never overwritten.
"$glint" sensors --source "serial:$port" --seconds 0.2 --record "$tmp/live.glrec" >/dev/null 2>"$tmp/e.txt"
rc=$?
[ $rc -ne 0 ] || fail "--record replaced an existing file"
grep -q "live.glrec" "$tmp/e.txt" || fail "the refusal does not name the file: $(cat "$tmp/e.txt")"

stop_server
finish "sensors live CLI"
