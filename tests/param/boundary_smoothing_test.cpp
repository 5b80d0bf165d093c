// Smoothing of the boundary and the interior (boundary_smoothing.h): an
// affine map is a fixed point, tangential and interior noise is removed, and
// on real parameterizations the map stays valid with the boundary exactly on
// ∂Ω and the measure misfit not rising.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <tbb/global_control.h>

#include "cube_param_meshes.h"
#include "test_data.h"
#include "test_shapes.h"
#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/boundary_smoothing.h"
#include "tet2spline/param/parameterize.h"
#include "tet2spline/param/tetrahedralize.h"
#include "tet2spline/param/topology.h"

using namespace tet2spline;

namespace {

const Eigen::Matrix3d kShear = (Eigen::Matrix3d() << 2.0, 0.3, -0.2, 0.1, 1.5, 0.4, 0.0, -0.3, 0.8).finished();
const Eigen::Vector3d kShift(0.4, -1.0, 2.5);

Eigen::MatrixX3d pointField(const TetMesh& m, const std::string& name) { return m.pointField(name)->values; }

std::vector<char> boundaryMask(Eigen::Index nv, const Eigen::MatrixX3i& F) {
  std::vector<char> b(static_cast<size_t>(nv), 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) b[static_cast<size_t>(F(f, c))] = 1;
  return b;
}

// What must hold after smoothing a valid cube map: every tet positive, no
// boundary triangle turned, interior rows bitwise unchanged, every pinned
// coordinate (0 or 1) bitwise unchanged, corners unchanged.
void expectCubeInvariants(const Eigen::MatrixX3d& before, const Eigen::MatrixX3d& after, const Eigen::MatrixX4i& T,
                          const Eigen::MatrixX3i& F, bool interiorHeld = true) {
  EXPECT_EQ(countNonPositiveTets(after, T), 0);
  EXPECT_EQ(countFlippedTriangles(after, F, Eigen::Vector3d(0.5, 0.5, 0.5)), 0);
  const std::vector<char> onBoundary = boundaryMask(before.rows(), F);
  for (Eigen::Index i = 0; i < before.rows(); ++i) {
    if (!onBoundary[static_cast<size_t>(i)]) {
      if (interiorHeld) {
        ASSERT_TRUE(after.row(i) == before.row(i)) << "interior vertex " << i << " moved";
      }
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      if (before(i, k) == 0.0 || before(i, k) == 1.0) {
        ASSERT_EQ(after(i, k), before(i, k)) << "vertex " << i;
      }
      ASSERT_GE(after(i, k), 0.0);
      ASSERT_LE(after(i, k), 1.0);
    }
  }
}

// Where noise flattened or turned a tet of U, its vertices go back to `exact`
// (repeated until every tet is positive).
void restoreFlattenedTets(Eigen::MatrixX3d& U, const Eigen::MatrixX3d& exact, const Eigen::MatrixX4i& T) {
  for (bool again = true; again;) {
    again = false;
    for (Eigen::Index t = 0; t < T.rows(); ++t) {
      const Eigen::Vector3d a = U.row(T(t, 0)), b = U.row(T(t, 1)), c = U.row(T(t, 2)), d = U.row(T(t, 3));
      if (orient3d(a.data(), b.data(), c.data(), d.data()) > 0) continue;
      for (int k = 0; k < 4; ++k) U.row(T(t, k)) = exact.row(T(t, k));
      again = true;
    }
  }
}

}  // namespace

