// White-box test: the analytic derivatives of the fit's Ceres cost functions
// (spline/src/fit_costs.h, internal) against central differences.
#include <gtest/gtest.h>

#include "../../spline/src/fit_costs.h"

#include <ceres/gradient_checker.h>
#include <ceres/manifold.h>

#include <random>
#include <vector>

using namespace tet2spline::spline::detail;

namespace {

constexpr int kLocal = 27;  // a degree-2 element: 3 × 3 × 3 control points

/// 27 control points; blocks are scalars (one coordinate's 27 values:
/// `coordinate` 0..2) or 3-vectors (coordinate = kPoints: block l = point l).
constexpr int kPoints = -2;
struct Params {
  std::vector<double> values;
  std::vector<const double*> blocks;
  explicit Params(unsigned seed, int coordinate = kPoints) : values(3 * kLocal) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> uni(-0.2, 0.2);
    // Near the identity grid (det J > 0), perturbed.
    for (int l = 0; l < kLocal; ++l) {
      values[3 * l + 0] = (l % 3) / 2.0 + uni(rng);
      values[3 * l + 1] = (l / 3 % 3) / 2.0 + uni(rng);
      values[3 * l + 2] = (l / 9) / 2.0 + uni(rng);
    }
    for (int l = 0; l < kLocal; ++l) {
      if (coordinate == kPoints) blocks.push_back(&values[3 * l]);
      else blocks.push_back(&values[3 * l + coordinate]);
    }
  }
};

void expectDerivativesMatch(const ceres::CostFunction& cost, const Params& x) {
  ceres::NumericDiffOptions nd;
  nd.relative_step_size = 1e-7;
  ceres::GradientChecker checker(&cost, static_cast<const std::vector<const ceres::Manifold*>*>(nullptr), nd);
  ceres::GradientChecker::ProbeResults results;
  const bool ok = checker.Probe(x.blocks.data(), 1e-7, &results);
  EXPECT_TRUE(ok) << results.error_log;
  EXPECT_LT(results.maximum_relative_error, 1e-7);
}

}  // namespace

TEST(FitCosts, PointDataCostDerivatives) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  Eigen::VectorXd N(kLocal);
  for (int l = 0; l < kLocal; ++l) N[l] = uni(rng);
  N /= N.sum();
  const PointDataCost cost(N, 0.3, 1.7);
  for (unsigned s = 0; s < 5; ++s) {
    const Params x(s, s % 3);
    expectDerivativesMatch(cost, x);
    double r = 0;
    ASSERT_TRUE(cost.Evaluate(x.blocks.data(), &r, nullptr));
    double v = 0;
    for (int l = 0; l < kLocal; ++l) v += N[l] * *x.blocks[l];
    EXPECT_NEAR(r, 1.7 * (v - 0.3), 1e-14);
  }
}

TEST(FitCosts, ElementQuadraticCostDerivativesAndValue) {
  std::srand(2);
  const Eigen::MatrixXd R = Eigen::MatrixXd::Random(20, kLocal);
  const Eigen::VectorXd d = Eigen::VectorXd::Random(20);
  const ElementQuadraticCost cost(R, d);
  for (unsigned s = 0; s < 5; ++s) {
    const Params x(s, s % 3);
    expectDerivativesMatch(cost, x);
    Eigen::VectorXd p(kLocal);
    for (int l = 0; l < kLocal; ++l) p[l] = *x.blocks[l];
    std::vector<double> r(20);
    ASSERT_TRUE(cost.Evaluate(x.blocks.data(), r.data(), nullptr));
    EXPECT_LT((Eigen::Map<Eigen::VectorXd>(r.data(), 20) - (R * p - d)).norm(), 1e-12);
  }
}

TEST(FitCosts, DetJPenaltyCostDerivativesOnBothSidesOfTheThreshold) {
  // A generic tensor gradient: G(d, l) for l = a + 3(b + 3c), quadratic Bernstein-like factors.
  Eigen::Matrix3Xd G(3, kLocal);
  const double t[3] = {0.3, 0.6, 0.45};
  auto B = [](int i, double x) { return i == 0 ? (1 - x) * (1 - x) : i == 1 ? 2 * x * (1 - x) : x * x; };
  auto dB = [](int i, double x) { return i == 0 ? -2 * (1 - x) : i == 1 ? 2 - 4 * x : 2 * x; };
  for (int l = 0; l < kLocal; ++l) {
    const int a = l % 3, b = l / 3 % 3, c = l / 9;
    G(0, l) = dB(a, t[0]) * B(b, t[1]) * B(c, t[2]);
    G(1, l) = B(a, t[0]) * dB(b, t[1]) * B(c, t[2]);
    G(2, l) = B(a, t[0]) * B(b, t[1]) * dB(c, t[2]);
  }
  int active = 0, inactive = 0;
  for (unsigned s = 0; s < 10; ++s) {
    Params x(s);
    const double d = DetJPenaltyCost::detJ(G, x.blocks.data());
    // Threshold above det J: the penalty is active; below: zero with zero gradient.
    for (double tau : {d + 0.5, d - 0.5}) {
      const DetJPenaltyCost cost(G, tau, 3.0);
      expectDerivativesMatch(cost, x);
      double r = 0;
      ASSERT_TRUE(cost.Evaluate(x.blocks.data(), &r, nullptr));
      if (tau > d) {
        EXPECT_NEAR(r, 3.0 * (tau - d), 1e-12);
        ++active;
      } else {
        EXPECT_EQ(r, 0.0);
        ++inactive;
      }
    }
  }
  EXPECT_EQ(active, 10);
  EXPECT_EQ(inactive, 10);
}

TEST(FitCosts, ElementQuadraticCost3DerivativesAndValue) {
  std::srand(4);
  const Eigen::MatrixXd R = Eigen::MatrixXd::Random(20, kLocal);
  const Eigen::MatrixX3d D = Eigen::MatrixX3d::Random(20, 3);
  const ElementQuadraticCost3 cost(R, D);
  for (unsigned s = 0; s < 5; ++s) {
    const Params x(s);
    expectDerivativesMatch(cost, x);
    Eigen::MatrixX3d P(kLocal, 3);
    for (int l = 0; l < kLocal; ++l) P.row(l) << x.blocks[l][0], x.blocks[l][1], x.blocks[l][2];
    std::vector<double> r(60);
    ASSERT_TRUE(cost.Evaluate(x.blocks.data(), r.data(), nullptr));
    // The same residuals as ElementQuadraticCost per coordinate.
    EXPECT_LT((Eigen::Map<Eigen::MatrixX3d>(r.data(), 20, 3) - (R * P - D)).norm(), 1e-12);
  }
}
