// Laws of the semi-discrete OT solver: masses reached, known solutions,
// Hessian = derivative of the gradient, invariances, global convergence,
// degenerate and bad input.
#include "tet2spline/param/optimal_transport.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <random>

using namespace tet2spline;

namespace {

Eigen::MatrixX3d randomPoints(int n, unsigned seed, double lo = 0, double hi = 1) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(lo, hi);
  Eigen::MatrixX3d p(n, 3);
  for (int i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) p(i, c) = u(rng);
  return p;
}

Eigen::VectorXd randomMasses(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.5, 1.5);
  Eigen::VectorXd m(n);
  for (auto& v : m) v = u(rng);
  return m;
}

void expectSolved(const OptimalTransportResult& r, const Domain& domain, double tol) {
  ASSERT_TRUE(r.status.ok) << r.status.message;
  EXPECT_LT(r.maxRelativeMassError, tol);
  EXPECT_NEAR(r.cellVolumes.sum(), domain.volume(), 1e-12 * domain.volume());
  EXPECT_NEAR(r.masses.sum(), domain.volume(), 1e-12 * domain.volume());
  for (int i = 0; i < r.cellVolumes.size(); ++i) {
    EXPECT_LT(std::abs(r.cellVolumes[i] - r.masses[i]) / r.masses[i], tol) << i;
    EXPECT_TRUE(domain.contains(r.centroids.row(i).transpose(), 1e-12)) << i;
  }
  EXPECT_EQ(static_cast<int>(r.stepSizes.size()), r.iterations);
}

}  // namespace

