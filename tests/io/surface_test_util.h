#pragma once
// Surfaces shared by the OFF/OBJ/STL/PLY tests.
#include "io_test_util.h"

namespace t2stest {

/// An octahedron; with `floatExact` its coordinates are exact in float32 (STL).
inline tet2spline::SurfaceMesh octahedron(bool floatExact = false) {
  tet2spline::SurfaceMesh s;
  const double a = floatExact ? 1.25 : std::sqrt(2.0), b = floatExact ? 0.375 : 1.0 / 3.0;
  s.V.resize(6, 3);
  s.V << a, 0, 0, -a, 0, 0, 0, a + b, 0, 0, -a, 0, 0, 0, a - b, 0, 0, -a;
  s.F.resize(8, 3);
  s.F << 0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5;
  return s;
}

/// Same triangles, compared by their corner coordinates (vertex order may differ).
inline void expectSameTriangles(const tet2spline::SurfaceMesh& a, const tet2spline::SurfaceMesh& b) {
  ASSERT_EQ(a.F.rows(), b.F.rows());
  for (Eigen::Index f = 0; f < a.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) EXPECT_TRUE(a.V.row(a.F(f, k)) == b.V.row(b.F(f, k))) << "face " << f << " corner " << k;
}

}  // namespace t2stest
