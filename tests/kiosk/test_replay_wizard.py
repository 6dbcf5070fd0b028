"""The maintenance menu's camera calibration wizard through the real program: `glint replay` of
simulated ChArUco board views with a technician's key presses recorded in events.csv (the key
switch opens the menu, F2 the calibrations page, space starts the first wizard; later space presses
Apply, which has taken the focus). The wizard must keep 12 views, compute the lens within 1 % of
the simulator's true focal length, and Apply must write the calibration into the replay's output.

usage: test_replay_wizard.py GLINT WORK_DIR
"""
import json
import os
import shutil
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from glint_test_util import Checks, scaled  # noqa: E402


def main():
    glint, work = sys.argv[1], sys.argv[2]
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    session, out = os.path.join(work, "board"), os.path.join(work, "out")
    vision = os.path.join(os.path.dirname(glint), "glint-vision")
    subprocess.run([vision, "simulate", "--charuco", "24", "--size", "640x360", "--out", session],
                   check=True, stdout=subprocess.DEVNULL)
    # The views half a second apart (the simulator writes one a second): a shorter replay.
    frames_csv = os.path.join(session, "frames.csv")
    with open(frames_csv) as f:
        lines = f.read().splitlines()
    rows = [lines[0]]
    for k, line in enumerate(lines[1:]):
        cols = line.split(",")
        cols[1] = str(1_000_000_000 + k * 500_000_000)
        rows.append(",".join(cols))
    with open(frames_csv, "w") as f:
        f.write("\n".join(rows) + "\n")
    last_s = 1 + (len(rows) - 2) * 0.5
    apply_ns = int((last_s - 0.3) * 1e9)
    with open(os.path.join(session, "events.csv"), "w") as f:
        f.write("t_ns,source,event\n"
                "1100000000,key_switch,on\n"
                "1200000000,key,F2\n1250000000,key_up,F2\n"
                "1400000000,key,space\n1450000000,key_up,space\n"
                f"{apply_ns},key,space\n{apply_ns + 50_000_000},key_up,space\n")

    run = subprocess.run([glint, "replay", session, "--out", out, "--snapshot-every", "0"],
                         capture_output=True, text=True, timeout=scaled(600))
    print(run.stderr[-3000:])
    check = Checks()
    check(run.returncode == 0, f"glint replay exits 0 (got {run.returncode})")
    log = run.stderr
    check("maintenance menu: opened by the key switch" in log, "the key switch opens the menu")
    check("calibration wizard: camera started" in log, "space on the calibrations page starts the camera wizard")
    check("calibration wizard: camera: RMS reprojection error" in log, "the wizard finishes with its error")
    check("maintenance menu: calibration saved to" in log, "Apply saves the calibration")
    runs = os.path.join(out, "calibration-sessions")
    kept = []
    if os.path.isdir(runs):
        for d in os.listdir(runs):
            fd = os.path.join(runs, d, "frames")
            if os.path.isdir(fd):
                kept += os.listdir(fd)
    check(len(kept) == 12, f"the wizard kept 12 views in its session (got {len(kept)})")
    saved = os.path.join(out, "calibration.json")
    check(os.path.isfile(saved), "calibration.json is written into --out")
    if os.path.isfile(saved):
        with open(saved) as f:
            k = json.load(f)["intrinsics"]
        with open(os.path.join(session, "truth", "calibration.json")) as f:
            t = json.load(f)["intrinsics"]
        print(f"fx {k['fx']:.2f} (true {t['fx']:.2f}), fy {k['fy']:.2f} (true {t['fy']:.2f}), "
              f"k1 {k['k1']:.4f} (true {t['k1']:.4f})")
        check(abs(k["fx"] / t["fx"] - 1) < 0.01 and abs(k["fy"] / t["fy"] - 1) < 0.01,
              "the applied focal lengths are within 1 % of the true camera's")
        with open(os.path.join(session, "calibration.json")) as f:
            guess = json.load(f)["intrinsics"]
        check(guess["k1"] == 0 and abs(k["k1"] - t["k1"]) < 0.02,
              "the lens distortion, unknown to the session's calibration, is found")
    check.exit()


if __name__ == "__main__":
    main()
