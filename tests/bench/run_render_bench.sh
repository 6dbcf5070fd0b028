#!/usr/bin/env bash
# The renderer's part-4 benchmark (issue 15; docs/render.md "Benchmark"). Writes
# tests/bench/results/render_frames.md (a: frame times of `glint render`) and
# tests/bench/results/render.md (b: shading against the exact maps; c: consistency of spheres lit
# by a simulated capture against the truth, through the same camera model). About 10 minutes on
# two cores with llvmpipe.
#
# Usage: tests/bench/run_render_bench.sh [BUILD_DIR]
#   without BUILD_DIR: the -march=native tree build-native/ (bench_build.sh)
#   FRAMES=N timed frames a run (default 20), ROUNDS=R runs of each configuration, interleaved
#   (default 3), PARTS="frames shading consistency" (any of them; the tables not run are kept).
set -euo pipefail
cd "$(dirname "$0")/../.."
if [ -n "${1:-}" ]; then
  BUILD=$1
  cmake --build "$BUILD" -j2 --target glint glint-vision glint_bench_render >/dev/null
else
  BUILD=$(tests/bench/bench_build.sh glint_bench_render)
fi
GLINT=$BUILD/appliance/app/glint
VISION=$BUILD/appliance/app/glint-vision
BENCH=$BUILD/tests/bench/glint_bench_render
WORLDS=/usr/share/blender/datafiles/studiolights/world
OUT=tests/bench/results
FRAMES=${FRAMES:-20}
ROUNDS=${ROUNDS:-3}
PARTS=${PARTS:-frames shading consistency}
want() { [[ " $PARTS " == *" $1 "* ]]; }
WORK=$(mktemp -d /tmp/glint_render_bench.XXXXXX)
trap 'rm -rf "$WORK"' EXIT
MACHINE="$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(nproc) cores"
DATE=$(date -u +%Y-%m-%dT%H:%MZ)
loadavg() { cut -d' ' -f1 /proc/loadavg; }
json() { python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print(eval(sys.argv[2]))" "$@"; }

# --- (a) frame times ---------------------------------------------------------------------------
MODEL=teapot:40
MATERIAL='kd=0.7,0.45,0.3;ks=0.15;n=40'
LIVE=no
"$GLINT" render --help | grep -q -- '--live-maps' && LIVE=yes
# The configurations: name | flags. The live row's budget: llvmpipe draws this frame in 250-700 ms,
# so a 30 Hz budget would leave nothing; 800 ms leaves the job a slice after most frames.
CONFIGS=("1x off|--msaa 1 --shadows off" "1x on|--msaa 1 --shadows on" "4x off|--msaa 4 --shadows off"
         "4x on|--msaa 4 --shadows on")
[[ $LIVE == yes ]] && CONFIGS+=("4x on live|--msaa 4 --shadows on --live-maps --frame-budget-ms 800")
# Half-float frame targets (docs/render.md, "Frame targets"): the Pi's plan, measured here too.
"$GLINT" render --help | grep -q -- '--frame-targets' && CONFIGS+=("4x on half|--msaa 4 --shadows on --frame-targets half")
# Matching the camera (docs/render.md): the shipped session's calibration with the simulator's
# sensor noise added, through the camera's response, without and with the noise and a 12x3 pixel
# motion blur: what the matching costs a frame.
if "$GLINT" render --help | grep -q -- '--camera-noise'; then
    python3 -c "import json,sys; j=json.load(open(sys.argv[1])); j['noise']={'full_well_electrons':6000,'read_noise':0.002}; json.dump(j,open(sys.argv[2],'w'))" \
        data/sessions/kiosk/calibration.json "$WORK/noise_calibration.json"
    CONFIGS+=("4x on camera|--msaa 4 --shadows on --camera $WORK/noise_calibration.json --exposure-ms 4"
              "4x on matched|--msaa 4 --shadows on --camera $WORK/noise_calibration.json --exposure-ms 4 --camera-noise --motion-blur 12,3")
fi
if want frames; then
    : > "$WORK/loads"
    for round in $(seq 1 "$ROUNDS"); do
        for k in "${!CONFIGS[@]}"; do
            IFS='|' read -r name flags <<< "${CONFIGS[$k]}"
            before=$(loadavg)
            # shellcheck disable=SC2086
            "$GLINT" render --env "$WORLDS/courtyard.exr" --model "$MODEL" --material "$MATERIAL" --size 1280x720 \
                --frames "$FRAMES" --stats "$WORK/s_${k}_$round.json" $flags >"$WORK/render.log" 2>&1 ||
                { cat "$WORK/render.log" >&2; exit 1; }
            echo "$k $before $(loadavg)" >> "$WORK/loads"
            echo "frames: round $round, $name done" >&2
        done
    done
    {
        echo "# glint render frame times (issue 15, part 4a)"
        echo
        echo "Command: \`tests/bench/run_render_bench.sh\` (FRAMES=$FRAMES, ROUNDS=$ROUNDS), date $DATE, machine: $MACHINE,"
        echo "Mesa llvmpipe (EGL surfaceless, headless display). Each run: \`glint render --env courtyard.exr --model"
        echo "$MODEL --material '$MATERIAL' --size 1280x720 --frames $FRAMES --stats s.json\` plus the row's flags;"
        echo "the rows' runs are interleaved ($ROUNDS rounds), and median and p99 are over all their frames pooled."
        echo "The frame is: draw the object into the float targets (MSAA: multisampled, resolved), composite (with"
        echo "shadows: the table's ratio per background pixel, baked against the teapot near it), present (glFinish)."
        echo "The last column is the load average (1 min) before/after each run: above 2, other work shared the cores."
        echo
        echo "| MSAA | shadows | flags | triangles | frames | median ms | p99 ms | max ms | medians of the runs | load |"
        echo "|---|---|---|---|---|---|---|---|---|---|"
        for k in "${!CONFIGS[@]}"; do
            IFS='|' read -r name flags <<< "${CONFIGS[$k]}"
            python3 - "$k" "$name" "$flags" "$WORK" "$ROUNDS" <<'PY'
import json, statistics, sys
k, name, flags, work, rounds = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4], int(sys.argv[5])
flags = flags.replace(work + "/", "")  # the temporary calibration's directory
runs = [json.load(open(f"{work}/s_{k}_{r}.json")) for r in range(1, rounds + 1)]
frames = sorted(x for d in runs for x in d["frame_ms_all"])
def p(q):
    import math
    return frames[min(len(frames) - 1, max(0, math.ceil(q * len(frames)) - 1))]
loads = [l.split()[1:] for l in open(f"{work}/loads") if l.split()[0] == k]
msaa, shadows = name.split()[0], name.split()[1]
row = f"| {msaa} | {shadows} | `{flags}` | {runs[0]['triangles']} | {len(frames)} | {statistics.median(frames):.1f} | {p(0.99):.1f} | {frames[-1]:.1f} | " \
      + ", ".join(f"{d['frame_ms']['median']:.0f}" for d in runs) + " | " + ", ".join("/".join(l) for l in loads) + " |"
print(row)
if "live_maps" in runs[0]:
    for r, d in enumerate(runs, 1):
        lm = d["live_maps"]
        f0 = lm["final_from_frame"]
        before = d["frame_ms_all"][:f0] if f0 is not None else d["frame_ms_all"]
        after = d["frame_ms_all"][f0:] if f0 is not None else []
        med = lambda v: f"{statistics.median(v):.0f}" if v else "-"
        print(f"|  | live run {r} | final maps from frame {f0}, job {lm['job_seconds'] or float('nan'):.1f} s, "
              f"{lm['tiles']} tiles ({lm['tile_gpu_ms']:.0f} ms) | | {len(d['frame_ms_all'])} | before {med(before)}, after {med(after)} | | | | |")
PY
        done
        echo
        echo "Live rows: the frame time is the frame's own (draw, composite, present); the job's tiles run after it"
        echo "in the granted slice (budget minus the frame) and its CPU parts at a lower priority; 'before' and"
        echo "'after' are the median frame while the job ran and once the final maps were in."
    } > "$OUT/render_frames.md"
