#!/usr/bin/env bash
# End to end, the glint-vision commands that tests/cli/test_glint_cli.sh does not run:
# `glint calibrate response|vignetting|alignment|intrinsics` on simulated sessions (the file is written and
# the result is compared with the session's truth), `glint cameras` without a camera, and
# `glint capture`'s --orientations-out, --drift-log, --adjustment-rounds and
# --no-global-adjustment. Each command runs through `glint` (which execs glint-vision).
#
# Usage: test_vision_cli.sh /path/to/glint
set -euo pipefail
GLINT=$1
WORLD=/usr/share/blender/datafiles/studiolights/world/courtyard.exr
[[ -f $WORLD ]] || { echo "FAIL - $WORLD is missing (blender-data)"; exit 1; }
# shellcheck source=cli_test_lib.sh
source "$(dirname "$0")/cli_test_lib.sh"
# The number printed after `label` in stdout.
number_after() { sed -n "s/.*$1 \([-0-9.]*\).*/\1/p" "$work/stdout" | head -1; }
below() { python3 -c "import sys; sys.exit(0 if abs(float('$1')) < float('$2') else 1)"; }

# cameras: this machine has no camera; one line, exit 1 (not a crash, not 0).
run cameras
[[ $rc -eq 1 ]] || fail "glint cameras without a camera: exit $rc, want 1"
[[ $(wc -l <"$work/stderr") -eq 1 ]] && grep -q "libcamera found no camera" "$work/stderr" ||
    fail "glint cameras without a camera: $(cat "$work/stderr")"
pass "glint cameras without a camera exits 1 with one line"

# calibrate response on a noise-free bracket of 16 frames (32768x): the simulator's true curve
# is recovered within 5 % over codes 64..250 (measured 3.4 %; with noise the low codes are biased,
# docs/capture.md "Calibration").
run simulate --env "$WORLD" --bracket 16 --bracket-first 3e-6 --no-camera-noise --out "$work/bracket" --size 96x54
[[ $rc -eq 0 ]] || fail "simulate --bracket: exit $rc: $(cat "$work/stderr")"
run calibrate response --session "$work/bracket" --calibration "$work/cal.json"
[[ $rc -eq 0 && -f $work/cal.json ]] || fail "calibrate response: exit $rc: $(cat "$work/stderr")"
err=$(number_after "worst relative error")
[[ -n $err ]] && below "$err" 5 || fail "calibrate response: worst relative error '$err' %, want < 5 %"
python3 - "$work/cal.json" "$work/bracket/calibration.json" <<'PY' || fail "calibrate response: cal.json does not hold a new increasing 256-entry response"
import json, sys
c, start = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
inv = c["response"]["inverse"]
assert len(inv) == 256 and all(b > a for a, b in zip(inv, inv[1:])), inv[:4]
assert inv != start["response"]["inverse"], "the session's own curve was written back unchanged"
PY
pass "calibrate response writes the curve, $err % from the truth"

# calibrate intrinsics on 8 ChArUco views: RMS reprojection under 0.5 px (measured 0.16), and
# the focal length near the simulator's.
run simulate --charuco 8 --size 640x360 --out "$work/charuco"
[[ $rc -eq 0 ]] || fail "simulate --charuco: exit $rc: $(cat "$work/stderr")"
run calibrate intrinsics --session "$work/charuco" --calibration "$work/cal.json"
[[ $rc -eq 0 ]] || fail "calibrate intrinsics: exit $rc: $(cat "$work/stderr")"
rms=$(number_after "RMS reprojection")
below "$rms" 0.5 || fail "calibrate intrinsics: RMS reprojection $rms px, want < 0.5"
python3 - "$work/cal.json" "$work/charuco/truth/calibration.json" <<'PY' || fail "calibrate intrinsics: fx far from the truth, or the response was lost"
import json, sys
got, truth = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
fx, tfx = got["intrinsics"]["fx"], truth["intrinsics"]["fx"]
assert abs(fx / tfx - 1) < 0.01, (fx, tfx)
assert len(got["response"]["inverse"]) == 256  # the earlier step's result is kept
PY
pass "calibrate intrinsics: RMS $rms px, fx within 1 % of the truth, the response kept"

