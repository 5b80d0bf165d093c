#!/usr/bin/env bash
# Configures (Release) and builds tet2spline in build/ with every core.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${T2S_BUILD_DIR:-$root/build}
# ccache hits across clones in other folders (CI clones afresh): paths under
# the source tree are hashed relative to it.
export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$root}
export CCACHE_NOHASHDIR=${CCACHE_NOHASHDIR:-true}
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j"$(nproc)"
