// Laws of trivariate B-spline volumes: derivatives, exact refinement,
// boundary faces, exact volume, polynomial reproduction.
#include <gtest/gtest.h>
#include <tet2spline/param/error.h>
#include <tet2spline/spline/bspline_volume.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>

using namespace tet2spline;
using namespace tet2spline::spline;

namespace {

BSplineVolume randomVolume(int p, int q, int r, unsigned seed) {
  const KnotVector ku = KnotVector::fromBreakpoints(p, {0.0, 0.3, 0.45, 1.0});
  const KnotVector kv = KnotVector::uniform(q, 3);
  const KnotVector kw = KnotVector::fromBreakpoints(r, {0.0, 0.7, 1.0});
  BSplineVolume id = BSplineVolume::identity(ku, kv, kw);
  std::srand(seed);
  Eigen::MatrixX3d P = id.controlPoints() + 0.05 * Eigen::MatrixX3d::Random(id.numControlPoints(), 3);
  return BSplineVolume(ku, kv, kw, P);
}

Eigen::MatrixX3d randomParameters(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  Eigen::MatrixX3d U(n + 8, 3);
  for (int i = 0; i < n; ++i) U.row(i) << uni(rng), uni(rng), uni(rng);
  for (int c = 0; c < 8; ++c) U.row(n + c) << (c & 1), (c >> 1 & 1), (c >> 2 & 1);  // corners
  return U;
}

/// Interpolates f at the tensor Greville points (exact when f is in the space).
template <class F>
BSplineVolume interpolate(const KnotVector& ku, const KnotVector& kv, const KnotVector& kw, F f) {
  const Eigen::VectorXd g[3] = {ku.greville(), kv.greville(), kw.greville()};
  const Eigen::MatrixXd A[3] = {basisMatrix(ku, g[0]), basisMatrix(kv, g[1]), basisMatrix(kw, g[2])};
  const Eigen::MatrixXd Ainv[3] = {A[0].inverse(), A[1].inverse(), A[2].inverse()};
  const Eigen::Index nu = g[0].size(), nv = g[1].size(), nw = g[2].size();
  Eigen::MatrixX3d Y(nu * nv * nw, 3);
  for (Eigen::Index k = 0; k < nw; ++k)
    for (Eigen::Index j = 0; j < nv; ++j)
      for (Eigen::Index i = 0; i < nu; ++i) Y.row(i + nu * (j + nv * k)) = f(Eigen::Vector3d(g[0][i], g[1][j], g[2][k])).transpose();
  // Apply A^{-1} along each direction (Kronecker structure).
  Eigen::MatrixX3d P = Eigen::MatrixX3d::Zero(Y.rows(), 3);
  for (Eigen::Index k = 0; k < nw; ++k)
    for (Eigen::Index j = 0; j < nv; ++j)
      for (Eigen::Index i = 0; i < nu; ++i)
        for (Eigen::Index c = 0; c < nw; ++c)
          for (Eigen::Index b = 0; b < nv; ++b)
            for (Eigen::Index a = 0; a < nu; ++a)
              P.row(i + nu * (j + nv * k)) += Ainv[0](i, a) * Ainv[1](j, b) * Ainv[2](k, c) * Y.row(a + nu * (b + nv * c));
  return BSplineVolume(ku, kv, kw, P);
}

}  // namespace

TEST(BSplineVolume, RejectsWrongControlCount) {
  const KnotVector k = KnotVector::uniform(2, 2);
  EXPECT_THROW(BSplineVolume(k, k, k, Eigen::MatrixX3d::Zero(10, 3)), Error);
}

