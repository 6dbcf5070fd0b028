#!/usr/bin/env python3
"""glint run under a stand-in for systemd (docs/service.md): the notify socket sees READY=1 after
the first frame, STATUS= with the state, WATCHDOG=1 pings from the frame loop; SIGHUP reloads the
configuration (a broken file keeps the running one); SIGTERM ends the program cleanly within 2 s
with STOPPING=1; a wrong key in the configuration is one error line naming file, line and key.

usage: test_run_service.py GLINT SESSION_DIR WORK_DIR
SESSION_DIR: a simulated session whose calibration.json and sensors.glrec the live run borrows.
"""
import os
import signal
import socket
import subprocess
import sys
import time

from glint_test_util import scaled, write_kiosk_config

glint, session, work = sys.argv[1], sys.argv[2], sys.argv[3]
os.makedirs(work, exist_ok=True)
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


def write_config(path, ar_idle_s=45, extra=""):
    write_kiosk_config(path, f"{session}/calibration.json", f"replay:{session}/sensors.glrec", f"{work}/state",
                       extra=f"[timeouts]\nar_idle_s = {ar_idle_s}\n{extra}")


config = os.path.join(work, "glint.toml")
write_config(config)
sock_path = os.path.join(work, "notify.sock")
if os.path.exists(sock_path):
    os.unlink(sock_path)
sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
sock.bind(sock_path)
sock.settimeout(0.2)
# The watchdog interval, the windows and the exit's limit grow with GLINT_TEST_TIME_SCALE (an
# instrumented build draws each frame several times slower); at 1: WatchdogSec 0.4 s, 6 s, 2 s.
watchdog_s = scaled(0.4)
env = dict(os.environ, NOTIFY_SOCKET=sock_path, WATCHDOG_USEC=str(round(watchdog_s * 1e6)))
env.pop("WATCHDOG_PID", None)
t_start = time.monotonic()
proc = subprocess.Popen([glint, "run", "--config", config], env=env, stderr=subprocess.PIPE, text=True)

messages = []  # (t since start, text)


def drain(until):
    while time.monotonic() < until:
        try:
            data = sock.recv(4096).decode()
            messages.append((time.monotonic() - t_start, data))
        except socket.timeout:
            pass


drain(time.monotonic() + scaled(6.0))
ready = [t for t, m in messages if "READY=1" in m]
check(bool(ready), "READY=1 sent")
if ready:
    print(f"     READY after {ready[0]:.2f} s (process start to the first frame on screen, on a loaded CI machine)")
check(any("STATUS=ATTRACT" in m for _, m in messages), "STATUS= names the state (ATTRACT)")
pings = [t for t, m in messages if "WATCHDOG=1" in m]
check(len(pings) >= 5, f"WATCHDOG=1 pinged from the frame loop ({len(pings)} pings in {scaled(6.0):g} s at WatchdogSec {watchdog_s:g} s)")
gaps = [b - a for a, b in zip(pings, pings[1:])]
check(bool(gaps) and max(gaps) < watchdog_s,
      f"no two pings further apart than the watchdog interval (largest {max(gaps) if gaps else 0:.3f} s)")

# SIGHUP: a live key changed, then a broken file (kept the running configuration).
write_config(config, ar_idle_s=30)
proc.send_signal(signal.SIGHUP)
drain(time.monotonic() + scaled(1.5))
check(any("RELOADING=1" in m for _, m in messages), "SIGHUP: RELOADING=1 sent")
with open(config, "a") as f:
    f.write("[timeouts]\nnot_a_key = 1\n")
proc.send_signal(signal.SIGHUP)
drain(time.monotonic() + scaled(1.5))
check(proc.poll() is None, "a broken configuration on SIGHUP does not stop the appliance")

t_term = time.monotonic()
proc.send_signal(signal.SIGTERM)
try:
    _, err = proc.communicate(timeout=scaled(10))
except subprocess.TimeoutExpired:
    proc.kill()
    _, err = proc.communicate()
t_exit = time.monotonic() - t_term
drain(time.monotonic() + scaled(0.3))
print(err[-2000:])
check(proc.returncode == 0, f"SIGTERM: exit code 0 (got {proc.returncode})")
check(t_exit <= scaled(2.0), f"SIGTERM to exit within {scaled(2.0):g} s ({t_exit:.2f} s)")
check(any("STOPPING=1" in m for _, m in messages), "STOPPING=1 sent")
check("config reloaded" in err or "applied timeouts.ar_idle_s" in err, "the first SIGHUP reloaded the changed key")
check("keeping the running" in err, "the second SIGHUP reported the broken file and kept the running configuration")

# A wrong key at start: exit 1 with one line naming file, line and key.
bad = os.path.join(work, "bad.toml")
write_config(bad, extra="[capture]\nmap_widht = 512\n")
r = subprocess.run([glint, "run", "--config", bad], capture_output=True, text=True, timeout=scaled(30))
check(r.returncode == 2, f"an unknown key: exit 2, bad input (got {r.returncode})")
check("bad.toml" in r.stderr and "capture.map_widht" in r.stderr, "the error names the file and the key: " + r.stderr.strip()[:200])

sys.exit(1 if failures else 0)