TEST(OptimalTransport, RegularGridWithEqualMassesHasConstantWeights) {
  const int m = 5;
  Eigen::MatrixX3d y(m * m * m, 3);
  for (int i = 0; i < m * m * m; ++i) y.row(i) << (i % m + 0.5) / m, ((i / m) % m + 0.5) / m, (i / (m * m) + 0.5) / m;
  OptimalTransportOptions options;
  options.maxRelativeMassError = 1e-10;
  const auto r = solveOptimalTransport(y, Eigen::VectorXd::Ones(y.rows()), Domain::unitCube(), options);
  expectSolved(r, Domain::unitCube(), 1e-10);
  const Eigen::ArrayXd psi = r.weights.array() - r.weights.mean();
  EXPECT_LT(psi.abs().maxCoeff(), 1e-10);
  EXPECT_LT((r.centroids - y).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(OptimalTransport, TwoPointsSplitAtTheAnalyticPlane) {
  Eigen::MatrixX3d y(2, 3);
  y << 0.2, 0.4, 0.7, 0.9, 0.6, 0.3;  // not aligned with the axes
  Eigen::VectorXd nu(2);
  nu << 1, 3;
  OptimalTransportOptions options;
  options.maxRelativeMassError = 1e-12;
  const auto r = solveOptimalTransport(y, nu, Domain::unitCube(), options);
  expectSolved(r, Domain::unitCube(), 1e-12);
  // The split plane {x : 2x·(y1 − y0) = |y1|² − |y0|² + ψ0 − ψ1} cuts off a quarter of the cube.
  EXPECT_NEAR(r.cellVolumes[0], 0.25, 1e-12);
  EXPECT_NEAR(r.cellVolumes[1], 0.75, 1e-12);
  // Axis-aligned case with a closed form: the plane is x = 1/4.
  y << 0.3, 0.5, 0.5, 0.7, 0.5, 0.5;
  const auto a = solveOptimalTransport(y, nu, Domain::unitCube(), options);
  ASSERT_TRUE(a.status.ok);
  // 2x·0.4 = 0.49 − 0.09 + ψ0 − ψ1 at x = 0.25  =>  ψ0 − ψ1 = −0.2.
  EXPECT_NEAR(a.weights[0] - a.weights[1], -0.2, 1e-12);
  EXPECT_NEAR(a.centroids(0, 0), 0.125, 1e-12);
  EXPECT_NEAR(a.centroids(1, 0), 0.625, 1e-12);
}

TEST(OptimalTransport, MassesAreReachedAndConserved) {
  const Eigen::MatrixX3d y = randomPoints(3000, 11);
  const Eigen::VectorXd nu = randomMasses(3000, 12);
  const auto r = solveOptimalTransport(y, nu, Domain::unitCube());
  expectSolved(r, Domain::unitCube(), 1e-6);
  EXPECT_LT(r.iterations, 20);
  EXPECT_EQ(r.stepSizes.back(), 1.0);  // full Newton steps at the end
}

TEST(OptimalTransport, HessianMatchesFiniteDifferencesOfTheGradient) {
  const int n = 150;
  const Eigen::MatrixX3d y = randomPoints(n, 13);
  const Eigen::VectorXd psi = 2e-3 * Eigen::VectorXd::Random(n);
  const PowerDiagram pd = computePowerDiagram(y, psi, Domain::unitCube());
  const Eigen::SparseMatrix<double> H = kantorovichHessian(y, pd);
  const Eigen::MatrixXd Hd(H);
  EXPECT_LT((Hd - Hd.transpose()).cwiseAbs().maxCoeff(), 1e-14 * Hd.cwiseAbs().maxCoeff());
  EXPECT_LT(Hd.rowwise().sum().cwiseAbs().maxCoeff(), 1e-12 * Hd.cwiseAbs().maxCoeff());
  const double h = 1e-6;
  for (int j : {0, 17, 42, 99, 149}) {
    Eigen::VectorXd plus = psi, minus = psi;
    plus[j] += h;
    minus[j] -= h;
    // g = ν − |Lag|, so ∂g/∂ψ_j = −∂|Lag|/∂ψ_j.
    const Eigen::VectorXd dg = -(computePowerDiagram(y, plus, Domain::unitCube()).volumes -
                                 computePowerDiagram(y, minus, Domain::unitCube()).volumes) /
                               (2 * h);
    EXPECT_LT((dg - Hd.col(j)).cwiseAbs().maxCoeff(), 1e-6 * Hd.col(j).cwiseAbs().maxCoeff()) << "column " << j;
  }
}

TEST(OptimalTransport, InvariantUnderPermutationAndWeightShift) {
  const int n = 800;
  const Eigen::MatrixX3d y = randomPoints(n, 14);
  const Eigen::VectorXd nu = randomMasses(n, 15);
  std::vector<int> perm(n);
  std::iota(perm.begin(), perm.end(), 0);
  std::shuffle(perm.begin(), perm.end(), std::mt19937(16));
  Eigen::MatrixX3d yp(n, 3);
  Eigen::VectorXd nup(n);
  for (int i = 0; i < n; ++i) {
    yp.row(i) = y.row(perm[i]);
    nup[i] = nu[perm[i]];
  }
  OptimalTransportOptions options;
  options.maxRelativeMassError = 1e-10;
  const auto a = solveOptimalTransport(y, nu, Domain::unitCube(), options);
  const auto b = solveOptimalTransport(yp, nup, Domain::unitCube(), options);
  ASSERT_TRUE(a.status.ok && b.status.ok);
  const double shift = a.weights[perm[0]] - b.weights[0];
  for (int i = 0; i < n; ++i) {
    EXPECT_NEAR(b.cellVolumes[i], a.cellVolumes[perm[i]], 1e-10 * a.cellVolumes[perm[i]]);
    EXPECT_LT((b.centroids.row(i) - a.centroids.row(perm[i])).norm(), 1e-8);
    EXPECT_NEAR(b.weights[i] + shift, a.weights[perm[i]], 1e-8);
  }
  // ψ + constant has the same cells.
  const PowerDiagram pa = computePowerDiagram(y, a.weights, Domain::unitCube());
  const PowerDiagram pb = computePowerDiagram(y, a.weights.array() - 12.5, Domain::unitCube());
  EXPECT_LT((pa.volumes - pb.volumes).cwiseAbs().maxCoeff(), 1e-12);
}

namespace {
// Points clustered in a small ball near a corner, masses ∝ x⁴ + small: far
// from the Voronoi volumes of either start.
void poorStart(Eigen::MatrixX3d& y, Eigen::VectorXd& nu) {
  const int n = 1500;
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(-1, 1);
  y.resize(n, 3);
  nu.resize(n);
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3d p;
    do p = Eigen::Vector3d(u(rng), u(rng), u(rng));
    while (p.squaredNorm() > 1);
    y.row(i) = (Eigen::Vector3d(0.2, 0.25, 0.3) + 0.08 * p).transpose();
    nu[i] = std::pow(y(i, 0), 4) + 1e-3;
  }
}
}  // namespace

TEST(OptimalTransport, ConvergesGloballyFromAPoorStart) {
  Eigen::MatrixX3d y;
  Eigen::VectorXd nu;
  poorStart(y, nu);
  for (OtStart start : {OtStart::Zero, OtStart::ScaledVoronoi}) {
    OptimalTransportOptions options;
    options.start = start;
    options.logNewtonAbove = 0;  // KMT's damped Newton from the start
    const auto r = solveOptimalTransport(y, nu, Domain::unitCube(), options);
    expectSolved(r, Domain::unitCube(), 1e-6);
    EXPECT_LT(*std::min_element(r.stepSizes.begin(), r.stepSizes.end()), 1.0);  // damping was needed
    // The line search brackets small steps by doubling gaps and bisects: a
    // step 2^-k that took k or more halvings from the iteration's first try
    // costs fewer than the k + 1 diagrams of halving one at a time.
    double previous = 1;
    int bracketed = 0;
    for (std::size_t it = 0; it < r.iterationStats.size(); ++it) {
      const auto& s = r.iterationStats[it];
      if (s.stepSize <= 0) continue;
      const int halvings = static_cast<int>(std::lround(std::log2(std::min(1.0, 2 * previous) / s.stepSize)));
      if (halvings >= 6) {
        EXPECT_LT(s.evaluations, halvings + 1) << "iteration " << it << ", step " << s.stepSize;
        ++bracketed;
      }
      previous = s.stepSize;
    }
    EXPECT_GE(bracketed, 1) << "no iteration needed 6 halvings: the check above means nothing";
  }
}

TEST(OptimalTransport, NewtonOnTheLogVolumesTakesLongerStepsFromAPoorStart) {
  // The poor start above (cells off by orders of magnitude both ways): the
  // log phase reaches the same cells (the solution is unique up to a
  // constant ψ) with fewer damped steps and fewer diagrams than KMT's
  // Newton from the start, and hands over to KMT's Newton, which takes the
  // last, full steps.
  Eigen::MatrixX3d y;
  Eigen::VectorXd nu;
  poorStart(y, nu);
  OptimalTransportOptions options;
  options.maxRelativeMassError = 1e-9;
  const auto withLog = solveOptimalTransport(y, nu, Domain::unitCube(), options);
  options.logNewtonAbove = 0;
  const auto kmt = solveOptimalTransport(y, nu, Domain::unitCube(), options);
  expectSolved(withLog, Domain::unitCube(), 1e-9);
  expectSolved(kmt, Domain::unitCube(), 1e-9);
  auto diagrams = [](const OptimalTransportResult& r) {
    int d = 0;
    for (const OtIterationStats& s : r.iterationStats) d += s.evaluations;
    return d;
  };
  auto damped = [](const OptimalTransportResult& r) {
    return std::count_if(r.stepSizes.begin(), r.stepSizes.end(), [](double t) { return t < 1; });
  };
  EXPECT_LT(diagrams(withLog), diagrams(kmt));
  EXPECT_LT(damped(withLog), damped(kmt));
  EXPECT_EQ(withLog.stepSizes.back(), 1.0);
  EXPECT_TRUE(withLog.iterationStats.front().logVolumes);  // the log phase first, KMT's Newton last
  EXPECT_FALSE(withLog.iterationStats.back().logVolumes);
  for (const OtIterationStats& s : kmt.iterationStats) EXPECT_FALSE(s.logVolumes);
  EXPECT_LT((withLog.centroids - kmt.centroids).cwiseAbs().maxCoeff(), 1e-7);
  const double shift = withLog.weights[0] - kmt.weights[0];
  EXPECT_LT((withLog.weights.array() - shift - kmt.weights.array()).abs().maxCoeff(), 1e-7);
  std::printf("diagrams %d (log phase) against %d, damped steps %d against %d\n", diagrams(withLog), diagrams(kmt),
              static_cast<int>(damped(withLog)), static_cast<int>(damped(kmt)));
}

TEST(OptimalTransport, LinearSolversAgree) {
  const Eigen::MatrixX3d y = randomPoints(1000, 18);
  const Eigen::VectorXd nu = randomMasses(1000, 19);
  OptimalTransportOptions options;
  options.maxRelativeMassError = 1e-9;
  std::vector<Eigen::VectorXd> volumes;
  for (OtLinearSolver s : {OtLinearSolver::ConjugateGradient, OtLinearSolver::IncompleteCholeskyCG,
                           OtLinearSolver::Cholmod, OtLinearSolver::AggregationAmgCG, OtLinearSolver::JacobiThenAmgCG}) {
    options.linearSolver = s;
    const auto r = solveOptimalTransport(y, nu, Domain::unitCube(), options);
    expectSolved(r, Domain::unitCube(), 1e-9);
    volumes.push_back(r.cellVolumes);
  }
  EXPECT_LT((volumes[0] - volumes[2]).cwiseAbs().maxCoeff(), 1e-9 * volumes[2].maxCoeff());
  EXPECT_LT((volumes[3] - volumes[2]).cwiseAbs().maxCoeff(), 1e-9 * volumes[2].maxCoeff());
  EXPECT_LT((volumes[4] - volumes[2]).cwiseAbs().maxCoeff(), 1e-9 * volumes[2].maxCoeff());
}

TEST(OptimalTransport, BallDomain) {
  // Level 4 (2562 planes): with few points each boundary cell meets hundreds
  // of the default level's planes, which is slow and tests nothing more.
  const Domain ball = Domain::unitBall(4);
  const int n = 2000;
  Eigen::MatrixX3d y = randomPoints(n, 20, -1, 1);
  for (int i = 0; i < n; ++i)
    if (i % 5 == 0) y.row(i).normalize();  // boundary vertices: exactly on the unit sphere
    else if (y.row(i).norm() > 1) y.row(i) *= 0.99 / y.row(i).norm();
  const Eigen::VectorXd nu = randomMasses(n, 21);
  for (OtStart start : {OtStart::Zero, OtStart::ScaledVoronoi}) {
    OptimalTransportOptions options;
    options.start = start;
    const auto r = solveOptimalTransport(y, nu, ball, options);
    expectSolved(r, ball, 1e-6);
  }
}

TEST(OptimalTransport, CoincidentPointsShareACell) {
  Eigen::MatrixX3d y = randomPoints(300, 22);
  y.row(5) = y.row(100);
  y.row(200) = y.row(100);
  Eigen::VectorXd nu = randomMasses(300, 23);
  const auto r = solveOptimalTransport(y, nu, Domain::unitCube());
  expectSolved(r, Domain::unitCube(), 1e-6);
  EXPECT_EQ(r.mergedPoints, 2);
  EXPECT_EQ(r.weights[5], r.weights[100]);
  EXPECT_EQ(r.centroids.row(5), r.centroids.row(200));
  OptimalTransportOptions strict;
  strict.mergeCoincidentPoints = false;
  try {
    solveOptimalTransport(y, nu, Domain::unitCube(), strict);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::Input);
    EXPECT_NE(std::string(e.what()).find("coincides"), std::string::npos) << e.what();
  }
}