# calibrate vignetting on a flat field (9 still frames of a constant world, 96x54): the fitted
# falloff V(r) within 0.01 of the simulator's true one over r = 0..1 (measured 0.0014; the
# coefficients trade against each other, the curve does not).
python3 "$(dirname "$0")/make_constant_exr.py" "$work/flat.exr" 64 32 0.5
printf '0,1,0,0,0\n4,1,0,0,0\n' >"$work/still.csv"
run simulate --env "$work/flat.exr" --trajectory "$work/still.csv" --out "$work/flat" --fps 2 --size 96x54
[[ $rc -eq 0 ]] || fail "simulate flat field: exit $rc: $(cat "$work/stderr")"
run calibrate vignetting --session "$work/flat" --calibration "$work/vignetting.json"
[[ $rc -eq 0 ]] || fail "calibrate vignetting: exit $rc: $(cat "$work/stderr")"
python3 - "$work/vignetting.json" "$work/flat/truth/calibration.json" <<'PY' || fail "calibrate vignetting: the falloff is off the truth"
import json, sys
got, truth = (json.load(open(f))["vignetting"] for f in sys.argv[1:3])
v = lambda g, r: 1 + g["a1"] * r**2 + g["a2"] * r**4 + g["a3"] * r**6
worst = max(abs(v(got, r / 20) - v(truth, r / 20)) for r in range(21))
assert worst < 0.01 and got != truth, (worst, got, truth)
PY
pass "calibrate vignetting finds the true falloff within 0.01"

# A short scan (8 s, yaw 160 degrees with a pitch wobble) for alignment and capture.
python3 - >"$work/scan.csv" <<'PY'
import math
for i in range(9):
    yaw, pitch = math.radians(20 * i), math.radians(10 * math.sin(i))
    cy, sy, cp, sp = math.cos(yaw / 2), math.sin(yaw / 2), math.cos(pitch / 2), math.sin(pitch / 2)
    print(f"{i},{cy * cp:.8f},{cy * sp:.8f},{sy * cp:.8f},{-sy * sp:.8f}")  # yaw about Y, then pitch about X
PY
run simulate --env "$WORLD" --trajectory "$work/scan.csv" --out "$work/scan" --fps 4 --size 160x90
[[ $rc -eq 0 ]] || fail "simulate scan: exit $rc: $(cat "$work/stderr")"
frames=$(($(wc -l <"$work/scan/frames.csv") - 1))

# calibrate alignment on a pan (yaw alone, 160 degrees): the mounting about the vertical is not
# observed at all, so the calibration is refused naming that axis, and nothing is written
# (docs/capture.md "Alignment", step 6). (The scan above, with its pitch wobble, is refused too,
# at 0.37 degrees; a pan leaves no doubt.)
python3 - >"$work/pan.csv" <<'PY'
import math
for i in range(9):
    yaw = math.radians(20 * i)
    print(f"{i},{math.cos(yaw / 2):.8f},0,{math.sin(yaw / 2):.8f},0")
PY
run simulate --env "$WORLD" --trajectory "$work/pan.csv" --out "$work/pan" --fps 4 --size 160x90
[[ $rc -eq 0 ]] || fail "simulate pan: exit $rc: $(cat "$work/stderr")"
cal_before=$(sha256sum <"$work/cal.json")
run calibrate alignment --session "$work/pan" --calibration "$work/cal.json"
[[ $rc -eq 2 ]] || fail "calibrate alignment on a one-axis scan: exit $rc, expected 2: $(cat "$work/stdout" "$work/stderr")"
grep -q "pan: the motion turned too little about the camera's axis" "$work/stderr" ||
    fail "calibrate alignment on a one-axis scan: no reason given: $(cat "$work/stderr")"
grep -q "turn the camera about all three axes" "$work/stderr" || fail "calibrate alignment: no advice: $(cat "$work/stderr")"
[[ $(sha256sum <"$work/cal.json") == "$cal_before" ]] || fail "calibrate alignment on a one-axis scan changed $work/cal.json"
pass "calibrate alignment refuses a one-axis scan, naming the loose axis, and leaves the calibration as it was"

# The three-axis calibration motion (simulate --trajectory alignment, small frames): calibrate
# alignment finds a 5-degree mounting and a -15 ms offset. Measured at 160x90: 0.06 degrees and
# 0.7 ms off (docs/capture.md "Alignment"); the bounds leave margin.
run simulate --env "$WORLD" --trajectory alignment --out "$work/align" --size 160x90 --mount 4,-2,3 --time-offset-ms -15
[[ $rc -eq 0 ]] || fail "simulate --trajectory alignment: exit $rc: $(cat "$work/stderr")"
run calibrate alignment --session "$work/align" --calibration "$work/align-cal.json"
[[ $rc -eq 0 ]] || fail "calibrate alignment (three axes): exit $rc: $(cat "$work/stderr")"
off=$(number_after "mounting against the session's truth:")
dt=$(number_after "time offset against the session's truth:")
below "$off" 0.5 || fail "calibrate alignment (three axes): mounting $off degrees off the truth"
below "$dt" 3 || fail "calibrate alignment (three axes): time offset $dt ms off the truth"
pass "calibrate alignment on the three-axis motion: mounting $off degrees, time offset $dt ms off the truth"