TEST(BoundarySmoothing, AnAffineCubeMapIsAFixedPoint) {
  // X = A U + b on a Kuhn grid of the cube: U is affine in X, so the local
  // fits reproduce it and nothing moves (beyond rounding).
  const TetMesh m = t2stest::kuhnCube(6, [](const Eigen::Vector3d& u) { return Eigen::Vector3d(kShear * u + kShift); });
  const Eigen::MatrixX3d U = pointField(m, "U");
  const Eigen::MatrixX3i F = boundaryFaces(m);
  const BoundarySmoothingResult r = smoothBoundary(m.V, m.T, U, F);
  EXPECT_GT(r.moves, 0);
  EXPECT_GT(r.interiorMoves, 0);
  EXPECT_EQ(r.refused, 0);
  EXPECT_LT((r.U - U).cwiseAbs().maxCoeff(), 1e-13);
  expectCubeInvariants(U, r.U, m.T, F, false);
}

TEST(BoundarySmoothing, RemovesInteriorNoise) {
  // The affine map with the interior vertices moved by up to 0.3 of the grid
  // step: the interior sweeps (no boundary sweep) must take away well over
  // half of the noise, the boundary staying bitwise.
  const int n = 10;
  const TetMesh m = t2stest::kuhnCube(n, [](const Eigen::Vector3d& u) { return Eigen::Vector3d(kShear * u + kShift); });
  const Eigen::MatrixX3d exact = pointField(m, "U");
  const Eigen::MatrixX3i F = boundaryFaces(m);
  const std::vector<char> onBoundary = boundaryMask(exact.rows(), F);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> noise(-0.3 / n, 0.3 / n);
  Eigen::MatrixX3d U = exact;
  for (Eigen::Index i = 0; i < U.rows(); ++i) {
    if (!onBoundary[static_cast<size_t>(i)]) {
      for (int k = 0; k < 3; ++k) U(i, k) += noise(rng);
    }
  }
  // (Where the noise flattened a Kuhn tet, its vertices go back.)
  restoreFlattenedTets(U, exact, m.T);
  ASSERT_EQ(countNonPositiveTets(U, m.T), 0);
  BoundarySmoothingOptions o;
  o.sweeps = 0;
  const BoundarySmoothingResult r = smoothBoundary(m.V, m.T, U, F, o);
  const double before = (U - exact).norm(), after = (r.U - exact).norm();
  std::printf("noise %.4g -> %.4g (%ld interior moves, %ld refused)\n", before, after, r.interiorMoves, r.refused);
  EXPECT_LT(after, 0.5 * before);
  EXPECT_EQ(r.moves, 0);
  EXPECT_EQ(countNonPositiveTets(r.U, m.T), 0);
  for (Eigen::Index i = 0; i < U.rows(); ++i) {
    if (onBoundary[static_cast<size_t>(i)]) {
      ASSERT_TRUE(r.U.row(i) == U.row(i)) << "boundary vertex " << i << " moved";
    }
  }
}

