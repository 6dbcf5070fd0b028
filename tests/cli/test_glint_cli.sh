#!/usr/bin/env bash
# End-to-end checks of the glint commands (docs/architecture.md, "Commands"):
# help, a small real run (files, report.json keys, compare against itself), and every kind of
# bad input: exit code 2, exactly one line on stderr naming the file or flag, nothing written,
# and no temp or staging files left behind.
#
# Usage: test_glint_cli.sh /path/to/glint
# Prints one line per check; exits non-zero on the first failed check.
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

# No *.tmp* or .glint-staging* anywhere under a directory.
expect_no_leftovers() {
    local what=$1 dir=$2
    [[ -e $dir ]] || return 0
    local left
    left=$(find "$dir" \( -name '*.tmp*' -o -name '.glint-staging*' \) -print)
    [[ -z $left ]] || fail "$what: left behind in $dir: $left"
}

# expect_bad NAME NEEDLE DIR ARGS...: exit 2, one stderr line containing NEEDLE, DIR empty or absent.
expect_bad() {
    local name=$1 needle=$2 dir=$3
    shift 3
    run "$@"
    [[ $rc -eq 2 ]] || fail "$name: exit code $rc, want 2 (stderr: $(stderr_text))"
    local lines
    lines=$(stderr_lines)
    [[ $lines -eq 1 ]] || fail "$name: $lines lines on stderr, want exactly 1: $(stderr_text)"
    grep -qF -- "$needle" "$work/stderr" || fail "$name: stderr does not name '$needle': $(stderr_text)"
    expect_no_leftovers "$name" "$dir"
    if [[ -e $dir ]]; then
        [[ -d $dir ]] || fail "$name: $dir was created as something other than a directory"
        local content
        content=$(ls -A "$dir")
        [[ -z $content ]] || fail "$name: $dir is not empty: $content"
    fi
    pass "$name: exit 2, $(head -n 1 "$work/stderr")"
}

cp "$WORLD" "$work/in.exr"

# --- help -------------------------------------------------------------------------------------
run --help
[[ $rc -eq 0 ]] || fail "glint --help: exit code $rc, want 0"
grep -q convolve "$work/stdout" || fail "glint --help does not list the convolve command"
grep -q compare "$work/stdout" || fail "glint --help does not list the compare command"
pass "glint --help exits 0 and lists convolve and compare"

run convolve --help
[[ $rc -eq 0 ]] || fail "glint convolve --help: exit code $rc, want 0"
for flag in --shininess --irradiance --out --method --tolerance --size; do
    grep -qF -- "$flag" "$work/stdout" || fail "glint convolve --help does not mention $flag"
done
pass "glint convolve --help exits 0 and mentions --shininess (and --irradiance, --out, --method, --tolerance, --size)"

run compare --help
[[ $rc -eq 0 ]] || fail "glint compare --help: exit code $rc, want 0"
pass "glint compare --help exits 0"

# --- a small real run ---------------------------------------------------------------------------
out=$work/out
run convolve "$work/in.exr" --out "$out" --irradiance --shininess 20 --size 32x16
[[ $rc -eq 0 ]] || fail "convolve: exit code $rc, want 0 (stderr: $(stderr_text))"
for f in irradiance.exr phong_20.exr report.json; do
    [[ -s $out/$f ]] || fail "convolve did not write a non-empty $out/$f"
done
listing=$(ls -A "$out" | sort | tr '\n' ' ')
[[ $listing == "irradiance.exr phong_20.exr report.json " ]] || fail "convolve wrote unexpected files: $listing"
expect_no_leftovers "convolve" "$out"
pass "convolve --irradiance --shininess 20 --size 32x16 writes irradiance.exr, phong_20.exr, report.json and nothing else"

grep -q "not 2:1" "$work/stderr" && fail "convolve warned that a 2:1 input is not 2:1: $(stderr_text)"
python3 "$(dirname "$0")/make_constant_exr.py" "$work/square.exr" 32 32 1.5
run convolve "$work/square.exr" --out "$work/square_out" --irradiance --size 16x8
[[ $rc -eq 0 ]] || fail "convolve of a square map: exit code $rc, want 0 (stderr: $(stderr_text))"
grep -qF "square.exr: 32x32 is not 2:1" "$work/stderr" || fail "convolve of a 32x32 map did not warn: $(stderr_text)"
pass "convolve warns that a 32x32 input is not 2:1 (and does not for a 2:1 one)"