TEST(OptimalTransport, PointsOutsideTheDomain) {
  Eigen::MatrixX3d y = randomPoints(200, 24);
  y.row(3) << 0.5, 0.5, 0.5;
  y.row(0) << 5, 0.5, 0.5;  // Voronoi cell misses the cube
  y.row(1) << 0.99, 0.5, 0.5;
  const Eigen::VectorXd nu = randomMasses(200, 25);
  // The scaled-Voronoi start pulls it in: solvable.
  const auto r = solveOptimalTransport(y, nu, Domain::unitCube());
  expectSolved(r, Domain::unitCube(), 1e-6);
  // From ψ = 0 its cell is empty: a clear error.
  OptimalTransportOptions zero;
  zero.start = OtStart::Zero;
  try {
    solveOptimalTransport(y, nu, Domain::unitCube(), zero);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::Input);
    EXPECT_NE(std::string(e.what()).find("point 0 (5, 0.5, 0.5)"), std::string::npos) << e.what();
  }
}

TEST(OptimalTransport, ProgressIsReportedAndCanStop) {
  const Eigen::MatrixX3d y = randomPoints(500, 26);
  const Eigen::VectorXd nu = randomMasses(500, 27);
  OptimalTransportOptions options;
  int calls = 0;
  options.progress = [&](double fraction, const std::string& message) {
    ++calls;
    EXPECT_LE(fraction, 1.0);
    EXPECT_NE(message.find("newton"), std::string::npos);
    return true;
  };
  auto r = solveOptimalTransport(y, nu, Domain::unitCube(), options);
  EXPECT_TRUE(r.status.ok);
  EXPECT_EQ(calls, r.iterations);
  options.progress = [](double, const std::string&) { return false; };
  r = solveOptimalTransport(y, nu, Domain::unitCube(), options);
  EXPECT_FALSE(r.status.ok);
  EXPECT_EQ(r.iterations, 1);
  options.progress = {};
  options.maxNewtonIterations = 1;
  r = solveOptimalTransport(y, nu, Domain::unitCube(), options);
  EXPECT_FALSE(r.status.ok);
  EXPECT_NE(r.status.message.find("no convergence"), std::string::npos);
}

