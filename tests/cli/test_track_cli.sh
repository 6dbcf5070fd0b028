#!/usr/bin/env bash
# End to end, `glint track` (runs in glint-vision): --print-board writes the sheet at the asked
# resolution; --frames on rendered views at known poses (tests/tracking/tools) gives the true
# poses in the CSV; --sequence fills a dropout with the held pose, and with --sensors
# replay:FILE (data/sessions' recording) turns it with the sensor; bad usage exits 2 naming the
# flag or key.
#
# Usage: test_track_cli.sh /path/to/glint /path/to/glint_render_board_views
set -euo pipefail
GLINT=$1
VIEWS=$2
# shellcheck source=cli_test_lib.sh
source "$(dirname "$0")/cli_test_lib.sh"

run track --help
[[ $rc -eq 0 ]] && grep -q "^Usage: glint track" "$work/stdout" && grep -q -- "--print-board" "$work/stdout" ||
    fail "track --help: exit $rc: $(head -2 "$work/stdout")"
[[ ! -s $work/stderr ]] || fail "track --help wrote to stderr: $(stderr_text)"
pass "track --help: usage on stdout, exit 0"

# --print-board: 280 x 380 mm at 3 px/mm is 840 x 1140 px; the margin is white, marker 0's
# corner (20 mm in) black.
run track --print-board "$work/board.png" --px-per-mm 3
[[ $rc -eq 0 && -f $work/board.png ]] || fail "track --print-board: exit $rc: $(stderr_text)"
python3 - "$work/board.png" <<'PY' || fail "track --print-board: wrong size or pixels"
import struct, sys, zlib
data = open(sys.argv[1], "rb").read()
w, h, depth, colour = struct.unpack(">IIBB", data[16:26])
assert (w, h) == (840, 1140), (w, h)
assert depth == 8 and colour == 0, (depth, colour)
# Decode the IDAT stream (filter bytes per row) to check two pixels.
idat, pos = b"", 8
while pos < len(data):
    n, kind = struct.unpack(">I4s", data[pos:pos + 8])
    if kind == b"IDAT": idat += data[pos + 8:pos + 8 + n]
    pos += 12 + n