python3 - "$out/report.json" <<'EOF' || fail "report.json does not hold what it should (see above)"
import json, math, sys
report = json.load(open(sys.argv[1]))
maps = report["maps"]
names = [m["map"] for m in maps]
assert names == ["irradiance", "phong_20"], f"maps are {names}"
for m in maps:
    for key in ("method", "input_level", "output_size", "cutoff_cos", "predicted_error", "wall_seconds"):
        assert key in m, f"{m['map']}: no key {key}"
    assert m["method"] in ("exact", "cone", "sh"), f"{m['map']}: method {m['method']} is not a concrete method of auto"
    assert m["method"] != "sh" or m["bright_split"], f"{m['map']}: auto chose sh without the bright split"
    assert m["output_size"] == [32, 16], f"{m['map']}: output_size {m['output_size']}"
    assert isinstance(m["input_level"], int) and m["input_level"] >= 0, f"{m['map']}: input_level {m['input_level']}"
    assert -1 <= m["cutoff_cos"] < 1, f"{m['map']}: cutoff_cos {m['cutoff_cos']}"
    pe = m["predicted_error"]
    assert pe is not None and math.isfinite(pe) and 0 <= pe <= report["tolerance"], f"{m['map']}: predicted_error {pe}"
    assert m["wall_seconds"] >= 0, f"{m['map']}: wall_seconds {m['wall_seconds']}"
    assert m["file"] == m["map"] + ".exr", f"{m['map']}: file {m['file']}"
assert report["input"]["size"] == [1024, 512], f"input size {report['input']['size']}"
EOF
pass "report.json: maps irradiance and phong_20, each with method, input_level, output_size, cutoff_cos, predicted_error, wall_seconds"

run compare "$out/irradiance.exr" "$out/irradiance.exr"
[[ $rc -eq 0 ]] || fail "compare of a map with itself: exit code $rc (stderr: $(stderr_text))"
rms=$(awk '$1 == "weighted_rel_rms" { print $2 }' "$work/stdout")
[[ -n $rms ]] || fail "compare printed no weighted_rel_rms line: $(tr '\n' ' ' <"$work/stdout")"
awk -v v="$rms" 'BEGIN { exit !(v + 0 == 0) }' || fail "compare of a map with itself: weighted_rel_rms $rms, want 0"
pass "compare of irradiance.exr against itself prints weighted_rel_rms $rms"

run compare "$out/phong_20.exr" "$out/irradiance.exr"
[[ $rc -eq 0 ]] || fail "compare phong_20 irradiance: exit code $rc (stderr: $(stderr_text))"
rms=$(awk '$1 == "weighted_rel_rms" { print $2 }' "$work/stdout")
awk -v v="$rms" 'BEGIN { exit !(v + 0 > 0) }' || fail "compare of two different maps: weighted_rel_rms '$rms', want > 0"
pass "compare of phong_20.exr against irradiance.exr prints weighted_rel_rms $rms > 0"

# A map read through its lobe (n = 1e6 on 1024x512: report.json "lookup": "lobe", its texels the
# input's radiance) is judged through the lobe: from report.json by default, bilinearly only when
# asked, where it is off by its whole lobe.
lobe_out="$work/lobe"
run convolve "$WORLD" --out "$lobe_out" --shininess 1000000
[[ $rc -eq 0 ]] || fail "convolve n = 1e6: exit code $rc (stderr: $(stderr_text))"
python3 -c "import json,sys; m=json.load(open(sys.argv[1]))['maps'][0]; sys.exit(0 if m['lookup']=='lobe' else 1)" \
    "$lobe_out/report.json" || fail "convolve n = 1e6: report.json lookup is not lobe"
run convolve "$WORLD" --out "$work/lobe_exact" --shininess 1000000 --method exact --size 37x19
[[ $rc -eq 0 ]] || fail "exact n = 1e6 at 37x19: exit code $rc (stderr: $(stderr_text))"
run compare "$lobe_out/phong_1000000.exr" "$work/lobe_exact/phong_1000000.exr"
[[ $rc -eq 0 ]] || fail "compare of a lobe map: exit code $rc (stderr: $(stderr_text))"
lobe_rms=$(awk '$1 == "weighted_rel_rms" { print $2 }' "$work/stdout")
grep -q '^lookup lobe (.*report.json)$' "$work/stdout" || fail "compare of a lobe map did not read it through the lobe: $(tr '\n' ' ' <"$work/stdout")"
run compare "$lobe_out/phong_1000000.exr" "$work/lobe_exact/phong_1000000.exr" --lookup bilinear
[[ $rc -eq 0 ]] || fail "compare --lookup bilinear: exit code $rc (stderr: $(stderr_text))"
bilinear_rms=$(awk '$1 == "weighted_rel_rms" { print $2 }' "$work/stdout")
python3 -c "import sys; sys.exit(0 if float('$lobe_rms') <= 1e-3 and float('$bilinear_rms') > max(1e-2, 10 * float('$lobe_rms')) else 1)" ||
    fail "lobe map against exact: through the lobe $lobe_rms (want <= 1e-3), bilinear $bilinear_rms (want over 1e-2 and 10x more)"
