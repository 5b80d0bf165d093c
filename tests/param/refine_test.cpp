// Chord splitting on real TetGen meshes: afterwards no interior edge joins two
// boundary vertices, the volume, orientation and regions are unchanged.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "test_data.h"
#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/refine.h"
#include "tet2spline/param/tetrahedralize.h"
#include "tet2spline/param/topology.h"

using namespace tet2spline;

namespace {
double totalVolume(const TetMesh& m) {
  double v = 0;
  for (Eigen::Index t = 0; t < m.numTets(); ++t) {
    const Eigen::Vector3d a = m.V.row(m.T(t, 0)), b = m.V.row(m.T(t, 1)), c = m.V.row(m.T(t, 2)), d = m.V.row(m.T(t, 3));
    v += (b - a).cross(c - a).dot(d - a) / 6.0;
  }
  return v;
}
}  // namespace

class RefineReal : public ::testing::TestWithParam<const char*> {};

TEST_P(RefineReal, SplittingChordsLeavesNoneAndKeepsTheSolid) {
  TetrahedralizeOptions o;
  TetMesh mesh = tetrahedralize(readSurface(t2stest::cgalMesh(GetParam())), o);
  mesh.pointFields.push_back({"x", mesh.V});
  const double volume = totalVolume(mesh);
  const Eigen::Index nv = mesh.numVertices(), nt = mesh.numTets();
  const int chords = countBoundaryChords(mesh);
  const Eigen::MatrixX3i F0 = boundaryFaces(mesh);
  EXPECT_EQ(splitBoundaryChords(mesh), chords);
  EXPECT_EQ(mesh.numVertices(), nv + chords);
  EXPECT_GT(mesh.numTets(), nt + chords);  // at least three tets around an interior edge
  EXPECT_EQ(countBoundaryChords(mesh), 0);
  EXPECT_EQ(countNonPositiveTets(mesh.V, mesh.T), 0);
  EXPECT_NEAR(totalVolume(mesh), volume, 1e-12 * std::abs(volume) * mesh.numTets());
  EXPECT_EQ(boundaryFaces(mesh).rows(), F0.rows());  // the boundary is untouched
  EXPECT_TRUE(analyzeSolid(mesh).valid());
  // The carried point field stays the position (it is affine).
  EXPECT_LT((mesh.pointFields[0].values - Eigen::MatrixXd(mesh.V)).cwiseAbs().maxCoeff(), 1e-12);
}

INSTANTIATE_TEST_SUITE_P(TestData, RefineReal, ::testing::Values("part", "fandisk", "spool", "homer"),
                         [](const auto& info) { return std::string(info.param); });
