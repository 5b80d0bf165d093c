// Point location in the parameter images of a tet mesh, element regions by
// element centre, and element density per region on meshes whose measure is
// known exactly.
#include <gtest/gtest.h>

#include <limits>
#include <random>

#include "cube_param_meshes.h"
#include "tet2spline/param/error.h"
#include "tet2spline/spline/element_regions.h"

using namespace tet2spline;
using namespace tet2spline::spline;
using t2stest::kuhnCube;

namespace {

Eigen::MatrixX3d parameters(const TetMesh& m) { return m.pointField("U")->values; }

/// x stretched piecewise linearly along u: [0, 0.5] -> [0, a], [0.5, 1] -> [a, 1],
/// region 2 on u < 0.5. Exact on the Kuhn grid when n is even (u = 0.5 is a grid plane).
TetMesh twoRegionSlab(int n, double a) {
  TetMesh m = kuhnCube(n, [a](const Eigen::Vector3d& u) {
    const double x = u[0] < 0.5 ? 2 * a * u[0] : a + (1 - a) * 2 * (u[0] - 0.5);
    return Eigen::Vector3d(x, u[1], u[2]);
  });
  const Eigen::MatrixX3d U = parameters(m);
  for (Eigen::Index t = 0; t < m.numTets(); ++t) {
    double cx = 0;
    for (int c = 0; c < 4; ++c) cx += U(m.T(t, c), 0) / 4;
    m.region[t] = cx < 0.5 ? 2 : 1;
  }
  return m;
}

}  // namespace

TEST(ParameterLocator, FindsTheTetHoldingEveryInteriorPoint) {
  const TetMesh m = kuhnCube(5, [](const Eigen::Vector3d& u) { return u; });
  const Eigen::MatrixX3d U = parameters(m);
  const ParameterLocator loc(U, m.T);
  // Every tet's own centroid is located in that tet.
  for (Eigen::Index t = 0; t < m.numTets(); ++t) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k) c += U.row(m.T(t, k)).transpose() / 4;
    EXPECT_EQ(loc.locate(c), t);
  }
  // Random points: the tet found contains them (barycentric >= 0, sum 1).
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> uni(0, 1);
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3d u(uni(rng), uni(rng), uni(rng));
    const long t = loc.locate(u);
    ASSERT_GE(t, 0);
    const Eigen::Vector4d b = loc.barycentric(t, u);
    EXPECT_GE(b.minCoeff(), -1e-12);
    EXPECT_NEAR(b.sum(), 1.0, 1e-12);
  }
}

TEST(ParameterLocator, PointsOutsideTakeTheNearestTet) {
  const TetMesh m = kuhnCube(4, [](const Eigen::Vector3d& u) { return u; });
  const Eigen::MatrixX3d U = parameters(m);
  const ParameterLocator loc(U, m.T);
  // Just outside the corner (0,0,0): a tet at that corner.
  const long t = loc.locate(Eigen::Vector3d(-1e-3, -1e-3, -1e-3));
  ASSERT_GE(t, 0);
  bool hasCorner = false;
  for (int k = 0; k < 4; ++k) hasCorner |= U.row(m.T(t, k)).norm() == 0;
  EXPECT_TRUE(hasCorner);
  // Far outside: still some tet.
  EXPECT_GE(loc.locate(Eigen::Vector3d(-5, 7, 0.5)), 0);
}

TEST(ParameterLocator, RejectsBadInput) {
  Eigen::MatrixX3d U(4, 3);
  U << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  Eigen::MatrixX4i T(1, 4);
  T << 0, 1, 2, 4;
  EXPECT_THROW(ParameterLocator(U, T), Error);
  EXPECT_THROW(ParameterLocator(U, Eigen::MatrixX4i(0, 4)), Error);
}

