#!/usr/bin/env python3
"""glint replay when the capture or the recording fails (found by a sweep of damaged inputs,
2026-12-06):

1. The camera switches to another size as the scan starts (--inject-fault camera-mode over the
   button press at 3 s): the capture cannot use such frames, and the kiosk says so at once
   (CAPTURE -> ATTRACT with the capture's error), not after the visitor has scanned on for nothing
   until the scan's end. The next visit (the recording's press at 73 s) gets a capture of its own,
   not the failed one's error again. The replay ends with 0.
2. A replay into the directory of an earlier one that fails (a frame of the recording is missing)
   exits 2 naming the file, and leaves none of the earlier run's summary.json, frame log or
   captured map behind for a script to read as this run's.

usage: test_replay_faults.py GLINT SESSION WORK_DIR
"""
import os
import re
import shutil
import subprocess
import sys

from glint_test_util import Checks, scaled

glint, session, work = sys.argv[1:4]
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
check = Checks()

# 1. Frames at half the calibration's size from 2.5 to 5 s (the button is pressed at 3 s).
out = os.path.join(work, "mode")
r = subprocess.run([glint, "replay", session, "--out", out, "--inject-fault", "camera-mode:2.5:5"],
                   capture_output=True, text=True, timeout=scaled(900))
print(r.stderr[-3000:])
check(r.returncode == 0, f"the replay rode the fault out and ended with 0 (got {r.returncode})")
failed = re.search(r"state CAPTURE -> ATTRACT at ([0-9.]+) s: frame [0-9]+ is [0-9]+x[0-9]+, the calibration is for", r.stderr)
check(failed is not None, "the capture's error ended the scan, naming the frame and the sizes")
if failed:
    check(float(failed.group(1)) < 5.5, f"at once, as the scan began at 3 s (at {failed.group(1)} s)")
check(r.stderr.count("ATTRACT -> CAPTURE") >= 2, "a later press started another visit")
check(len(re.findall(r"CAPTURE -> ATTRACT at [0-9.]+ s: frame", r.stderr)) == 1,
      "the later visit did not fail with the first one's error")
check("CAPTURE -> PROCESSING" in r.stderr, "the later visit's capture went on to PROCESSING")

# 2. An earlier replay's outputs, then a replay of a copy whose sixth frame is missing.
damaged = os.path.join(work, "session")
shutil.copytree(session, damaged)
missing = os.path.join(damaged, "frames", "000005.jpg")
os.remove(missing)
stale = os.path.join(work, "stale")
os.makedirs(os.path.join(stale, "frames"))
for name in ["summary.json", "frames.csv", "env.exr", "env.coverage.exr", os.path.join("frames", "00001_ATTRACT_old.png")]:
    with open(os.path.join(stale, name), "w") as f:
        f.write("from an earlier run\n")
r = subprocess.run([glint, "replay", damaged, "--out", stale], capture_output=True, text=True, timeout=scaled(300))
print(r.stderr[-2000:])
check(r.returncode == 2, f"a missing frame is an input error, exit 2 (got {r.returncode})")
check("000005.jpg" in r.stderr, "the error names the missing frame")
left = [n for n in ["summary.json", "frames.csv", "env.exr", "env.coverage.exr"] if os.path.exists(os.path.join(stale, n))]
check(not left, f"none of the earlier run's outputs is left (left: {left})")
check(not os.path.exists(os.path.join(stale, "frames", "00001_ATTRACT_old.png")), "nor its frames")
check.exit()
