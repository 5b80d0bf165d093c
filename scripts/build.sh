#!/usr/bin/env bash
# Configures (Release) and builds tet2spline in build/ with every core.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${T2S_BUILD_DIR:-$root/build}
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j"$(nproc)"
