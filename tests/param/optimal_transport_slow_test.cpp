// Larger OT solves (seconds each): convergence at benchmark-like sizes in
// the cube and the ball, and bit-identical results for the same input.
#include <gtest/gtest.h>

#include <cstdio>
#include <random>

#include "param/test_shapes.h"
#include "test_data.h"
#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/ball_map.h"
#include "tet2spline/param/optimal_transport.h"
#include "tet2spline/param/parameterize.h"
#include "tet2spline/param/refine.h"
#include "tet2spline/param/tetrahedralize.h"

using namespace tet2spline;

namespace {

// N points uniform in the ball of radius r around `centre`, masses in [0.5, 1.5].
void ballCloud(int n, const Eigen::Vector3d& centre, double r, unsigned seed, Eigen::MatrixX3d& y,
               Eigen::VectorXd& nu) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1), m(0.5, 1.5);
  y.resize(n, 3);
  nu.resize(n);
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3d p;
    do p = Eigen::Vector3d(u(rng), u(rng), u(rng));
    while (p.squaredNorm() > 1);
    y.row(i) = (centre + r * p).transpose();
    nu[i] = m(rng);
  }
}

void expectConverged(const OptimalTransportResult& r, const Domain& domain) {
  ASSERT_TRUE(r.status.ok) << r.status.message;
  EXPECT_LT(r.maxRelativeMassError, 1e-6);
  EXPECT_NEAR(r.cellVolumes.sum(), domain.volume(), 1e-11 * domain.volume());
  for (int i = 0; i < r.cellVolumes.size(); ++i)
    ASSERT_TRUE(domain.contains(r.centroids.row(i).transpose(), 1e-12)) << i;
}

}  // namespace

TEST(OptimalTransportSlow, BenchmarkCloudInTheCube) {
  Eigen::MatrixX3d y;
  Eigen::VectorXd nu;
  ballCloud(30000, Eigen::Vector3d::Constant(0.5), 0.45, 1, y, nu);
  const auto r = solveOptimalTransport(y, nu, Domain::unitCube());
  expectConverged(r, Domain::unitCube());
  EXPECT_LT(r.iterations, 15);
}

TEST(OptimalTransportSlow, HarmonicImageLikeCloudInTheBall) {
  // Like the pipeline: vertices inside the unit ball, a tenth on the sphere.
  Eigen::MatrixX3d y;
  Eigen::VectorXd nu;
  ballCloud(30000, Eigen::Vector3d::Zero(), 1.0, 2, y, nu);
  for (int i = 0; i < y.rows(); i += 10) y.row(i).normalize();
  const Domain ball = Domain::unitBall();
  const auto r = solveOptimalTransport(y, nu, ball);
  expectConverged(r, ball);
}

TEST(OptimalTransportSlow, SameInputGivesBitIdenticalOutput) {
  Eigen::MatrixX3d y;
  Eigen::VectorXd nu;
  ballCloud(20000, Eigen::Vector3d::Constant(0.5), 0.45, 3, y, nu);
  const auto a = solveOptimalTransport(y, nu, Domain::unitCube());
  const auto b = solveOptimalTransport(y, nu, Domain::unitCube());
  ASSERT_TRUE(a.status.ok && b.status.ok);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_TRUE((a.weights.array() == b.weights.array()).all());
  EXPECT_TRUE((a.centroids.array() == b.centroids.array()).all());
  EXPECT_TRUE((a.cellVolumes.array() == b.cellVolumes.array()).all());
}

// Real sites with masses over eight orders of magnitude: hand.off meshed
// with a 15° dihedral bound (TetGen's smallest tets in the fingertips), its
// ball map (nearly equiareal sphere, harmonic map, untangled) as the cube
// parameterization places the sites, volume-preserving masses (ν from
// 2.9e-13 to 1e-3 of the cube). ‖g‖ reached the big cells' rounding noise
// (3.8e-17) while the worst tiny cell was still 6e-6 of itself off, and every
// line search failed; the relative merit (optimal_transport.cpp) converges.
TEST(OptimalTransportSlow, HandSitesWithMassesOverEightOrdersConverge) {
  TetrahedralizeOptions meshing;
  meshing.exactBoundary = false;
  meshing.minDihedral = 15;
  TetMesh mesh = tetrahedralize(readSurface(t2stest::cgalMesh("hand")), meshing, "hand");
  splitBoundaryChords(mesh);
  BallMapOptions ballOptions;
  ballOptions.sphere.areaCorrectionIterations = ParamOptions().sphereAreaCorrectionIterations;
  const BallMapResult ball = mapToBall(mesh, ballOptions);
  const Eigen::MatrixX3d y = (0.5 * ball.U.array() + 0.5).matrix();
  Eigen::VectorXd nu = Eigen::VectorXd::Zero(mesh.numVertices());
  for (Eigen::Index t = 0; t < mesh.numTets(); ++t)
    for (int k = 0; k < 4; ++k) nu[mesh.T(t, k)] += t2stest::tetVolume(mesh, t) / 4;
  ASSERT_LT(nu.minCoeff(), 1e-8 * nu.maxCoeff());
  const OptimalTransportResult r = solveOptimalTransport(y, nu, Domain::unitCube());
  std::printf("hand sites: %lld points, %d iterations, error %.3g, switches %d\n", (long long)y.rows(), r.iterations,
              r.maxRelativeMassError, r.solverSwitches);
  expectConverged(r, Domain::unitCube());
}
