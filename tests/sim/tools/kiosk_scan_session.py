#!/usr/bin/env python3
"""Makes a session of a kiosk session's scan alone, for `glint capture` (docs/capture.md "Kiosk
sessions": the compression was measured with it). The kiosk program captures only the scan's
frames; a capture of the whole session would also take in the attract and AR frames, which see
the table.

Usage: kiosk_scan_session.py KIOSK_SESSION OUT_DIR
OUT_DIR gets frames.csv and truth/camera.csv cut to the frames inside kiosk.json's "scan" phase,
and links to the rest (frames, sensor stream, calibrations, map).
"""
import json
import os
import sys


def main(argv):
    if len(argv) != 3:
        print(__doc__.strip().splitlines()[-3], file=sys.stderr)
        return 2
    src, dst = os.path.abspath(argv[1]), argv[2]
    with open(os.path.join(src, "kiosk.json"), encoding="utf-8") as f:
        phases = {p["name"]: p for p in json.load(f)["phases"]}
    if "scan" not in phases:
        print("%s/kiosk.json: no scan phase" % src, file=sys.stderr)
        return 2
    scan = phases["scan"]
    os.makedirs(os.path.join(dst, "truth"), exist_ok=True)
    for rel in ["session.json", "calibration.json", "sensors.glrec", "frames",
                "truth/env.exr", "truth/calibration.json"]:
        link = os.path.join(dst, rel)
        if not os.path.lexists(link):
            os.symlink(os.path.join(src, rel), link)
    kept = set()
    with open(os.path.join(src, "frames.csv"), encoding="utf-8") as i, \
            open(os.path.join(dst, "frames.csv"), "w", encoding="utf-8") as o:
        o.write(i.readline())
        for line in i:
            fields = line.split(",")
            if scan["start_ns"] <= int(fields[1]) < scan["end_ns"]:
                o.write(line)
                kept.add(fields[0])
    with open(os.path.join(src, "truth", "camera.csv"), encoding="utf-8") as i, \
            open(os.path.join(dst, "truth", "camera.csv"), "w", encoding="utf-8") as o:
        o.write(i.readline())
        for line in i:
            if line.split(",")[0] in kept:
                o.write(line)
    print("%s: %d frames of the scan" % (dst, len(kept)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
