#!/usr/bin/env python3
"""Start-up cost of the glint commands, measured as whole processes (what systemd and scripts pay).

Runs each command N times (default 10) after one warm-up run and reports the median and the
fastest wall time, and the shared libraries each executable loads (ldd). Writes a Markdown
table to --out. Usage: startup_bench.py BUILD_DIR [--runs N] [--out FILE]
"""
import argparse
import datetime
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time

TARGETS_MS = {"glint --version": 30.0, "glint convolve (8x4 map)": 60.0}


def cpu_name():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def shared_libraries(path):
    out = subprocess.run(["ldd", path], capture_output=True, text=True, check=True).stdout
    return sum(1 for line in out.splitlines() if line.strip())


def time_runs(args, runs):
    subprocess.run(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)  # warm-up
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        subprocess.run(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
        times.append((time.perf_counter() - start) * 1e3)
    return statistics.median(times), min(times)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("build_dir")
    p.add_argument("--runs", type=int, default=10)
    p.add_argument("--out", default=None)
    a = p.parse_args()
    glint = os.path.join(a.build_dir, "appliance/app/glint")
    vision = os.path.join(a.build_dir, "appliance/app/glint-vision")
    source = os.path.join(os.path.dirname(__file__), "../../data/courtyard_256x128.exr")
    with tempfile.TemporaryDirectory() as work:
        small = os.path.join(work, "small")
        subprocess.run([glint, "convolve", source, "--out", small, "--irradiance", "--size", "8x4",
                        "--engine", "cpu"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
        eight_by_four = os.path.join(small, "irradiance.exr")
        cases = [
            ("glint --version", [glint, "--version"]),
            ("glint --help", [glint, "--help"]),
            ("glint convolve (8x4 map)", [glint, "convolve", eight_by_four, "--out", os.path.join(work, "o"),
                                          "--irradiance", "--shininess", "20"]),
            ("glint capture --help (runs glint-vision)", [glint, "capture", "--help"]),
        ]
        rows = []
        for name, args in cases:
            median, fastest = time_runs(args, a.runs)
            target = TARGETS_MS.get(name)
            verdict = "" if target is None else ("met" if median <= target else "MISSED")
            rows.append((name, median, fastest, target, verdict))
            print(f"{name:45s} median {median:7.1f} ms  fastest {fastest:7.1f} ms"
                  + (f"  target {target:.0f} ms: {verdict}" if target else ""), file=sys.stderr)
    libs = {"glint": shared_libraries(glint), "glint-vision": shared_libraries(vision)}
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        "# Start-up of the glint commands",
        "",
        f"Measured {now} on {cpu_name()} ({os.cpu_count()} cores) with "
        f"`tests/bench/run_startup_bench.sh` ({a.runs} runs after a warm-up; whole processes, wall time).",
        "",
        "| command | median | fastest | target |",
        "|---|---|---|---|",
    ]
    for name, median, fastest, target, verdict in rows:
        t = f"<= {target:.0f} ms, {verdict}" if target else ""
        lines.append(f"| `{name}` | {median:.1f} ms | {fastest:.1f} ms | {t} |")
    lines += [
        "",
        "| executable | shared libraries (ldd) |",
        "|---|---|",
        f"| `glint` (convolve, compare, sensors) | {libs['glint']} |",
        f"| `glint-vision` (simulate, capture, calibrate, cameras: OpenCV, libcamera) | {libs['glint-vision']} |",
        "",
        "Before the split (one `glint` executable linking everything, commit d64db0f): 158 shared libraries, "
        "`glint --help` 180-250 ms, most of it loading OpenCV's imgcodecs (GDAL, HDF5, Poppler, ...) and "
        "libcamera's tracing (lttng-ust).",
        "",
    ]
    text = "\n".join(lines)
    if a.out:
        with open(a.out, "w") as f:
            f.write(text)
    else:
        print(text)
    return 0 if all(v != "MISSED" for *_, v in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
