#!/usr/bin/env bash
# The main job: installs what is missing, builds, and runs tet2spline on the
# default model. Outputs go to out/demo/.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bash "$root/scripts/install-deps.sh"
bash "$root/scripts/build.sh"
build=${T2S_BUILD_DIR:-$root/build}
model=${1:-$root/models/bracket.step}
out=$root/out/demo
mkdir -p "$out"
"$build/apps/tet2spline" mesh "$model" -o "$out/bracket.vtu"
"$build/apps/tet2spline" check "$out/bracket.vtu"
echo "demo: tet mesh written to $out/bracket.vtu (open it in ParaView)"
