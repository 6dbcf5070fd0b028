#!/usr/bin/env python3
"""glint run after a restart (docs/state.md): the last scene saved in the state directory is
verified and loaded (ATTRACT shows it); a damaged scene, or an older build's plain scene
directory, is set aside into <state>/corrupt/, logged naming the file and the reason, and the
appliance still starts (the grey room); a damaged calibration in the state directory is refused
(exit 2, the file and the reason named) and set aside.

usage: test_restart_scene.py GLINT STATE_WRITER SESSION_DIR WORK_DIR
STATE_WRITER: tests/faults' glint_state_writer, which saves a scene through the state store.
SESSION_DIR: a simulated session whose calibration.json and sensors.glrec the live run borrows.
"""
import glob
import os
import shutil
import subprocess
import sys

# The Python tests' shared helpers (GLINT_TEST_TIME_SCALE).
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "kiosk"))
from glint_test_util import scaled, write_kiosk_config  # noqa: E402

glint, writer, session, work = sys.argv[1:5]
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
state = os.path.join(work, "state")
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


config = os.path.join(work, "glint.toml")
write_kiosk_config(config, f"{session}/calibration.json", f"replay:{session}/sensors.glrec", state)


def run(what):
    r = subprocess.run([glint, "run", "--config", config, "--max-seconds", "2"], capture_output=True, text=True,
                       timeout=scaled(120))
    check(r.returncode == 0, f"{what}: glint run started and stopped cleanly (exit {r.returncode})")
    if r.returncode != 0:
        print(r.stderr[-3000:])
    return r.stderr


# A scene saved by the store (the writer's version 1, through the kiosk's own path).
subprocess.run([writer, state, "1", "1"], check=True, stdout=subprocess.DEVNULL)
err = run("a saved scene")
check("the last scene (0000000001, 64x32) verified and loaded" in err,
      "the last scene is verified and loaded at start: " + next((l for l in err.splitlines() if "state:" in l), "(no line)"))
check(not os.path.exists(os.path.join(state, "corrupt")), "nothing set aside")

# One byte of the saved map flipped: set aside, logged with the file and the reason, grey room.
env = os.path.join(os.path.realpath(os.path.join(state, "scene")), "env.exr")
with open(env, "r+b") as f:
    f.seek(os.path.getsize(env) // 2)
    b = f.read(1)
    f.seek(-1, 1)
    f.write(bytes([b[0] ^ 0x10]))
err = run("a damaged scene")
line = next((l for l in err.splitlines() if "set aside" in l), "")
check("env.exr: checksum" in line and "corrupt" in line, "the damage is logged with the file and the reason: " + line)
check("verified and loaded" not in err, "the damaged scene is not shown")
aside = glob.glob(os.path.join(state, "corrupt", "*", "scene.generation-*", "env.exr"))
check(len(aside) == 1, f"the damaged map was moved aside, not deleted ({aside})")
check(not os.path.lexists(os.path.join(state, "scene")) or not os.listdir(os.path.join(state, "scene")),
      "the scene is gone from its place (an empty directory at most)")

# An older build's plain scene directory (no manifest): set aside, the appliance starts.
shutil.rmtree(os.path.join(state, "scene"), ignore_errors=True)
os.makedirs(os.path.join(state, "scene"))
shutil.copy(aside[0] if aside else env, os.path.join(state, "scene", "env.exr"))
err = run("an unverified scene directory")
line = next((l for l in err.splitlines() if "set aside" in l), "")
check("not written by the state store" in line, "an unverified scene is set aside and logged: " + line)
check(len(glob.glob(os.path.join(state, "corrupt", "*"))) == 2, "two set-asides kept")

# The state directory's calibration (glint run's default) with one digit changed: it still parses,
# but it does not verify; glint run refuses it naming the file and the reason, and sets it aside.
cal = os.path.join(state, "calibration.json")
check(os.path.islink(cal), "the writer saved the calibration as a state item")
real = os.path.realpath(cal)
text = open(real).read()
at = text.find('"time_offset_s": 1')
if at >= 0:
    open(real, "w").write(text[:at + 17] + "2" + text[at + 18:])
with open(config) as f:
    cfg = f.read()
with open(config, "w") as f:
    f.write(cfg.replace(f'calibration = "{session}/calibration.json"', 'calibration = ""'))
r = subprocess.run([glint, "run", "--config", config, "--max-seconds", "2"], capture_output=True, text=True, timeout=scaled(120))
check(r.returncode == 2, f"a damaged calibration: glint run exits 2, bad input (got {r.returncode})")
check("calibration.json: the camera calibration did not verify: calibration.json: checksum" in r.stderr and "set aside in" in r.stderr,
      "the error names the file and the reason: " + r.stderr.strip()[-300:])
check(len(glob.glob(os.path.join(state, "corrupt", "*", "calibration.json.generation-*", "calibration.json"))) == 1,
      "the damaged calibration was moved aside")

sys.exit(1 if failures else 0)
