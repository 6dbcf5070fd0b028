#!/usr/bin/env python3
"""glint run with its GPIO (docs/kiosk.md, "Live"): the visitor's button, the technician's key
switch and the button's lamp, through the test chip `[gpio] chip = "fifo:PATH"` (raw levels
written into a named pipe, the lamp's changes read from PATH.out; the libgpiod chip is the same
interface). The lamp blinks in ATTRACT and goes dark when the scan starts; the button (active low)
starts the scan; the key switch opens the maintenance menu without the PIN and closes it when
turned back; on SIGTERM the lamp is left dark.

usage: test_run_gpio.py GLINT SESSION_DIR WORK_DIR
"""
import os
import shutil
import signal
import sys
import time

from glint_test_util import Checks, Process, write_kiosk_config

glint, session, work = sys.argv[1:4]
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
check = Checks()

fifo = os.path.join(work, "gpio")
os.mkfifo(fifo)
config = os.path.join(work, "glint.toml")
write_kiosk_config(config, f"{session}/calibration.json", f"replay:{session}/sensors.glrec", f"{work}/state",
                   gpio=f'chip = "fifo:{fifo}"\nbutton_line = 17\nkey_switch_line = 27\nlamp_line = 22')

def lamp_changes():
    path = fifo + ".out"
    if not os.path.exists(path):
        return []
    return [tuple(int(x) for x in l.split()) for l in open(path).read().splitlines() if l.strip()]


run = Process([glint, "run", "--config", config, "--max-seconds", "120"])
pipe = open(fifo, "w")


def level(line, value):
    pipe.write(f"{line} {value}\n")
    pipe.flush()


try:
    check(run.wait_for("display headless: opened", 60), "the kiosk started")
    time.sleep(3.5)
    attract = [c for c in lamp_changes() if c[1] == 22]
    check(len(attract) >= 4 and {c[2] for c in attract} == {0, 1},
          f"the lamp blinks in ATTRACT ({len(attract)} changes in about 3 s)")
    level(17, 0)  # pressed (active low)
    time.sleep(0.2)
    level(17, 1)
    check(run.wait_for("ATTRACT -> CAPTURE", 30), "the GPIO button started the scan")
    time.sleep(1.5)
    during = lamp_changes()
    time.sleep(1.5)
    after = lamp_changes()
    check(len(after) == len(during) and after[-1][2] == 0, "the lamp is dark and steady while the visitor scans")
    level(27, 0)  # key switch turned on
    check(run.wait_for("maintenance menu: opened by the key switch", 30), "the key switch opened the menu (no PIN)")
    time.sleep(0.5)
    level(27, 1)
    check(run.wait_for("maintenance menu: closed by the key switch", 30), "turning the key back closed it")
finally:
    pipe.close()
    returncode, err = run.stop(signal.SIGTERM)
print(err[-2000:])
check(returncode == 0, f"SIGTERM: exit 0 (got {returncode})")
check("key switch on" in err and "key switch off" in err, "the key switch's turns are journalled")
final = [c for c in lamp_changes() if c[1] == 22]
check(bool(final) and final[-1][2] == 0, "the lamp is left dark when the kiosk stops")
check.exit()