TEST(BoundarySmoothing, RemovesTangentialNoiseOnTheSphere) {
  // A TetGen ball with its boundary vertices exactly on the unit sphere and
  // X = 2 U + b. The local fits are affine in the tangent plane, so on the
  // curved sphere they are exact only to O(h²); moved along the sphere by up
  // to 0.3 of the mean edge, two sweeps must take away well over a third.
  TetMesh m = tetrahedralize(t2stest::sphere(4), TetrahedralizeOptions{});
  const Eigen::MatrixX3i F = boundaryFaces(m);
  const std::vector<char> onBoundary = boundaryMask(m.numVertices(), F);
  Eigen::MatrixX3d exact = m.V;
  for (Eigen::Index i = 0; i < exact.rows(); ++i)
    if (onBoundary[static_cast<size_t>(i)]) exact.row(i).normalize();
  ASSERT_EQ(countNonPositiveTets(exact, m.T), 0);
  double edge = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) edge += (exact.row(F(f, 0)) - exact.row(F(f, 1))).norm();
  edge /= static_cast<double>(F.rows());
  const Eigen::MatrixX3d X = (2.0 * exact).rowwise() + kShift.transpose();
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> noise(-0.3 * edge, 0.3 * edge);
  Eigen::MatrixX3d U = exact;
  for (Eigen::Index i = 0; i < U.rows(); ++i) {
    if (!onBoundary[static_cast<size_t>(i)]) continue;
    const Eigen::Vector3d u = U.row(i), kick(noise(rng), noise(rng), noise(rng));
    U.row(i) = (u + kick - kick.dot(u) * u).normalized().transpose();
  }
  // (The ball's boundary tets are thin: where the noise flattened one, its
  // vertices go back to the exact sphere map.)
  restoreFlattenedTets(U, exact, m.T);
  BoundarySmoothingOptions o;
  o.shape = BoundaryShape::UnitSphere;
  o.interiorSweeps = 0;
  const BoundarySmoothingResult r = smoothBoundary(X, m.T, U, F, o);
  const double before = (U - exact).norm(), after = (r.U - exact).norm();
  std::printf("noise %.4g -> %.4g (%ld moves, %ld refused)\n", before, after, r.moves, r.refused);
  EXPECT_LT(after, 0.6 * before);
  EXPECT_EQ(countNonPositiveTets(r.U, m.T), 0);
  EXPECT_EQ(countFlippedTriangles(r.U, F, Eigen::Vector3d::Zero()), 0);
  for (Eigen::Index i = 0; i < U.rows(); ++i) {
    if (onBoundary[static_cast<size_t>(i)]) {
      ASSERT_NEAR(r.U.row(i).norm(), 1.0, 1e-15) << "vertex " << i;
    } else {
      ASSERT_TRUE(r.U.row(i) == U.row(i)) << "interior vertex " << i << " moved";
    }
  }
}

TEST(BoundarySmoothing, RemovesTangentialNoiseOnTheCube) {
  // The affine map of the first test with the boundary vertices moved along
  // their faces (and edges) by up to 0.3 of the grid step: two sweeps at
  // step 0.5 must take away well over a third of the noise.
  const int n = 10;
  const TetMesh m = t2stest::kuhnCube(n, [](const Eigen::Vector3d& u) { return Eigen::Vector3d(kShear * u + kShift); });
  const Eigen::MatrixX3d exact = pointField(m, "U");
  const Eigen::MatrixX3i F = boundaryFaces(m);
  const std::vector<char> onBoundary = boundaryMask(exact.rows(), F);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> noise(-0.3 / n, 0.3 / n);
  Eigen::MatrixX3d U = exact;
  for (Eigen::Index i = 0; i < U.rows(); ++i) {
    if (!onBoundary[static_cast<size_t>(i)]) continue;
    for (int k = 0; k < 3; ++k)
      if (U(i, k) != 0.0 && U(i, k) != 1.0) U(i, k) += noise(rng);
  }
  ASSERT_EQ(countNonPositiveTets(U, m.T), 0);
  const double before = (U - exact).norm();
  BoundarySmoothingOptions o;
  o.interiorSweeps = 0;
  const BoundarySmoothingResult r = smoothBoundary(m.V, m.T, U, F, o);
  const double after = (r.U - exact).norm();
  std::printf("noise %.4g -> %.4g (%ld moves, %ld refused)\n", before, after, r.moves, r.refused);
  EXPECT_LT(after, 0.6 * before);
  expectCubeInvariants(U, r.U, m.T, F);
}

