#!/bin/sh
# Small, very bright sources through glint simulate + glint capture (true orientations, no drift
# correction or adjustment, to isolate the camera, the brackets and the accumulation), and per
# source the energy in the frames and in the map against the truth. Prints; writes nothing in
# the repo. Usage: tests/bench/run_bright_sources_bench.sh [WORKDIR] [MAP-NAME...]
#   (maps: dim_1e+02 .. dim_1e+06, bright_1e+02 .. bright_1e+06; also any .exr path, e.g. the
#   studio lights' courtyard/studio/sunset, for which only the downstream errors are printed).
# SIMFLAGS=--sensor-limits models the sensor's shortest exposure (20 us) and glare: sources still
# clipped there are estimated (docs/capture.md, "Estimated sources").
set -e
# BUILD=DIR: an existing build tree; without it the -march=native tree build-native/ (bench_build.sh).
[ -n "$BUILD" ] || BUILD=$("$(dirname "$0")/bench_build.sh" glint_bench_bright_sources)
G=$BUILD/appliance/app/glint
X=$BUILD/tests/bench/glint_bench_bright_sources
W=${1:-/tmp/glint-bright-sources}
[ $# -gt 0 ] && shift
mkdir -p "$W/maps"
[ -f "$W/maps/dim_1e+02.exr" ] || $X make "$W/maps" > /dev/null
NAMES=${*:-"dim_1e+02 dim_1e+03 dim_1e+04 dim_1e+05 dim_1e+06 bright_1e+02 bright_1e+03 bright_1e+04 bright_1e+05 bright_1e+06"}
for n in $NAMES; do
  case $n in *.exr) env=$n; n=$(basename "$n" .exr); src= ;; *) env=$W/maps/$n.exr; src=$W/maps/$n.sources ;; esac
  echo "== $n"
  [ -n "$SKIPSIM" ] || $G simulate --env "$env" --trajectory guided --hdr-bracket --heading-drift 1 --guided-speed 35 --fps 3 \
     --out "$W/s_$n" --force --threads 2 ${SIMFLAGS} | tail -1
  $G capture --session "$W/s_$n" --out "$W/c_$n.exr" --size 1024x512 --orientations truth --no-drift-correction \
     --no-global-adjustment --threads 2 ${CAPFLAGS} | grep -v '^camera orientation\|^coverage map\|^guided'
  if [ -n "$src" ]; then
    $X frames "$W/s_$n" "$src"
    $X map "$W/s_$n/truth/env.exr" "$W/c_$n.exr" "$src"
  fi
  $X downstream "$W/s_$n/truth/env.exr" "$W/c_$n.exr"
done