pass "compare reads a lobe map through its lobe from report.json: $lobe_rms against exact (bilinear $bilinear_rms)"
expect_bad "compare --lookup lobe without --shininess" "--shininess" "$work/bad_lobe" \
    compare "$lobe_out/phong_1000000.exr" "$work/lobe_exact/phong_1000000.exr" --lookup lobe
# An exported scene's maps/maps.json says the same (glint run's export, docs/kiosk.md).
scene="$work/scene_maps"
mkdir -p "$scene"
cp "$lobe_out/phong_1000000.exr" "$scene/"
printf '{"phong_1000000.exr": {"width": 1024, "height": 512, "from": "test", "lookup": "lobe", "shininess": 1000000}}\n' >"$scene/maps.json"
run compare "$scene/phong_1000000.exr" "$work/lobe_exact/phong_1000000.exr"
[[ $rc -eq 0 ]] || fail "compare of an exported lobe map: exit code $rc (stderr: $(stderr_text))"
grep -q '^lookup lobe (.*maps.json)$' "$work/stdout" || fail "compare did not read maps.json's lookup: $(tr '\n' ' ' <"$work/stdout")"
pass "compare reads an exported scene's maps.json lookup"
# A listing that lists the file with a lookup but no shininess: exit 2 naming it.
printf '{"phong_1000000.exr": {"lookup": "lobe"}}\n' >"$scene/maps.json"
expect_bad "compare with a lobe listed without its shininess" "maps.json" "$work/bad_listing" \
    compare "$scene/phong_1000000.exr" "$work/lobe_exact/phong_1000000.exr"
rm -rf "$scene"
rm -rf "$lobe_out" "$work/lobe_exact"

# A second run into the same directory replaces the maps and leaves nothing behind.
run convolve "$work/in.exr" --out "$out" --irradiance --shininess 20 --size 32x16 --method exact
[[ $rc -eq 0 ]] || fail "convolve again into $out: exit code $rc (stderr: $(stderr_text))"
listing=$(ls -A "$out" | sort | tr '\n' ' ')
[[ $listing == "irradiance.exr phong_20.exr report.json " ]] || fail "second convolve left: $listing"
expect_no_leftovers "second convolve" "$out"
grep -q '"method": "exact"' "$out/report.json" || fail "second convolve did not replace report.json"
pass "convolve again into the same directory replaces the files and leaves no temp or staging files"

# --- bad input ----------------------------------------------------------------------------------
head -c 1000 "$WORLD" >"$work/truncated.exr"
head -c 4096 /dev/urandom >"$work/corrupt.exr"
: >"$work/empty.exr"
echo "a regular file" >"$work/afile"

expect_bad "truncated EXR" "$work/truncated.exr" "$work/bad1" \
    convolve "$work/truncated.exr" --out "$work/bad1" --irradiance --size 32x16
expect_bad "corrupt EXR (random bytes)" "$work/corrupt.exr" "$work/bad2" \
    convolve "$work/corrupt.exr" --out "$work/bad2" --irradiance --size 32x16
expect_bad "empty file" "$work/empty.exr" "$work/bad3" \
    convolve "$work/empty.exr" --out "$work/bad3" --irradiance --size 32x16
expect_bad "missing file" "$work/missing.exr" "$work/bad4" \
    convolve "$work/missing.exr" --out "$work/bad4" --irradiance --size 32x16
expect_bad "--shininess -3" "--shininess" "$work/bad5" \
    convolve "$work/in.exr" --out "$work/bad5" --shininess -3 --size 32x16
expect_bad "--shininess nan" "--shininess" "$work/bad6" \
    convolve "$work/in.exr" --out "$work/bad6" --shininess nan --size 32x16
expect_bad "--shininess abc" "--shininess" "$work/bad7" \
    convolve "$work/in.exr" --out "$work/bad7" --shininess abc --size 32x16
expect_bad "--shininess 20,,40" "--shininess" "$work/bad8" \
    convolve "$work/in.exr" --out "$work/bad8" --shininess 20,,40 --size 32x16
expect_bad "--size 0x0" "--size" "$work/bad9" \
    convolve "$work/in.exr" --out "$work/bad9" --irradiance --size 0x0
expect_bad "--tolerance 0" "--tolerance" "$work/bad10" \
    convolve "$work/in.exr" --out "$work/bad10" --irradiance --tolerance 0 --size 32x16
