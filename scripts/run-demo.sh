#!/usr/bin/env bash
# The main job: installs what is missing, builds, generates a small-motion burst
# with ground truth and runs the depth-from-small-motion pipeline on it.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/install-deps.sh"
export BUILD_DIR="${BUILD_DIR:-$root/build}"
"$root/scripts/build.sh" -DDFSM_BUILD_TESTS=OFF -DDFSM_BUILD_BENCH=OFF
dfsm="$BUILD_DIR/tools/dfsm/dfsm"
demo="${DFSM_DEMO_DIR:-$root/out/demo}"
mkdir -p "$demo"
"$dfsm" synth --out "$demo/burst" --width 1280 --height 720 --frames 15 --seed 7
"$dfsm" process "$demo/burst" --out "$demo/result"
"$dfsm" evaluate --result "$demo/result" --truth "$demo/burst"
echo "demo: outputs in $demo/result"
