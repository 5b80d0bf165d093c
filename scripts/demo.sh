#!/usr/bin/env bash
# The main job: installs what is missing, builds, and runs the whole pipeline
# (tet2spline convert) on the default model, the two-material solid with its
# inner sphere (region 2) at density 4. Outputs go to out/demo/.
#   bash scripts/demo.sh [MODEL [convert options...]]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bash "$root/scripts/install-deps.sh"
bash "$root/scripts/build.sh"
build=${T2S_BUILD_DIR:-$root/build}
model=${1:-$root/models/two_material.off}
shift || true
args=("$@")
if [ $# -eq 0 ] && [ "$model" = "$root/models/two_material.off" ]; then args=(--density 2=4); fi
out=$root/out/demo
rm -rf "$out"
mkdir -p "$(dirname "$out")"
"$build/apps/tet2spline" convert "$model" -o "$out" "${args[@]}"
cat <<MSG
demo: every output is in $out
  report.html       open in a browser: verdict, figures, timings
  report.json       the quality figures (design.md's keys)
  param.vtu         the tet mesh with its cube parameterization U (ParaView)
  spline.vtu        the B-spline sampled as hexahedra: det J, scaled Jacobian, region (ParaView)
  control_net.vtu   the control grid (ParaView)
  spline.step/.igs  the spline's boundary as a B-rep solid (any CAD viewer, e.g. FreeCAD or gmsh)
  spline.xml        G+Smo TensorBSpline3;  spline.mfem + spline_regions.gf: MFEM NURBS mesh and element regions
MSG