expect_bad "--method foo" "--method" "$work/bad11" \
    convolve "$work/in.exr" --out "$work/bad11" --irradiance --method foo --size 32x16
expect_bad "unwritable output directory (under a regular file)" "$work/afile/out" "$work/afile/out" \
    convolve "$work/in.exr" --out "$work/afile/out" --irradiance --size 32x16
[[ -f $work/afile && $(cat "$work/afile") == "a regular file" ]] || fail "the regular file $work/afile was changed"
pass "the regular file in the way of the output directory is untouched"
expect_bad "no maps requested" "--shininess" "$work/bad12" \
    convolve "$work/in.exr" --out "$work/bad12" --size 32x16
expect_bad "compare with a missing map" "$work/missing.exr" "$work/bad13" \
    compare "$work/missing.exr" "$out/irradiance.exr"
expect_bad "compare with a corrupt reference" "$work/corrupt.exr" "$work/bad14" \
    compare "$out/irradiance.exr" "$work/corrupt.exr"

expect_bad "--engine foo" "--engine" "$work/bad15" \
    convolve "$work/in.exr" --out "$work/bad15" --irradiance --engine foo --size 32x16

# The GPU engine (Mesa llvmpipe here) writes the same files, and says which engine ran.
gpu_out="$work/gpu"
run convolve "$work/in.exr" --out "$gpu_out" --irradiance --shininess 20 --size 32x16 --method exact --engine gpu
[[ $rc -eq 0 ]] || fail "convolve --engine gpu exited $rc: $(stderr_text)"
[[ -f $gpu_out/irradiance.exr && -f $gpu_out/phong_20.exr ]] || fail "convolve --engine gpu: maps missing"
# The renderer and version in report.json must be those of the context that ran, which glint
# names on stderr ("glint: GL: EGL 1.5, OpenGL ES 3.2 Mesa ... (GLSL ...), llvmpipe (...); ..."):
# any non-empty string would not do.
python3 - "$gpu_out/report.json" "$work/stderr" <<'PY' || fail "report.json of the GPU run"
import json, sys
r = json.load(open(sys.argv[1]))
assert r["engine"] == "gpu", r["engine"]
g = r["gpu"]
assert g["tiles"] >= 1 and g["largest_tile_ms"] > 0, g
assert g["version"].startswith("OpenGL ES 3."), g["version"]
assert g["renderer"].strip(), g
gl = [l for l in open(sys.argv[2]) if l.startswith("glint: GL: ")]
assert len(gl) == 1, gl
assert ", " + g["version"] + " (GLSL " in gl[0], (g["version"], gl[0])
assert "), " + g["renderer"] + "; " in gl[0], (g["renderer"], gl[0])
PY
pass "convolve --engine gpu writes the maps and report.json (engine gpu)"
run compare "$gpu_out/phong_20.exr" "$out/phong_20.exr"
rms=$(awk '/weighted_rel_rms/ { print $2 }' "$work/stdout")
python3 -c "import sys; sys.exit(0 if float('$rms') <= 1e-4 else 1)" || fail "GPU exact differs from CPU exact: $rms"
pass "GPU exact phong_20 within 1e-4 of the CPU's ($rms)"
rm -rf "$gpu_out"

# simulate and capture: help, a tiny session end to end, bad input.
run simulate --help
[[ $rc -eq 0 ]] && grep -q -- "--trajectory" "$work/stdout" || fail "simulate --help"
run capture --help
[[ $rc -eq 0 ]] && grep -q -- "--orientations" "$work/stdout" || fail "capture --help"
pass "simulate and capture --help"
printf '0,1,0,0,0\n3,0.70710678,0,0.70710678,0\n' > "$work/turn.csv"
run simulate --env "$WORLD" --trajectory "$work/turn.csv" --out "$work/session" --fps 2 --size 64x36
[[ $rc -eq 0 ]] || fail "simulate: exit $rc: $(stderr_text)"
[[ -f $work/session/session.json && -f $work/session/sensors.glrec && ! -e $work/session.partial ]] ||
    fail "simulate did not write a whole session"
pass "simulate writes a session ($(awk 'END { print NR - 1 }' "$work/session/frames.csv") frames)"
# simulate warns of a map that is not 2:1, as convolve and render do (square.exr from above).
run simulate --env "$work/square.exr" --trajectory "$work/turn.csv" --out "$work/square_session" --fps 2 --size 64x36
[[ $rc -eq 0 ]] || fail "simulate of a square map: exit $rc: $(stderr_text)"
grep -qF "square.exr: 32x32 is not 2:1" "$work/stderr" || fail "simulate of a 32x32 map did not warn: $(stderr_text)"
pass "simulate warns that a 32x32 map is not 2:1"
expect_bad "simulate onto an existing session" "already exists" "$work/none" \
    simulate --env "$WORLD" --trajectory "$work/turn.csv" --out "$work/session"
