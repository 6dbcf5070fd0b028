#!/usr/bin/env python3
"""glint run --record on live devices (the camera simulator, the sensor board's firmware on a
pseudo-terminal): the board's button starts a live scan (CAPTURE); SIGTERM in the middle of it
ends the appliance within 2 s; the recording is a session that glint replay reads back, with
frames, their times, the sensor's byte stream, the button's events and a calibration; a second
--record into the same directory is refused.

usage: test_run_record.py GLINT SENSOR_SIM CALIBRATION WORK_DIR
"""
import json
import os
import signal
import shutil
import subprocess
import sys
import time

from glint_test_util import Process, scaled, write_kiosk_config

glint, sensor_sim, calibration, work = sys.argv[1:5]
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


link = os.path.join(work, "sensor-pty")
# The board's button 0 pressed 1.5 s after it starts (the visitor's button, wired to the board).
board = subprocess.Popen([sensor_sim, "--pty-link", link, "--trajectory", "kiosk", "--press", "0:1.5:1.6"], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
for _ in range(100):
    if os.path.exists(link):
        break
    time.sleep(0.05)
config = os.path.join(work, "glint.toml")
write_kiosk_config(config, calibration, f"serial:{link}", f"{work}/state")
record = os.path.join(work, "recorded")
try:
    run = Process([glint, "run", "--config", config, "--record", record])
    # 5.5 s of the scan from the first frame on screen (about 7 s from the start on this machine;
    # an instrumented build takes longer to start, hence the wait for the line, not a fixed time).
    check(run.wait_for("first frame on screen", 60), "glint run --record started")
    time.sleep(5.5)
    t_term = time.monotonic()
    returncode, err = run.stop(signal.SIGTERM)
    t_exit = time.monotonic() - t_term
    print(err[-1500:])
    check(returncode == 0, f"glint run --record ends with 0 on SIGTERM (got {returncode})")
    check("ATTRACT -> CAPTURE" in err, "the board's button started a live scan")
    check("-> PROCESSING" not in err, "SIGTERM came while the scan was running")
    check(t_exit <= scaled(2.0), f"SIGTERM in the middle of a scan: out within {scaled(2.0):g} s ({t_exit:.2f} s)")
    again = subprocess.run([glint, "run", "--config", config, "--record", record, "--max-seconds", "1"],
                           capture_output=True, text=True, timeout=scaled(60))
    check(again.returncode == 2 and "never written over" in again.stderr,
          "a second --record into the same directory is refused (exit 2, bad input): " + again.stderr.strip()[-160:])
finally:
    board.terminate()
    board.wait(timeout=scaled(10))

lines = open(os.path.join(record, "frames.csv")).read().strip().splitlines()
check(lines[0] == "index,t_ns,exposure_s,analogue_gain,digital_gain,file", "frames.csv header")
check(len(lines) - 1 >= 10, f"frames recorded: {len(lines) - 1} in 5.5 s or more at the simulator's 4 fps")
times = [int(l.split(",")[1]) for l in lines[1:]]
# The scan's exposure control: the courtyard's sun clips the auto-exposed frames, and the
# controller asks for frames 64 times shorter (the capture's brackets) while the visitor scans.
exposures = [float(l.split(",")[2]) for l in lines[1:]]
check(min(exposures) < max(exposures) / 32,
      f"the exposure controller bracketed the live scan (exposures {min(exposures):.3g} .. {max(exposures):.3g} s)")
check(all(b > a for a, b in zip(times, times[1:])), "frame times increase")
check(all(os.path.getsize(os.path.join(record, l.split(",")[5])) > 1000 for l in lines[1:]), "every frame file is there")
check(os.path.getsize(os.path.join(record, "sensors.glrec")) > 10000, "the sensor's byte stream was recorded")
for name in ["session.json", "calibration.json", "events.csv"]:
    check(os.path.exists(os.path.join(record, name)), name + " written")
events = open(os.path.join(record, "events.csv")).read().strip().splitlines()
check(len(events) >= 2 and events[1].endswith(",button,press"), f"the press is in events.csv: {events[1:3]}")

out = os.path.join(work, "replayed")
r = subprocess.run([glint, "replay", record, "--out", out, "--snapshot-every", "0"], capture_output=True, text=True,
                   timeout=scaled(300))
print(r.stdout[-800:], r.stderr[-800:])
check(r.returncode == 0, f"glint replay reads the recording (exit {r.returncode})")
if r.returncode == 0:
    s = json.load(open(os.path.join(out, "summary.json")))
    names = [x["name"] for x in s["states"]]
    check(names[:2] == ["ATTRACT", "CAPTURE"], f"the replay starts the scan at the recorded press: {names}")
sys.exit(1 if failures else 0)