TEST(BoundarySmoothing, HeldVerticesKeepAKinkWhereTheDensityJumps) {
  // X = f(U) piecewise affine: slope 3 in x beyond u_x = 1/2, as a density
  // jump makes it. U(X) is affine on either side of the plane, so the only
  // vertices whose local fit is not exact are those on it. Unheld, they move
  // and the parametric volume of each side changes; held (as the pipeline
  // holds the vertices where the density jumps), nothing moves.
  const int n = 8;
  const TetMesh m = t2stest::kuhnCube(n, [](const Eigen::Vector3d& u) {
    const double x = u.x() <= 0.5 ? u.x() : 0.5 + 3.0 * (u.x() - 0.5);
    return Eigen::Vector3d(kShear * Eigen::Vector3d(x, u.y(), u.z()) + kShift);
  });
  const Eigen::MatrixX3d U = pointField(m, "U");
  const Eigen::MatrixX3i F = boundaryFaces(m);
  auto leftVolume = [&](const Eigen::MatrixX3d& P) {
    double v = 0;
    for (Eigen::Index t = 0; t < m.numTets(); ++t) {
      const double cx = 0.25 * (U(m.T(t, 0), 0) + U(m.T(t, 1), 0) + U(m.T(t, 2), 0) + U(m.T(t, 3), 0));
      if (cx >= 0.5) continue;
      v += t2stest::tetVolume(P, m.T, t);
    }
    return v;
  };
  BoundarySmoothingOptions o;
  const BoundarySmoothingResult loose = smoothBoundary(m.V, m.T, U, F, o);
  EXPECT_GT((loose.U - U).cwiseAbs().maxCoeff(), 1e-3);
  EXPECT_GT(std::abs(leftVolume(loose.U) - 0.5), 1e-3);

  o.held.assign(static_cast<size_t>(m.numVertices()), false);
  for (Eigen::Index i = 0; i < m.numVertices(); ++i) o.held[static_cast<size_t>(i)] = U(i, 0) == 0.5;
  const BoundarySmoothingResult held = smoothBoundary(m.V, m.T, U, F, o);
  EXPECT_GT(held.moves + held.interiorMoves, 0);
  EXPECT_LT((held.U - U).cwiseAbs().maxCoeff(), 1e-13);
  EXPECT_NEAR(leftVolume(held.U), 0.5, 1e-13);
  expectCubeInvariants(U, held.U, m.T, F, false);
}

TEST(BoundarySmoothing, RejectsMismatchedInput) {
  const TetMesh m = t2stest::kuhnCube(2, [](const Eigen::Vector3d& u) { return u; });
  const Eigen::MatrixX3d U = pointField(m, "U");
  const Eigen::MatrixX3i F = boundaryFaces(m);
  EXPECT_THROW(smoothBoundary(m.V, m.T, U.topRows(3), F), Error);
  Eigen::MatrixX3i bad = F;
  bad(0, 0) = static_cast<int>(m.numVertices());
  EXPECT_THROW(smoothBoundary(m.V, m.T, U, bad), Error);
  BoundarySmoothingOptions o;
  o.targetVolumes = Eigen::VectorXd::Ones(m.numTets() - 1);
  EXPECT_THROW(smoothBoundary(m.V, m.T, U, F, o), Error);
  BoundarySmoothingOptions h;
  h.held.assign(static_cast<size_t>(m.numVertices() - 1), false);
  EXPECT_THROW(smoothBoundary(m.V, m.T, U, F, h), Error);
}

// Real meshes: the parameterization without the smoothing, then smoothed.
class BoundarySmoothingReal : public ::testing::TestWithParam<std::tuple<const char*, ParamDomain>> {};