fi

# --- (b) shading against the exact maps ---------------------------------------------------------
{
    echo "# The renderer against exact maps and against a simulated capture (issue 15, part 4b, 4c)"
    echo
    echo "Command: \`tests/bench/run_render_bench.sh\`, date $DATE, machine: $MACHINE, Mesa llvmpipe."
    echo "Frame times: [render_frames.md](render_frames.md)."
    echo
    echo "## (b) Shading: radiance.exr against the exact maps at normal.exr / reflect.exr"
    echo
    echo "\`glint_bench_render shading --world W\`: a sphere (36 480 triangles) at 1280x720, shaded with the maps"
    echo "\`glint render\` makes (auto, tolerance 1 %) from the Blender world averaged to 256x128, against the exact"
    echo "maps of that world at the same sizes, looked up on the CPU at each pixel's own normal and reflection"
    echo "direction. RMS: sqrt(sum |A - B|^2 / sum |B|^2) over the object's pixels and channels; worst pixel:"
    echo "max |A - B| / max(|B|, mean |B|). Targets: 1 % and 5 %. Load average before: $(loadavg)."
    echo
    echo "| world | material | frame | object pixels | maps used | weighted RMS | worst pixel |"
    echo "|---|---|---|---|---|---|---|"
} > "$WORK/render.md"
want shading && for world in courtyard studio sunset; do
    "$BENCH" shading --world "$world" >> "$WORK/render.md"
    echo "shading: $world done" >&2