TEST(BSplineVolume, IdentityAndControlOrdering) {
  const BSplineVolume V = BSplineVolume::identity(KnotVector::uniform(3, 2), KnotVector::uniform(2, 3),
                                                  KnotVector::uniform(1, 4));
  EXPECT_EQ(V.numControl(0), 5);
  EXPECT_EQ(V.numControl(1), 5);
  EXPECT_EQ(V.numControl(2), 5);
  // u fastest: the second row is the next control point in u.
  EXPECT_GT(V.controlPoints()(1, 0), V.controlPoints()(0, 0));
  EXPECT_EQ(V.controlPoints()(1, 1), V.controlPoints()(0, 1));
  const Eigen::MatrixX3d U = randomParameters(200, 1);
  Eigen::VectorXd detJ;
  const Eigen::MatrixX3d X = V.evaluate(U, &detJ);
  EXPECT_LT((X - U).cwiseAbs().maxCoeff(), 1e-14);
  EXPECT_LT((detJ.array() - 1.0).abs().maxCoeff(), 1e-13);
  EXPECT_NEAR(V.volume(), 1.0, 1e-14);
  EXPECT_EQ(V.elements().size(), 2u * 3u * 4u);
}

TEST(BSplineVolume, JacobianMatchesFiniteDifferences) {
  const BSplineVolume V = randomVolume(3, 2, 4, 2);
  const Eigen::MatrixX3d U = randomParameters(100, 2);
  const double h = 1e-6;
  for (Eigen::Index i = 0; i < 100; ++i) {
    const Eigen::Vector3d u = U.row(i).transpose().cwiseMax(2 * h).cwiseMin(1 - 2 * h);
    const Eigen::Matrix3d J = V.jacobian(u);
    for (int d = 0; d < 3; ++d) {
      const Eigen::Vector3d e = Eigen::Vector3d::Unit(d) * h;
      const Eigen::Vector3d fd = (V.evaluate(Eigen::Vector3d(u + e)) - V.evaluate(Eigen::Vector3d(u - e))) / (2 * h);
      EXPECT_LT((fd - J.col(d)).norm(), 1e-7) << "direction " << d;
    }
    EXPECT_NEAR(V.detJacobian(u), J.determinant(), 1e-14);
    const double sj = V.scaledJacobian(u);
    EXPECT_LE(std::abs(sj), 1.0 + 1e-14);
  }
}

TEST(BSplineVolume, ReproducesPolynomialMapsOfItsDegree) {
  const KnotVector ku = KnotVector::fromBreakpoints(3, {0.0, 0.3, 0.45, 1.0});
  const KnotVector kv = KnotVector::uniform(2, 3);
  const KnotVector kw = KnotVector::fromBreakpoints(3, {0.0, 0.7, 1.0});
  auto f = [](const Eigen::Vector3d& u) {
    return Eigen::Vector3d(u[0] * u[0] * u[0] - 2 * u[1] * u[1] * u[2] + 1, u[0] * u[1] * u[2] + u[2] * u[2] * u[2],
                           u[0] * u[0] * u[1] * u[1] * u[2] * u[2] * u[2] - u[1]);
  };
  const BSplineVolume V = interpolate(ku, kv, kw, f);
  const Eigen::MatrixX3d U = randomParameters(300, 3);
  for (Eigen::Index i = 0; i < U.rows(); ++i) {
    const Eigen::Vector3d u = U.row(i).transpose();
    EXPECT_LT((V.evaluate(u) - f(u)).norm(), 1e-12);
  }
}

