#pragma once
// Per-format readers and writers behind mesh_io.h (internal to the io module).
#include <string>

#include "tet2spline/param/tet_mesh.h"

namespace tet2spline::detail {

SurfaceMesh readOff(const std::string& path);

}  // namespace tet2spline::detail
