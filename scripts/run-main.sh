#!/usr/bin/env bash
# The main job on the embedded default: until the appliance exists, `glint convolve`
# on the HDR map that ships in data/ (irradiance + three reflection maps) into ./out.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/build.sh
./build/appliance/app/glint convolve data/courtyard_256x128.exr --out out \
    --irradiance --shininess 20,160,1280
echo "maps and report.json are in $(pwd)/out"
