#pragma once
/// A surface of the test data meshed as the command line meshes it.
#include <string>

#include "test_data.h"
#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/tetrahedralize.h"

namespace t2stest {

/// data/meshes/<name>.off through TetGen with the command line's default
/// options (coplanar input facets merged and remeshed: exactBoundary false).
inline tet2spline::TetMesh cliMeshedCgalSurface(const std::string& name) {
  tet2spline::TetrahedralizeOptions meshing;
  meshing.exactBoundary = false;
  return tet2spline::tetrahedralize(tet2spline::readSurface(cgalMesh(name)), meshing, name);
}

}  // namespace t2stest
