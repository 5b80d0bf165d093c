#include "tet2spline/param/barrier_morph.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "ball_test_meshes.h"
#include "tet2spline/param/topology.h"

using namespace tet2spline;

namespace {

// The unit ball meshed (ballGrid) and a target that folds it: every vertex
// turned about z by an angle growing fast with its radius (boundary vertices
// stay on the sphere), then a third of them jittered by about an edge.
struct FoldedBall {
  TetMesh mesh;
  Eigen::MatrixX3i faces;
  Eigen::MatrixX3d target;
};

FoldedBall foldedBall(int n) {
  FoldedBall b;
  b.mesh = t2stest::ballGrid(n);
  b.faces = boundaryFaces(b.mesh);
  b.target = b.mesh.V;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> jitter(-1.0 / n, 1.0 / n);
  std::vector<char> onSphere(static_cast<size_t>(b.mesh.V.rows()), 0);
  for (Eigen::Index f = 0; f < b.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) onSphere[static_cast<size_t>(b.faces(f, k))] = 1;
  for (Eigen::Index v = 0; v < b.target.rows(); ++v) {
    const Eigen::Vector3d x = b.mesh.V.row(v);
    const double angle = 4 * x.squaredNorm();
    Eigen::Vector3d y(std::cos(angle) * x[0] - std::sin(angle) * x[1], std::sin(angle) * x[0] + std::cos(angle) * x[1], x[2]);
    if (v % 3 == 0)
      for (int d = 0; d < 3; ++d) y[d] += jitter(rng);
    if (onSphere[static_cast<size_t>(v)]) y.normalize();
    b.target.row(v) = y.transpose();
  }
  return b;
}

}  // namespace

class BarrierMorphMethods : public ::testing::TestWithParam<UntangleMethod> {};
INSTANTIATE_TEST_SUITE_P(Methods, BarrierMorphMethods, ::testing::Values(UntangleMethod::Lbfgs, UntangleMethod::Newton),
                         [](const auto& info) { return info.param == UntangleMethod::Lbfgs ? "Lbfgs" : "Newton"; });

// The target folds hundreds of tets; the morph never does, keeps the boundary
// on the sphere without flipping a triangle, and still comes closer.
TEST_P(BarrierMorphMethods, NeverInvertsTowardsAFoldedTarget) {
  const FoldedBall b = foldedBall(6);
  ASSERT_GT(countNonPositiveTets(b.target, b.mesh.T), 100);
  ASSERT_EQ(countNonPositiveTets(b.mesh.V, b.mesh.T), 0);
  BarrierMorphOptions o;
  o.method = GetParam();
  o.sphereFaces = b.faces;
  const BarrierMorphResult r =
      morphTowards(b.mesh.V, b.mesh.T, b.mesh.V, b.target, std::vector<bool>(static_cast<size_t>(b.mesh.V.rows()), false), o);
  EXPECT_TRUE(r.status.ok) << r.status.message;
  EXPECT_EQ(countNonPositiveTets(r.U, b.mesh.T), 0);
  EXPECT_EQ(countFlippedTriangles(r.U, b.faces, Eigen::Vector3d::Zero()), 0);
  for (Eigen::Index f = 0; f < b.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(r.U.row(b.faces(f, k)).norm(), 1, 1e-14);
  EXPECT_LT(r.distance, 0.5 * r.startDistance) << "start " << r.startDistance << ", end " << r.distance;
  std::printf("folded ball: distance %.3g -> %.3g target edges (max %.3g), %d L-BFGS / %d Newton iterations\n",
              r.startDistance, r.distance, r.maxDistance, r.lbfgsIterations, r.newtonIterations);
}

// A bijective target is reached: a smooth map of the cube onto itself (faces
// onto faces), from the identity, the boundary sliding on the cube.
TEST(BarrierMorph, ReachesABijectiveTargetOnTheCube) {
  TetMesh m = t2stest::cubeGrid(6);
  m.V = (m.V.array() + 1) / 2;
  const Eigen::MatrixX3i faces = boundaryFaces(m);
  Eigen::MatrixX3d target = m.V;
  for (Eigen::Index v = 0; v < m.V.rows(); ++v)
    for (int d = 0; d < 3; ++d) {  // f_d(0) = 0, f_d(1) = 1, ∂f_d/∂x_d >= 1 − 0.25π > 0
      const double x = m.V(v, d), y = m.V(v, (d + 1) % 3);
      target(v, d) = x + 0.25 * std::sin(M_PI * x) * std::sin(M_PI * y) * (d == 2 ? -1 : 1);
    }
  ASSERT_EQ(countNonPositiveTets(target, m.T), 0);
  BarrierMorphOptions o;
  o.cubeFaces = faces;
  const std::vector<bool> none(static_cast<size_t>(m.V.rows()), false);
  const BarrierMorphResult r = morphTowards(m.V, m.T, m.V, target, none, o);
  EXPECT_EQ(countNonPositiveTets(r.U, m.T), 0);
  EXPECT_EQ(countFlippedTriangles(r.U, faces, Eigen::Vector3d(0.5, 0.5, 0.5)), 0);
  EXPECT_GT(r.startDistance, 0.3);
  EXPECT_LT(r.maxDistance, 0.1) << "rms " << r.distance;
  // What is left is the shape term's pull, which falls like 1/λ.
  o.attraction.push_back(1e4);
  o.attraction.push_back(1e5);
  const BarrierMorphResult closer = morphTowards(m.V, m.T, m.V, target, none, o);
  EXPECT_LT(closer.maxDistance, 0.1 * r.maxDistance);
  std::printf("bijective cube target: max distance %.3g (λ = 10³), %.3g (λ = 10⁵) target edges\n", r.maxDistance,
              closer.maxDistance);
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const Eigen::RowVector3d u = closer.U.row(faces(f, k));
      EXPECT_TRUE((u.array() == 0).any() || (u.array() == 1).any()) << u;  // exactly on a face
      EXPECT_GE(u.minCoeff(), 0);
      EXPECT_LE(u.maxCoeff(), 1);
    }
}

