#!/usr/bin/env python3
"""The main job with its figures asserted: `glint replay` on the session that ships in
data/sessions/kiosk (the README's first command). Every visitor state is reached in order, the
scan covers the room, the captured map and the irradiance the object was lit with are close to
the simulated room's truth, the board is tracked in the AR phase, the replay saw no device fault, and a PNG frame of every
state was written. Frame times are printed, not asserted: they belong to the machine's load
(tests/bench/run_kiosk_bench.sh measures them).

usage: test_replay_shipped.py GLINT SESSION OUT
"""
import json
import os
import shutil
import sys

from glint_test_util import Checks, run_replay

glint, session, out = sys.argv[1:4]
shutil.rmtree(out, ignore_errors=True)
check = Checks()
r, s = run_replay(check, glint, session, out)
# The warm-up tracks a drawn board (docs/kiosk.md): found, or the first AR frame pays OpenCV's set-up.
check("warm-up: the drawn board was found in" not in r.stderr, "the warm-up found the drawn board")
names = [x["name"] for x in s["states"]]
check(names[:4] == ["ATTRACT", "CAPTURE", "PROCESSING", "AR"], f"states in order: {names}")
check(s["coverage"] is not None and s["coverage"] >= 0.9, f"coverage {s['coverage']} >= 0.9")
# The targets of issue 17: the irradiance within 5 % of the truth's. The whole map's error is
# dominated by the sharp edges a 320x180 camera blurs; bounded loosely, it catches a broken capture.
check(s["irradiance_error"] is not None and s["irradiance_error"] <= 0.05, f"irradiance error {s['irradiance_error']} <= 0.05")
check(s["env_error"] is not None and s["env_error"] <= 0.5, f"environment map error {s['env_error']} <= 0.5")
check(s["tracking_detection_rate"] is not None and s["tracking_detection_rate"] >= 0.8,
      f"board detected in {s['tracking_detection_rate']} of the AR phase's frames (>= 0.8)")
rot = s.get("tracking_rotation_error_deg", {})
check(rot.get("median", 99) <= 1.0, f"tracking rotation error median {rot.get('median')} deg <= 1")
f = s["frame_ms"]
print(f"frame times (not asserted): median {f['median']:.1f} ms, p99 {f['p99']:.1f} ms, max {f['max']:.1f} ms, "
      f"{f['over_hard_cap']} over the hard cap of {f['hard_cap']} ms")
d = s["devices"]
check(d["camera_losses"] == 0 and d["sensor_losses"] == 0 and d["frames_out_of_order"] == 0 and d["scan_paused_s"] == 0,
      f"a recorded session has no device faults: {d}")
check(s["scan_end_to_lit_s"] is not None, f"the object was lit after the scan ({s['scan_end_to_lit_s']} s)")
# The scan checks the camera-sensor calibration; the shipped session's is right (its mounting is
# the simulator's truth), so it is measured and not called stale, and the log says so.
cap = s.get("capture", {})
turn = cap.get("calibration_turn_deg")
check(turn is not None and turn < 0.4 and cap.get("calibration_stale") is False,
      f"the calibration check ran and found it right: turn {turn} deg, stale {cap.get('calibration_stale')}")
check(cap.get("calibration_refined") is False and "calibration_refined_during_scan_s" in cap
      and cap["calibration_refined_during_scan_s"] is None,
      f"neither the check during the scan nor the one after kept a refined calibration: {cap}")
check("sensor-camera calibration ok: " in r.stderr, "the log has the calibration check's line")
# The camera's world orientation the AR view lights the object by (sensor and mounting) against
# the truth: 1.27 degrees in the median measured (the sensor's heading drift since the scan).
ar = s.get("ar_camera_orientation_error_deg", {})
check(ar.get("median", 99) < 2.0, f"the AR view's camera orientation {ar.get('median')} degrees from the truth < 2")
frames = os.listdir(os.path.join(out, "frames"))
for state in ["ATTRACT", "CAPTURE", "PROCESSING", "AR"]:
    check(any(f"_{state}_" in name for name in frames), f"a PNG frame of {state}")
print("frame time per state (ms):", json.dumps(f["by_state"]))
check.exit()