# --force replaces a session, never a directory of other files (it removed them all).
mkdir -p "$work/notes" && echo "keep me" > "$work/notes/notes.txt"
expect_bad "simulate --force onto a directory that is not a session" "not a session" "$work/none" \
    simulate --env "$WORLD" --trajectory "$work/turn.csv" --out "$work/notes" --force
[[ $(cat "$work/notes/notes.txt") == "keep me" ]] || fail "simulate --force touched a directory that is not a session"
run simulate --env "$WORLD" --trajectory "$work/turn.csv" --out "$work/session" --fps 2 --size 64x36 --force
[[ $rc -eq 0 ]] || fail "simulate --force onto a session: exit $rc: $(stderr_text)"
pass "simulate --force replaces a session, and refuses a directory of other files"
expect_bad "simulate with a bad trajectory" "nothing.csv" "$work/none" \
    simulate --env "$WORLD" --trajectory "$work/nothing.csv" --out "$work/session2"
[[ ! -e $work/session2 && ! -e $work/session2.partial ]] || fail "a failed simulate left a session behind"
expect_bad "simulate with top-ups but no brackets" "--top-up-below needs --hdr-bracket" "$work/none" \
    simulate --env "$WORLD" --trajectory "$work/turn.csv" --out "$work/session3" --top-up-below 0.1
expect_bad "simulate with top-ups at half the range" "--top-up-below must be" "$work/none" \
    simulate --env "$WORLD" --trajectory "$work/turn.csv" --out "$work/session3" --hdr-bracket --top-up-below 0.5
run capture --session "$work/session" --out "$work/env.exr" --size 64x32 --orientations truth --no-drift-correction
[[ $rc -eq 0 ]] || fail "capture: exit $rc: $(stderr_text)"
[[ -f $work/env.exr && -f $work/env.coverage.exr ]] || fail "capture did not write env.exr and env.coverage.exr"
grep -q "coverage" "$work/stdout" || fail "capture printed no coverage"
pass "capture writes the map and its coverage map"
expect_bad "capture of a missing session" "no such session" "$work/none" \
    capture --session "$work/nope" --out "$work/env2.exr"
expect_bad "capture --engine with a bad name" "--engine" "$work/none" \
    capture --session "$work/session" --out "$work/env2.exr" --engine tpu
expect_bad "capture --bracket-fill on the GPU engine" "--bracket-fill" "$work/none" \
    capture --session "$work/session" --out "$work/env2.exr" --size 64x32 --bracket-fill --engine gpu
[[ ! -e $work/env2.exr ]] || fail "a failed capture wrote a map"
run capture --session "$work/session" --out "$work/env-fill.exr" --size 64x32 --orientations truth --no-drift-correction --bracket-fill
[[ $rc -eq 0 && -f $work/env-fill.exr ]] || fail "capture --bracket-fill: exit $rc: $(stderr_text)"
pass "capture --bracket-fill (experimental) runs on the CPU engine and is refused on the GPU one"
run capture --session "$work/session" --out "$work/env-gpu.exr" --size 64x32 --orientations truth --no-drift-correction --engine gpu
[[ $rc -eq 0 && -f $work/env-gpu.exr ]] || fail "capture --engine gpu: exit $rc: $(stderr_text)"
run compare "$work/env-gpu.exr" "$work/env.exr"
rms=$(awk '/weighted_rel_rms/ { print $2 }' "$work/stdout")
python3 -c "import sys; sys.exit(0 if float('$rms') <= 1e-4 else 1)" || fail "GPU capture differs from the CPU's: $rms"
pass "capture --engine gpu agrees with the CPU engine ($rms)"

# --help for every command and subcommand: exit 0, a usage line naming it, on stdout only.
for cmd in convolve compare sensors simulate capture cameras calibrate "calibrate response" \
    "calibrate vignetting" "calibrate noise" "calibrate alignment" "calibrate readout" "calibrate intrinsics"; do
    # shellcheck disable=SC2086
    run $cmd --help
    [[ $rc -eq 0 ]] || fail "glint $cmd --help: exit code $rc, want 0"
    grep -q "^Usage: glint $cmd" "$work/stdout" || fail "glint $cmd --help: no 'Usage: glint $cmd' line: $(head -2 "$work/stdout")"
    [[ ! -s $work/stderr ]] || fail "glint $cmd --help wrote to stderr: $(stderr_text)"
done
pass "--help of every command and calibrate step exits 0 with its usage"