raw, rows, prev = zlib.decompress(idat), [], bytearray(w)
for y in range(h):
    f, line = raw[y * (w + 1)], bytearray(raw[y * (w + 1) + 1:(y + 1) * (w + 1)])
    for x in range(w):
        a = line[x - 1] if x else 0; b = prev[x]; c = prev[x - 1] if x else 0
        if f == 1: line[x] = (line[x] + a) & 255
        elif f == 2: line[x] = (line[x] + b) & 255
        elif f == 3: line[x] = (line[x] + (a + b) // 2) & 255
        elif f == 4:
            p = a + b - c; pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
            line[x] = (line[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
    rows.append(line); prev = line
assert rows[10][10] == 255 and rows[60][60] == 0 and rows[59][59] == 255, (rows[10][10], rows[60][60], rows[59][59])
PY
pass "track --print-board: 840x1140 px at 3 px/mm, margin white, marker 0 where the board frame puts it"

# Frames at known poses: every pose within 0.1 degree and 0.5 mm of the truth.
intrinsics=$("$VIEWS" "$work/views" 10 --blank 6 7)
run track --frames "$work/views/frames" --intrinsics "$intrinsics" --out "$work/poses.csv"
[[ $rc -eq 0 ]] || fail "track --frames: exit $rc: $(stderr_text)"
grep -q "board detected in 8" "$work/stdout" || fail "track --frames: $(cat "$work/stdout")"
python3 - "$work/poses.csv" "$work/views/truth.csv" <<'PY' || fail "track --frames: poses off the truth"
import csv, math, sys
got = list(csv.DictReader(open(sys.argv[1])))
truth = {r["file"]: r for r in csv.DictReader(open(sys.argv[2]))}
assert list(got[0].keys()) == "file,detected,qw,qx,qy,qz,tx,ty,tz,quality".split(","), got[0].keys()
for r in got:
    t = truth[r["file"]]
    if r["file"] in ("006.png", "007.png"):
        assert r["detected"] == "0" and r["qw"] == "", r
        continue
    assert r["detected"] == "1", r
    q = [float(r[k]) for k in ("qw", "qx", "qy", "qz")]; p = [float(t[k]) for k in ("qw", "qx", "qy", "qz")]
    angle = 2 * math.degrees(math.acos(min(1, abs(sum(a * b for a, b in zip(q, p))))))
    dist = math.dist([float(r[k]) for k in ("tx", "ty", "tz")], [float(t[k]) for k in ("tx", "ty", "tz")])
    assert angle < 0.1 and dist < 5e-4, (r["file"], angle, dist)
    assert 0 < float(r["quality"]) < 0.5, r
PY
pass "track --frames: 8 of 10 frames detected, each within 0.1 degree and 0.5 mm of the truth"

# --sequence: the two blank frames get the last pose (no sensor: held), detected 0.
run track --frames "$work/views/frames" --intrinsics "$intrinsics" --out "$work/seq.csv" --sequence --fps 30
[[ $rc -eq 0 ]] && grep -q "bridged in 2" "$work/stdout" || fail "track --sequence: exit $rc: $(cat "$work/stdout") $(stderr_text)"
awk -F, '$1 == "006.png" && $2 == "0" && $3 != "" { ok = 1 } END { exit !ok }' "$work/seq.csv" ||
    fail "track --sequence: no held pose for the blank frame"
pass "track --sequence: the dropout is bridged (held without a sensor)"

# --sequence --sensors replay:FILE: the recorded sensor (turning ~45 deg/s) carries the blank
# frames' rotation: frame 006 is no longer frame 005's pose.
RECORDING=$(dirname "$0")/../../data/sessions/synthetic-rotation-4s.glrec
run track --frames "$work/views/frames" --intrinsics "$intrinsics" --out "$work/bridged.csv" --sequence \
    --sensors "replay:$RECORDING"
[[ $rc -eq 0 ]] && grep -q "bridged in 2" "$work/stdout" || fail "track --sensors: exit $rc: $(cat "$work/stdout") $(stderr_text)"
python3 - "$work/bridged.csv" "$work/seq.csv" <<'PY' || fail "track --sensors: the blank frame's pose did not turn with the sensor"
import csv, math, sys
rows = {r["file"]: r for r in csv.DictReader(open(sys.argv[1]))}
held = {r["file"]: r for r in csv.DictReader(open(sys.argv[2]))}
q = lambda r: [float(r[k]) for k in ("qw", "qx", "qy", "qz")]
angle = lambda a, b: 2 * math.degrees(math.acos(min(1, abs(sum(x * y for x, y in zip(a, b))))))
assert rows["006.png"]["detected"] == "0" and rows["006.png"]["qw"] != ""
assert angle(q(held["006.png"]), q(held["005.png"])) < 1e-3          # held without the sensor
assert angle(q(rows["006.png"]), q(rows["005.png"])) > 0.1, angle(q(rows["006.png"]), q(rows["005.png"]))
PY
pass "track --sequence --sensors replay:FILE: the dropout turns with the recorded sensor"

# Bad usage: exit 2, one line naming the flag, file or key.
expect_usage() {
    local want=$1
    shift
    run track "$@"
    [[ $rc -eq 2 ]] || fail "track $*: exit $rc, want 2"
    grep -q -- "$want" "$work/stderr" || fail "track $*: '$(stderr_text)' does not name '$want'"
}
expect_usage "--out" --frames "$work/views/frames" --intrinsics "$intrinsics"
expect_usage "--calibration" --frames "$work/views/frames" --out "$work/x.csv"
expect_usage "--intrinsics" --frames "$work/views/frames" --intrinsics 1,2,3 --out "$work/x.csv"
expect_usage "--intrinsics" --frames "$work/views/frames" --intrinsics 700,700,x,270 --out "$work/x.csv"
expect_usage "--frames" --frames "$work/nothing" --intrinsics "$intrinsics" --out "$work/x.csv"
expect_usage "--sequence" --frames "$work/views/frames" --intrinsics "$intrinsics" --out "$work/x.csv" --sensors replay:x
expect_usage "nonexistent.glrec" --frames "$work/views/frames" --intrinsics "$intrinsics" --out "$work/x.csv" \
    --sequence --sensors "replay:$work/nonexistent.glrec"
expect_usage "--px-per-mm" --print-board "$work/b.png" --px-per-mm 0
expect_usage "--no-such-flag" --no-such-flag
echo '{"columns": 5, "rowz": 7}' >"$work/board.json"
expect_usage "key 'rowz'" --print-board "$work/b.png" --board "$work/board.json"
expect_usage "calibration.json" --frames "$work/views/frames" --calibration "$work/calibration.json" --out "$work/x.csv"
pass "track: bad flags, files and board keys exit 2 naming them"
echo "all $checks checks passed"