TEST(BarrierMorph, KeepsFixedVerticesBitwise) {
  const FoldedBall b = foldedBall(4);
  std::vector<bool> fixed(static_cast<size_t>(b.mesh.V.rows()), false);
  for (Eigen::Index f = 0; f < b.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) fixed[static_cast<size_t>(b.faces(f, k))] = true;
  const BarrierMorphResult r = morphTowards(b.mesh.V, b.mesh.T, b.mesh.V, b.target, fixed);
  EXPECT_EQ(countNonPositiveTets(r.U, b.mesh.T), 0);
  for (Eigen::Index v = 0; v < b.mesh.V.rows(); ++v)
    if (fixed[static_cast<size_t>(v)]) {
      EXPECT_EQ(r.U.row(v), b.mesh.V.row(v));
    }
  EXPECT_LT(r.distance, r.startDistance);
}

TEST(BarrierMorph, EverythingFixedIsTheStart) {
  const FoldedBall b = foldedBall(3);
  for (const UntangleMethod method : {UntangleMethod::Lbfgs, UntangleMethod::Newton}) {
    BarrierMorphOptions o;
    o.method = method;
    const BarrierMorphResult r =
        morphTowards(b.mesh.V, b.mesh.T, b.mesh.V, b.target, std::vector<bool>(static_cast<size_t>(b.mesh.V.rows()), true), o);
    EXPECT_EQ(r.U, b.mesh.V);
    EXPECT_EQ(r.distance, r.startDistance);
  }
}

TEST(BarrierMorph, RejectsAnInvalidStartAndBadOptions) {
  const FoldedBall b = foldedBall(3);
  const std::vector<bool> none(static_cast<size_t>(b.mesh.V.rows()), false);
  EXPECT_THROW(morphTowards(b.mesh.V, b.mesh.T, b.target, b.mesh.V, none), Error);  // the folded map as start
  BarrierMorphOptions o;
  o.attraction = {1, -2};
  EXPECT_THROW(morphTowards(b.mesh.V, b.mesh.T, b.mesh.V, b.target, none, o), Error);
  o.attraction = {1};
  o.sphereFaces = b.faces;
  o.cubeFaces = b.faces;
  EXPECT_THROW(morphTowards(b.mesh.V, b.mesh.T, b.mesh.V, b.target, none, o), Error);
  EXPECT_THROW(morphTowards(b.mesh.V, b.mesh.T, b.mesh.V, b.target.topRows(3), none), Error);
}
