#include "tet2spline/param/harmonic_map.h"

#include <gtest/gtest.h>

#include <random>

#include "ball_test_meshes.h"
#include "tet2spline/param/topology.h"

using namespace tet2spline;

namespace {

// A grid with interior vertices jittered (still positively oriented), so the
// cotangent weights differ and some are negative.
TetMesh jitteredGrid(int n, double amount) {
  TetMesh m = t2stest::cubeGrid(n);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-amount, amount);
  for (Eigen::Index v = 0; v < m.V.rows(); ++v)
    if (m.V.row(v).cwiseAbs().maxCoeff() < 1 - 1e-12)
      for (int d = 0; d < 3; ++d) m.V(v, d) += u(rng) * 2.0 / n;
  return m;
}

bool onBoundary(const TetMesh& m, Eigen::Index v) { return m.V.row(v).cwiseAbs().maxCoeff() > 1 - 1e-12; }

}  // namespace

TEST(CotangentStiffness, SymmetricRowsSumToZeroAndLinearFunctionsAreHarmonic) {
  const TetMesh m = jitteredGrid(6, 0.2);
  ASSERT_EQ(countNonPositiveTets(m.V, m.T), 0);
  const Eigen::SparseMatrix<double> L = cotangentStiffness(m.V, m.T);
  ASSERT_EQ(L.rows(), m.V.rows());
  const Eigen::SparseMatrix<double> Lt = L.transpose();
  EXPECT_EQ((L - Lt).norm(), 0.0);  // exactly symmetric
  const double scale = L.diagonal().maxCoeff();
  const Eigen::VectorXd rowSums = L * Eigen::VectorXd::Ones(L.cols());
  EXPECT_LT(rowSums.cwiseAbs().maxCoeff(), 1e-12 * scale);
  bool negative = false;
  for (Eigen::Index j = 0; j < L.outerSize(); ++j)
    for (Eigen::SparseMatrix<double>::InnerIterator it(L, j); it; ++it) negative |= it.row() != j && it.value() > 0;
  EXPECT_TRUE(negative) << "expected some negative cotangent weights in a jittered grid";
  // L x = 0 at interior vertices for linear x.
  const Eigen::Vector3d a(0.3, -1.2, 2.5);
  const Eigen::VectorXd x = m.V * a + Eigen::VectorXd::Constant(m.V.rows(), 0.7);
  const Eigen::VectorXd Lx = L * x;
  for (Eigen::Index v = 0; v < m.V.rows(); ++v)
    if (!onBoundary(m, v)) {
      EXPECT_NEAR(Lx[v], 0.0, 1e-12 * scale) << "vertex " << v;
    }
  // xᵀ L x is the Dirichlet energy: |a|² · volume (8 for [-1,1]³).
  EXPECT_NEAR(x.dot(Lx), a.squaredNorm() * 8, 1e-10);
}

TEST(CotangentStiffness, DeterministicAndRejectsFlatTets) {
  const TetMesh m = jitteredGrid(4, 0.2);
  const Eigen::SparseMatrix<double> A = cotangentStiffness(m.V, m.T), B = cotangentStiffness(m.V, m.T);
  EXPECT_EQ((A - B).norm(), 0.0);
  TetMesh flat = m;
  flat.V.row(flat.T(5, 3)) = flat.V.row(flat.T(5, 0));
  EXPECT_THROW(cotangentStiffness(flat.V, flat.T), Error);
  Eigen::MatrixX4i badT = m.T;
  badT(0, 0) = -1;
  EXPECT_THROW(cotangentStiffness(m.V, badT), Error);
}

TEST(HarmonicMap, ReproducesAffineBoundaryDataAndSmallResidual) {
  const TetMesh m = jitteredGrid(7, 0.2);
  std::vector<int> b;
  for (Eigen::Index v = 0; v < m.V.rows(); ++v)
    if (onBoundary(m, v)) b.push_back(static_cast<int>(v));
  const Eigen::VectorXi fixedVertices = Eigen::Map<Eigen::VectorXi>(b.data(), static_cast<Eigen::Index>(b.size()));
  Eigen::Matrix3d A;
  A << 1.5, 0.2, -0.1, 0.0, 0.8, 0.3, 0.4, -0.2, 1.1;
  const Eigen::RowVector3d t(0.5, -2, 1);
  const Eigen::MatrixX3d expected = (m.V * A.transpose()).rowwise() + t;
  Eigen::MatrixX3d fixedPositions(fixedVertices.size(), 3);
  for (Eigen::Index k = 0; k < fixedVertices.size(); ++k) fixedPositions.row(k) = expected.row(fixedVertices[k]);
  const HarmonicMapResult r = harmonicMap(m.V, m.T, fixedVertices, fixedPositions);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  EXPECT_EQ(r.solver, "cholmod");
  EXPECT_LT(r.relativeResidual, 1e-8);
  EXPECT_LT((r.U - expected).cwiseAbs().maxCoeff(), 1e-10);
  for (Eigen::Index k = 0; k < fixedVertices.size(); ++k) EXPECT_EQ(r.U.row(fixedVertices[k]), fixedPositions.row(k));
}

TEST(HarmonicMap, RejectsBadFixedLists) {
  const TetMesh m = t2stest::cubeGrid(2);
  Eigen::VectorXi twice(2);
  twice << 0, 0;
  EXPECT_THROW(harmonicMap(m.V, m.T, twice, Eigen::MatrixX3d::Zero(2, 3)), Error);
  Eigen::VectorXi one(1);
  one << 0;
  EXPECT_THROW(harmonicMap(m.V, m.T, one, Eigen::MatrixX3d::Zero(2, 3)), Error);
}
