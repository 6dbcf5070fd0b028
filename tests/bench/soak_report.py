#!/usr/bin/env python3
"""tests/bench/results/soak.md from the soak.csv of `glint replay --loop-for` (run_soak_bench.sh).

Start: the row after the first pass (the warm-up: the driver's shader variants, the allocator's
arenas and the libraries' caches are made in it). End: the row after the last pass. Both are
taken between passes, where nothing of a visit is alive, so growth between them is what a visit
leaves behind.
usage: soak_report.py SOAK_CSV OUT_MD STARTED LOAD_BEFORE LOAD_AFTER SECONDS
"""
import csv
import platform
import sys

RSS_TARGET_MIB = 2.0


def main():
    path, out, started, before, after, seconds = sys.argv[1:7]
    rows = list(csv.DictReader(open(path)))
    passes = [r for r in rows if r["kind"] == "pass"]
    if len(passes) < 2:
        sys.exit(f"soak_report.py: {path}: {len(passes)} pass(es); the report needs a warm-up pass and at least one more")
    start, end = passes[0], passes[-1]
    gl_kinds = [k for k in rows[0] if k.startswith("gl_") and k != "gl_total"]
    cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), platform.machine())
    mib = lambda r, k: int(r[k]) / 1024.0
    peak = {}
    for r in rows:
        if r["kind"] in ("during", "pass"):
            peak[r["pass"]] = max(peak.get(r["pass"], 0.0), mib(r, "rss_kib"))

    rss_growth = mib(end, "rss_kib") - mib(start, "rss_kib")
    heap_growth = mib(end, "heap_kib") - mib(start, "heap_kib")
    fd_growth = int(end["fds"]) - int(start["fds"])
    gl_growth = int(end["gl_total"]) - int(start["gl_total"])
    thread_growth = int(end["threads"]) - int(start["threads"])
    ok = lambda b: "yes" if b else "**no**"
    wall = float(end["wall_s"])
    lines = [
        "# Soak (issue 18, part 3)",
        "",
        f"Command: `tests/bench/run_soak_bench.sh build tests/bench/results/soak.md {seconds}`, that is "
        f"`nice -n 5 glint replay data/sessions/kiosk --out DIR --snapshot-every 0 --loop-for {seconds}`: "
        f"the shipped session (81 s of session time) replayed {len(passes)} times in one process on one headless "
        f"display and GL context (Mesa llvmpipe, 1280x720), {wall / 60:.1f} min of wall time. Started {started}; "
        f"machine: {cpu}, 2 cores, shared with other jobs (load average before {before}, after {after}): "
        "frame times are the loaded machine's, compare passes within this run only.",
        "",
        "Rows are sampled between passes (after a pass's kiosk loop, source and GL objects are gone). "
        "Start: after pass 1 (the warm-up). RSS: VmRSS; heap: the allocator's bytes in use (core/memory.hpp "
        "heap_usage: jemalloc's stats.allocated, or glibc's mallinfo2); "
        "descriptors: /proc/self/fd; GL: names alive in the RAII wrappers of appliance/gl/gl_objects.hpp "
        "(the headless display's own two renderbuffers are raw calls and not counted).",
        "",
        "| | pass | wall s | RSS MiB | heap MiB | descriptors | threads | GL objects | frame median ms | frame p99 ms |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for label, r in (("start (after warm-up)", start), ("end", end)):
        lines.append(f"| {label} | {r['pass']} | {float(r['wall_s']):.0f} | {mib(r, 'rss_kib'):.1f} | {mib(r, 'heap_kib'):.1f} | "
                     f"{r['fds']} | {r['threads']} | {r['gl_total']} | {float(r['frame_median_ms']):.2f} | "
                     f"{float(r['frame_p99_ms']):.2f} |")
    lines += [
        "",
        "| growth, start to end | value | target | met |",
        "|---|---|---|---|",
        f"| resident memory | {rss_growth:+.2f} MiB | < {RSS_TARGET_MIB:.0f} MiB | {ok(rss_growth < RSS_TARGET_MIB)} |",
        f"| heap in use | {heap_growth:+.2f} MiB | | |",
        f"| open descriptors | {fd_growth:+d} | 0 | {ok(fd_growth <= 0)} |",
        f"| live GL objects | {gl_growth:+d} | 0 | {ok(gl_growth <= 0)} |",
        f"| threads | {thread_growth:+d} | | |",
    ]
    if len(passes) >= 3:
        # The allocator's arenas may take more than one pass to reach their size: the same growth
        # from the second pass on, beside the brief's (from the first).
        p2 = passes[1]
        lines.append(f"| resident memory from pass 2 to the end | {mib(end, 'rss_kib') - mib(p2, 'rss_kib'):+.2f} MiB | "
                     f"< {RSS_TARGET_MIB:.0f} MiB | {ok(mib(end, 'rss_kib') - mib(p2, 'rss_kib') < RSS_TARGET_MIB)} |")
    if "heap_held_kib" in start:
        lines.append(f"| heap held from the system (jemalloc stats.resident, or glibc mallinfo2 arena + hblkhd) | "
                     f"{mib(end, 'heap_held_kib') - mib(start, 'heap_held_kib'):+.2f} MiB | | |")
    lines += [
        "",
        "GL objects by kind at the start / end: "
        + ", ".join(f"{k[3:]} {start[k]} / {end[k]}" for k in gl_kinds) + ".",
        "",
        "Every pass (peak RSS: the largest sample within the pass, every 5 s):",
        "",
        "| pass | ended at s | RSS MiB | peak RSS MiB | heap MiB | descriptors | threads | GL objects | frames | median ms | p99 ms |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in passes:
        lines.append(f"| {r['pass']} | {float(r['wall_s']):.0f} | {mib(r, 'rss_kib'):.1f} | {peak[r['pass']]:.1f} | "
                     f"{mib(r, 'heap_kib'):.1f} | {r['fds']} | {r['threads']} | {r['gl_total']} | {r['frames']} | "
                     f"{float(r['frame_median_ms']):.2f} | {float(r['frame_p99_ms']):.2f} |")
    text = "\n".join(lines) + "\n"
    open(out, "w").write(text)
    print(text)


if __name__ == "__main__":
    main()