TEST_P(BoundarySmoothingReal, KeepsTheMapValidAndTheBoundaryOnTheDomain) {
  const auto [name, domain] = GetParam();
  ParamOptions o;
  o.domain = domain;
  o.boundarySmoothing.sweeps = 0;
  o.boundarySmoothing.interiorSweeps = 0;
  const ParamResult p = parameterize(tetrahedralize(readSurface(t2stest::cgalMesh(name)), TetrahedralizeOptions{}), o);
  ASSERT_TRUE(p.status.ok) << p.status.message;
  const bool cube = domain == ParamDomain::Cube;
  BoundarySmoothingOptions so;
  so.shape = cube ? BoundaryShape::UnitCube : BoundaryShape::UnitSphere;
  so.targetVolumes = p.targetVolume;  // as parameterize() does
  const BoundarySmoothingResult r = smoothBoundary(p.mesh.V, p.mesh.T, p.U, p.boundaryFaces, so);
  EXPECT_GT(r.moves, p.boundaryVertices.size() / 2);
  EXPECT_GT(r.interiorMoves, (p.U.rows() - static_cast<long>(p.boundaryVertices.size())) / 2);
  if (cube) {
    expectCubeInvariants(p.U, r.U, p.mesh.T, p.boundaryFaces, false);
  } else {
    EXPECT_EQ(countNonPositiveTets(r.U, p.mesh.T), 0);
    EXPECT_EQ(countFlippedTriangles(r.U, p.boundaryFaces, Eigen::Vector3d::Zero()), 0);
    const std::vector<char> onBoundary = boundaryMask(p.U.rows(), p.boundaryFaces);
    for (Eigen::Index i = 0; i < p.U.rows(); ++i) {
      if (onBoundary[static_cast<size_t>(i)]) {
        ASSERT_NEAR(r.U.row(i).norm(), 1.0, 1e-12) << "vertex " << i;
      }
    }
  }
  // Each move keeps Σ log²(volume / target) over its vertex's tets from
  // rising, and no other tet changes: the sum over the mesh cannot rise.
  auto misfit = [&](const Eigen::MatrixX3d& U, std::vector<double>* ratios) {
    double sum = 0;
    for (Eigen::Index t = 0; t < p.mesh.numTets(); ++t) {
      const Eigen::Vector3d a = U.row(p.mesh.T(t, 0)), b = U.row(p.mesh.T(t, 1)), c = U.row(p.mesh.T(t, 2)),
                            d = U.row(p.mesh.T(t, 3));
      const double q = (b - a).cross(c - a).dot(d - a) / 6 / p.targetVolume(t);
      sum += std::log(q) * std::log(q);
      ratios->push_back(q);
    }
    std::sort(ratios->begin(), ratios->end());
    return sum;
  };
  std::vector<double> q0, q1;
  const double m0 = misfit(p.U, &q0), m1 = misfit(r.U, &q1);
  const size_t n = q0.size();
  std::printf("%s %s: %ld moves, %ld refused, rms move %.3g; sum log^2 ratio %.4g -> %.4g; ratio p1 %.3f -> %.3f, "
              "p99 %.3f -> %.3f\n",
              name, cube ? "cube" : "ball", r.moves, r.refused, r.rmsMove, m0, m1, q0[n / 100], q1[n / 100],
              q0[n * 99 / 100], q1[n * 99 / 100]);
  EXPECT_LE(m1, m0 * (1 + 1e-12));
  EXPECT_LT(m1, 0.98 * m0);  // and it does fall
  // The vertices of a colour move together on the cores: on one thread the
  // result must be the same bits.
  BoundarySmoothingResult single;
  {
    tbb::global_control oneThread(tbb::global_control::max_allowed_parallelism, 1);
    single = smoothBoundary(p.mesh.V, p.mesh.T, p.U, p.boundaryFaces, so);
  }
  EXPECT_EQ(single.moves, r.moves);
  EXPECT_EQ(single.interiorMoves, r.interiorMoves);
  EXPECT_EQ(single.refused, r.refused);
  for (Eigen::Index i = 0; i < r.U.size(); ++i)
    ASSERT_EQ(std::memcmp(&single.U.data()[i], &r.U.data()[i], sizeof(double)), 0) << "coordinate " << i;
}

INSTANTIATE_TEST_SUITE_P(TestData, BoundarySmoothingReal,
                         ::testing::Combine(::testing::Values("blob-closed", "blobby"),
                                            ::testing::Values(ParamDomain::Cube, ParamDomain::Ball)),
                         [](const auto& info) {
                           return t2stest::testName(std::get<0>(info.param)) +
                                  (std::get<1>(info.param) == ParamDomain::Cube ? "_cube" : "_ball");
                         });
