#!/usr/bin/env bash
# End-to-end checks of `glint bake-ao` and of `glint render` using its file (docs/render.md,
# "Ambient occlusion"): help, a bake of a small OBJ (a floor with a box on it), the .ao header,
# render loading it, a stale file warned about and ignored, and bad input: exit 2 with one line on
# stderr naming what is wrong, nothing written.
#
# Usage: test_bake_ao_cli.sh /path/to/glint
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

# A floor (4 x 4) with a unit box standing on it: the floor next to the box is occluded.
cat >"$work/scene.obj" <<'OBJ'
v -2 0 -2
v 2 0 -2
v 2 0 2
v -2 0 2
v -0.5 0 -0.5
v 0.5 0 -0.5
v 0.5 0 0.5
v -0.5 0 0.5
v -0.5 1 -0.5
v 0.5 1 -0.5
v 0.5 1 0.5
v -0.5 1 0.5
vn 0 1 0
f 1//1 4//1 3//1 2//1
f 9 12 11 10
f 5 6 10 9
f 6 7 11 10
f 7 8 12 11
f 8 5 9 12
OBJ

# --- help -------------------------------------------------------------------------------------
run --help
[[ $rc -eq 0 ]] && grep -q "bake-ao" "$work/stdout" || fail "glint --help does not list bake-ao"
run bake-ao --help
[[ $rc -eq 0 ]] || fail "glint bake-ao --help: exit code $rc"
for flag in --rays --out --max-distance --threads; do
    grep -qF -- "$flag" "$work/stdout" || fail "glint bake-ao --help does not describe $flag"
done
pass "glint --help lists bake-ao; glint bake-ao --help describes its flags"

# --- a bake and its file ------------------------------------------------------------------------
run bake-ao "$work/scene.obj" --rays 128
[[ $rc -eq 0 ]] || fail "bake-ao: exit code $rc (stderr: $(stderr_text))"
[[ -s $work/scene.obj.ao ]] || fail "bake-ao did not write scene.obj.ao"
head -n 1 "$work/scene.obj.ao" | grep -qx "glint-ao 1" || fail "scene.obj.ao does not start with 'glint-ao 1'"
grep -aq "^vertices " "$work/scene.obj.ao" && grep -aq "^model-fnv1a64 " "$work/scene.obj.ao" && grep -aqx "end" "$work/scene.obj.ao" ||
    fail "scene.obj.ao lacks a header line"
grep -q "ao: mean" "$work/stdout" || fail "bake-ao does not report the mean ao"
# The floor's corners are far from the box (ao near 1), the box's bottom edges meet the floor
# (well below 1): the minimum must be under 0.9.
python3 - "$work/stdout" <<'EOF2' || fail "bake-ao's ao range is not plausible: $(cat "$work/stdout")"
import re, sys
text = open(sys.argv[1]).read()
mean, lo = map(float, re.search(r"ao: mean ([0-9.]+), min ([0-9.]+)", text).groups())
assert 0.3 < mean < 1.0 and lo < 0.9, (mean, lo)
EOF2
pass "bake-ao writes MODEL.ao with its header; ao mean and min plausible"

run render --env "$WORLD" --model "$work/scene.obj" --size 32x32 --out "$work/f.png" --background black
[[ $rc -eq 0 ]] || fail "render with the .ao: exit code $rc (stderr: $(stderr_text))"
grep -q "ambient occlusion: loaded .*scene.obj.ao" "$work/stdout" || fail "render did not load scene.obj.ao: $(cat "$work/stdout")"
pass "render loads MODEL.ao"

# --- stale: the model changed after the bake ----------------------------------------------------
echo "# edited" >>"$work/scene.obj"
run render --env "$WORLD" --model "$work/scene.obj" --size 32x32 --out "$work/f.png" --background black
[[ $rc -eq 0 ]] || fail "render with a stale .ao: exit code $rc, want 0 (stderr: $(stderr_text))"
grep -q "stale" "$work/stderr" && grep -q "scene.obj.ao" "$work/stderr" || fail "render did not warn about the stale file: $(stderr_text)"
grep -q "ambient occlusion: none (ao = 1)" "$work/stdout" || fail "render used a stale .ao"
pass "a stale MODEL.ao is warned about and ignored"

# --- bad input ----------------------------------------------------------------------------------
expect_bad() {
    local name=$1 needle=$2
    shift 2
    run "$@"
    [[ $rc -eq 2 ]] || fail "$name: exit code $rc, want 2 (stderr: $(stderr_text))"
    [[ $(stderr_lines) -eq 1 ]] || fail "$name: want exactly 1 line on stderr: $(stderr_text)"
    grep -qF -- "$needle" "$work/stderr" || fail "$name: stderr does not name '$needle': $(stderr_text)"
    pass "$name: exit 2, $(head -n 1 "$work/stderr")"
}
expect_bad "a built-in model" "teapot" bake-ao teapot
expect_bad "a missing model" "$work/nope.obj" bake-ao "$work/nope.obj"
expect_bad "--rays 0" "--rays" bake-ao "$work/scene.obj" --rays 0
expect_bad "--max-distance 0" "--max-distance" bake-ao "$work/scene.obj" --max-distance 0
expect_bad "--out into a missing directory" "--out" bake-ao "$work/scene.obj" --out "$work/no/such/dir/x.ao"
[[ ! -e $work/no ]] || fail "bake-ao created a directory"

echo "all $checks checks passed"
