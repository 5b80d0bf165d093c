// Laws of B-spline bases: partition of unity, derivatives, exact refinement.
#include <gtest/gtest.h>
#include <tet2spline/param/error.h>
#include <tet2spline/spline/bspline_basis.h>

#include <Eigen/LU>

#include <cmath>
#include <random>

using namespace tet2spline;
using namespace tet2spline::spline;

namespace {
KnotVector irregular(int p) {
  return KnotVector::fromBreakpoints(p, {0.0, 0.13, 0.2, 0.55, 0.61, 1.0});
}
std::vector<double> sampleParameters(const KnotVector& K, int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uni(K.front(), K.back());
  std::vector<double> u(K.knots());  // every knot, including both ends
  for (int i = 0; i < n; ++i) u.push_back(uni(rng));
  return u;
}
}  // namespace

TEST(KnotVector, ClampedConstructionAndSpans) {
  const KnotVector K = KnotVector::uniform(3, 4);
  EXPECT_EQ(K.size(), 4 + 1 + 2 * 3);
  EXPECT_EQ(K.numBasis(), 7);
  EXPECT_EQ(K.numElements(), 4);
  EXPECT_EQ(K.findSpan(0.0), 3);
  EXPECT_EQ(K.findSpan(0.25), 4);
  EXPECT_EQ(K.findSpan(0.2499), 3);
  EXPECT_EQ(K.findSpan(1.0), 6);
  EXPECT_EQ(K.elementSpans(), (std::vector<int>{3, 4, 5, 6}));
  for (double u : sampleParameters(K, 100, 1)) {
    const int s = K.findSpan(u);
    EXPECT_LE(K[s], u);
    EXPECT_TRUE(u < K[s + 1] || (u == K.back() && K[s + 1] == K.back()));
  }
}

TEST(KnotVector, RejectsBadInput) {
  EXPECT_THROW(KnotVector(2, {0, 0, 1, 1, 1}), Error);          // not clamped at the front
  EXPECT_THROW(KnotVector(1, {0, 0, 0.5, 0.4, 1, 1}), Error);   // decreasing
  EXPECT_THROW(KnotVector(2, {0, 0, 0, 0.5, 0.5, 0.5, 1, 1, 1}), Error);  // multiplicity > p
  EXPECT_THROW(KnotVector::uniform(3, 0), Error);
  EXPECT_THROW(KnotVector::fromBreakpoints(2, {0, 0.5, 0.5, 1}), Error);
  try {
    KnotVector(2, {0, 0, 1, 1, 1});
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::Usage);
    EXPECT_NE(std::string(e.what()).find("KnotVector"), std::string::npos);
  }
}

TEST(BSplineBasis, PartitionOfUnityAndNonNegativity) {
  for (int p = 0; p <= 5; ++p) {
    const KnotVector K = irregular(p);
    for (double u : sampleParameters(K, 200, 2 + p)) {
      const int s = K.findSpan(u);
      std::vector<double> N(p + 1);
      basisFunctions(K, s, u, N.data());
      double sum = 0;
      for (double v : N) {
        EXPECT_GE(v, -1e-15);
        sum += v;
      }
      EXPECT_NEAR(sum, 1.0, 1e-14) << "p=" << p << " u=" << u;
      // Derivatives of a partition of unity sum to zero.
      const Eigen::MatrixXd d = basisDerivatives(K, s, u, p + 1);
      EXPECT_NEAR(d.row(0).sum(), 1.0, 1e-14);
      for (int k = 1; k <= p + 1; ++k) EXPECT_NEAR(d.row(k).sum(), 0.0, 1e-13 * (1 + d.row(k).cwiseAbs().sum()));
      for (int j = 0; j <= p; ++j) EXPECT_NEAR(d(0, j), N[j], 1e-15);
      for (int j = 0; j <= p; ++j) EXPECT_EQ(d(p + 1, j), 0.0);
    }
  }
}

