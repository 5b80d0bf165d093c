// The aggregation AMG that preconditions the transport's Newton systems: on
// a Laguerre Hessian whose cells span orders of magnitude it is a symmetric
// operator, positive on mean-free vectors (so CG may use it), its levels
// shrink, and it saves most of Jacobi's CG iterations with the same result;
// the default solver turns to it only where Jacobi is slow.
#include "../../param/src/aggregation_amg.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "tet2spline/param/optimal_transport.h"
#include "tet2spline/param/power_diagram.h"

using namespace tet2spline;

namespace {

// Half the points uniform in the cube, half in a small ball: with equal
// masses the small ball's cells must grow by about 10⁶ in volume.
Eigen::MatrixX3d clusteredPoints(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1), v(-1, 1);
  Eigen::MatrixX3d p(n, 3);
  for (int i = 0; i < n; ++i) {
    if (i % 2 == 0) {
      p.row(i) << u(rng), u(rng), u(rng);
      continue;
    }
    Eigen::RowVector3d q;
    do q << v(rng), v(rng), v(rng);
    while (q.squaredNorm() > 1);
    p.row(i) = Eigen::RowVector3d(0.3, 0.6, 0.4) + 0.005 * q;
  }
  return p;
}

// L = −H at the Voronoi diagram of the points (ψ = 0) in the unit cube.
Eigen::SparseMatrix<double> laguerreLaplacian(const Eigen::MatrixX3d& p) {
  const PowerDiagram pd = computePowerDiagram(p, Eigen::VectorXd::Zero(p.rows()), Domain::unitCube());
  return -kantorovichHessian(p, pd);
}

Eigen::VectorXd meanFree(Eigen::VectorXd v) {
  v.array() -= v.mean();
  return v;
}

}  // namespace

TEST(AggregationAmg, IsSymmetricAndPositiveOnMeanFreeVectors) {
  const Eigen::MatrixX3d p = clusteredPoints(6000, 3);
  const Eigen::SparseMatrix<double> L = laguerreLaplacian(p);
  const Eigen::VectorXd diagonal = L.diagonal();
  ASSERT_GT(diagonal.maxCoeff() / diagonal.minCoeff(), 1e3);  // entries over orders of magnitude
  const detail::AggregationAmg amg(L);
  std::mt19937 rng(5);
  std::normal_distribution<double> normal;
  std::vector<Eigen::VectorXd> vectors;
  for (int k = 0; k < 4; ++k) {
    Eigen::VectorXd v(p.rows());
    for (auto& x : v) x = normal(rng);
    vectors.push_back(meanFree(v));
  }
  for (int c = 0; c < 3; ++c) vectors.push_back(meanFree(p.col(c)));  // smooth ones
  for (size_t a = 0; a < vectors.size(); ++a) {
    Eigen::VectorXd ma;
    amg.apply(vectors[a], ma);
    EXPECT_GT(ma.dot(vectors[a]), 0) << a;
    for (size_t b = a + 1; b < vectors.size(); ++b) {
      Eigen::VectorXd mb;
      amg.apply(vectors[b], mb);
      EXPECT_NEAR(ma.dot(vectors[b]), mb.dot(vectors[a]), 1e-10 * ma.norm() * vectors[b].norm()) << a << " " << b;
    }
  }
}

TEST(AggregationAmg, LevelsShrinkToADenseCoarsest) {
  const Eigen::SparseMatrix<double> L = laguerreLaplacian(clusteredPoints(20000, 4));
  const std::vector<int> sizes = detail::AggregationAmg(L).levelSizes();
  ASSERT_GE(sizes.size(), 3u);
  EXPECT_EQ(sizes.front(), 20000);
  EXPECT_LE(sizes.back(), detail::AggregationAmg::Options().coarsestSize);
  for (size_t l = 1; l < sizes.size(); ++l) EXPECT_LT(sizes[l], sizes[l - 1] / 2) << "level " << l;
}

TEST(AggregationAmg, AMatrixThatDoesNotCoarsenIsSweptNotFactorisedDensely) {
  // No off-diagonal entries: nothing pairs, and 5000 rows are too many for
  // the dense solve; the cycle is then Jacobi sweeps, which here converge
  // to the inverse.
  const int n = 5000;
  Eigen::SparseMatrix<double> D(n, n);
  Eigen::VectorXd r(n);
  for (int i = 0; i < n; ++i) D.insert(i, i) = 1.0 + i % 7, r[i] = std::sin(i);
  const detail::AggregationAmg amg(D);
  EXPECT_EQ(amg.levelSizes(), std::vector<int>{n});
  Eigen::VectorXd z;
  amg.apply(r, z);
  for (int i = 0; i < n; ++i) ASSERT_NEAR(z[i], r[i] / (1.0 + i % 7), 1e-8) << i;
}

TEST(AggregationAmg, TransportNeedsFewerCgIterationsThanJacobiForTheSameResult) {
  const Eigen::MatrixX3d p = clusteredPoints(8000, 6);
  const Eigen::VectorXd masses = Eigen::VectorXd::Ones(p.rows());
  OptimalTransportOptions options;
  options.maxRelativeMassError = 1e-8;
  long iterations[2] = {0, 0};
  Eigen::VectorXd volumes[2];
  const OtLinearSolver solvers[2] = {OtLinearSolver::AggregationAmgCG, OtLinearSolver::ConjugateGradient};
  for (int s = 0; s < 2; ++s) {
    options.linearSolver = solvers[s];
    const OptimalTransportResult r = solveOptimalTransport(p, masses, Domain::unitCube(), options);
    ASSERT_TRUE(r.status.ok) << r.status.message;
    EXPECT_LT(r.maxRelativeMassError, 1e-8);
    for (const OtIterationStats& it : r.iterationStats) iterations[s] += it.linearIterations;
    volumes[s] = r.cellVolumes;
  }
  EXPECT_LT(iterations[0] * 4, iterations[1]) << "AMG " << iterations[0] << ", Jacobi " << iterations[1];
  EXPECT_LT((volumes[0] - volumes[1]).cwiseAbs().maxCoeff(), 2e-8 * volumes[1].maxCoeff());
}

TEST(AggregationAmg, TheDefaultSolverTurnsToItOnlyWhereJacobiIsSlow) {
  OptimalTransportOptions options;  // JacobiThenAmgCG
  options.maxRelativeMassError = 1e-8;
  options.logNewtonAbove = 0;  // KMT's systems throughout (the log phase's tighter solves differ)
  auto amgIterations = [&](const Eigen::MatrixX3d& p) {
    const OptimalTransportResult r = solveOptimalTransport(p, Eigen::VectorXd::Ones(p.rows()), Domain::unitCube(), options);
    EXPECT_TRUE(r.status.ok) << r.status.message;
    EXPECT_LT(r.maxRelativeMassError, 1e-8);
    int amg = 0;
    for (const OtIterationStats& it : r.iterationStats) {
      amg += it.amg;
      if (it.amg) {
        EXPECT_LT(it.linearIterations, options.jacobiIterationsAtMost + 100);
      }
    }
    return amg;
  };
  // Even cells: Jacobi solves every system within its 200 iterations.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.2, 0.8);
  Eigen::MatrixX3d even(8000, 3);
  for (Eigen::Index i = 0; i < even.rows(); ++i) even.row(i) << u(rng), u(rng), u(rng);
  EXPECT_EQ(amgIterations(even), 0);
  // Cells over six orders of magnitude: the AMG takes over.
  EXPECT_GT(amgIterations(clusteredPoints(8000, 6)), 0);
}