# --version: the project version from CMakeLists.txt and the build's git description.
run --version
version=$(sed -n 's/^project(glint VERSION \([0-9.]*\).*/\1/p' "$(dirname "$0")/../../CMakeLists.txt")
[[ $rc -eq 0 ]] || fail "glint --version: exit code $rc"
grep -qE "^glint $version \(.+\)$" "$work/stdout" || fail "glint --version: '$(cat "$work/stdout")', want 'glint $version (...)'"
pass "glint --version prints 'glint $version (git description)'"

# The GPU policy: auto falls back to the CPU and says why (llvmpipe is a software rasteriser, or
# there is no render node); cpu opens no GL; gpu was shown to work above.
run convolve "$work/in.exr" --out "$work/auto" --irradiance --size 16x8 --engine auto
[[ $rc -eq 0 ]] || fail "convolve --engine auto: exit $rc: $(stderr_text)"
grep -q "engine auto: .*runs on the CPU" "$work/stderr" || fail "engine auto did not say why the CPU runs: $(stderr_text)"
python3 -c "import json,sys; sys.exit(0 if json.load(open('$work/auto/report.json'))['engine'] == 'cpu' else 1)" ||
    fail "engine auto on a machine without a hardware GPU did not run the CPU engine"
run convolve "$work/in.exr" --out "$work/auto" --irradiance --size 16x8 --engine cpu
[[ $rc -eq 0 ]] && ! grep -q "engine\|GL" "$work/stderr" || fail "convolve --engine cpu: exit $rc, stderr: $(stderr_text)"
pass "engine auto runs the CPU and says why; engine cpu says nothing"
# --engine gpu with no EGL at all (glvnd pointed at no vendor library): exit 1, one line, nothing
# written; an explicit choice is never replaced by the CPU.
for cmd in convolve capture; do
    if [[ $cmd == convolve ]]; then
        args=(convolve "$out/irradiance.exr" --out "$work/noegl" --irradiance --size 16x8 --engine gpu)
    else
        args=(capture --session "$work/session" --out "$work/noegl/env.exr" --size 64x32 --orientations truth
              --no-drift-correction --engine gpu)
    fi
    rc=0
    __EGL_VENDOR_LIBRARY_FILENAMES=/nonexistent.json "$GLINT" "${args[@]}" >"$work/stdout" 2>"$work/stderr" || rc=$?
    [[ $rc -eq 1 ]] || fail "$cmd --engine gpu without EGL: exit code $rc, want 1 ($(stderr_text))"
    [[ $(stderr_lines) -eq 1 ]] && grep -q -- "--engine gpu: .* cannot run on the GPU" "$work/stderr" ||
        fail "$cmd --engine gpu without EGL: want one line saying why: $(stderr_text)"
    [[ -z $(ls -A "$work/noegl" 2>/dev/null) ]] || fail "$cmd --engine gpu without EGL wrote $(ls -A "$work/noegl")"
done
pass "convolve and capture --engine gpu without an EGL context exit 1 with one line"
rm -rf "$work/noegl"
rm -rf "$work/session" "$work/env.exr" "$work/env.coverage.exr" "$work/env-gpu.exr" "$work/env-gpu.coverage.exr" "$work/turn.csv"
rm -rf "$work/auto"

# SIGTERM and SIGINT while the maps are staged: the staging directory is removed, nothing is moved
# into place, and the exit code is 128 + the signal (GLINT_TEST_HOLD_STAGING_MS holds the staged
# files long enough to signal the command then).
for sig in TERM INT; do
    GLINT_TEST_HOLD_STAGING_MS=60000 "$GLINT" convolve "$work/in.exr" --out "$work/sig" --irradiance \
        --size 16x8 --engine cpu >"$work/stdout" 2>"$work/stderr" &
    pid=$!
    # Until the staged report is there (the staging directory appears before its files: waiting
    # for the directory alone failed on a loaded machine).
    for _ in $(seq 600); do
        [[ -n $(find "$work/sig" -path '*.glint-staging*' -name report.json -print 2>/dev/null) ]] && break
        sleep 0.05
    done
    [[ -f $(find "$work/sig" -path '*.glint-staging*' -name report.json -print | head -1) ]] ||
        fail "SIG$sig: the staged report.json never appeared"
    kill -s "$sig" "$pid"
    rc=0
    wait "$pid" || rc=$?
    want=$((128 + $(kill -l "$sig")))
    [[ $rc -eq $want ]] || fail "SIG$sig while staging: exit code $rc, want $want"
    expect_no_leftovers "SIG$sig while staging" "$work/sig"
    [[ -z $(ls -A "$work/sig") ]] || fail "SIG$sig while staging: maps were moved into place: $(ls -A "$work/sig")"
    grep -q "removed .*glint-staging" "$work/stderr" || fail "SIG$sig: no line about the removed staging directory: $(stderr_text)"