TEST(BSplineVolume, KnotInsertionAndDegreeElevationAreExact) {
  const BSplineVolume V0 = randomVolume(3, 2, 3, 4);
  const Eigen::MatrixX3d U = randomParameters(300, 4);
  Eigen::VectorXd det0;
  const Eigen::MatrixX3d X0 = V0.evaluate(U, &det0);
  for (int d = 0; d < 3; ++d) {
    BSplineVolume V = V0;
    V.insertKnot(d, 0.61, 2);
    V.insertKnot(d, 0.3 + 1e-3, 1);
    EXPECT_EQ(V.numControl(d), V0.numControl(d) + 3);
    Eigen::VectorXd det;
    EXPECT_LT((V.evaluate(U, &det) - X0).cwiseAbs().maxCoeff(), 1e-12) << "insertion, direction " << d;
    EXPECT_LT((det - det0).cwiseAbs().maxCoeff(), 1e-10);
    BSplineVolume E = V0;
    E.elevateDegree(d, 2);
    EXPECT_EQ(E.degree(d), V0.degree(d) + 2);
    EXPECT_LT((E.evaluate(U, &det) - X0).cwiseAbs().maxCoeff(), 1e-12) << "elevation, direction " << d;
    EXPECT_LT((det - det0).cwiseAbs().maxCoeff(), 1e-10);
    EXPECT_NEAR(E.volume(), V0.volume(), 1e-12);
  }
  BSplineVolume R = V0;
  R.refine(2);
  EXPECT_EQ(R.numElements(), Eigen::Vector3i(6, 6, 4));
  EXPECT_LT((R.evaluate(U) - X0).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(BSplineVolume, BoundaryFacesCoincideWithVolumeAndPointOutward) {
  const BSplineVolume V = randomVolume(3, 2, 4, 5);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  for (int f = 0; f < 6; ++f) {
    const VolumeFace face = static_cast<VolumeFace>(f);
    const BSplineSurface S = V.face(face);
    for (int it = 0; it < 100; ++it) {
      const double s = uni(rng), t = uni(rng);
      const Eigen::Vector3d u = V.faceToVolumeParameter(face, s, t);
      EXPECT_EQ(u[direction(face)], isUpper(face) ? 1.0 : 0.0);
      Eigen::Matrix3d J;
      const Eigen::Vector3d x = V.evaluate(u, &J);
      ASSERT_GT(J.determinant(), 0.0);
      EXPECT_LT((S.evaluate(s, t) - x).norm(), 1e-14) << "face " << f;
      // Outward: the normal points along +x_d on the upper face, −x_d on the lower one.
      const Eigen::Vector3d n = S.normal(s, t);
      const double side = n.dot(J.col(direction(face))) * (isUpper(face) ? 1 : -1);
      EXPECT_GT(side, 0.0) << "face " << f;
      EXPECT_NEAR(std::abs(side), J.determinant(), 1e-12);  // n = ±(other two columns' cross product)
    }
  }
}

TEST(BSplineVolume, ExactVolumeOfAffineAndNonlinearMaps) {
  // Affine map x = A u + b on any knot vectors: volume det A.
  Eigen::Matrix3d A;
  A << 2.0, 0.3, -0.1, 0.2, 1.5, 0.4, 0.0, -0.2, 0.7;
  const Eigen::Vector3d b(1, -2, 3);
  BSplineVolume V = randomVolume(3, 2, 2, 6);
  V = BSplineVolume::identity(V.knots(0), V.knots(1), V.knots(2));
  V.setControlPoints((V.controlPoints() * A.transpose()).rowwise() + b.transpose());
  EXPECT_NEAR(V.volume(), A.determinant(), 1e-13);
  // x = (u, v, w (1 + u^2 v)): det J = 1 + u^2 v, integral 1 + 1/6. Degree 3 in u (cubic), 1 in v.
  auto f = [](const Eigen::Vector3d& u) { return Eigen::Vector3d(u[0], u[1], u[2] * (1 + u[0] * u[0] * u[1])); };
  const BSplineVolume N = interpolate(KnotVector::uniform(3, 2), KnotVector::uniform(2, 3), KnotVector::uniform(2, 1), f);
  EXPECT_NEAR(N.volume(), 1.0 + 1.0 / 6.0, 1e-13);
  // A general spline: refinement changes the elements and the Gauss points,
  // not the integral, so an exact rule gives the same volume.
  BSplineVolume R = randomVolume(2, 3, 2, 7);
  const double vol = R.volume();
  R.refine(3);
  EXPECT_NEAR(R.volume(), vol, 1e-13);
}

TEST(BSplineVolume, ElementsAndCentres) {
  const BSplineVolume V = randomVolume(3, 2, 3, 8);
  const auto els = V.elements();
  ASSERT_EQ(els.size(), 3u * 3u * 2u);
  double total = 0;
  for (const auto& e : els) {
    total += (e.upper - e.lower).prod();
    for (int d = 0; d < 3; ++d) EXPECT_EQ(V.knots(d).findSpan(e.centre[d]), e.span[d]);
  }
  EXPECT_NEAR(total, 1.0, 1e-15);
  EXPECT_EQ(els[1].index, Eigen::Vector3i(1, 0, 0));
}
