"""What the tests that run glint as a process share: named checks that print ok/FAIL and decide the
exit code, and a program's stderr read line by line on a thread, so that a test waits for the
program's own log lines instead of for fixed times (a loaded machine starts glint slowly)."""
import json
import os
import subprocess
import sys
import threading
import time


def _time_scale():
    """GLINT_TEST_TIME_SCALE (default 1): how many times longer than usual the programs under test
    may take. An instrumented build (scripts/run-sanitizers.sh sets 4) runs several times slower;
    the tests' time limits, waits and the intervals they allow grow with it, what they check does
    not change. Unset, every limit is as written."""
    text = os.environ.get("GLINT_TEST_TIME_SCALE", "1")
    try:
        scale = float(text)
    except ValueError:
        sys.exit(f"GLINT_TEST_TIME_SCALE={text!r}: not a number")
    if not scale >= 1:
        sys.exit(f"GLINT_TEST_TIME_SCALE={text!r}: must be 1 or more")
    return scale


TIME_SCALE = _time_scale()


def scaled(seconds):
    """`seconds` (a time limit or a wait) times GLINT_TEST_TIME_SCALE."""
    return seconds * TIME_SCALE


class Checks:
    def __init__(self):
        self.failures = []

    def __call__(self, ok, what):
        print(("ok   " if ok else "FAIL ") + what)
        if not ok:
            self.failures.append(what)

    def exit(self):
        sys.exit(1 if self.failures else 0)


def run_replay(check, glint, session, out, tail=3000):
    """`glint replay SESSION --out OUT`, its output's tails printed; checks that it exits 0 (else
    exits 1) and returns the process and OUT/summary.json."""
    r = subprocess.run([glint, "replay", session, "--out", out], capture_output=True, text=True,
                       timeout=scaled(1500))
    print(r.stdout[-tail:])
    print(r.stderr[-tail:])
    check(r.returncode == 0, f"glint replay exits 0 (got {r.returncode})")
    if r.returncode != 0:
        sys.exit(1)
    return r, json.load(open(os.path.join(out, "summary.json")))


class Process:
    """A started program whose stderr lines are collected as they come."""

    def __init__(self, args, **popen_args):
        self.lines = []
        self.proc = subprocess.Popen(args, stderr=subprocess.PIPE, text=True, **popen_args)
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self):
        for line in self.proc.stderr:
            self.lines.append(line)

    def wait_for(self, text, timeout_s):
        """True once a stderr line holds `text`, False after timeout_s (times TIME_SCALE)."""
        t0 = time.monotonic()
        while time.monotonic() - t0 < scaled(timeout_s):
            if any(text in line for line in self.lines):
                return True
            if self.proc.poll() is not None and not self._reader.is_alive():
                return any(text in line for line in self.lines)
            time.sleep(0.05)
        return False

    def stop(self, sig, timeout_s=30):
        """Sends `sig`, waits (kills after timeout_s, times TIME_SCALE); returns the exit code and all
        of stderr."""
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
        try:
            self.proc.wait(timeout=scaled(timeout_s))
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        self._reader.join(timeout=10)
        return self.proc.returncode, "".join(self.lines)

    def stderr(self):
        return "".join(self.lines)


COURTYARD_CAMERA = "simulator:/usr/share/blender/datafiles/studiolights/world/courtyard.exr"


def write_kiosk_config(path, calibration, sensor, state_dir, camera=COURTYARD_CAMERA, gpio='chip = ""', extra=""):
    """A glint.toml for `glint run` in a test: headless 320x180, the camera simulator (the courtyard
    by default), the calibration file, the sensor source spec, the [gpio] table's lines (no chip by
    default), the state directory, and `extra` TOML appended (whole tables)."""
    with open(path, "w") as f:
        f.write(f"""[display]
kind = "headless"
width = 320
height = 180
[camera]
source = "{camera}"
calibration = "{calibration}"
[sensor]
source = "{sensor}"
[gpio]
{gpio}
[state]
dir = "{state_dir}"
{extra}""")
