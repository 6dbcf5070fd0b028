#!/usr/bin/env python3
"""glint replay --repeat / --loop-for (the soak, docs/kiosk.md "Soak"): correctness only, no timing.

A tiny session (the shipped one's first 5 s of frames, without its kiosk recording: the button is
pressed at the first frame) replayed twice in one process: soak.csv has its start row and one row
per pass, every pass deletes the GL objects it made and closes the descriptors it opened, and
summary.json is written as without the flag. Without the flag no soak.csv is written.
usage: test_replay_soak.py GLINT SHIPPED_SESSION WORK_DIR
"""
import csv
import glob
import json
import os
import shutil
import subprocess
import sys

from glint_test_util import scaled

glint, shipped, work = sys.argv[1:4]
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


shutil.rmtree(work, ignore_errors=True)
session = os.path.join(work, "tiny")
os.makedirs(session)
for name in ("session.json", "calibration.json", "sensors.glrec"):
    shutil.copy(os.path.join(shipped, name), session)
os.symlink(os.path.abspath(os.path.join(shipped, "frames")), os.path.join(session, "frames"))
with open(os.path.join(shipped, "frames.csv")) as src, open(os.path.join(session, "frames.csv"), "w") as dst:
    dst.writelines(src.readlines()[:16])  # the header and 15 frames (5 s)


def replay(out, *extra):
    return subprocess.run([glint, "replay", session, "--out", out, "--snapshot-every", "0", *extra],
                          capture_output=True, text=True, timeout=scaled(600))


out = os.path.join(work, "soak")
r = replay(out, "--repeat", "2")
check(r.returncode == 0, f"glint replay --repeat 2 exits 0 (exit {r.returncode}; {r.stderr.strip()[-300:]})")
rows = list(csv.DictReader(open(os.path.join(out, "soak.csv")))) if r.returncode == 0 else []
passes = [x for x in rows if x["kind"] == "pass"]
check([x["pass"] for x in passes] == ["1", "2"], f"soak.csv has one row per pass: {[x['pass'] for x in passes]}")
check(len(rows) > 0 and rows[0]["kind"] == "start", "soak.csv starts with the row before the first pass")
if passes:
    start = rows[0]
    check(all(int(x["gl_total"]) == int(start["gl_total"]) for x in passes),
          f"every pass deletes its GL objects: start {start['gl_total']}, after passes {[x['gl_total'] for x in passes]}")
    check(any(int(x["gl_total"]) > int(start["gl_total"]) for x in rows if x["kind"] == "during") or
          not any(x["kind"] == "during" for x in rows),
          "GL objects are counted while a pass runs (the counters are live)")
    check(passes[0]["fds"] == passes[1]["fds"], f"no descriptors left open by a pass: {[x['fds'] for x in passes]}")
    check(all(int(x["frames"]) > 0 and float(x["frame_p99_ms"]) >= float(x["frame_median_ms"]) > 0 for x in passes),
          "each pass row has its frame count and percentiles")
    check(all(int(x["rss_kib"]) > 0 and int(x["heap_kib"]) > 0 for x in rows), "memory is sampled")
summary = json.load(open(os.path.join(out, "summary.json"))) if r.returncode == 0 else {}
# The kiosk re-executes itself on jemalloc where Debian's libjemalloc2 is installed (it is in
# install-deps.sh and the .deb's Depends), else it stays on glibc (core/memory.hpp).
jemalloc = glob.glob("/usr/lib/*/libjemalloc.so.2") + glob.glob("/usr/lib/libjemalloc.so.2")
# (An AddressSanitizer build keeps the sanitizer's allocator: "asan".)
check(summary.get("allocator") in ("jemalloc" if jemalloc else "glibc", "asan"),
      f"the kiosk's allocator is {'jemalloc' if jemalloc else 'glibc'}: {summary.get('allocator')}")
check([s["name"] for s in summary.get("states", [])] == ["ATTRACT", "CAPTURE"],
      f"summary.json is the last pass's replay: {summary.get('states')}")

plain = os.path.join(work, "plain")
r = replay(plain)
check(r.returncode == 0, f"glint replay without the flag exits 0 (exit {r.returncode})")
check(os.path.exists(os.path.join(plain, "summary.json")) and not os.path.exists(os.path.join(plain, "soak.csv")),
      "without the flag: summary.json and no soak.csv")

r = replay(os.path.join(work, "both"), "--repeat", "2", "--loop-for", "60")
check(r.returncode != 0 and "excludes" in (r.stderr + r.stdout), "--repeat and --loop-for exclude each other")

if failures:
    sys.exit(f"{len(failures)} check(s) failed")