TEST(OptimalTransport, BadInputThrowsNamingTheCause) {
  const Eigen::MatrixX3d y = randomPoints(10, 28);
  auto expectError = [&](const Eigen::MatrixX3d& p, const Eigen::VectorXd& m, ErrorKind kind, const char* cause) {
    try {
      solveOptimalTransport(p, m, Domain::unitCube());
      ADD_FAILURE() << "no throw for " << cause;
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), kind) << e.what();
      EXPECT_NE(std::string(e.what()).find("solveOptimalTransport"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(cause), std::string::npos) << e.what();
    }
  };
  expectError(y, Eigen::VectorXd::Ones(9), ErrorKind::Usage, "9 masses");
  expectError(Eigen::MatrixX3d(0, 3), Eigen::VectorXd(0), ErrorKind::Usage, "0 points");
  Eigen::VectorXd m = Eigen::VectorXd::Ones(10);
  m[4] = 0;
  expectError(y, m, ErrorKind::Input, "mass 0 of point 4");
  m[4] = -1;
  expectError(y, m, ErrorKind::Input, "mass -1 of point 4");
  m[4] = std::nan("");
  expectError(y, m, ErrorKind::Input, "of point 4");
  Eigen::MatrixX3d p = y;
  p(6, 2) = std::nan("");
  expectError(p, Eigen::VectorXd::Ones(10), ErrorKind::Input, "point 6");
  p(6, 2) = INFINITY;
  expectError(p, Eigen::VectorXd::Ones(10), ErrorKind::Input, "point 6");
  // The log phase's options.
  for (const double tolerance : {0.0, -1e-6, std::nan("")}) {
    OptimalTransportOptions options;
    options.logNewtonCgTolerance = tolerance;
    EXPECT_THROW(solveOptimalTransport(y, Eigen::VectorXd::Ones(10), Domain::unitCube(), options), Error) << tolerance;
    options.logNewtonAbove = 0;  // (off: not used)
    EXPECT_TRUE(solveOptimalTransport(y, Eigen::VectorXd::Ones(10), Domain::unitCube(), options).status.ok);
  }
  OptimalTransportOptions options;
  options.logNewtonHalvings = -1;
  try {
    solveOptimalTransport(y, Eigen::VectorXd::Ones(10), Domain::unitCube(), options);
    ADD_FAILURE() << "no throw for logNewtonHalvings -1";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::Usage);
    EXPECT_NE(std::string(e.what()).find("logNewtonHalvings"), std::string::npos) << e.what();
  }
}

