// Distance between a spline volume's boundary and a triangle surface, on
// configurations whose distances are known exactly.
#include <gtest/gtest.h>

#include <cmath>

#include "cube_param_meshes.h"
#include "tet2spline/param/error.h"
#include "tet2spline/param/topology.h"
#include "tet2spline/spline/boundary_distance.h"

using namespace tet2spline;
using namespace tet2spline::spline;

namespace {

/// The boundary of the box [lo, hi]^3 as the boundary of a Kuhn tet mesh
/// (n × n triangles pairs per face).
SurfaceMesh boxSurface(int n, double lo, double hi) {
  const TetMesh m = t2stest::kuhnCube(n, [lo, hi](const Eigen::Vector3d& u) {
    return Eigen::Vector3d((lo + (hi - lo) * u.array()).matrix());
  });
  return {m.V, boundaryFaces(m)};
}

BSplineVolume unitCube(int p, int n) {
  return BSplineVolume::identity(KnotVector::uniform(p, n), KnotVector::uniform(p, n + 1), KnotVector::uniform(p, n + 2));
}

}  // namespace

TEST(BoundaryDistance, ZeroForTheSameBox) {
  const BoundaryDistance d = boundaryDistance(unitCube(3, 3), boxSurface(4, 0, 1));
  EXPECT_LT(d.hausdorff, 1e-12);
  EXPECT_GT(d.splineSamples, 6 * 24 * 24);
  EXPECT_EQ(d.surfaceSamples, 6 * 4 * 4 * 2 + (6 * 4 * 4 + 2));  // centroids + vertices (V − E + F = 2)
}

// The unit cube against the box grown by δ on every side: every face sample
// of the spline is δ from the surface (corners included: nearest face), the
// surface's corners are δ√3 from the cube's corners - which the projection
// reaches only by clamping both face parameters.
TEST(BoundaryDistance, GrownBoxGivesDeltaAndDeltaRootThree) {
  const double delta = 0.05;
  const BoundaryDistance d = boundaryDistance(unitCube(2, 4), boxSurface(3, -delta, 1 + delta));
  EXPECT_NEAR(d.splineToSurface, delta, 1e-12);
  EXPECT_NEAR(d.surfaceToSpline, delta * std::sqrt(3.0), 1e-9);
  EXPECT_NEAR(d.hausdorff, delta * std::sqrt(3.0), 1e-9);
  EXPECT_NEAR(d.meanSplineToSurface, delta, 1e-12);
}

// A curved spline against its own boundary triangulated ever finer: the
// distance is the chordal error, which falls like h^2.
TEST(BoundaryDistance, ChordalErrorOfACurvedBoundaryFallsQuadratically) {
  BSplineVolume S = unitCube(3, 2);
  Eigen::MatrixX3d P = S.controlPoints();
  for (Eigen::Index i = 0; i < P.rows(); ++i) P.row(i) = t2stest::ballLikeMap(P.row(i).transpose()).transpose();
  S.setControlPoints(P);
  double previous = 0;
  for (int n : {4, 8, 16}) {
    const TetMesh m = t2stest::kuhnCube(n, [&S](const Eigen::Vector3d& u) { return S.evaluate(u); });
    const BoundaryDistance d = boundaryDistance(S, {m.V, boundaryFaces(m)});
    EXPECT_GT(d.hausdorff, 0);
    if (previous > 0) {
      EXPECT_LT(d.hausdorff, previous / 3) << n;
      EXPECT_GT(d.hausdorff, previous / 5) << n;
    }
    previous = d.hausdorff;
  }
}

TEST(BoundaryDistance, RejectsBadInput) {
  const BSplineVolume S = unitCube(2, 2);
  SurfaceMesh empty;
  EXPECT_THROW(boundaryDistance(S, empty), Error);
  SurfaceMesh bad = boxSurface(1, 0, 1);
  bad.F(0, 0) = 99;
  EXPECT_THROW(boundaryDistance(S, bad), Error);
  BoundaryDistanceOptions o;
  o.samplesPerSpan = 0;
  EXPECT_THROW(boundaryDistance(S, boxSurface(1, 0, 1), o), Error);
}
