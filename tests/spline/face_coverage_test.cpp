// Fit data on the parts of the cube's faces that no boundary triangle covers
// (face_coverage.h): none for a boundary that tiles the cube; for a corner cut
// off, exactly the grid samples of the cut-off footprint, each with the
// physical position of its nearest point on the cutting triangles.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include <Eigen/Geometry>

#include "cube_param_meshes.h"
#include "tet2spline/param/error.h"
#include "tet2spline/param/topology.h"
#include "tet2spline/spline/face_coverage.h"

using namespace tet2spline;
using namespace tet2spline::spline;

namespace {

struct CubeBoundary {
  Eigen::MatrixX3d U, X;
  Eigen::MatrixX3i F;
};

/// The boundary of a Kuhn cube mesh (n × n square pairs per face), with
/// physical positions X = A U + b.
CubeBoundary cubeBoundary(int n, const Eigen::Matrix3d& A, const Eigen::Vector3d& b) {
  const TetMesh m = t2stest::kuhnCube(n, [](const Eigen::Vector3d& u) { return u; });
  CubeBoundary c{m.V, m.V, boundaryFaces(m)};
  c.X = (c.U * A.transpose()).rowwise() + b.transpose();
  return c;
}

double triangleArea(const Eigen::MatrixX3d& U, const Eigen::Vector3i& f) {
  return 0.5 * (U.row(f[1]) - U.row(f[0])).cross(U.row(f[2]) - U.row(f[0])).norm();
}

const Eigen::Matrix3d kA = (Eigen::Matrix3d() << 2, 0.3, 0, -0.1, 1.5, 0.2, 0, 0.4, 3).finished();
const Eigen::Vector3d kB(1, -2, 0.5);

}  // namespace

TEST(FaceCoverage, NoSamplesWhereTheBoundaryTilesTheCube) {
  const CubeBoundary c = cubeBoundary(4, kA, kB);
  const FaceCoverageSamples s = uncoveredFaceSamples(c.U, c.X, c.F, 33);
  EXPECT_EQ(s.U.rows(), 0);
  EXPECT_NEAR(s.coveredArea, 6.0, 1e-12);
  EXPECT_EQ(s.samplesPerFace, 33 * 33);
}

