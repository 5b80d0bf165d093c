// Laws of the least-squares B-spline fit: exact reproduction of maps in the
// spline space, agreement of the two linear solvers, validity repair,
// refinement to a target error, input errors.
#include <gtest/gtest.h>
#include <tet2spline/param/error.h>
#include <tet2spline/spline/bspline_basis.h>
#include <tet2spline/spline/fit.h>

#include <Eigen/LU>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <utility>
#include <vector>

using namespace tet2spline;
using namespace tet2spline::spline;

namespace {

Eigen::MatrixX3d randomParameters(long n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  Eigen::MatrixX3d U(n, 3);
  for (long i = 0; i < n; ++i) U.row(i) << uni(rng), uni(rng), uni(rng);
  return U;
}

template <class F>
Eigen::MatrixX3d apply(const Eigen::MatrixX3d& U, F f) {
  Eigen::MatrixX3d X(U.rows(), 3);
  for (Eigen::Index i = 0; i < U.rows(); ++i) X.row(i) = f(Eigen::Vector3d(U.row(i).transpose())).transpose();
  return X;
}

Eigen::Vector3d trilinear(const Eigen::Vector3d& u) {
  return {1 + 2 * u[0] + 0.3 * u[0] * u[1] - 0.2 * u[0] * u[1] * u[2], 0.5 * u[1] + 0.1 * u[0] * u[2] + u[1] * u[2],
          3 * u[2] - 0.4 * u[0] * u[1]};
}
Eigen::Vector3d tricubic(const Eigen::Vector3d& u) {
  const double a = u[0], b = u[1], c = u[2];
  return {a + 0.3 * a * a * a * b * b * b * c * c * c - 0.2 * a * a * b, b + 0.1 * a * a * a * c * c - 0.2 * b * b * b,
          c + 0.25 * a * b * b * c * c * c + 0.1 * a * a};
}

double maxDeviation(const BSplineVolume& V, const Eigen::MatrixX3d& U, const Eigen::MatrixX3d& X) {
  return (V.evaluate(U) - X).rowwise().norm().maxCoeff();
}

}  // namespace

// jacobianQuality (whose per-element sum factorisation also serves the
// validity stage) against BSplineVolume's own Jacobian at the same Gauss
// points: degrees 2, 3, 1, non-uniform knots, a curved and twisted map.
TEST(Fit, JacobianQualityAgreesWithTheVolumesJacobian) {
  const std::array<KnotVector, 3> K{KnotVector::fromBreakpoints(2, {0, 0.1, 0.45, 0.5, 1}),
                                    KnotVector::fromBreakpoints(3, {0, 0.3, 0.35, 0.8, 1}),
                                    KnotVector::fromBreakpoints(1, {0, 0.6, 0.7, 1})};
  const Eigen::VectorXd gu = K[0].greville(), gv = K[1].greville(), gw = K[2].greville();
  Eigen::MatrixX3d P(gu.size() * gv.size() * gw.size(), 3);
  Eigen::Index at = 0;
  for (Eigen::Index k = 0; k < gw.size(); ++k)
    for (Eigen::Index j = 0; j < gv.size(); ++j)
      for (Eigen::Index i = 0; i < gu.size(); ++i) {
        const double a = gu[i], b = gv[j], c = gw[k], twist = 0.6 * c;
        P.row(at++) << (1 + a) * std::cos(twist + b), (1 + a) * std::sin(twist + b), 2 * c + 0.3 * a * b;
      }
  const BSplineVolume V(K[0], K[1], K[2], P);
  double minDet = std::numeric_limits<double>::infinity(), minScaled = minDet, integral = 0;
  long points = 0, nonPositive = 0;
  std::array<std::vector<std::pair<double, double>>, 3> nodes;  // (parameter, weight) per direction
  for (int d = 0; d < 3; ++d) {
    const std::vector<double> br = K[d].breakpoints();
    for (size_t e = 0; e + 1 < br.size(); ++e) {
      const GaussRule r = gaussLegendre(K[d].degree() + 1, br[e], br[e + 1]);
      for (Eigen::Index g = 0; g < r.points.size(); ++g) nodes[d].push_back({r.points[g], r.weights[g]});
    }
  }
  for (const auto& [w, ww] : nodes[2])
    for (const auto& [v, wv] : nodes[1])
      for (const auto& [u, wu] : nodes[0]) {
        const Eigen::Vector3d x(u, v, w);
        const double det = V.detJacobian(x);
        minDet = std::min(minDet, det);
        minScaled = std::min(minScaled, V.scaledJacobian(x));
        integral += wu * wv * ww * det;
        nonPositive += det <= 0;
        ++points;
      }
  ASSERT_GT(minDet, 0);  // the map is valid: the test compares values, not signs
  const JacobianQuality q = jacobianQuality(V);
  EXPECT_EQ(q.gaussPoints, points);
  EXPECT_EQ(q.nonPositive, nonPositive);
  EXPECT_NEAR(q.minDetJ, minDet, 1e-12 * std::abs(minDet));
  EXPECT_NEAR(q.minScaledJacobian, minScaled, 1e-12);
  EXPECT_NEAR(q.meanDetJ, integral, 1e-12 * integral);  // parameter box [0,1]^3
}

