#!/usr/bin/env bash
# The main job on the embedded default: the kiosk program replaying the recorded session that
# ships in data/sessions/kiosk (attract, a visitor's scan, processing, the object on the marker),
# headless, into ./out/replay: PNG frames of every state and summary.json. Builds only the two
# executables it runs.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/build.sh glint glint-vision
./build/appliance/app/glint replay data/sessions/kiosk --out out/replay
echo "frames are in $(pwd)/out/replay/frames, the figures in $(pwd)/out/replay/summary.json"
