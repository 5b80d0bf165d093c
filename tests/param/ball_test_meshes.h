#pragma once
// Small tet meshes built in the tests: a Kuhn-subdivided cube grid and a ball
// made from it by the radial cube-to-ball map.
#include <Eigen/Geometry>
#include <cmath>

#include "tet2spline/param/tet_mesh.h"

namespace t2stest {

/// n³ cubes of [-1,1]³, six tets each (Kuhn subdivision), positively oriented.
inline tet2spline::TetMesh cubeGrid(int n) {
  tet2spline::TetMesh m;
  const int s = n + 1;
  m.V.resize(s * s * s, 3);
  auto id = [s](int i, int j, int k) { return i + s * (j + s * k); };
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) m.V.row(id(i, j, k)) << -1 + 2.0 * i / n, -1 + 2.0 * j / n, -1 + 2.0 * k / n;
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  m.T.resize(6 * n * n * n, 4);
  int t = 0;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        for (const auto& p : perms) {
          int c[3] = {i, j, k};
          m.T(t, 0) = id(c[0], c[1], c[2]);
          for (int step = 0; step < 3; ++step) {
            ++c[p[step]];
            m.T(t, step + 1) = id(c[0], c[1], c[2]);
          }
          const Eigen::Vector3d a = m.V.row(m.T(t, 0)), b = m.V.row(m.T(t, 1)), cc = m.V.row(m.T(t, 2)),
                                d = m.V.row(m.T(t, 3));
          if ((b - a).cross(cc - a).dot(d - a) < 0) std::swap(m.T(t, 2), m.T(t, 3));
          ++t;
        }
  m.region = Eigen::VectorXi::Ones(m.T.rows());
  return m;
}

/// cubeGrid(n) pushed radially onto the unit ball: x ↦ x·|x|∞/|x|₂ (boundary
/// vertices on the sphere).
inline tet2spline::TetMesh ballGrid(int n) {
  tet2spline::TetMesh m = cubeGrid(n);
  for (Eigen::Index v = 0; v < m.V.rows(); ++v) {
    const double r = m.V.row(v).norm();
    if (r > 0) m.V.row(v) *= m.V.row(v).cwiseAbs().maxCoeff() / r;
  }
  return m;
}

}  // namespace t2stest