TEST(Fit, ReproducesTrilinearAndTricubicMaps) {
  const Eigen::MatrixX3d U = randomParameters(20000, 1);
  const Eigen::MatrixX3d Ucheck = randomParameters(2000, 2);
  FitOptions opt;
  opt.smoothingWeight = 0;  // the thin-plate term would bend a non-affine map
  opt.elements = {4, 3, 5};
  for (auto f : {&trilinear, &tricubic}) {
    const Eigen::MatrixX3d X = apply(U, f);
    const FitResult r = fitBSplineVolume(U, X, {}, {}, opt);
    ASSERT_TRUE(r.status.ok) << r.status.message;
    EXPECT_LT(r.maxError, 1e-9);
    EXPECT_LT(r.rmsError, 1e-10);
    EXPECT_LT(maxDeviation(r.volume, Ucheck, apply(Ucheck, f)), 1e-9);
    EXPECT_EQ(r.negativeGaussPoints, 0);
    EXPECT_EQ(r.gaussPoints, 4L * 3 * 5 * 64);
    EXPECT_EQ(r.volume.numControl(0), 7);
    EXPECT_EQ(r.volume.numControl(2), 8);
  }
}

TEST(Fit, AffineMapsSurviveSmoothingAndWeights) {
  // The thin-plate energy vanishes on affine maps, so any λ, weights and
  // boundary flags reproduce them.
  const Eigen::MatrixX3d U = randomParameters(5000, 3);
  auto affine = [](const Eigen::Vector3d& u) {
    return Eigen::Vector3d(2 * u[0] + u[1] - 1, -u[0] + 3 * u[1] + 0.5 * u[2], u[2] - 0.2 * u[1] + 4);
  };
  const Eigen::MatrixX3d X = apply(U, affine);
  Eigen::VectorXd w = Eigen::VectorXd::LinSpaced(U.rows(), 0.5, 2.0);
  Eigen::Array<bool, Eigen::Dynamic, 1> boundary = (U.array() < 0.1).rowwise().any();
  FitOptions opt;
  opt.smoothingWeight = 1e-2;
  opt.elements = {3, 3, 3};
  const FitResult r = fitBSplineVolume(U, X, w, boundary, opt);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  EXPECT_LT(r.maxError, 1e-10);
  const double detA = (Eigen::Matrix3d() << 2, 1, 0, -1, 3, 0.5, 0, -0.2, 1).finished().determinant();
  EXPECT_NEAR(r.meanDetJ, detA, 1e-9);
  EXPECT_NEAR(r.minDetJ, detA, 1e-9);
  EXPECT_NEAR(r.volume.volume(), detA, 1e-9);
}