// Region 2 (u < 1/2) is squeezed into x < a: its parametric volume per unit of
// physical volume is (1/2)/a, region 1's is (1/2)/(1 − a). With uniform knots
// the element density per unit physical volume follows exactly that ratio,
// and every element's region is the region of its centre.
TEST(ElementRegions, DensityFollowsTheParametricVolume) {
  const double a = 0.125;
  const TetMesh m = twoRegionSlab(8, a);
  const Eigen::MatrixX3d U = parameters(m);
  const BSplineVolume S = BSplineVolume::identity(KnotVector::uniform(3, 8), KnotVector::uniform(3, 6),
                                                  KnotVector::uniform(3, 5));
  const std::vector<int> reg = elementRegions(S, U, m.T, m.region);
  const std::vector<BezierElement> els = S.elements();
  ASSERT_EQ(reg.size(), els.size());
  for (size_t e = 0; e < els.size(); ++e) EXPECT_EQ(reg[e], els[e].centre[0] < 0.5 ? 2 : 1);

  const auto d = regionElementDensity(reg, m.V, U, m.T, m.region);
  ASSERT_EQ(d.size(), 2u);
  EXPECT_EQ(d[0].id, 1);
  EXPECT_EQ(d[1].id, 2);
  EXPECT_EQ(d[0].elements + d[1].elements, static_cast<long>(els.size()));
  EXPECT_NEAR(d[1].volume, a, 1e-12);
  EXPECT_NEAR(d[0].volume, 1 - a, 1e-12);
  EXPECT_NEAR(d[1].parametricVolume, 0.5, 1e-12);
  EXPECT_NEAR(d[0].elementsPerVolume, d[0].elements / (1 - a), 1e-9);
  const double wantRatio = (0.5 / a) / (0.5 / (1 - a));
  EXPECT_NEAR(d[1].elementsPerVolume / d[0].elementsPerVolume, wantRatio, 1e-9);
}

// With the element boundaries not on the region boundary, the counts are
// right to within one layer of elements.
TEST(ElementRegions, CountsWithinOneLayerWhenKnotsDoNotAlign) {
  const double a = 0.25;
  const TetMesh m = twoRegionSlab(10, a);
  const Eigen::MatrixX3d U = parameters(m);
  const int n = 7;  // element centres at (i + 1/2)/7: none on u = 1/2
  const BSplineVolume S = BSplineVolume::identity(KnotVector::uniform(2, n), KnotVector::uniform(2, n),
                                                  KnotVector::uniform(2, n));
  const auto d = regionElementDensity(elementRegions(S, U, m.T, m.region), m.V, U, m.T, m.region);
  ASSERT_EQ(d.size(), 2u);
  const double layer = n * n;
  EXPECT_NEAR(d[1].elements, 0.5 * n * n * n, layer);
  EXPECT_NEAR(d[0].elements, 0.5 * n * n * n, layer);
}

TEST(ElementRegions, RejectsMismatchedSizes) {
  const TetMesh m = kuhnCube(2, [](const Eigen::Vector3d& u) { return u; });
  const BSplineVolume S = BSplineVolume::identity(KnotVector::uniform(2, 2), KnotVector::uniform(2, 2),
                                                  KnotVector::uniform(2, 2));
  EXPECT_THROW(elementRegions(S, parameters(m), m.T, Eigen::VectorXi::Ones(3)), Error);
  EXPECT_THROW(regionElementDensity({1}, m.V, parameters(m).topRows(3), m.T, m.region), Error);
  EXPECT_THROW(regionElementDensity(std::vector<int>(8, 7), m.V, parameters(m), m.T, m.region), Error);
}

// One region: every element is in it (without the locator), and the
// locator's checks still hold: flat parameters, indices out of range and
// non-finite parameters are refused.
TEST(ElementRegions, OneRegionTagsEveryElementAndKeepsTheChecks) {
  TetMesh m = kuhnCube(3, [](const Eigen::Vector3d& u) { return u; });
  m.region.setConstant(5);
  const Eigen::MatrixX3d U = parameters(m);
  const BSplineVolume S = BSplineVolume::identity(KnotVector::uniform(2, 3), KnotVector::uniform(2, 4),
                                                  KnotVector::uniform(2, 2));
  const std::vector<int> reg = elementRegions(S, U, m.T, m.region);
  ASSERT_EQ(reg.size(), S.elements().size());
  for (int r : reg) EXPECT_EQ(r, 5);
  Eigen::MatrixX3d flat = U;
  flat.col(2).setZero();
  EXPECT_THROW(elementRegions(S, flat, m.T, m.region), Error);
  Eigen::MatrixX4i bad = m.T;
  bad(0, 0) = static_cast<int>(U.rows());
  EXPECT_THROW(elementRegions(S, U, bad, m.region), Error);
  Eigen::MatrixX3d nan = U;
  nan(0, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(elementRegions(S, nan, m.T, m.region), Error);
}
