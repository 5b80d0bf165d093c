#!/usr/bin/env bash
# Installs what is missing, builds, fetches the real test meshes and runs the
# whole test suite. Extra arguments go to ctest (e.g. -L param, -LE slow).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bash "$root/scripts/install-deps.sh"
bash "$root/scripts/build.sh"
build=${T2S_BUILD_DIR:-$root/build}
cd "$build"
ctest --output-on-failure -j"$(nproc)" "$@"
