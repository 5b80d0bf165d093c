#include "tet2spline/param/ball_map.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/SVD>

#include "ball_test_meshes.h"
#include "param/test_shapes.h"
#include "tet2spline/param/topology.h"

using namespace tet2spline;

namespace {

// Largest row distance between A and B·R for the best rotation R (Kabsch).
double distanceUpToRotation(const Eigen::MatrixX3d& A, const Eigen::MatrixX3d& B) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(B.transpose() * A, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d R = svd.matrixU() * svd.matrixV().transpose();
  if (R.determinant() < 0) {
    Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
    D(2, 2) = -1;
    R = svd.matrixU() * D * svd.matrixV().transpose();
  }
  return (B * R - A).rowwise().norm().maxCoeff();
}

void expectValidBallMap(const TetMesh& m, const BallMapResult& r) {
  EXPECT_TRUE(r.status.ok) << r.status.message;
  ASSERT_EQ(r.U.rows(), m.V.rows());
  EXPECT_EQ(r.sphere.flippedTriangles, 0);
  EXPECT_EQ(r.ball.invertedTets, 0);
  EXPECT_EQ(countNonPositiveTets(r.U, m.T), 0);
  EXPECT_LT(r.ball.harmonicResidual, 1e-8);
  EXPECT_LT(r.boundaryMaxDistance, 1e-12);
  for (Eigen::Index k = 0; k < r.boundaryVertices.size(); ++k)
    EXPECT_NEAR(r.U.row(r.boundaryVertices[k]).norm(), 1.0, 1e-12);
  EXPECT_LE(r.U.rowwise().norm().maxCoeff(), 1 + 1e-12);
}

}  // namespace

TEST(MapToBall, ABallMapsCloseToItself) {
  const TetMesh m = t2stest::ballGrid(6);
  ASSERT_EQ(countNonPositiveTets(m.V, m.T), 0);
  const BallMapResult r = mapToBall(m);
  expectValidBallMap(m, r);
  EXPECT_EQ(r.boundaryVertices.size(), 6 * 6 * 6 + 2);  // 6n² + 2 grid vertices on the cube's surface
  // The sphere map of a (polyhedral) sphere is nearly a rotation after Möbius
  // normalisation, and the harmonic extension of a rotation is that rotation.
  EXPECT_LT(distanceUpToRotation(m.V, r.U), 0.1);
  EXPECT_LT(r.sphere.angleDistortionMean, 1.2);
}

TEST(MapToBall, InvariantUnderRigidMotionAndScaling) {
  const TetMesh m = t2stest::ballGrid(5);
  TetMesh moved = m;
  const Eigen::Matrix3d R = Eigen::AngleAxisd(1.1, Eigen::Vector3d(-1, 0.5, 2).normalized()).toRotationMatrix();
  moved.V = ((m.V * R.transpose()) * 0.013).rowwise() + Eigen::RowVector3d(100, 5, -7);
  const BallMapResult a = mapToBall(m), b = mapToBall(moved);
  expectValidBallMap(m, a);
  expectValidBallMap(moved, b);
  EXPECT_LT(distanceUpToRotation(a.U, b.U), 1e-6);
  EXPECT_EQ(a.U, mapToBall(m).U);  // deterministic
}

TEST(MapToBall, VoidTetsAreOrdinaryTetsOfTheFilledSolid) {
  TetMesh m = t2stest::ballGrid(6);
  TetMesh withVoid = m;
  for (Eigen::Index t = 0; t < m.T.rows(); ++t) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k) c += m.V.row(m.T(t, k)).transpose() / 4;
    if (c.norm() < 0.4) withVoid.region[t] = 2;
  }
  withVoid.voidRegions = {2};
  ASSERT_GT((withVoid.region.array() == 2).count(), 0);
  const BallMapResult a = mapToBall(m), b = mapToBall(withVoid);
  expectValidBallMap(withVoid, b);
  EXPECT_EQ(a.U, b.U);
}

