#pragma once
/// A surface of the test data meshed as the command line meshes it.
#include <string>

#include "test_data.h"
#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/tetrahedralize.h"

namespace t2stest {

/// data/meshes/<name>.off through TetGen with the command line's default
/// options (coplanar input facets merged and remeshed: exactBoundary false),
/// the surface first scaled by `scale` (1 + k·10⁻⁹: another input in its
/// last bits, as a unit conversion would make it).
inline tet2spline::TetMesh cliMeshedCgalSurface(const std::string& name, double scale = 1) {
  tet2spline::TetrahedralizeOptions meshing;
  meshing.exactBoundary = false;
  tet2spline::SurfaceMesh surface = tet2spline::readSurface(cgalMesh(name));
  if (scale != 1) surface.V *= scale;
  return tet2spline::tetrahedralize(surface, meshing, name);
}

}  // namespace t2stest