done
pass "SIGTERM and SIGINT while staging remove the staging directory and leave the output directory empty"
rm -rf "$work/sig"

# A map predicted to miss --tolerance is not delivered as success: exit 1, each such map named
# with its predicted error, nothing written. --allow-over-tolerance writes it, marked.
run convolve "$work/in.exr" --out "$work/over" --shininess 100,5 --method sh --sh-order 2 --size 32x16
[[ $rc -eq 1 ]] || fail "over tolerance: exit code $rc, want 1 (stderr: $(stderr_text))"
grep -q "phong_100: predicted error .* exceeds --tolerance" "$work/stderr" ||
    fail "over tolerance: stderr does not name phong_100 and its predicted error: $(stderr_text)"
[[ ! -e $work/over ]] || fail "over tolerance: the output directory it made was left behind: $(ls -A "$work/over")"
pass "a map over --tolerance: exit 1, named with its predicted error, nothing written, no directory left"
run convolve "$work/in.exr" --out "$work/over" --shininess 100 --method sh --sh-order 2 --size 32x16 \
    --allow-over-tolerance
[[ $rc -eq 0 ]] || fail "--allow-over-tolerance: exit code $rc, want 0 (stderr: $(stderr_text))"
python3 - "$work/over/report.json" <<'EOF2' || fail "--allow-over-tolerance: report.json does not mark the map"
import json, sys
m = json.load(open(sys.argv[1]))["maps"][0]
assert m["over_tolerance"] is True and m["predicted_error"] > 0.01, m
EOF2
pass "--allow-over-tolerance writes the map and marks it over_tolerance in report.json"
# A later run into the same directory removes the maps the earlier report.json listed that it did
# not write again; files of the user's own stay.
echo mine >"$work/over/notes.txt"
run convolve "$work/in.exr" --out "$work/over" --irradiance --size 32x16
[[ $rc -eq 0 ]] || fail "convolve into a used directory: exit code $rc (stderr: $(stderr_text))"
[[ ! -e $work/over/phong_100.exr ]] || fail "the earlier run's phong_100.exr was left beside the new maps"
[[ -s $work/over/irradiance.exr && -s $work/over/notes.txt ]] || fail "a used directory: $(ls -A "$work/over")"
pass "a later run removes the earlier run's maps it did not write again, and keeps other files"
# ... but never its own input, though the earlier report.json listed it.
run convolve "$work/over/irradiance.exr" --out "$work/over" --shininess 20 --size 32x16
[[ $rc -eq 0 && -s $work/over/irradiance.exr ]] || fail "a run reading a map of the directory it writes: rc $rc, $(ls -A "$work/over")"
pass "a run whose input an earlier run wrote into its output directory keeps that input"
# A refused run removes every directory of --out it made, not only the last.
run convolve "$work/in.exr" --out "$work/nest/a/b" --shininess 100 --method sh --sh-order 2 --size 32x16
[[ $rc -eq 1 && ! -e $work/nest ]] || fail "a refused run into nest/a/b: rc $rc, left $(find "$work/nest" 2>/dev/null | tr '\n' ' ')"
pass "a refused run leaves none of the directories it made"
expect_bad "--shininess 2e7" "mirror" "$work/bad16" \
    convolve "$work/in.exr" --out "$work/bad16" --shininess 2e7 --size 32x16

# The mirror map at the planner's size is the input itself; report.json says why each size.
run convolve "$work/in.exr" --out "$work/mirror" --mirror --shininess 1e7
[[ $rc -eq 0 ]] || fail "--mirror: exit code $rc (stderr: $(stderr_text))"
run compare "$work/mirror/mirror.exr" "$work/in.exr"
rms=$(awk '$1 == "weighted_rel_rms" { print $2 }' "$work/stdout")
awk -v v="$rms" 'BEGIN { exit !(v + 0 < 1e-6) }' || fail "mirror.exr against the input: weighted_rel_rms '$rms'"
python3 - "$work/mirror/report.json" <<'EOF2' || fail "--mirror: report.json (see above)"
import json, sys
r = json.load(open(sys.argv[1]))
for m in r["maps"]:
    assert m["size_reason"], m
    assert m["output_size"] == [1024, 512], m
    assert not m["over_tolerance"], m
# phong_1e7: the input's texels, read through the lobe; the mirror: the input, read bilinearly.
assert r["maps"][0]["method"] == "mirror" and r["maps"][0]["lookup"] == "lobe", r["maps"][0]
assert r["maps"][1]["method"] == "mirror" and r["maps"][1]["lookup"] == "bilinear", r["maps"][1]
assert r["load_seconds"] > 0 and r["load_megatexels_per_s"] > 0, r
EOF2
pass "--mirror writes the input itself at its size; phong_1e7 too, read through its lobe (lookup \"lobe\"); load time and size reasons in report.json"
rm -rf "$work/mirror" "$work/over"