TEST(BSplineBasis, DerivativesMatchFiniteDifferences) {
  for (int p = 1; p <= 5; ++p) {
    const KnotVector K = irregular(p);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    Eigen::MatrixXd C = Eigen::MatrixXd::Random(K.numBasis(), 2);
    const SplineCoefficients c{K, C};
    for (int it = 0; it < 50; ++it) {
      const double u = uni(rng), h = 1e-6;
      // Skip points within h of a knot where the derivative may jump.
      bool nearKnot = false;
      for (double k : K.knots()) nearKnot |= std::abs(k - u) < 2 * h;
      if (nearKnot) continue;
      for (int k = 1; k <= std::min(p, 3); ++k) {
        const Eigen::RowVectorXd fd =
            (evaluateCurve(c, u + h, k - 1) - evaluateCurve(c, u - h, k - 1)) / (2 * h);
        const Eigen::RowVectorXd an = evaluateCurve(c, u, k);
        EXPECT_LT((fd - an).norm(), 1e-6 * (1 + an.norm()) * std::pow(10.0, k)) << "p=" << p << " k=" << k;
      }
    }
  }
}

TEST(BSplineBasis, ReproducesPolynomialsUpToDegree) {
  // Interpolating u^m (m <= p) at the Greville abscissae reproduces it exactly.
  for (int p = 1; p <= 5; ++p) {
    const KnotVector K = irregular(p);
    const Eigen::VectorXd g = K.greville();
    const Eigen::MatrixXd A = basisMatrix(K, g);
    for (int m = 0; m <= p; ++m) {
      const Eigen::VectorXd f = g.array().pow(m);
      const Eigen::VectorXd c = A.fullPivLu().solve(f);
      for (double u : sampleParameters(K, 50, 3)) {
        const double v = evaluateCurve({K, c}, u)(0);
        EXPECT_NEAR(v, std::pow(u, m), 1e-12) << "p=" << p << " m=" << m;
      }
    }
  }
}

TEST(BSplineBasis, GaussLegendreIntegratesPolynomialsExactly) {
  for (int n = 1; n <= 12; ++n) {
    const GaussRule g = gaussLegendre(n, 0.3, 2.0);
    for (int m = 0; m <= 2 * n - 1; ++m) {
      const double exact = (std::pow(2.0, m + 1) - std::pow(0.3, m + 1)) / (m + 1);
      EXPECT_NEAR(g.points.array().pow(m).matrix().dot(g.weights), exact, 1e-12 * std::max(1.0, exact))
          << "n=" << n << " m=" << m;
    }
  }
  const KnotVector K = irregular(3);
  const GaussRule g = gaussPointsPerSpan(K, 4);
  EXPECT_EQ(g.points.size(), 4 * K.numElements());
  EXPECT_NEAR(g.weights.sum(), 1.0, 1e-14);
}

TEST(BSplineBasis, KnotInsertionLeavesCurveUnchanged) {
  for (int p = 1; p <= 5; ++p) {
    const KnotVector K = irregular(p);
    const SplineCoefficients c{K, Eigen::MatrixXd::Random(K.numBasis(), 3)};
    for (double t : {0.05, 0.2, 0.55, 0.9}) {  // new knots and existing ones
      const int room = p - K.multiplicity(t);
      for (int times = 1; times <= room; ++times) {
        const SplineCoefficients d = insertKnot(c, t, times);
        EXPECT_EQ(d.knots.numBasis(), K.numBasis() + times);
        EXPECT_EQ(d.knots.multiplicity(t), K.multiplicity(t) + times);
        for (double u : sampleParameters(K, 40, 4)) {
          EXPECT_LT((evaluateCurve(c, u) - evaluateCurve(d, u)).norm(), 1e-13) << "p=" << p << " t=" << t;
        }
      }
    }
    EXPECT_THROW(insertKnot(c, 0.2, p + 1), Error);
    EXPECT_THROW(insertKnot(c, 1.0), Error);
  }
}

TEST(BSplineBasis, DegreeElevationLeavesCurveUnchanged) {
  for (int p = 1; p <= 4; ++p) {
    const KnotVector K = irregular(p);
    const SplineCoefficients c{K, Eigen::MatrixXd::Random(K.numBasis(), 3)};
    for (int t = 1; t <= 3; ++t) {
      const SplineCoefficients d = elevateDegree(c, t);
      EXPECT_EQ(d.knots.degree(), p + t);
      EXPECT_EQ(d.knots.numElements(), K.numElements());
      for (double u : sampleParameters(K, 40, 5)) {
        EXPECT_LT((evaluateCurve(c, u) - evaluateCurve(d, u)).norm(), 1e-12) << "p=" << p << " t=" << t;
      }
    }
  }
}
