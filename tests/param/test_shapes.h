#pragma once
/// Small synthetic meshes built in the tests (no files): cubes of tets,
/// triangulated spheres and tori with known topology.
#include <Eigen/Geometry>
#include <cmath>
#include <map>
#include <utility>

#include "tet2spline/param/tet_mesh.h"
#include "tet2spline/param/topology.h"

namespace t2stest {

/// Signed volume of tet t of T with its corners at the rows of P.
inline double tetVolume(const Eigen::MatrixX3d& P, const Eigen::MatrixX4i& T, Eigen::Index t) {
  const Eigen::Vector3d a = P.row(T(t, 0)), b = P.row(T(t, 1)), c = P.row(T(t, 2)), d = P.row(T(t, 3));
  return (b - a).dot((c - a).cross(d - a)) / 6;
}

/// Signed volume of tet t.
inline double tetVolume(const tet2spline::TetMesh& m, Eigen::Index t) { return tetVolume(m.V, m.T, t); }

inline double totalVolume(const tet2spline::TetMesh& m) {
  double v = 0;
  for (Eigen::Index t = 0; t < m.T.rows(); ++t) v += tetVolume(m, t);
  return v;
}

/// Flips every negatively oriented tet (builders write tets in any order).
inline void orientPositive(tet2spline::TetMesh& m) {
  for (Eigen::Index t = 0; t < m.T.rows(); ++t)
    if (tetVolume(m, t) < 0) std::swap(m.T(t, 2), m.T(t, 3));
}

/// The unit cube [0,1]^3 (shifted by `offset`) cut into 5 tets; vertex x+2y+4z.
inline tet2spline::TetMesh cube5(const Eigen::RowVector3d& offset = Eigen::RowVector3d::Zero()) {
  tet2spline::TetMesh m;
  m.V.resize(8, 3);
  for (int i = 0; i < 8; ++i) m.V.row(i) = Eigen::RowVector3d(i & 1, (i >> 1) & 1, (i >> 2) & 1) + offset;
  m.T.resize(5, 4);
  m.T << 1, 2, 4, 7,  //
      0, 1, 2, 4,     //
      3, 1, 2, 7,     //
      5, 1, 4, 7,     //
      6, 2, 4, 7;
  m.region = Eigen::VectorXi::Ones(5);
  orientPositive(m);
  return m;
}

/// The unit cube cut into 6 tets around the diagonal 0–7.
inline tet2spline::TetMesh cube6() {
  tet2spline::TetMesh m = cube5();
  m.T.resize(6, 4);
  m.T << 0, 1, 3, 7,  //
      0, 3, 2, 7,     //
      0, 2, 6, 7,     //
      0, 6, 4, 7,     //
      0, 4, 5, 7,     //
      0, 5, 1, 7;
  m.region = Eigen::VectorXi::Ones(6);
  orientPositive(m);
  return m;
}

/// Two tets in opposite octants; they share `shared` vertices (0: apart,
/// 1: a vertex, 2: an edge, 3: a face). Unshared copies stay as unused vertices.
inline tet2spline::TetMesh twoTets(int shared) {
  tet2spline::TetMesh m;
  m.V.resize(8, 3);
  m.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1,  //
      0, 0, 0, -1, 0, 0, 0, -1, 0, 0, 0, -1;
  if (shared == 0) m.V.bottomRows(4).col(0).array() += 5;
  m.T.resize(2, 4);
  m.T << 0, 1, 2, 3, 4, 5, 6, 7;
  for (int k = 0; k < shared; ++k) m.T(1, k) = k;
  m.region = Eigen::VectorXi::Ones(2);
  orientPositive(m);
  return m;
}

/// twoTets(3) with a third tet on their shared face, overlapping the first:
/// a triangle of three tets (a non-manifold solid).
inline tet2spline::TetMesh threeTetsOnOneFace() {
  tet2spline::TetMesh m = twoTets(3);
  m.V.conservativeResize(9, 3);
  m.V.row(8) << 0.2, 0.2, 5;
  m.T.conservativeResize(3, 4);
  m.T.row(2) << 0, 1, 2, 8;
  m.region = Eigen::VectorXi::Ones(3);
  orientPositive(m);
  return m;
}

/// Triangulated sphere: an octahedron subdivided `levels` times, projected;
/// outward-oriented (inward when `inward`).
inline tet2spline::SurfaceMesh sphere(int levels, double radius = 1,
                                      const Eigen::RowVector3d& center = Eigen::RowVector3d::Zero(),
                                      bool inward = false) {
  std::vector<Eigen::RowVector3d> V = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  std::vector<Eigen::Vector3i> F = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                    {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      V.push_back(((V[a] + V[b]) / 2).normalized());
      return mid[key] = int(V.size()) - 1;
    };
    std::vector<Eigen::Vector3i> G;
    for (const auto& f : F) {
      const int ab = midpoint(f[0], f[1]), bc = midpoint(f[1], f[2]), ca = midpoint(f[2], f[0]);
      G.push_back({f[0], ab, ca});
      G.push_back({ab, f[1], bc});
      G.push_back({ca, bc, f[2]});
      G.push_back({ab, bc, ca});
    }
    F = std::move(G);
  }
  tet2spline::SurfaceMesh s;
  s.V.resize(V.size(), 3);
  for (std::size_t i = 0; i < V.size(); ++i) s.V.row(i) = V[i] * radius + center;
  s.F.resize(F.size(), 3);
  for (std::size_t f = 0; f < F.size(); ++f) s.F.row(f) = inward ? Eigen::RowVector3i(F[f][0], F[f][2], F[f][1])
                                                                 : Eigen::RowVector3i(F[f].transpose());
  return s;
}

/// Torus of radii R > r, n × m quads split into triangles, outward.
inline tet2spline::SurfaceMesh torus(int n = 24, int m = 12, double R = 2, double r = 0.7) {
  tet2spline::SurfaceMesh s;
  s.V.resize(n * m, 3);
  const double pi = 3.14159265358979323846;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < m; ++j) {
      const double u = 2 * pi * i / n, v = 2 * pi * j / m;
      s.V.row(i * m + j) << (R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u), r * std::sin(v);
    }
  s.F.resize(2 * n * m, 3);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < m; ++j) {
      const int a = i * m + j, b = ((i + 1) % n) * m + j, c = ((i + 1) % n) * m + (j + 1) % m, d = i * m + (j + 1) % m;
      s.F.row(2 * (i * m + j)) << a, b, c;
      s.F.row(2 * (i * m + j) + 1) << a, c, d;
    }
  return s;
}

/// Concatenation of surfaces (vertex indices shifted).
inline tet2spline::SurfaceMesh merge(const tet2spline::SurfaceMesh& a, const tet2spline::SurfaceMesh& b) {
  tet2spline::SurfaceMesh s;
  s.V.resize(a.V.rows() + b.V.rows(), 3);
  s.V << a.V, b.V;
  s.F.resize(a.F.rows() + b.F.rows(), 3);
  s.F << a.F, (b.F.array() + int(a.V.rows())).matrix();
  return s;
}

}  // namespace t2stest
