#pragma once
// Private to tet2spline::param: the one place that runs CGAL's
// Polygon_mesh_processing on a surface (self_intersection.cpp).
#include "tet2spline/param/tet_mesh.h"

namespace tet2spline {

/// Number of intersecting pairs of triangles of `surface` (pairs that share a
/// vertex or an edge count only when they overlap beyond it), stopping at
/// about `cap` pairs. Returns −1 when the triangles do not form a manifold,
/// consistently oriented triangle mesh (CGAL's precondition); callers refuse
/// such surfaces for that reason first.
int countSelfIntersections(const SurfaceMesh& surface, int cap);

}  // namespace tet2spline
