#include "tet2spline/param/untangle.h"

#include <gtest/gtest.h>

#include <random>

#include "ball_test_meshes.h"
#include "tet2spline/param/topology.h"

using namespace tet2spline;

namespace {

std::vector<bool> boundaryMask(const TetMesh& m) {
  std::vector<bool> fixed(static_cast<size_t>(m.V.rows()));
  for (Eigen::Index v = 0; v < m.V.rows(); ++v) fixed[v] = m.V.row(v).cwiseAbs().maxCoeff() > 1 - 1e-12;
  return fixed;
}

}  // namespace

TEST(Untangle, FixesARandomlyTangledGrid) {
  const TetMesh m = t2stest::cubeGrid(8);
  const auto fixed = boundaryMask(m);
  Eigen::MatrixX3d U = m.V;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-0.3, 0.3);  // cell size 0.25: heavy tangling
  for (Eigen::Index v = 0; v < U.rows(); ++v)
    if (!fixed[v])
      for (int d = 0; d < 3; ++d) U(v, d) += jitter(rng);
  const int before = countNonPositiveTets(U, m.T);
  ASSERT_GT(before, 50);
  UntangleOptions options;
  options.rings = -1;
  const UntangleResult r = untangle(m.V, m.T, U, fixed, options);
  EXPECT_EQ(r.invertedBefore, before);
  EXPECT_EQ(r.invertedAfter, 0) << r.status.message;
  EXPECT_EQ(countNonPositiveTets(r.U, m.T), 0);
  EXPECT_TRUE(r.status.ok) << r.status.message;
  for (Eigen::Index v = 0; v < U.rows(); ++v)
    if (fixed[v]) {
      EXPECT_EQ(r.U.row(v), U.row(v));  // bitwise kept
    }
}

TEST(Untangle, LocalRegionFixesAFewInvertedTets) {
  const TetMesh m = t2stest::cubeGrid(10);
  const auto fixed = boundaryMask(m);
  Eigen::MatrixX3d U = m.V;
  // Push three interior vertices through their neighbours.
  for (int v : {333, 555, 777}) U.row(v) += Eigen::RowVector3d(0.3, -0.25, 0.2);
  ASSERT_GT(countNonPositiveTets(U, m.T), 0);
  const UntangleResult r = untangle(m.V, m.T, U, fixed);
  EXPECT_EQ(r.invertedAfter, 0) << r.status.message;
  EXPECT_LT(r.freeVertices, m.V.rows() / 2);
}

TEST(Untangle, NothingToDoLeavesTheMapAlone) {
  const TetMesh m = t2stest::cubeGrid(3);
  const UntangleResult r = untangle(m.V, m.T, m.V, boundaryMask(m));
  EXPECT_EQ(r.invertedBefore, 0);
  EXPECT_EQ(r.invertedAfter, 0);
  EXPECT_EQ(r.U, m.V);
}

TEST(Untangle, RejectsMismatchedShapes) {
  const TetMesh m = t2stest::cubeGrid(2);
  EXPECT_THROW(untangle(m.V, m.T, m.V.topRows(3), boundaryMask(m)), Error);
}
