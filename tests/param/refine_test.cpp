// Chord splitting on real TetGen meshes: afterwards no interior edge joins two
// boundary vertices, the volume, orientation and regions are unchanged.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <utility>
#include <vector>

#include "test_data.h"
#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/refine.h"
#include "tet2spline/param/tetrahedralize.h"
#include "tet2spline/param/topology.h"

using namespace tet2spline;

namespace {
double tetVolume(const TetMesh& m, Eigen::Index t) {
  const Eigen::Vector3d a = m.V.row(m.T(t, 0)), b = m.V.row(m.T(t, 1)), c = m.V.row(m.T(t, 2)), d = m.V.row(m.T(t, 3));
  return (b - a).cross(c - a).dot(d - a) / 6.0;
}

double totalVolume(const TetMesh& m) {
  double v = 0;
  for (Eigen::Index t = 0; t < m.numTets(); ++t) v += tetVolume(m, t);
  return v;
}
}  // namespace

class RefineReal : public ::testing::TestWithParam<const char*> {};

TEST_P(RefineReal, SplittingChordsLeavesNoneAndKeepsTheSolid) {
  TetrahedralizeOptions o;
  const std::string name = GetParam();
  const std::string path = name == "two_material" ? t2stest::sourceDir() + "/models/two_material.off" : t2stest::cgalMesh(name);
  TetMesh mesh = tetrahedralize(readSurface(path), o);
  mesh.pointFields.push_back({"x", mesh.V});
  const double volume = totalVolume(mesh);
  const Eigen::Index nv = mesh.numVertices(), nt = mesh.numTets();
  const int chords = countBoundaryChords(mesh);
  const Eigen::MatrixX3i F0 = boundaryFaces(mesh);
  EXPECT_EQ(splitBoundaryChords(mesh), chords);  // every chord can be split in these meshes
  EXPECT_EQ(mesh.numVertices(), nv + chords);
  EXPECT_GT(mesh.numTets(), nt + chords);  // at least three tets around an interior edge
  EXPECT_EQ(countBoundaryChords(mesh), 0);
  EXPECT_EQ(countNonPositiveTets(mesh.V, mesh.T), 0);
  for (Eigen::Index t = 0; t < mesh.numTets(); ++t)  // later stages divide by the volume in doubles
    ASSERT_GT(tetVolume(mesh, t), 0) << "tet " << t;
  EXPECT_NEAR(totalVolume(mesh), volume, 1e-12 * std::abs(volume) * mesh.numTets());
  EXPECT_EQ(boundaryFaces(mesh).rows(), F0.rows());  // the boundary is untouched
  EXPECT_TRUE(analyzeSolid(mesh).valid());
  // The carried point field stays the position (it is affine).
  EXPECT_LT((mesh.pointFields[0].values - Eigen::MatrixXd(mesh.V)).cwiseAbs().maxCoeff(), 1e-12);
}

INSTANTIATE_TEST_SUITE_P(TestData, RefineReal, ::testing::Values("part", "fandisk", "spool", "homer", "two_material"),
                         [](const auto& info) { return std::string(info.param); });

// Splitting given edges (the final untangling's last resort, parameterize.cpp):
// one new vertex per edge on it, each tet around it cut in two whose volumes
// add up to its own, regions following the tet cut, the boundary untouched.
// A pair of vertices that is no edge, or an edge given twice, is left.
TEST_P(RefineReal, SplittingEdgesCutsEveryTetAroundThem) {
  const std::string name = GetParam();
  const std::string path = name == "two_material" ? t2stest::sourceDir() + "/models/two_material.off" : t2stest::cgalMesh(name);
  TetMesh mesh = tetrahedralize(readSurface(path), TetrahedralizeOptions{});
  mesh.pointFields.push_back({"x", mesh.V});
  const TetMesh before = mesh;
  const Eigen::Index nv = mesh.numVertices(), nt = mesh.numTets();
  // The edge (T(t,0), T(t,1)) of every 97th tet unless both ends are on the
  // boundary (as parameterize picks them), once, and one given twice.
  std::vector<char> onBoundary(static_cast<size_t>(nv), 0);
  const Eigen::MatrixX3i F = boundaryFaces(mesh);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) onBoundary[static_cast<size_t>(F(f, k))] = 1;
  std::vector<std::pair<int, int>> edges;
  for (Eigen::Index t = 0; t < nt; t += 97) {
    const int a = mesh.T(t, 0), b = mesh.T(t, 1);
    if (!onBoundary[static_cast<size_t>(a)] || !onBoundary[static_cast<size_t>(b)]) edges.emplace_back(std::min(a, b), std::max(a, b));
  }
  ASSERT_GT(edges.size(), 5u);
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  const size_t distinct = edges.size();
  edges.push_back(edges.front());  // no edge any more once split
  // Two vertices of the mesh farthest apart along x are no edge.
  Eigen::Index lo, hi;
  mesh.V.col(0).minCoeff(&lo), mesh.V.col(0).maxCoeff(&hi);
  edges.emplace_back(static_cast<int>(lo), static_cast<int>(hi));

  const EdgeSplits cut = splitEdges(mesh, edges);
  ASSERT_EQ(cut.splits.size(), distinct);
  EXPECT_EQ(mesh.numVertices(), nv + static_cast<Eigen::Index>(distinct));
  ASSERT_EQ(cut.parent.size(), static_cast<size_t>(mesh.numTets()));
  EXPECT_GE(mesh.numTets(), nt + 3 * static_cast<Eigen::Index>(distinct));  // at least three tets around an interior edge
  for (size_t k = 0; k < cut.splits.size(); ++k) {
    const EdgeSplit& e = cut.splits[k];
    EXPECT_EQ(e.vertex, nv + static_cast<Eigen::Index>(k));
    EXPECT_EQ(std::make_pair(e.a, e.b), edges[k]);
    EXPECT_GT(e.t, 0);
    EXPECT_LT(e.t, 1);
    EXPECT_LT((Eigen::RowVector3d(mesh.V.row(e.vertex)) - ((1 - e.t) * before.V.row(e.a) + e.t * before.V.row(e.b))).norm(), 1e-12);
  }
  EXPECT_EQ(countNonPositiveTets(mesh.V, mesh.T), 0);
  // Each tet's pieces fill it: their volumes add up to its own, and they keep its region.
  Eigen::VectorXd pieces = Eigen::VectorXd::Zero(nt);
  for (Eigen::Index t = 0; t < mesh.numTets(); ++t) {
    const int p = cut.parent[static_cast<size_t>(t)];
    ASSERT_GE(p, 0);
    ASSERT_LT(p, nt);
    if (t < nt) EXPECT_EQ(p, t);  // a tet cut keeps its index for its first piece
    pieces(p) += tetVolume(mesh, t);
    EXPECT_EQ(mesh.region(t), before.region(p));
  }
  for (Eigen::Index t = 0; t < nt; ++t) ASSERT_NEAR(pieces(t), tetVolume(before, t), 1e-12 * tetVolume(before, t)) << "tet " << t;
  EXPECT_EQ(boundaryFaces(mesh), F);  // the boundary is untouched
  EXPECT_TRUE(analyzeSolid(mesh).valid());
  EXPECT_LT((mesh.pointFields[0].values - Eigen::MatrixXd(mesh.V)).cwiseAbs().maxCoeff(), 1e-12);
}
