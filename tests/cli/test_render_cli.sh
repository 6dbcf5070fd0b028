#!/usr/bin/env bash
# End-to-end checks of `glint render` (docs/render.md): help, a small headless run (PNG, AOVs,
# stats), maps from `glint convolve`, and bad input: exit 2 with one line on stderr naming the
# flag or file, nothing written.
#
# Usage: test_render_cli.sh /path/to/glint
set -euo pipefail

if [[ $# -ne 1 ]]; then
    echo "usage: $0 /path/to/glint" >&2
    exit 2
fi
GLINT=$1
[[ -x $GLINT ]] || { echo "FAIL - $GLINT is not an executable" >&2; exit 1; }
WORLD=/usr/share/blender/datafiles/studiolights/world/studio.exr
[[ -f $WORLD ]] || { echo "FAIL - $WORLD is missing (blender-data)" >&2; exit 1; }

# shellcheck source=cli_test_lib.sh
source "$(dirname "$0")/cli_test_lib.sh"

# expect_bad NAME NEEDLE ARGS...: exit 2, exactly one stderr line containing NEEDLE, no frame written.
expect_bad() {
    local name=$1 needle=$2
    shift 2
    rm -f "$work/bad.png"
    run "$@" --out "$work/bad.png"
    [[ $rc -eq 2 ]] || fail "$name: exit code $rc, want 2 (stderr: $(stderr_text))"
    [[ $(stderr_lines) -eq 1 ]] || fail "$name: want exactly 1 line on stderr: $(stderr_text)"
    grep -qF -- "$needle" "$work/stderr" || fail "$name: stderr does not name '$needle': $(stderr_text)"
    [[ ! -e $work/bad.png ]] || fail "$name: wrote a frame"
    pass "$name: exit 2, $(head -n 1 "$work/stderr")"
}

# --- help ---------------------------------------------------------------------------------------
run --help
[[ $rc -eq 0 ]] || fail "glint --help: exit code $rc"
grep -q "render" "$work/stdout" || fail "glint --help does not list render"
run render --help
[[ $rc -eq 0 ]] || fail "glint render --help: exit code $rc, want 0"
for flag in --env --maps --model --material --background --size --out --aov --no-ao --frames --stats --display \
    --shadows --table-height --proxy --msaa --camera --exposure-ms --gain --live-maps --frame-budget-ms; do
    grep -qF -- "$flag" "$work/stdout" || fail "glint render --help does not describe $flag"
done
pass "glint --help lists render; glint render --help exits 0 and describes every flag"

# --- a small real run ---------------------------------------------------------------------------
run render --env "$WORLD" --model sphere --material glossy:40 --size 64x48 --out "$work/f.png" --aov "$work/aov" \
    --frames 3 --stats "$work/stats.json" --display headless
[[ $rc -eq 0 ]] || fail "render: exit code $rc (stderr: $(stderr_text))"
for f in f.png aov/radiance.exr aov/normal.exr aov/reflect.exr stats.json; do
    [[ -s $work/$f ]] || fail "render did not write $f"
done
python3 - "$work/stats.json" <<'EOF2' || fail "stats.json is not what it should be"
import json, sys
s = json.load(open(sys.argv[1]))
assert s["frames"] == 3 and s["width"] == 64 and s["height"] == 48, s
t = s["frame_ms"]
assert 0 < t["median"] <= t["p99"] <= t["max"], t
assert s["material"] == "glossy:40" and s["irradiance"] is None and s["reflection"], s
assert s["tone_map"]["operator"] == "reinhard" and s["tone_map"]["key"] == 0.18, s
EOF2
pass "render writes the PNG, the three AOVs and stats.json (3 frames, median <= p99 <= max)"

# --- the phantom table, a proxy and the shadow ---------------------------------------------------
# A small quad far behind the object (world coordinates): drawn to depth only, it changes nothing
# the command reports, but it has to load.
printf 'v -0.2 -0.2 -3\nv 0.2 -0.2 -3\nv 0.2 0.2 -3\nv -0.2 0.2 -3\nf 1 2 3 4\n' > "$work/proxy.obj"
run render --env "$WORLD" --model sphere --size 48x32 --out "$work/s.png" --aov "$work/aov_shadow" --shadows on \
    --table-height -1.0 --proxy "$work/proxy.obj"
[[ $rc -eq 0 ]] || fail "render --shadows on --proxy: exit code $rc (stderr: $(stderr_text))"
[[ -s $work/aov_shadow/shadow.exr && -s $work/s.png ]] || fail "render --shadows on did not write shadow.exr and the frame"
run render --env "$WORLD" --model sphere --size 48x32 --out "$work/s2.png" --aov "$work/aov_noshadow" --shadows off
[[ $rc -eq 0 ]] || fail "render --shadows off: exit code $rc (stderr: $(stderr_text))"
[[ -s $work/aov_noshadow/radiance.exr ]] || fail "render --shadows off did not write its AOVs"
pass "render --shadows on with --table-height and --proxy writes shadow.exr; --shadows off runs"
expect_bad "bad --shadows" "--shadows" render --env "$WORLD" --shadows sometimes
run render --env "$WORLD" --model sphere --size 48x32 --out "$work/m1.png" --msaa 1 --stats "$work/m1.json"
[[ $rc -eq 0 && -s $work/m1.png ]] || fail "render --msaa 1: exit code $rc (stderr: $(stderr_text))"
grep -q '"msaa": 1' "$work/m1.json" || fail "render --msaa 1: stats do not say msaa 1"
pass "render --msaa 1 runs and says so in its stats"
expect_bad "bad --msaa" "--msaa" render --env "$WORLD" --msaa 3

# --- the camera's response: a tabulated curve (code z at exposure ((z + 0.5) / 256)^2) --------
{
    printf '{"format": "glint-camera-calibration", "response": {"inverse": ['
    for z in $(seq 0 255); do printf '%s%s' "$([[ $z -gt 0 ]] && echo ,)" "$(awk -v z="$z" 'BEGIN { printf "%.9g", ((z + 0.5) / 256) ^ 2 }')"; done
    printf '], "gamma": 0, "shoulder": 0}, "sensitivity": 100}\n'
} > "$work/cal.json"
run render --env "$WORLD" --size 48x32 --out "$work/cam.png" --camera "$work/cal.json" --exposure-ms 5 --gain 2 \
    --stats "$work/cam.json"
[[ $rc -eq 0 && -s $work/cam.png ]] || fail "render --camera: exit code $rc (stderr: $(stderr_text))"
grep -q '"exposure_ms": 5' "$work/cam.json" || fail "render --camera: stats do not hold the exposure"
grep -q "camera: .*tabulated response" "$work/stdout" || fail "render --camera: does not describe the response"
pass "render --camera CAL.json --exposure-ms --gain runs (tabulated response)"
expect_bad "--gain without --camera" "--gain" render --env "$WORLD" --gain 2
expect_bad "missing --camera file" "--camera" render --env "$WORLD" --camera "$work/none.json"
printf '{"response": {"inverse": [1, 2]}}' > "$work/badcal.json"
expect_bad "calibration with a short table" "response.inverse" render --env "$WORLD" --camera "$work/badcal.json"
expect_bad "bad --exposure-ms" "--exposure-ms" render --env "$WORLD" --camera "$work/cal.json" --exposure-ms -1

# --- live maps: coarse first, the final ones on the GPU in the frames' leftover time ---------------
run render --env "$WORLD" --size 48x32 --material 'kd=0.5;ks=0.5;n=20' --live-maps --frame-budget-ms 300 --frames 3 \
    --out "$work/live.png" --stats "$work/live.json"
[[ $rc -eq 0 && -s $work/live.png ]] || fail "render --live-maps: exit code $rc (stderr: $(stderr_text))"
grep -q '"live_maps"' "$work/live.json" || fail "render --live-maps: no live_maps in the stats"
grep -q "live maps: final maps after" "$work/stdout" || fail "render --live-maps: never switched to the final maps"
grep -q "irradiance: coarse" "$work/stdout" || fail "render --live-maps: did not start with coarse maps"
pass "render --live-maps: coarse maps first, the final ones from the GPU engine, stats say when"
mkdir -p "$work/nomaps"
expect_bad "--live-maps with --maps" "--live-maps" render --env "$WORLD" --live-maps --maps "$work/nomaps"
expect_bad "--frame-budget-ms without --live-maps" "--frame-budget-ms" render --env "$WORLD" --frame-budget-ms 20

# --- several materials: two usemtl groups, each with its MTL material, one draw each ------------
printf 'newmtl red\nKd 0.8 0.1 0.1\nnewmtl gold\nKd 0 0 0\nKs 0.9 0.7 0.3\nNs 160\n' > "$work/two.mtl"
printf 'mtllib two.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nusemtl red\nf 1 2 3\nf 1 3 4\nusemtl gold\nf 1 2 5\nf 1 5 4\n' > "$work/two.obj"
run render --env "$WORLD" --model "$work/two.obj" --size 48x32 --out "$work/two.png" --stats "$work/two.json" --msaa 1
[[ $rc -eq 0 && -s $work/two.png ]] || fail "render two-material OBJ: exit code $rc (stderr: $(stderr_text))"
grep -q '"draws": 2' "$work/two.json" || fail "render two-material OBJ: stats do not say 2 draws"
grep -q 'phong_40' "$work/two.json" || fail "render two-material OBJ: no phong_40 map (Ns 160 / 4)"
grep -q "material 1: mtl 'gold'" "$work/stdout" || fail "render two-material OBJ: does not list the second material"
! grep -qi "first" "$work/stderr" || fail "render two-material OBJ: still warns about the first material: $(stderr_text)"
pass "render: an OBJ with two MTL materials is drawn with both (2 draws, irradiance and phong_40)"
run render --env "$WORLD" --model "$work/two.obj" --size 48x32 --out "$work/two_shadow.png" --shadows on --msaa 1
[[ $rc -eq 0 ]] || fail "render a mesh with --shadows on: exit code $rc (stderr: $(stderr_text))"
grep -q "shadow: baked against the mesh" "$work/stdout" || fail "render a mesh with --shadows on: no baked shadow"
pass "render: a mesh's table shadow is baked against the mesh (--shadows on)"
expect_bad "missing --proxy file" "$work/nope.obj" render --env "$WORLD" --proxy "$work/nope.obj"
expect_bad "--proxy not an OBJ" "--proxy" render --env "$WORLD" --proxy "$work/proxy.ply"
expect_bad "bad --table-height" "--table-height" render --env "$WORLD" --table-height low

# --- maps from glint convolve -------------------------------------------------------------------
run convolve "$WORLD" --out "$work/maps" --irradiance
[[ $rc -eq 0 ]] || fail "convolve --irradiance: exit code $rc"
run render --env "$WORLD" --maps "$work/maps" --material matte --size 32x32 --out "$work/m.png" --background black
[[ $rc -eq 0 ]] || fail "render --maps: exit code $rc (stderr: $(stderr_text))"
grep -qF "irradiance: $work/maps/irradiance.exr" "$work/stdout" || fail "render --maps did not use irradiance.exr"
pass "render --maps uses the irradiance map glint convolve wrote"
expect_bad "--maps without the phong_160 map" "phong_160" render --env "$WORLD" --maps "$work/maps" --material glossy:160
# Maps with fine tiles (glint convolve's default) are read through them: the shader looks the
# tiles up (render/tiled_map.hpp), the stdout line says so.
run convolve "$WORLD" --out "$work/tiled" --irradiance --shininess 1280
[[ $rc -eq 0 ]] || fail "convolve --irradiance --shininess 1280: exit code $rc (stderr: $(stderr_text))"
[[ -s $work/tiled/phong_1280.tiles.exr ]] || fail "convolve wrote no phong_1280.tiles.exr: $(ls -A "$work/tiled")"
run render --env "$WORLD" --maps "$work/tiled" --material glossy:1280 --size 32x32 --out "$work/t.png" --background black
[[ $rc -eq 0 ]] || fail "render --maps with fine tiles: exit code $rc (stderr: $(stderr_text))"
grep -qF "$work/tiled/phong_1280.exr" "$work/stdout" || fail "render --maps did not use the tiled phong_1280.exr: $(tr '\n' ' ' <"$work/stdout")"
grep -qE "phong_1280.exr \([0-9]+ of [0-9]+ tiles [0-9]+x finer, read through them\)" "$work/stdout" ||
    fail "render --maps did not read phong_1280's tiles in the shader: $(tr '\n' ' ' <"$work/stdout")"
rm "$work/tiled/phong_1280.tiles.exr"
expect_bad "--maps with a tiles file missing" "phong_1280.tiles.exr" render --env "$WORLD" --maps "$work/tiled" --material glossy:1280
pass "render --maps reads a map with fine tiles, and names its tiles file when it is missing"

# --- bad input ----------------------------------------------------------------------------------
expect_bad "bad --material" "--material" render --env "$WORLD" --material shiny
expect_bad "bad --material value" "--material" render --env "$WORLD" --material glossy:-3
expect_bad "missing --env" "--env" render --model sphere
expect_bad "missing environment file" "$work/nope.exr" render --env "$work/nope.exr"
expect_bad "--model teapot:0 (a level out of range)" "--model teapot:0" render --env "$WORLD" --model teapot:0
printf 'v 0 0 0\nv 1 0 0\nf 1 2 3\n' >"$work/bad.obj"
expect_bad "OBJ with a bad index" "bad.obj:3" render --env "$WORLD" --model "$work/bad.obj"
printf '{ "asset": ' >"$work/bad.gltf"
expect_bad "unreadable glTF" "bad.gltf" render --env "$WORLD" --model "$work/bad.gltf"
run render --env "$WORLD" --size 32x32 --out "$work/no/such/dir/f.png"
[[ $rc -eq 2 ]] || fail "--out into a missing directory: exit code $rc, want 2"
grep -qF -- "--out" "$work/stderr" || fail "--out into a missing directory: stderr does not name --out: $(stderr_text)"
pass "--out into a missing directory: exit 2, $(head -n 1 "$work/stderr")"
expect_bad "bad --size" "--size" render --env "$WORLD" --size 12
expect_bad "bad --display" "--display" render --env "$WORLD" --display projector
expect_bad "bad --background" "--background" render --env "$WORLD" --background grey

echo "all $checks checks passed"