# calibrate readout: the same motion shows the rolling shutter (the simulator's 20 ms; measured
# +0.4 to +1.5 ms off at 160x90, docs/capture.md "Readout"); the slow pan does not, and is refused
# with the calibration left as it was.
run calibrate readout --session "$work/align" --calibration "$work/align-cal.json"
[[ $rc -eq 0 ]] || fail "calibrate readout (three axes): exit $rc: $(cat "$work/stderr")"
readout=$(number_after "readout against the session's truth:")
below "$readout" 4 || fail "calibrate readout (three axes): $readout ms off the truth"
cal_before=$(sha256sum <"$work/cal.json")
run calibrate readout --session "$work/pan" --calibration "$work/cal.json"
[[ $rc -eq 2 ]] || fail "calibrate readout on a slow pan: exit $rc, expected 2: $(cat "$work/stdout" "$work/stderr")"
grep -q "the motion does not show the rolling shutter's readout" "$work/stderr" ||
    fail "calibrate readout on a slow pan: no reason given: $(cat "$work/stderr")"
[[ $(sha256sum <"$work/cal.json") == "$cal_before" ]] || fail "calibrate readout on a slow pan changed $work/cal.json"
pass "calibrate readout finds the rolling shutter $readout ms off the truth on the three-axis motion and refuses a slow pan"

# capture with the outputs that describe the run.
run capture --session "$work/scan" --out "$work/env.exr" --size 128x64 --orientations-out "$work/poses.csv" \
    --drift-log "$work/drift.csv" --adjustment-rounds 2
[[ $rc -eq 0 ]] || fail "capture: exit $rc: $(cat "$work/stderr")"
[[ $(head -1 "$work/poses.csv") == "index,t_ns,w,x,y,z" ]] || fail "--orientations-out header: $(head -1 "$work/poses.csv")"
[[ $(($(wc -l <"$work/poses.csv") - 1)) -eq $frames ]] || fail "--orientations-out: $(wc -l <"$work/poses.csv") lines for $frames frames"
awk -F, 'NR > 1 { n = $3*$3 + $4*$4 + $5*$5 + $6*$6; if (n < 0.999999 || n > 1.000001) exit 1 }' "$work/poses.csv" ||
    fail "--orientations-out: a quaternion is not unit"
head -1 "$work/drift.csv" | grep -q "^index,t_s,pixels,estimate_deg,sigma_deg" || fail "--drift-log header: $(head -1 "$work/drift.csv")"
[[ $(($(wc -l <"$work/drift.csv") - 1)) -ge $((frames - 1)) ]] || fail "--drift-log: $(wc -l <"$work/drift.csv") lines for $frames frames"
grep -q "^global adjustment (2 rounds after the scan)" "$work/stdout" || fail "--adjustment-rounds 2 not reported: $(grep 'global' "$work/stdout")"
run capture --session "$work/scan" --out "$work/env2.exr" --size 128x64 --no-global-adjustment
[[ $rc -eq 0 ]] || fail "capture --no-global-adjustment: exit $rc"
! grep -q "^global adjustment" "$work/stdout" || fail "--no-global-adjustment still adjusted"
pass "capture: --orientations-out ($frames poses), --drift-log, --adjustment-rounds 2, --no-global-adjustment"

# --out is checked before the work: a directory (or a trailing slash) is refused at once, a
# missing parent directory is made.
mkdir -p "$work/adir.exr"
for out in "$work/adir.exr" "$work/adir.exr/"; do
    run capture --session "$work/scan" --out "$out" --size 64x32
    [[ $rc -eq 2 ]] || fail "capture --out $out: exit $rc, expected 2"
    grep -q "must name the environment map's file, not a directory" "$work/stderr" || fail "capture --out $out: $(cat "$work/stderr")"
done
run capture --session "$work/scan" --out "$work/made/here/env.exr" --size 64x32 --no-global-adjustment
[[ $rc -eq 0 && -f "$work/made/here/env.exr" && -f "$work/made/here/env.coverage.exr" ]] ||
    fail "capture into a new directory: exit $rc: $(cat "$work/stderr")"
pass "capture: --out a directory refused before the work, a new directory made"

echo "all $checks checks passed"
