#!/usr/bin/env python3
"""glint run --record with a sensor that has no byte stream (a Modbus pan/tilt head served by
glint_test_modbus_head): the session's sensors.glrec holds the samples the driver published
(docs/capture.md "Session directory"; FORMAT.md 3.2), verifies, and replays through glint sensors
with the head's motion in it.

usage: test_run_record_modbus.py GLINT MODBUS_HEAD GLINT_RECORDING CALIBRATION WORK_DIR
"""
import os
import shutil
import subprocess
import sys

from glint_test_util import Checks, scaled, write_kiosk_config

glint, head_sim, recording_tool, calibration, work = sys.argv[1:6]
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
check = Checks()

head = subprocess.Popen([head_sim, "--seconds", str(scaled(60))], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
try:
    port = head.stdout.readline().strip()
    check(port.isdigit(), f"the head simulator serves on a port ({port!r})")
    config = os.path.join(work, "glint.toml")
    write_kiosk_config(config, calibration, f"modbus-tcp:127.0.0.1:{port}", f"{work}/state")
    record = os.path.join(work, "recorded")
    r = subprocess.run([glint, "run", "--config", config, "--record", record, "--max-seconds", str(scaled(4))],
                       capture_output=True, text=True, timeout=scaled(120))
    print(r.stderr[-1200:])
    check(r.returncode == 0, f"glint run --record with a Modbus head ends with 0 (got {r.returncode})")
finally:
    head.terminate()
    head.wait(timeout=scaled(10))

glrec = os.path.join(record, "sensors.glrec")
check(os.path.exists(glrec) and os.path.getsize(glrec) > 1000, "the head's samples were recorded in sensors.glrec")
v = subprocess.run([recording_tool, "verify", glrec], capture_output=True, text=True, timeout=scaled(60))
check(v.returncode == 0 and "modbus: no byte stream" in v.stdout, f"the recording verifies: {v.stdout.strip()[-200:]}")
p = subprocess.run([glint, "sensors", "--source", "replay:" + glrec, "--print-csv"], capture_output=True, text=True,
                   timeout=scaled(60))
rows = [l.split(",") for l in p.stdout.split()[1:]]
check(p.returncode == 0 and len(rows) >= 20, f"glint sensors replays it: {len(rows)} samples (exit {p.returncode})")
check(len({tuple(x[1:]) for x in rows}) > 10, "the head's motion is in the replayed samples")
check(all(int(b[0]) > int(a[0]) for a, b in zip(rows, rows[1:])), "their times increase")
check.exit()
