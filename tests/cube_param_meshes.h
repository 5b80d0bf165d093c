#pragma once
/// Parameterized tet meshes with an exactly known cube parameterization, for
/// the fit tests (spline/ and the `fit` command): the parameters U tile
/// [0,1]^3 and the physical positions are X = f(U) for a known map f, so a
/// correct fit of degree p reproduces f when f is a polynomial of degree <= p
/// per direction.
#include <Eigen/Core>
#include <cmath>
#include <functional>

#include "tet2spline/param/tet_mesh.h"

namespace t2stest {

using CubeMap = std::function<Eigen::Vector3d(const Eigen::Vector3d&)>;

/// The unit cube split into n^3 cells of 6 tets each (Kuhn/Freudenthal:
/// conforming, all positively oriented in U). Point field "U" = the grid
/// points; V = f(U); region 1 everywhere.
inline tet2spline::TetMesh kuhnCube(int n, const CubeMap& f) {
  tet2spline::TetMesh m;
  const int np = n + 1;
  Eigen::MatrixX3d U(np * np * np, 3);
  auto id = [np](int i, int j, int k) { return i + np * (j + np * k); };
  for (int k = 0; k < np; ++k)
    for (int j = 0; j < np; ++j)
      for (int i = 0; i < np; ++i) U.row(id(i, j, k)) << double(i) / n, double(j) / n, double(k) / n;
  // The 6 paths from corner 000 to 111 along the axes (permutations of xyz).
  const int perms[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};
  m.T.resize(6 * n * n * n, 4);
  int t = 0;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        for (int p = 0; p < 6; ++p) {
          int c[3] = {i, j, k};
          int v[4];
          v[0] = id(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            ++c[perms[p][s]];
            v[s + 1] = id(c[0], c[1], c[2]);
          }
          if (p >= 3) std::swap(v[2], v[3]);  // odd permutations: restore positive orientation
          m.T.row(t++) << v[0], v[1], v[2], v[3];
        }
  m.V.resize(U.rows(), 3);
  for (Eigen::Index i = 0; i < U.rows(); ++i) m.V.row(i) = f(U.row(i).transpose()).transpose();
  m.region = Eigen::VectorXi::Ones(m.T.rows());
  m.pointFields.push_back({"U", U});
  return m;
}

/// A tricubic map of the cube with det J > 0 everywhere (a small cubic
/// perturbation of a stretched, sheared box).
inline Eigen::Vector3d tricubicMap(const Eigen::Vector3d& u) {
  const double a = u[0], b = u[1], c = u[2];
  return {2.0 * a + 0.3 * b + 0.08 * a * a * a * b * c * c + 0.05 * b * b * b,
          1.5 * b + 0.1 * a * a * c - 0.06 * b * b * b * c * c * c,
          1.0 * c + 0.2 * a * b + 0.05 * c * c * c * a * a * b * b};
}

/// The classic cube-to-ball map, scaled by 10 and slightly sheared: smooth
/// but not polynomial, onto a ball-like solid (as in the fit benchmark).
inline Eigen::Vector3d ballLikeMap(const Eigen::Vector3d& u) {
  const double a = 2 * u[0] - 1, b = 2 * u[1] - 1, c = 2 * u[2] - 1;
  Eigen::Vector3d x(a * std::sqrt(1 - b * b / 2 - c * c / 2 + b * b * c * c / 3),
                    b * std::sqrt(1 - c * c / 2 - a * a / 2 + c * c * a * a / 3),
                    c * std::sqrt(1 - a * a / 2 - b * b / 2 + a * a * b * b / 3));
  x[0] += 0.1 * x[1];
  return 10.0 * x;
}

}  // namespace t2stest