# Fine tiles (the default): a map that needs a finer grid gets it only in tiles (<map>.tiles.exr,
# described in report.json); glint compare reads the map through them, and the whole finer grid
# made with --no-fine-tiles compares within the tolerance.
run convolve "$WORLD" --out "$work/tiles" --shininess 5120
[[ $rc -eq 0 ]] || fail "fine tiles: exit code $rc (stderr: $(stderr_text))"
[[ -s $work/tiles/phong_5120.tiles.exr ]] || fail "convolve wrote no phong_5120.tiles.exr: $(ls -A "$work/tiles")"
python3 - "$work/tiles/report.json" <<'EOF2' || fail "fine tiles: report.json does not describe the tiles"
import json, sys
m = json.load(open(sys.argv[1]))["maps"][0]
t = m["fine_tiles"]
assert t["file"] == "phong_5120.tiles.exr" and t["factor"] in (2, 4) and t["tile"] == 4, t
w, h = m["output_size"]
assert 0 < len(t["tiles"]) < (w // 8) * (h // 8) // 4, (len(t["tiles"]), m["output_size"])
assert "tiles of 4x4" in m["size_reason"] and not m["over_tolerance"], m["size_reason"]
EOF2
run convolve "$WORLD" --out "$work/whole" --shininess 5120 --no-fine-tiles
[[ $rc -eq 0 ]] || fail "--no-fine-tiles: exit code $rc (stderr: $(stderr_text))"
[[ ! -e $work/whole/phong_5120.tiles.exr ]] || fail "--no-fine-tiles wrote phong_5120.tiles.exr"
python3 -c "import json,sys; m=json.load(open(sys.argv[1]))['maps'][0]; sys.exit(0 if m['fine_tiles'] is None and m['output_size']==[4096,2048] else 1)" \
    "$work/whole/report.json" || fail "--no-fine-tiles: report.json has fine tiles or not the whole 4096x2048 grid"
run compare "$work/tiles/phong_5120.exr" "$work/whole/phong_5120.exr"
[[ $rc -eq 0 ]] || fail "compare of a tiled map: exit code $rc (stderr: $(stderr_text))"
grep -q "with its fine tiles" "$work/stdout" || fail "compare did not read the fine tiles: $(tr '\n' ' ' <"$work/stdout")"
rms=$(awk '$1 == "weighted_rel_rms" { print $2 }' "$work/stdout")
awk -v v="$rms" 'BEGIN { exit !(v + 0 > 0 && v + 0 < 0.005) }' ||
    fail "tiled phong_5120 against the whole finer grid: weighted_rel_rms '$rms', want (0, 0.005)"
pass "convolve writes phong_5120.tiles.exr and report.json's fine_tiles; compare reads through them ($rms against --no-fine-tiles's whole grid)"
rm "$work/tiles/phong_5120.tiles.exr"
run compare "$work/tiles/phong_5120.exr" "$work/whole/phong_5120.exr"
[[ $rc -eq 2 ]] || fail "compare with its tiles file missing: exit code $rc, want 2"
grep -q "phong_5120.tiles.exr" "$work/stderr" || fail "compare with its tiles file missing does not name it: $(stderr_text)"
pass "compare of a tiled map whose tiles file is missing exits 2 naming the file"
run convolve "$WORLD" --out "$work/whole" --shininess 5120
[[ $rc -eq 0 && -s $work/whole/phong_5120.tiles.exr ]] || fail "convolve into a directory of whole grids: rc $rc, no tiles file"
run convolve "$WORLD" --out "$work/whole" --shininess 5120 --no-fine-tiles
[[ $rc -eq 0 ]] || fail "--no-fine-tiles over a tiled map: exit code $rc (stderr: $(stderr_text))"
[[ ! -e $work/whole/phong_5120.tiles.exr ]] || fail "--no-fine-tiles left the earlier run's phong_5120.tiles.exr"
pass "a map delivered whole over a tiled one leaves no tiles file behind"
rm -rf "$work/tiles" "$work/whole"

# The good output directory is still exactly what the good runs wrote.
listing=$(ls -A "$out" | sort | tr '\n' ' ')
[[ $listing == "irradiance.exr phong_20.exr report.json " ]] || fail "output directory changed: $listing"
expect_no_leftovers "all runs" "$work"
pass "no *.tmp* or .glint-staging* file anywhere in the work directory"

echo "all $checks checks passed"