TEST(MapToBall, UntanglesWhatTheHarmonicMapInverts) {
  // A ball whose interior is strongly non-convexly graded: squeeze one side
  // so that the harmonic map of the boundary inverts some tets.
  TetMesh m = t2stest::ballGrid(6);
  for (Eigen::Index v = 0; v < m.V.rows(); ++v)
    if (m.V(v, 0) > 0) m.V(v, 0) *= 0.05;  // a thin half: sliver-ish tets near the equator
  ASSERT_EQ(countNonPositiveTets(m.V, m.T), 0);
  BallMapOptions noUntangle;
  noUntangle.untangleMap = false;
  const BallMapResult raw = mapToBall(m, noUntangle);
  const BallMapResult r = mapToBall(m);
  expectValidBallMap(m, r);
  EXPECT_EQ(r.ball.invertedTetsBeforeUntangling, raw.ball.invertedTets);
}

TEST(MapToBall, RefusesASolidWithAnUnfilledVoid) {
  const TetMesh grid = t2stest::cubeGrid(3);
  TetMesh holed = grid;
  std::vector<int> keep;
  for (Eigen::Index t = 0; t < grid.T.rows(); ++t) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k) c += grid.V.row(grid.T(t, k)).transpose() / 4;
    if (c.cwiseAbs().maxCoeff() > 1.0 / 3) keep.push_back(static_cast<int>(t));  // drop the central cube
  }
  holed.T.resize(static_cast<Eigen::Index>(keep.size()), 4);
  for (size_t k = 0; k < keep.size(); ++k) holed.T.row(static_cast<Eigen::Index>(k)) = grid.T.row(keep[k]);
  try {
    mapToBall(holed);
    ADD_FAILURE() << "accepted a solid with two boundary shells";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::Topology);
    EXPECT_NE(std::string(e.what()).find("2 shells"), std::string::npos) << e.what();
  }
}

TEST(MapToBall, ProgressCanStopIt) {
  BallMapOptions o;
  o.progress = [](double, const std::string&) { return false; };
  const BallMapResult r = mapToBall(t2stest::ballGrid(3), o);
  EXPECT_FALSE(r.status.ok);
}

// The harmonic map's system is built on a thread of its own beside the
// spherical map: its error (here a flat interior tet, which the boundary
// and the spherical map do not see) must reach the caller as the library's
// Error, not end the program.
TEST(MapToBall, AFlatInteriorTetIsAnInputError) {
  TetMesh m = t2stest::ballGrid(4);
  std::vector<char> onBoundary(static_cast<size_t>(m.V.rows()), 0);
  const Eigen::MatrixX3i F = boundaryFaces(m);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) onBoundary[static_cast<size_t>(F(f, k))] = 1;
  Eigen::Index flat = -1;
  for (Eigen::Index t = 0; t < m.T.rows() && flat < 0; ++t) {
    bool interior = true;
    for (int k = 0; k < 4; ++k) interior = interior && !onBoundary[static_cast<size_t>(m.T(t, k))];
    if (interior) flat = t;
  }
  ASSERT_GE(flat, 0);
  // Vertex 3 onto vertex 0: this tet's volume is exactly 0.
  m.V.row(m.T(flat, 3)) = m.V.row(m.T(flat, 0));
  try {
    const BallMapResult r = mapToBall(m);
    ADD_FAILURE() << "accepted a mesh with a flat tet: " << r.status.message;
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::Input) << e.what();
    EXPECT_NE(std::string(e.what()).find("non-positive volume"), std::string::npos) << e.what();
  }
}

// The shell's faces come from the solid's face adjacency (detail::tetFaces):
// a triangle of three tets is refused, with their number.
TEST(MapToBall, ATriangleOfThreeTetsIsATopologyError) {
  const TetMesh m = t2stest::threeTetsOnOneFace();
  try {
    mapToBall(m);
    ADD_FAILURE() << "accepted a triangle shared by three tets";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::Topology) << e.what();
    EXPECT_NE(std::string(e.what()).find("shared by 3 tets"), std::string::npos) << e.what();
  }
}
