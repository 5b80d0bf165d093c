// Fit data on the uncovered parts of the cube's faces (face_coverage.h).
#include <tet2spline/spline/face_coverage.h>

#include <tet2spline/param/error.h>

#include "parallel_chunks.h"
#include "triangle_tree.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

namespace tet2spline::spline {
namespace {

[[noreturn]] void usage(const std::string& what) { throw Error(ErrorKind::Usage, "uncoveredFaceSamples: " + what); }

/// The face (2·axis + side) that all three vertices lie in, or -1.
int faceOf(const Eigen::MatrixX3d& U, const Eigen::Vector3i& f, double tol) {
  for (int d = 0; d < 3; ++d)
    for (int s = 0; s < 2; ++s) {
      bool all = true;
      for (int k = 0; k < 3 && all; ++k) all = std::fabs(U(f[k], d) - s) <= tol;
      if (all) return 2 * d + s;
    }
  return -1;
}

}  // namespace

FaceCoverageSamples uncoveredFaceSamples(const Eigen::MatrixX3d& U, const Eigen::MatrixX3d& X,
                                         const Eigen::MatrixX3i& F, int perSide, int threads) {
  if (U.rows() != X.rows()) usage(std::to_string(U.rows()) + " parameters but " + std::to_string(X.rows()) + " positions");
  if (perSide < 2) usage("perSide < 2");
  if (F.rows() > 0 && (F.minCoeff() < 0 || F.maxCoeff() >= U.rows())) usage("triangle index out of range");
  if (!U.allFinite() || !X.allFinite()) usage("non-finite coordinates");
  const double tol = 1e-9;
  const int n = perSide;
  const double h = 1.0 / (n - 1);
  FaceCoverageSamples out;
  out.samplesPerFace = static_cast<long>(n) * n;

  // Samples covered by the triangles lying in their face (2D inclusion with a
  // small tolerance, so samples on shared edges count as covered).
  std::vector<std::vector<std::uint8_t>> covered(6, std::vector<std::uint8_t>(static_cast<size_t>(n) * n, 0));
  std::vector<int> cutting;
  double maxCutEdge = 0;
  for (Eigen::Index t = 0; t < F.rows(); ++t) {
    const Eigen::Vector3i f = F.row(t).transpose();
    const int face = faceOf(U, f, tol);
    if (face < 0) {
      cutting.push_back(static_cast<int>(t));
      for (int k = 0; k < 3; ++k) maxCutEdge = std::max(maxCutEdge, (U.row(f[k]) - U.row(f[(k + 1) % 3])).norm());
      continue;
    }
    const int d = face / 2, a1 = (d + 1) % 3, a2 = (d + 2) % 3;
    std::array<Eigen::Vector2d, 3> p;
    for (int k = 0; k < 3; ++k) p[k] = Eigen::Vector2d(U(f[k], a1), U(f[k], a2));
    const double area2 = (p[1] - p[0]).x() * (p[2] - p[0]).y() - (p[1] - p[0]).y() * (p[2] - p[0]).x();
    if (std::fabs(area2) <= 0) continue;
    out.coveredArea += 0.5 * std::fabs(area2);
    const double sign = area2 > 0 ? 1 : -1;
    const Eigen::Vector2d lo = p[0].cwiseMin(p[1]).cwiseMin(p[2]), hi = p[0].cwiseMax(p[1]).cwiseMax(p[2]);
    const int i0 = std::max(0, static_cast<int>(std::floor(lo.x() / h - 1e-6))),
              i1 = std::min(n - 1, static_cast<int>(std::ceil(hi.x() / h + 1e-6)));
    const int j0 = std::max(0, static_cast<int>(std::floor(lo.y() / h - 1e-6))),
              j1 = std::min(n - 1, static_cast<int>(std::ceil(hi.y() / h + 1e-6)));
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) {
        const Eigen::Vector2d q(i * h, j * h);
        bool inside = true;
        for (int k = 0; k < 3 && inside; ++k) {
          const Eigen::Vector2d e = p[(k + 1) % 3] - p[k], r = q - p[k];
          inside = sign * (e.x() * r.y() - e.y() * r.x()) >= -1e-9 * e.norm();
        }
        if (inside) covered[static_cast<size_t>(face)][static_cast<size_t>(j) * n + i] = 1;
      }
  }
  if (cutting.empty()) return out;

  std::vector<Eigen::Vector3d> samples;
  for (int face = 0; face < 6; ++face) {
    const int d = face / 2, a1 = (d + 1) % 3, a2 = (d + 2) % 3;
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        if (covered[static_cast<size_t>(face)][static_cast<size_t>(j) * n + i]) continue;
        Eigen::Vector3d s;
        s[d] = face % 2;
        s[a1] = i * h;
        s[a2] = j * h;
        samples.push_back(s);
      }
  }
  // Nearest cutting-triangle point of each uncovered sample; samples farther
  // than the longest cutting edge are not in a wedge (a hole of some other
  // kind) and get no target.
  std::vector<detail::Triangle> triangles;
  triangles.reserve(cutting.size());
  for (int t : cutting)
    triangles.emplace_back(detail::toPoint(U.row(F(t, 0)).transpose()), detail::toPoint(U.row(F(t, 1)).transpose()),
                           detail::toPoint(U.row(F(t, 2)).transpose()));
  detail::TriangleTree tree(triangles.begin(), triangles.end());
  tree.accelerate_distance_queries();
  const long ns = static_cast<long>(samples.size());
  std::vector<Eigen::Vector3d> target(static_cast<size_t>(ns));
  std::vector<std::uint8_t> keep(static_cast<size_t>(ns), 0);
  detail::parallelChunks(static_cast<int>(std::max<long>(1, std::min<long>(threads, ns / 256))), ns, [&](long b, long e, int) {
    for (long k = b; k < e; ++k) {
      const Eigen::Vector3d& s = samples[static_cast<size_t>(k)];
      const auto hit = tree.closest_point_and_primitive(detail::toPoint(s));
      const Eigen::Vector3d p = detail::toEigen(hit.first);
      if ((p - s).norm() > maxCutEdge) continue;
      const Eigen::Vector3i f = F.row(cutting[static_cast<size_t>(hit.second - triangles.begin())]).transpose();
      const Eigen::Vector3d w = detail::barycentric(p, U.row(f[0]).transpose(), U.row(f[1]).transpose(), U.row(f[2]).transpose());
      target[static_cast<size_t>(k)] = (w[0] * X.row(f[0]) + w[1] * X.row(f[1]) + w[2] * X.row(f[2])).transpose();
      keep[static_cast<size_t>(k)] = 1;
    }
  });

  const long kept = std::count(keep.begin(), keep.end(), 1);
  out.U.resize(kept, 3);
  out.X.resize(kept, 3);
  long row = 0;
  for (long k = 0; k < ns; ++k)
    if (keep[static_cast<size_t>(k)]) {
      out.U.row(row) = samples[static_cast<size_t>(k)].transpose();
      out.X.row(row) = target[static_cast<size_t>(k)].transpose();
      ++row;
    }
  return out;
}

}  // namespace tet2spline::spline
