#!/usr/bin/env python3
"""glint run riding out devices that misbehave (docs/kiosk.md, "Devices that misbehave"), on live
devices: the camera simulator and the sensor board's firmware on a pseudo-terminal.

1. The board's button starts a scan. Mid-scan the board is unplugged (its firmware killed: the
   pty hangs up) and plugged in again 2.5 s later (a new firmware process on the same link); the
   camera stops delivering for 4.5 s (--inject-fault camera-stall) and frames arrive out of order
   for a while (camera-shuffle). The kiosk says "sensor lost", pauses the scan, restarts the
   camera, drops the out-of-order frames, resumes, and the visit is not failed; nothing crashes,
   SIGTERM ends it with 0.
2. A frame loop that blocks (loop-stall) stops the watchdog pings: a stand-in for systemd's notify
   socket sees READY=1, WATCHDOG=1 pings, then none for longer than the watchdog interval.
3. A lost GL context (gl-lost) ends the program with one error line and exit code 1, so that
   systemd restarts it.
4. An input flood (input-flood: 3000 button and random key events a second for 10 s, the menu's
   chord among them): no crash, no way out of the kiosk, the PIN's lock-out holds (the flood types
   wrong PINs, never the right one), SIGTERM still ends it with 0.

usage: test_run_faults.py GLINT SENSOR_SIM CALIBRATION WORK_DIR
"""
import os
import shutil
import signal
import socket
import subprocess
import sys
import time

from glint_test_util import Checks, Process, scaled, write_kiosk_config

glint, sensor_sim, calibration, work = sys.argv[1:5]
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
check = Checks()

link = os.path.join(work, "sensor-pty")


def start_board(press):
    args = [sensor_sim, "--pty-link", link, "--trajectory", "kiosk"]
    if press:
        args += ["--press", press]
    board = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    for _ in range(100):
        if os.path.exists(link):
            break
        time.sleep(0.05)
    return board


def write_config(path):
    write_kiosk_config(path, calibration, f"serial:{link}", f"{work}/state")


config = os.path.join(work, "glint.toml")
write_config(config)

# 1. Sensor unplugged and replugged, camera stalled, frames out of order, all mid-scan. Each step
# waits for the program's own log line (a loaded machine starts it slowly), never for a fixed time.
board = start_board("0:1.0:1.1")
run = Process([glint, "run", "--config", config, "--max-seconds", "120",
               "--inject-fault", "camera-shuffle:3:4,camera-stall:10:14.5"])
try:
    check(run.wait_for("ATTRACT -> CAPTURE", 60), "the board's button started a live scan")
    time.sleep(1.5)
    board.kill()  # the cable pulled: the pty hangs up
    board.wait()
    check(run.wait_for("sensor: no orientation for", 30), "the unplugged sensor was noticed")
    time.sleep(2.0)
    if os.path.lexists(link):
        os.unlink(link)
    board = start_board(None)  # plugged in again
    check(run.wait_for("sensor: orientation again after", 30), "the replugged sensor was taken up again")
    check(run.wait_for("camera: frames again after", 60), "the camera delivered again")
    returncode, err = run.stop(signal.SIGTERM)
finally:
    board.terminate()
    board.wait(timeout=scaled(10))
print(err[-3000:])
check(returncode == 0, f"glint run rode the faults out and ended with 0 on SIGTERM (got {returncode})")
check("scan paused" in err and "scan resumed" in err, "the scan paused while the devices were lost and resumed")
check("camera: no frame for" in err and "camera: restarted" in err, "the stalled camera was restarted")
check("CAPTURE -> ATTRACT" not in err, "the visit was not failed by the faults")
check("failed" not in err.lower().replace("restart failed", ""), "no failure logged")

# 2. The watchdog: pings stop while the frame loop is blocked.
sock_path = os.path.join(work, "notify.sock")
sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
sock.bind(sock_path)
sock.settimeout(0.1)
env = dict(os.environ, NOTIFY_SOCKET=sock_path, WATCHDOG_USEC="400000")
env.pop("WATCHDOG_PID", None)
board = start_board(None)
try:
    run = subprocess.Popen([glint, "run", "--config", config, "--max-seconds", "14", "--inject-fault", "loop-stall:8:3"],
                           env=env, stderr=subprocess.PIPE, text=True)
    t0 = time.monotonic()
    messages = []  # (t, text)
    while run.poll() is None and time.monotonic() - t0 < scaled(60):
        try:
            messages.append((time.monotonic() - t0, sock.recv(4096).decode()))
        except socket.timeout:
            pass
    _, err = run.communicate(timeout=scaled(30))
finally:
    board.terminate()
    board.wait(timeout=scaled(10))
pings = [t for t, m in messages if "WATCHDOG=1" in m]
ready = [t for t, m in messages if "READY=1" in m]
check(run.returncode == 0, f"the stalled run ends with 0 (got {run.returncode}): {err[-300:]}")
check(bool(ready) and bool(pings) and ready[0] <= pings[0], "READY=1, then WATCHDOG=1 pings")
gaps = [b - a for a, b in zip(pings, pings[1:])]
longest = max(gaps) if gaps else 0
check(longest >= 2.5, f"no ping while the frame loop was blocked for 3 s (longest gap {longest:.2f} s, "
                      f"watchdog 0.4 s)")
check(any(t > (pings[0] if pings else 0) + 5 for t in pings), "pings again after the stall")

# 3. A lost GL context: one error line, exit 1.
board = start_board(None)
try:
    r = subprocess.run([glint, "run", "--config", config, "--max-seconds", "20", "--inject-fault", "gl-lost:2"],
                       capture_output=True, text=True, timeout=scaled(120))
finally:
    board.terminate()
    board.wait(timeout=scaled(10))
failed_lines = [l for l in r.stderr.splitlines() if "failed" in l]
print(r.stderr[-600:])
check(r.returncode == 1, f"a lost GL context exits with 1 (got {r.returncode})")
check(len(failed_lines) == 1 and "GL context was lost" in failed_lines[0],
      f"one error line naming the lost context: {failed_lines}")

# 4. An input flood with a PIN set.
pin_hash = subprocess.run(["openssl", "passwd", "-6", "93517284"], capture_output=True, text=True, check=True).stdout.strip()
with open(config, "a") as f:
    f.write(f"""[maintenance]
pin_hash = "{pin_hash}"
""")
board = start_board(None)
try:
    run = Process([glint, "run", "--config", config, "--max-seconds", "120", "--inject-fault", "input-flood:3:13:3000"])
    ended = run.wait_for("an input flood of", 90)
    time.sleep(1.0)
    alive = run.proc.poll() is None
    returncode, err = run.stop(signal.SIGTERM)
finally:
    board.terminate()
    board.wait(timeout=scaled(10))
flood = [l for l in err.splitlines() if "input flood of" in l]
print("\n".join(flood), err[-1500:])
check(ended and alive, "the kiosk lived through the flood: " + (flood[0].strip() if flood else "no flood logged"))
check(returncode == 0, f"SIGTERM after the flood: exit 0 (got {returncode})")
check("ATTRACT -> CAPTURE" in err, "the flood's presses reached the visitor flow")
check("opened by the key chord" in err, "the flood typed the menu's chord (the PIN prompt opened)")
check("maintenance PIN: locked out" in err, "the flood's wrong PINs locked the prompt")
check("maintenance PIN: success" not in err, "the flood never unlocked the menu")
check("maintenance menu: restart" not in err and "stopped after" in err, "no restart or exit but SIGTERM's")
check.exit()
