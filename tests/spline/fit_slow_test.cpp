// Convergence of the fit under uniform refinement (slow: 100k points, 16^3 elements).
#include <gtest/gtest.h>
#include <tet2spline/spline/fit.h>

#include <cmath>
#include <random>

using namespace tet2spline::spline;

TEST(FitSlow, ErrorFallsUnderRefinementForASmoothMap) {
  // A smooth, non-polynomial, orientation-preserving map of the cube onto a
  // bulged, twisted solid.
  auto f = [](const Eigen::Vector3d& u) {
    const double a = u[0], b = u[1], c = u[2];
    return Eigen::Vector3d(a + 0.15 * std::sin(M_PI * b) * std::sin(M_PI * c), b + 0.1 * std::sin(2 * a + c),
                           c + 0.1 * std::cos(1.5 * a + b) * a);
  };
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  const long N = 100000;
  Eigen::MatrixX3d U(N, 3), X(N, 3);
  for (long i = 0; i < N; ++i) {
    U.row(i) << uni(rng), uni(rng), uni(rng);
    X.row(i) = f(U.row(i).transpose()).transpose();
  }
  FitOptions opt;
  opt.smoothingWeight = 1e-11;
  double previous = 0;
  for (int e : {4, 8, 16}) {
    opt.elements = Eigen::Vector3i::Constant(e);
    const FitResult r = fitBSplineVolume(U, X, {}, {}, opt);
    ASSERT_TRUE(r.status.ok) << r.status.message;
    EXPECT_EQ(r.negativeGaussPoints, 0);
    EXPECT_GT(r.minScaledJacobian, 0.0);
    std::printf("elements %2d^3: rms_rel %.3e max_rel %.3e (%.2f s)\n", e, r.rmsErrorRelative, r.maxErrorRelative,
                r.timings.total);
    if (previous > 0) {
      EXPECT_LT(r.rmsErrorRelative, 0.5 * previous) << e << " elements";
    }
    previous = r.rmsErrorRelative;
  }
}