TEST(Fit, CeresAndCholmodLinearStagesAgree) {
  const Eigen::MatrixX3d U = randomParameters(600, 4);
  const Eigen::MatrixX3d X = apply(U, [](const Eigen::Vector3d& u) {
    return Eigen::Vector3d(std::sin(u[0]) + 0.2 * u[1], u[1] + 0.2 * std::cos(u[0] + u[2]), std::exp(0.3 * u[0] * u[2]) + u[2]);
  });
  FitOptions opt;
  opt.elements = {2, 1, 2};
  opt.smoothingWeight = 1e-4;
  const FitResult a = fitBSplineVolume(U, X, {}, {}, opt);
  opt.linearSolver = FitOptions::LinearSolver::Ceres;
  const FitResult b = fitBSplineVolume(U, X, {}, {}, opt);
  ASSERT_TRUE(a.status.ok && b.status.ok) << a.status.message << b.status.message;
  EXPECT_LT((a.volume.controlPoints() - b.volume.controlPoints()).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_GT(b.solverIterations, 0);
}

TEST(Fit, SmoothingFillsElementsWithoutData) {
  Eigen::MatrixX3d U = randomParameters(5000, 5);
  U.col(0) *= 0.5;  // no data for u > 0.5
  // Affine data: the thin-plate energy extends it exactly into the empty half.
  const Eigen::MatrixX3d X = apply(U, [](const Eigen::Vector3d& u) { return Eigen::Vector3d(u[0], u[1] + 0.1 * u[0], u[2]); });
  FitOptions opt;
  opt.elements = {4, 2, 2};
  opt.smoothingWeight = 1e-5;
  const FitResult r = fitBSplineVolume(U, X, {}, {}, opt);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  EXPECT_LT(r.maxError, 1e-9);
  EXPECT_EQ(r.negativeGaussPoints, 0);
  EXPECT_NEAR(r.volume.volume(), 1.0, 1e-9);
  opt.smoothingWeight = 0;
  const FitResult s = fitBSplineVolume(U, X, {}, {}, opt);
  EXPECT_FALSE(s.status.ok);
  EXPECT_NE(s.status.message.find("normal equations"), std::string::npos) << s.status.message;
}

class FitValidity : public ::testing::TestWithParam<FitOptions::ValiditySolver> {};

TEST_P(FitValidity, RepairsAFold) {
  // x(u) = u + 0.12 sin(6πu) is not monotone: a close fit folds (det J < 0).
  const Eigen::MatrixX3d U = randomParameters(6000, 6);
  const Eigen::MatrixX3d X = apply(U, [](const Eigen::Vector3d& u) {
    return Eigen::Vector3d(u[0] + 0.12 * std::sin(6 * M_PI * u[0]), u[1], u[2]);
  });
  FitOptions opt;
  opt.validitySolver = GetParam();
  opt.elements = {6, 2, 2};
  opt.smoothingWeight = 1e-8;
  opt.enforceValidity = false;
  const FitResult folded = fitBSplineVolume(U, X, {}, {}, opt);
  ASSERT_GT(folded.negativeGaussPoints, 0);
  EXPECT_FALSE(folded.status.ok && folded.negativeGaussPoints == 0);
  opt.enforceValidity = true;
  int calls = 0;
  opt.progress = [&](double, const std::string&) { ++calls; return true; };
  const FitResult r = fitBSplineVolume(U, X, {}, {}, opt);
  EXPECT_TRUE(r.status.ok) << r.status.message;
  EXPECT_EQ(r.negativeGaussPointsBeforeValidity, folded.negativeGaussPoints);
  EXPECT_EQ(r.negativeGaussPoints, 0);
  EXPECT_GT(r.minDetJ, 0.0);
  EXPECT_GT(r.minScaledJacobian, 0.0);
  EXPECT_GE(r.validityIterations, 1);
  EXPECT_GT(calls, 2);
  EXPECT_EQ(jacobianQuality(r.volume).nonPositive, 0);
  // Unfolding costs accuracy, but the fit still follows the data's trend.
  EXPECT_LT(r.rmsErrorRelative, 0.1);
}

INSTANTIATE_TEST_SUITE_P(Solvers, FitValidity,
                         ::testing::Values(FitOptions::ValiditySolver::Lbfgs,
                                           FitOptions::ValiditySolver::LevenbergMarquardt));

TEST(Fit, RefinesUntilTheTargetError) {
  const Eigen::MatrixX3d U = randomParameters(20000, 7);
  const Eigen::MatrixX3d X = apply(U, [](const Eigen::Vector3d& u) {
    return Eigen::Vector3d(u[0] + 0.1 * std::sin(3 * u[1]), u[1] + 0.1 * std::cos(3 * u[2]), u[2] + 0.1 * std::sin(3 * u[0]));
  });
  FitOptions opt;
  opt.elements = {1, 1, 1};
  opt.smoothingWeight = 1e-9;
  opt.targetRmsRelative = 1e-5;
  opt.maxRefinements = 4;
  const FitResult r = fitBSplineVolume(U, X, {}, {}, opt);
  ASSERT_TRUE(r.status.ok) << r.status.message;
  EXPECT_LT(r.rmsErrorRelative, 1e-5);
  EXPECT_GE(r.refinements, 1);
  EXPECT_EQ(r.elements, Eigen::Vector3i::Constant(1 << r.refinements));
  opt.maxRefinements = 0;
  const FitResult s = fitBSplineVolume(U, X, {}, {}, opt);
  EXPECT_FALSE(s.status.ok);
  EXPECT_NE(s.status.message.find("target"), std::string::npos);
}

TEST(Fit, ProgressCallbackCanStop) {
  const Eigen::MatrixX3d U = randomParameters(500, 8);
  FitOptions opt;
  opt.elements = {2, 2, 2};
  opt.progress = [](double, const std::string&) { return false; };
  const FitResult r = fitBSplineVolume(U, U, {}, {}, opt);
  EXPECT_FALSE(r.status.ok);
  EXPECT_NE(r.status.message.find("stopped"), std::string::npos);
}

TEST(Fit, RejectsBadInput) {
  const Eigen::MatrixX3d U = randomParameters(100, 9);
  auto expectUsage = [](auto&& call, const std::string& needle) {
    try {
      call();
      ADD_FAILURE() << "no exception, expected one mentioning " << needle;
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::Usage);
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("fitBSplineVolume"), std::string::npos) << e.what();
    }
  };
  expectUsage([&] { fitBSplineVolume(U, U.topRows(50)); }, "positions");
  expectUsage([&] { fitBSplineVolume(U, U, Eigen::VectorXd::Ones(3)); }, "weights");
  expectUsage([&] { fitBSplineVolume(U, U, -Eigen::VectorXd::Ones(100)); }, "weight");
  expectUsage([&] { fitBSplineVolume(U, U, {}, Eigen::Array<bool, Eigen::Dynamic, 1>::Zero(7)); }, "boundary");
  Eigen::MatrixX3d Ubad = U;
  Ubad(3, 1) = 1.5;
  expectUsage([&] { fitBSplineVolume(Ubad, U); }, "outside");
  Ubad(3, 1) = std::nan("");
  expectUsage([&] { fitBSplineVolume(Ubad, U); }, "non-finite");
  FitOptions opt;
  opt.degree = 0;
  expectUsage([&] { fitBSplineVolume(U, U, {}, {}, opt); }, "degree");
  opt = {};
  opt.elements = {2, 0, 2};
  expectUsage([&] { fitBSplineVolume(U, U, {}, {}, opt); }, "element");
}