// Below the precision that the cells' volumes are computed to, no Newton
// step reduces the error: a tolerance of 1e-18 stalls after every fallback
// (CHOLMOD, the relative merit, ψ in two doubles). Within stallAcceptFactor
// of the tolerance the transport ends there, successful and flagged, with
// the masses reached to that error; with a factor of 1 it fails as before.
TEST(OptimalTransport, StallJustAboveTheToleranceEndsFlaggedOrFails) {
  const Eigen::MatrixX3d y = randomPoints(500, 21);
  const Eigen::VectorXd nu = randomMasses(500, 22);
  OptimalTransportOptions o;
  o.maxRelativeMassError = 1e-18;
  o.stallAcceptFactor = 1e8;
  const auto r = solveOptimalTransport(y, nu, Domain::unitCube(), o);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  EXPECT_TRUE(r.stalledAboveTolerance);
  EXPECT_GT(r.maxRelativeMassError, o.maxRelativeMassError);
  EXPECT_LE(r.maxRelativeMassError, o.stallAcceptFactor * o.maxRelativeMassError);
  EXPECT_GE(r.solverSwitches, 3);
  for (int i = 0; i < r.cellVolumes.size(); ++i)
    EXPECT_LE(std::abs(r.cellVolumes[i] - r.masses[i]), r.maxRelativeMassError * r.masses[i] * (1 + 1e-9)) << i;
  o.stallAcceptFactor = 1;
  const auto failed = solveOptimalTransport(y, nu, Domain::unitCube(), o);
  EXPECT_FALSE(failed.status.ok);
  EXPECT_FALSE(failed.stalledAboveTolerance);
  EXPECT_NE(failed.status.message.find("line search failed"), std::string::npos) << failed.status.message;
  // Converged runs are not flagged.
  EXPECT_FALSE(solveOptimalTransport(y, nu, Domain::unitCube()).stalledAboveTolerance);
}