done

# --- (c) consistency against a simulated capture ------------------------------------------------
{
    echo
    echo "## (c) Consistency: spheres lit by a simulated capture against the truth"
    echo
    echo "Per world: \`glint-vision simulate --env W.exr --trajectory guided --hdr-bracket --out D\` (320x180,"
    echo "4 fps, noise, motion blur, rolling shutter, the sensor stream with its errors), \`glint-vision capture"
    echo "--session D --out c.exr\` (1024x512), then \`glint_bench_render consistency\`: matte and glossy:160 spheres"
    echo "at 640x360 shaded with the auto maps of c.exr against the same spheres shaded with the exact maps of the"
    echo "true environment (averaged to 256x128; exact maps at the captured maps' sizes), both through the"
    echo "session's camera response (calibration.json) at one exposure that puts the truth's mean object"
    echo "luminance at code 118; relative error of the real-valued code per pixel (mean of R, G, B). Targets: mean"
    echo "3 %, p95 8 %."
    echo
    echo "| world | material | frame | object pixels | captured maps | mean | p95 | simulate + capture s | load |"
    echo "|---|---|---|---|---|---|---|---|---|"
} >> "$WORK/render.md"
want consistency && for world in courtyard studio sunset; do
    t0=$(date +%s)
    "$VISION" simulate --env "$WORLDS/$world.exr" --trajectory guided --hdr-bracket --out "$WORK/s_$world" \
        >"$WORK/sim.log" 2>&1 || { cat "$WORK/sim.log" >&2; exit 1; }
    "$VISION" capture --session "$WORK/s_$world" --out "$WORK/c_$world.exr" >"$WORK/cap.log" 2>&1 ||
        { cat "$WORK/cap.log" >&2; exit 1; }
    t1=$(date +%s)
    "$BENCH" consistency --truth "$WORLDS/$world.exr" --captured "$WORK/c_$world.exr" \
        --calibration "$WORK/s_$world/calibration.json" | sed "s/\$/ $((t1 - t0)) | $(loadavg) |/" >> "$WORK/render.md"
    rm -rf "$WORK/s_$world"
    echo "consistency: $world done" >&2
done
if want shading && want consistency; then cp "$WORK/render.md" "$OUT/render.md"; fi
echo "wrote the results of: $PARTS (in $OUT)"