// The corner vertex (1,1,1) pulled inside: its triangles now cut the corner
// off; the samples are the grid points of their former footprint (open
// towards the rest of the face), on the cube's faces, and their targets are
// the affine image of their nearest point on the moved triangles.
TEST(FaceCoverage, ACutCornerGetsSamplesOnItsFootprintWithTheNearestCuttingPoint) {
  const int n = 4, perSide = 4 * 8 + 1;
  CubeBoundary c = cubeBoundary(n, kA, kB);
  Eigen::Index corner = -1;
  for (Eigen::Index i = 0; i < c.U.rows(); ++i)
    if ((c.U.row(i).array() == 1.0).all()) corner = i;
  ASSERT_GE(corner, 0);
  double footprint = 0;
  std::vector<Eigen::Vector3i> fan;
  for (Eigen::Index t = 0; t < c.F.rows(); ++t)
    if ((c.F.row(t).array() == corner).any()) {
      footprint += triangleArea(c.U, c.F.row(t).transpose());
      fan.push_back(c.F.row(t).transpose());
    }
  const Eigen::Vector3d moved(0.9, 0.9, 0.9);
  c.U.row(corner) = moved.transpose();
  c.X.row(corner) = (kA * moved + kB).transpose();

  const FaceCoverageSamples s = uncoveredFaceSamples(c.U, c.X, c.F, perSide);
  EXPECT_NEAR(s.coveredArea, 6.0 - footprint, 1e-12);
  // Footprint samples: on a face with u_d = 1, within 1/n of the corner in
  // both other coordinates and strictly beyond the fan's outer edge (the
  // diagonal or axis edges through the neighbours lie in covered triangles).
  ASSERT_GT(s.U.rows(), 0);
  const double h = 1.0 / (perSide - 1);
  for (Eigen::Index k = 0; k < s.U.rows(); ++k) {
    const Eigen::Vector3d u = s.U.row(k).transpose();
    int onOneFace = 0;
    for (int d = 0; d < 3; ++d) onOneFace += u[d] == 1.0;
    EXPECT_GE(onOneFace, 1) << u.transpose();
    EXPECT_GT(u.minCoeff(), 1.0 - 1.0 / n - 1e-12) << u.transpose();
    // The distance to the moved fan, by brute-force barycentric sampling.
    double best = 1e300;
    for (const auto& f : fan)
      for (int i = 0; i <= 200; ++i)
        for (int j = 0; i + j <= 200; ++j) {
          const double a = i / 200.0, b = j / 200.0;
          const Eigen::Vector3d p = (1 - a - b) * c.U.row(f[0]).transpose() + a * c.U.row(f[1]).transpose() +
                                    b * c.U.row(f[2]).transpose();
          best = std::min(best, (p - u).norm());
        }
    // The target's preimage is a point of the fan as near as the best one
    // (ties between triangles allowed).
    const Eigen::Vector3d pre = kA.inverse() * (s.X.row(k).transpose() - kB);
    EXPECT_NEAR((pre - u).norm(), best, 2e-3) << u.transpose();
    double onFan = 1e300;
    for (const auto& f : fan) {
      const Eigen::Vector3d a = c.U.row(f[0]).transpose(), e1 = c.U.row(f[1]).transpose() - a,
                            e2 = c.U.row(f[2]).transpose() - a;
      const Eigen::Vector3d nrm = e1.cross(e2).normalized();
      onFan = std::min(onFan, std::fabs((pre - a).dot(nrm)));
    }
    EXPECT_LT(onFan, 1e-12) << u.transpose();
  }
  // Every grid sample strictly inside the footprint of one face is there: the
  // footprint on face u_d = 1 holds the points within 1/n of the corner that
  // the covered triangles miss; count them on the grid independently.
  long expectedCount = 0;
  for (int d = 0; d < 3; ++d)
    for (int j = 0; j < perSide; ++j)
      for (int i = 0; i < perSide; ++i) {
        const double a = i * h, b = j * h;
        // Uncovered iff inside the fan's triangles on this face but not on
        // their edges opposite the corner.
        bool inside = false;
        for (const auto& f : fan) {
          int cornerAt = -1;
          bool onFace = true;
          for (int k = 0; k < 3; ++k) {
            if (f[k] == corner) cornerAt = k;
            else onFace = onFace && c.U(f[k], d) == 1.0;
          }
          if (!onFace || cornerAt < 0) continue;
          // 2D point-in-triangle with the corner at (1,1), open on the opposite edge.
          const int a1 = (d + 1) % 3, a2 = (d + 2) % 3;
          const Eigen::Vector2d q(a, b), p0(1, 1);
          const Eigen::Vector2d p1(c.U(f[(cornerAt + 1) % 3], a1), c.U(f[(cornerAt + 1) % 3], a2));
          const Eigen::Vector2d p2(c.U(f[(cornerAt + 2) % 3], a1), c.U(f[(cornerAt + 2) % 3], a2));
          auto cross = [](const Eigen::Vector2d& e, const Eigen::Vector2d& r) { return e.x() * r.y() - e.y() * r.x(); };
          const double s0 = cross(p1 - p0, q - p0), s1 = cross(p2 - p1, q - p1), s2 = cross(p0 - p2, q - p2);
          const double sg = cross(p1 - p0, p2 - p0) > 0 ? 1 : -1;
          if (sg * s1 > 1e-12 && sg * s0 >= -1e-12 && sg * s2 >= -1e-12) inside = true;
        }
        // Points on the two cube edges through the corner belong to two faces' fans.
        if (inside) ++expectedCount;
      }
  // Samples on the cube's edges through the corner appear once per face.
  EXPECT_EQ(s.U.rows(), expectedCount);
}

TEST(FaceCoverage, BadInputIsAUsageError) {
  const CubeBoundary c = cubeBoundary(2, kA, kB);
  EXPECT_THROW(uncoveredFaceSamples(c.U, c.X.topRows(3), c.F, 9), Error);
  EXPECT_THROW(uncoveredFaceSamples(c.U, c.X, c.F, 1), Error);
  Eigen::MatrixX3i bad = c.F;
  bad(0, 0) = static_cast<int>(c.U.rows());
  EXPECT_THROW(uncoveredFaceSamples(c.U, c.X, bad, 9), Error);
}
