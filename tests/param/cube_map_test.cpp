// The volume-preserving map of the unit ball onto [0,1]³ (param/src/cube_map.h)
// that can place the cube's transport sites: its Jacobian determinant is the
// constant 3/(4π) (the cube's volume over the ball's) wherever it is smooth,
// the sphere goes onto the cube's surface, the map is continuous across the
// planes where its 48 pieces meet, commutes with the cube's symmetries, and
// is one-to-one (the images of a fine grid in the ball, binned, fill every
// bin with its share).
#include "../../param/src/cube_map.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <array>
#include <cmath>
#include <random>
#include <vector>

using tet2spline::detail::equalVolumeBallToCube;

namespace {

Eigen::Vector3d randomInBall(std::mt19937& g) {
  std::normal_distribution<double> n;
  std::uniform_real_distribution<double> u(0, 1);
  Eigen::Vector3d x(n(g), n(g), n(g));
  return x * (std::cbrt(u(g)) / x.norm());
}

Eigen::Matrix3d centralJacobian(const Eigen::Vector3d& x, double h) {
  Eigen::Matrix3d J;
  for (int d = 0; d < 3; ++d) {
    const Eigen::Vector3d e = Eigen::Vector3d::Unit(d) * h;
    J.col(d) = (equalVolumeBallToCube(x + e) - equalVolumeBallToCube(x - e)) / (2 * h);
  }
  return J;
}

// Distance from x to the nearest plane |x_i| = |x_j| or coordinate plane (where the pieces meet).
double distanceToSeams(const Eigen::Vector3d& x) {
  double d = x.cwiseAbs().minCoeff();
  for (int i = 0; i < 3; ++i)
    for (int j = i + 1; j < 3; ++j) d = std::min(d, std::abs(std::abs(x[i]) - std::abs(x[j])) / std::sqrt(2.0));
  return d;
}

TEST(EqualVolumeBallToCube, JacobianDeterminantIsTheConstantVolumeRatio) {
  std::mt19937 g(7);
  const double expected = 3.0 / (4.0 * M_PI);
  int checked = 0;
  double worst = 0;
  for (int s = 0; s < 20000; ++s) {
    const Eigen::Vector3d x = randomInBall(g);
    if (distanceToSeams(x) < 1e-4 || x.norm() < 1e-3) continue;
    const double det = centralJacobian(x, 1e-6).determinant();
    worst = std::max(worst, std::abs(det / expected - 1));
    ++checked;
  }
  EXPECT_GT(checked, 15000);
  EXPECT_LT(worst, 1e-5);
}

TEST(EqualVolumeBallToCube, TheSphereGoesOntoTheCubesSurfaceAndTheCentreToTheCentre) {
  std::mt19937 g(11);
  std::normal_distribution<double> n;
  for (int s = 0; s < 20000; ++s) {
    const Eigen::Vector3d x = Eigen::Vector3d(n(g), n(g), n(g)).normalized();
    const Eigen::Vector3d c = equalVolumeBallToCube(x);
    EXPECT_GE(c.minCoeff(), -1e-15);
    EXPECT_LE(c.maxCoeff(), 1 + 1e-15);
    EXPECT_NEAR(std::min(c.minCoeff(), 1 - c.maxCoeff()), 0.0, 1e-15) << x.transpose();
    // degree-1 homogeneous about the centres
    const Eigen::Vector3d half = equalVolumeBallToCube(0.5 * x);
    EXPECT_LT((half - Eigen::Vector3d::Constant(0.5) - 0.5 * (c - Eigen::Vector3d::Constant(0.5))).norm(), 1e-14);
  }
  EXPECT_EQ(equalVolumeBallToCube(Eigen::Vector3d::Zero()), Eigen::Vector3d::Constant(0.5));
  // the faces' centres and the corners' directions
  EXPECT_LT((equalVolumeBallToCube(Eigen::Vector3d(0, 0, 1)) - Eigen::Vector3d(0.5, 0.5, 1)).norm(), 1e-15);
  EXPECT_LT((equalVolumeBallToCube(Eigen::Vector3d(-1, 1, 1).normalized()) - Eigen::Vector3d(0, 1, 1)).norm(), 1e-12);
}

TEST(EqualVolumeBallToCube, ContinuousAcrossTheSeamsAndSymmetric) {
  std::mt19937 g(13);
  double jump = 0, asymmetry = 0;
  for (int s = 0; s < 20000; ++s) {
    Eigen::Vector3d x = randomInBall(g);
    // onto a seam: |x_0| = |x_1| (a diagonal plane; between faces when it holds the largest coordinate)
    x[1] = std::copysign(std::abs(x[0]), x[1]);
    for (int d = 0; d < 3; ++d) {
      const Eigen::Vector3d e = Eigen::Vector3d::Unit(d) * 1e-9;
      jump = std::max(jump, (equalVolumeBallToCube(x + e) - equalVolumeBallToCube(x - e)).norm());
    }
    // the cube's symmetries: a permutation of the axes and a sign flip
    const Eigen::Vector3d y = randomInBall(g);
    const Eigen::Vector3d c = equalVolumeBallToCube(y) - Eigen::Vector3d::Constant(0.5);
    const Eigen::Vector3d py(-y[2], y[0], y[1]);
    const Eigen::Vector3d pc = equalVolumeBallToCube(py) - Eigen::Vector3d::Constant(0.5);
    asymmetry = std::max(asymmetry, (pc - Eigen::Vector3d(-c[2], c[0], c[1])).norm());
  }
  EXPECT_LT(jump, 1e-7);  // Lipschitz: a step of 2e-9 moves the image by a few times that
  EXPECT_LT(asymmetry, 1e-14);
}

TEST(EqualVolumeBallToCube, ImagesOfUniformBallPointsFillTheCubeUniformly) {
  // One-to-one and onto up to measure: the images of a fine grid of the ball
  // (cell volume h³) fill each of 8³ bins with 1/512 of them, up to the
  // grid's discreteness.
  const int n = 160;
  const double h = 2.0 / n;
  std::vector<long> bins(512, 0);
  long total = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k) {
        const Eigen::Vector3d x(-1 + (i + 0.5) * h, -1 + (j + 0.5) * h, -1 + (k + 0.5) * h);
        if (x.squaredNorm() > 1) continue;
        const Eigen::Vector3d c = equalVolumeBallToCube(x);
        const std::array<int, 3> b{std::min(7, static_cast<int>(c[0] * 8)), std::min(7, static_cast<int>(c[1] * 8)),
                                   std::min(7, static_cast<int>(c[2] * 8))};
        ++bins[static_cast<size_t>(b[0] + 8 * (b[1] + 8 * b[2]))];
        ++total;
      }
  const double share = static_cast<double>(total) / 512;
  for (size_t b = 0; b < bins.size(); ++b) EXPECT_NEAR(static_cast<double>(bins[b]) / share, 1.0, 0.05) << "bin " << b;
}

}  // namespace
