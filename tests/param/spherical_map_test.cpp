#include "tet2spline/param/spherical_map.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <iostream>

#include "test_data.h"
#include "tet2spline/io/mesh_io.h"

using namespace tet2spline;

namespace {

void expectBijectiveNormalisedMap(const SurfaceMesh& s, const SphericalMapResult& r) {
  ASSERT_EQ(r.U.rows(), s.V.rows());
  EXPECT_TRUE(r.status.ok) << r.status.message;
  EXPECT_EQ(r.flippedTriangles, 0);
  EXPECT_EQ(countFlippedSphereTriangles(r.U, s.F), 0);
  for (Eigen::Index i = 0; i < r.U.rows(); ++i) ASSERT_NEAR(r.U.row(i).norm(), 1.0, 1e-12);
  // Area-weighted (input areas) mass centre at the origin.
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  double total = 0;
  for (Eigen::Index f = 0; f < s.F.rows(); ++f) {
    const double a = 0.5 * (s.V.row(s.F(f, 1)) - s.V.row(s.F(f, 0))).cross(s.V.row(s.F(f, 2)) - s.V.row(s.F(f, 0))).norm();
    for (int k = 0; k < 3; ++k) c += a / 3 * r.U.row(s.F(f, k)).transpose();
    total += a;
  }
  EXPECT_LT((c / total).norm(), 1e-3);
  EXPECT_GE(r.angleDistortionMean, 1.0);
  EXPECT_TRUE(std::isfinite(r.angleDistortionMax));
}

}  // namespace

class SphericalMapReal : public ::testing::TestWithParam<const char*> {};

TEST_P(SphericalMapReal, BijectiveAndNormalised) {
  const SurfaceMesh s = readSurface(t2stest::cgalMesh(GetParam()));
  const SphericalMapResult r = sphericalMap(s);
  expectBijectiveNormalisedMap(s, r);
  std::cout << GetParam() << ": " << s.V.rows() << " vertices, " << r.method << ", distortion mean "
            << r.angleDistortionMean << " max " << r.angleDistortionMax << ", Möbius iterations " << r.mobiusIterations
            << "\n";
  RecordProperty("method", r.method);
  RecordProperty("distortion_mean", std::to_string(r.angleDistortionMean));
}

INSTANTIATE_TEST_SUITE_P(Genus0, SphericalMapReal,
                         ::testing::Values("blob-closed", "part", "spool", "hand", "blobby", "triceratops", "fandisk",
                                           "retinal", "homer", "bunny00"));

TEST(SphericalMap, TutteRouteIsBijectiveToo) {
  const SurfaceMesh s = readSurface(t2stest::cgalMesh("blobby"));
  SphericalMapOptions o;
  o.conformal = false;
  const SphericalMapResult r = sphericalMap(s, o);
  expectBijectiveNormalisedMap(s, r);
  EXPECT_EQ(r.method.substr(0, 5), "tutte");
  // The conformal route distorts angles less.
  EXPECT_LT(sphericalMap(s).angleDistortionMean, r.angleDistortionMean);
}

TEST(SphericalMap, InvariantUnderRigidMotionAndScaling) {
  const SurfaceMesh s = readSurface(t2stest::cgalMesh("blob-closed"));
  SurfaceMesh moved = s;
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  moved.V = ((s.V * R.transpose()) * 3.7).rowwise() + Eigen::RowVector3d(10, -4, 2);
  const SphericalMapResult a = sphericalMap(s), b = sphericalMap(moved);
  // Everything the map uses is intrinsic (lengths, angles, areas), so the
  // two maps agree, not just up to a rotation.
  EXPECT_LT((a.U - b.U).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_EQ(a.U, sphericalMap(s).U);  // deterministic
}

TEST(SphericalMap, RefusesSurfacesThatAreNotGenus0Shells) {
  for (const char* name : {"elephant", "lion"}) {
    try {
      sphericalMap(readSurface(t2stest::cgalMesh(name)));
      ADD_FAILURE() << name << " was accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::Topology) << e.what();
      EXPECT_NE(std::string(e.what()).find("sphericalMap"), std::string::npos);
    }
  }
}

TEST(SphericalMap, CountsFlipsExactly) {
  const SurfaceMesh s = readSurface(t2stest::cgalMesh("part"));
  SphericalMapResult r = sphericalMap(s);
  Eigen::MatrixX3d mirrored = r.U;
  mirrored.col(0) *= -1;
  EXPECT_EQ(countFlippedSphereTriangles(mirrored, s.F), s.F.rows());
}
