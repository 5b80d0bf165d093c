// Topology of tet solids and triangle surfaces: synthetic shapes whose
// answer is known, and the real libcgal-demo surfaces of design.md.
#include "tet2spline/param/topology.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <map>
#include <numeric>
#include <random>
#include <vector>

#include "param/test_shapes.h"
#include "test_data.h"
#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/parameterize.h"
#include "tet2spline/param/tetrahedralize.h"

using namespace tet2spline;

namespace {

bool mentions(const std::vector<std::string>& problems, const std::string& word) {
  for (const auto& p : problems)
    if (p.find(word) != std::string::npos) return true;
  return false;
}

ErrorKind kindOfRequireValidSolid(const SolidReport& r) {
  try {
    requireValidSolid(r, "x.mesh");
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("x.mesh: ", 0), 0u) << e.what();
    return e.kind();
  }
  ADD_FAILURE() << "requireValidSolid did not throw";
  return ErrorKind::Usage;
}

}  // namespace

TEST(AnalyzeSolid, CubeOfFiveOrSixTetsIsABall) {
  for (const TetMesh& m : {t2stest::cube5(), t2stest::cube6()}) {
    const SolidReport r = analyzeSolid(m);
    EXPECT_TRUE(r.valid()) << (r.problems.empty() ? "" : r.problems[0]);
    EXPECT_EQ(r.components, 1);
    ASSERT_EQ(r.shells.size(), 1u);
    EXPECT_EQ(r.shells[0].faces, 12);
    EXPECT_EQ(r.shells[0].edges, 18);
    EXPECT_EQ(r.shells[0].vertices, 8);
    EXPECT_EQ(r.shells[0].eulerCharacteristic, 2);
    EXPECT_TRUE(r.shells[0].closed);
    EXPECT_EQ(r.genus, 0);
    EXPECT_EQ(r.voids, 0);
    EXPECT_NEAR(r.shells[0].enclosedVolume, 1.0, 1e-14);
    EXPECT_NEAR(t2stest::totalVolume(m), 1.0, 1e-14);
    EXPECT_EQ(r.invertedTets, 0);
    EXPECT_EQ(r.degenerateTets, 0);
    EXPECT_EQ(r.regions, std::vector<int>{1});
    EXPECT_NO_THROW(requireValidSolid(r, "cube"));
  }
}

TEST(AnalyzeSolid, BoundaryFacesAreOrientedOutward) {
  const TetMesh m = t2stest::cube6();
  const Eigen::MatrixX3i B = boundaryFaces(m);
  ASSERT_EQ(B.rows(), 12);
  const Eigen::RowVector3d center(0.5, 0.5, 0.5);
  for (Eigen::Index f = 0; f < B.rows(); ++f) {
    const Eigen::RowVector3d a = m.V.row(B(f, 0)), b = m.V.row(B(f, 1)), c = m.V.row(B(f, 2));
    // The centre lies on the inner side of every outward face.
    EXPECT_EQ(orient3d(a.data(), b.data(), c.data(), center.data()), -1) << "face " << f;
  }
}

TEST(AnalyzeSolid, TwoDisjointTetsAreTwoComponents) {
  const SolidReport r = analyzeSolid(t2stest::twoTets(0));
  EXPECT_EQ(r.components, 2);
  EXPECT_EQ(r.shells.size(), 2u);
  EXPECT_FALSE(r.valid());
  EXPECT_TRUE(mentions(r.problems, "2 connected components")) << r.problems[0];
  EXPECT_EQ(kindOfRequireValidSolid(r), ErrorKind::Topology);
}

TEST(AnalyzeSolid, TetsSharingOnlyAnEdgeAreNonManifold) {
  const SolidReport r = analyzeSolid(t2stest::twoTets(2));
  EXPECT_EQ(r.components, 2);
  EXPECT_EQ(r.nonManifoldBoundaryEdges, 1);
  EXPECT_EQ(r.nonManifoldBoundaryVertices, 2);
  EXPECT_TRUE(mentions(r.problems, "non-manifold"));
  EXPECT_EQ(kindOfRequireValidSolid(r), ErrorKind::Topology);
}

TEST(AnalyzeSolid, TetsSharingOnlyAVertexAreNonManifold) {
  const SolidReport r = analyzeSolid(t2stest::twoTets(1));
  EXPECT_EQ(r.nonManifoldBoundaryEdges, 0);
  EXPECT_EQ(r.nonManifoldBoundaryVertices, 1);
  EXPECT_FALSE(r.valid());
}

TEST(AnalyzeSolid, TetsSharingAFaceAreOneSolid) {
  const SolidReport r = analyzeSolid(t2stest::twoTets(3));
  EXPECT_TRUE(r.valid()) << r.problems[0];
  EXPECT_EQ(r.shells.size(), 1u);
  EXPECT_EQ(r.shells[0].faces, 6);
  EXPECT_EQ(r.unusedVertices, 3);    // the unshared copies
  EXPECT_EQ(r.duplicateVertices, 0); // unused copies do not count
}

TEST(AnalyzeSolid, FaceSharedByThreeTetsIsReported) {
  const TetMesh m = t2stest::threeTetsOnOneFace();
  const SolidReport r = analyzeSolid(m);
  EXPECT_EQ(r.nonManifoldFaces, 1);
  EXPECT_FALSE(r.valid());
}

// boundaryFaces against a plain reference (every face of every tet in a
// map from its sorted vertices): the faces of exactly one tet, each once,
// oriented as in that tet, in the order of their sorted vertices. On a real
// mesh (TetGen's of fandisk), renumbered by a fixed shuffle so that the
// smallest-vertex buckets of the face sort are not TetGen's order.
TEST(AnalyzeSolid, BoundaryFacesAreTheFacesOfOneTetInKeyOrder) {
  TetMesh m = tetrahedralize(readSurface(t2stest::cgalMesh("fandisk")));
  const Eigen::Index nv = m.V.rows();
  std::vector<int> perm(static_cast<size_t>(nv));
  std::iota(perm.begin(), perm.end(), 0);
  std::mt19937 rng(7);
  std::shuffle(perm.begin(), perm.end(), rng);
  for (Eigen::Index t = 0; t < m.T.rows(); ++t)
    for (int k = 0; k < 4; ++k) m.T(t, k) = perm[static_cast<size_t>(m.T(t, k))];
  Eigen::MatrixX3d V(nv, 3);
  for (Eigen::Index v = 0; v < nv; ++v) V.row(perm[static_cast<size_t>(v)]) = m.V.row(v);
  m.V = V;
  constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  std::map<std::array<int, 3>, std::vector<std::array<int, 3>>> uses;
  for (Eigen::Index t = 0; t < m.T.rows(); ++t)
    for (const auto& f : kFace) {
      const std::array<int, 3> oriented = {m.T(t, f[0]), m.T(t, f[1]), m.T(t, f[2])};
      std::array<int, 3> key = oriented;
      std::sort(key.begin(), key.end());
      uses[key].push_back(oriented);
    }
  std::vector<std::array<int, 3>> expected;
  for (const auto& [key, list] : uses) {
    ASSERT_LE(list.size(), 2u);
    if (list.size() == 1) expected.push_back(list[0]);
  }
  const Eigen::MatrixX3i B = boundaryFaces(m);
  ASSERT_EQ(static_cast<size_t>(B.rows()), expected.size());
  for (Eigen::Index f = 0; f < B.rows(); ++f)
    for (int k = 0; k < 3; ++k) ASSERT_EQ(B(f, k), expected[static_cast<size_t>(f)][static_cast<size_t>(k)]) << "face " << f;
  const SolidReport r = analyzeSolid(m);
  EXPECT_TRUE(r.valid()) << (r.problems.empty() ? "" : r.problems[0]);
  EXPECT_EQ(r.components, 1);
}

TEST(AnalyzeSolid, AllInvertedIsReorientedSomeInvertedIsRefused) {
  TetMesh m = t2stest::cube5();
  for (Eigen::Index t = 0; t < m.T.rows(); ++t) std::swap(m.T(t, 0), m.T(t, 1));
  SolidReport r = analyzeSolid(m);
  EXPECT_EQ(r.invertedTets, 5);
  EXPECT_TRUE(mentions(r.problems, "5 of 5 tets are inverted"));
  EXPECT_EQ(kindOfRequireValidSolid(r), ErrorKind::Input);
  EXPECT_TRUE(reorientIfAllInverted(m));
  r = analyzeSolid(m);
  EXPECT_TRUE(r.valid());
  EXPECT_EQ(countNonPositiveTets(m.V, m.T), 0);

  std::swap(m.T(2, 0), m.T(2, 1));  // one tet inverted
  EXPECT_FALSE(reorientIfAllInverted(m));
  r = analyzeSolid(m);
  EXPECT_EQ(r.invertedTets, 1);
  EXPECT_TRUE(mentions(r.problems, "1 of 5 tets are inverted"));
  EXPECT_EQ(kindOfRequireValidSolid(r), ErrorKind::Input);
}

TEST(AnalyzeSolid, DegenerateTetIsRefused) {
  TetMesh m = t2stest::cube5();
  m.V.conservativeResize(9, 3);
  m.V.row(8) << 0.5, 0, 0;  // on the edge 0–1: a flat tet glued nowhere
  m.T.conservativeResize(6, 4);
  m.T.row(5) << 0, 8, 1, 2;
  m.region = Eigen::VectorXi::Ones(6);
  const SolidReport r = analyzeSolid(m);
  EXPECT_EQ(r.degenerateTets, 1);
  EXPECT_FALSE(r.valid());
}

TEST(AnalyzeSolid, VoidsCountInnerShellsAndVoidRegions) {
  TetMesh m = t2stest::cube5();
  m.region(0) = 2;
  m.voidRegions = {2};
  const SolidReport r = analyzeSolid(m);
  EXPECT_EQ(r.voids, 1);
  EXPECT_EQ(r.regions, (std::vector<int>{1, 2}));
  EXPECT_TRUE(r.valid());
}

TEST(AnalyzeSolid, RemoveUnusedVerticesRenumbers) {
  TetMesh m = t2stest::twoTets(3);
  m.pointFields.push_back({"id", Eigen::VectorXd::LinSpaced(8, 0, 7)});
  EXPECT_EQ(removeUnusedVertices(m), 3);
  EXPECT_EQ(m.V.rows(), 5);
  EXPECT_EQ(m.pointFields[0].values.rows(), 5);
  EXPECT_EQ(m.pointFields[0].values(4, 0), 7);
  EXPECT_EQ(analyzeSolid(m).unusedVertices, 0);
  EXPECT_EQ(countNonPositiveTets(m.V, m.T), 0);
}

TEST(AnalyzeSolid, OutOfRangeIndexThrowsInput) {
  TetMesh m = t2stest::cube5();
  m.T(0, 0) = 99;
  try {
    analyzeSolid(m);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::Input);
  }
}

TEST(AnalyzeSurface, SphereIsClosedGenusZero) {
  const SurfaceMesh s = t2stest::sphere(3);
  const SurfaceReport r = analyzeSurface(s);
  EXPECT_TRUE(r.valid()) << r.problems[0];
  ASSERT_EQ(r.shells.size(), 1u);
  EXPECT_EQ(r.shells[0].eulerCharacteristic, 2);
  EXPECT_EQ(r.shells[0].genus, 0);
  EXPECT_GT(r.shells[0].enclosedVolume, 0);
  EXPECT_TRUE(r.selfIntersectionsChecked);
  EXPECT_EQ(r.selfIntersections, 0);
  EXPECT_EQ(r.boundaryEdges, 0);
}

TEST(AnalyzeSurface, TorusHasGenusOne) {
  const SurfaceReport r = analyzeSurface(t2stest::torus());
  ASSERT_EQ(r.shells.size(), 1u);
  EXPECT_EQ(r.shells[0].eulerCharacteristic, 0);
  EXPECT_EQ(r.shells[0].genus, 1);
  ASSERT_FALSE(r.valid());
  EXPECT_EQ(r.problems[0], "outer boundary has genus 1; only genus-0 solids can be mapped to a ball");
  try {
    requireValidSurface(r, "torus.off");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::Topology);
    EXPECT_EQ(std::string(e.what()).rfind("torus.off: ", 0), 0u);
  }
}

TEST(AnalyzeSurface, OpenSurfaceHasBoundaryEdges) {
  SurfaceMesh s = t2stest::sphere(2);
  s.F.conservativeResize(s.F.rows() - 1, 3);  // punch one triangle out
  const SurfaceReport r = analyzeSurface(s);
  EXPECT_EQ(r.boundaryEdges, 3);
  EXPECT_EQ(r.boundaryLoops, 1);
  EXPECT_FALSE(r.shells[0].closed);
  EXPECT_EQ(r.shells[0].genus, -1);
  ASSERT_FALSE(r.valid());
  EXPECT_TRUE(mentions(r.problems, "open"));
  EXPECT_EQ(r.problemKinds[0], ErrorKind::Topology);
}

TEST(AnalyzeSurface, FlippedTriangleIsInconsistentOrientation) {
  SurfaceMesh s = t2stest::sphere(2);
  std::swap(s.F(0, 1), s.F(0, 2));
  const SurfaceReport r = analyzeSurface(s);
  EXPECT_EQ(r.inconsistentEdges, 3);
  EXPECT_EQ(r.shells[0].inconsistentEdges, 3);
  EXPECT_TRUE(mentions(r.problems, "not consistently oriented"));
}

TEST(AnalyzeSurface, InwardSphereHasNegativeVolume) {
  const SurfaceReport r = analyzeSurface(t2stest::sphere(2, 1, Eigen::RowVector3d::Zero(), true));
  EXPECT_TRUE(r.valid());
  EXPECT_LT(r.shells[0].enclosedVolume, 0);
}

TEST(AnalyzeSurface, TwoSpheresSharingAVertexAreNonManifold) {
  const SurfaceMesh a = t2stest::sphere(1), b = t2stest::sphere(1, 1, Eigen::RowVector3d(2, 0, 0));
  SurfaceMesh s = t2stest::merge(a, b);
  // Glue b's vertex (−1,0,0)+(2,0,0) = (1,0,0) onto a's vertex 0.
  for (Eigen::Index f = a.F.rows(); f < s.F.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      if (s.F(f, k) == a.V.rows() + 1) s.F(f, k) = 0;
  const SurfaceReport r = analyzeSurface(s);
  EXPECT_EQ(r.nonManifoldEdges, 0);
  EXPECT_EQ(r.nonManifoldVertices, 1);
  EXPECT_EQ(r.shells.size(), 2u);
  EXPECT_FALSE(r.valid());
}

TEST(AnalyzeSurface, IntersectingSpheresSelfIntersect) {
  const SurfaceMesh s = t2stest::merge(t2stest::sphere(2), t2stest::sphere(2, 1, Eigen::RowVector3d(0.5, 0.1, 0.2)));
  const SurfaceReport r = analyzeSurface(s);
  EXPECT_TRUE(r.selfIntersectionsChecked);
  EXPECT_GT(r.selfIntersections, 0);
  ASSERT_FALSE(r.valid());
  EXPECT_TRUE(mentions(r.problems, "intersects itself"));
  EXPECT_EQ(r.problemKinds[0], ErrorKind::Input);
}

TEST(AnalyzeSurface, NestingOfShells) {
  // Outer sphere, a cavity (inward) with an island inside, and a second cavity.
  const SurfaceMesh s = t2stest::merge(
      t2stest::merge(t2stest::merge(t2stest::sphere(1, 0.5, Eigen::RowVector3d(-1, 0, 0)),  // island, shell 1
                                    t2stest::sphere(2, 4)),                                // outer, shell 2
                     t2stest::sphere(2, 1.2, Eigen::RowVector3d(-1, 0, 0), true)),         // cavity, shell 3
      t2stest::sphere(1, 0.5, Eigen::RowVector3d(2, 0, 0), true));                         // cavity, shell 4
  const SurfaceReport r = analyzeSurface(s);
  EXPECT_TRUE(r.valid()) << r.problems[0];
  EXPECT_EQ(r.shellParent, (std::vector<int>{2, -1, 1, 1}));
  EXPECT_EQ(r.shellDepth, (std::vector<int>{2, 0, 1, 1}));
}

TEST(AnalyzeSurface, SideBySideShellsAreSeparateSolids) {
  const SurfaceReport r =
      analyzeSurface(t2stest::merge(t2stest::sphere(1), t2stest::sphere(1, 1, Eigen::RowVector3d(3, 0, 0))));
  EXPECT_EQ(r.shellDepth, (std::vector<int>{0, 0}));
  ASSERT_FALSE(r.valid());
  EXPECT_EQ(r.problems[0], "the surface bounds 2 separate solids side by side; expected one solid");
  EXPECT_EQ(r.problemKinds[0], ErrorKind::Topology);
}

TEST(AnalyzeSurface, DegenerateTriangleIsReported) {
  SurfaceMesh s = t2stest::sphere(1);
  s.F(0, 2) = s.F(0, 1);
  const SurfaceReport r = analyzeSurface(s);
  EXPECT_GE(r.degenerateFaces, 1);
  EXPECT_FALSE(r.valid());
}

// Real surfaces (design.md, "Test data").

TEST(AnalyzeSurfaceReal, Genus0MeshesAreValid) {
  for (const char* name : t2stest::kGenus0Meshes) {
    const SurfaceReport r = analyzeSurface(readSurface(t2stest::cgalMesh(name)));
    EXPECT_TRUE(r.valid()) << name << ": " << (r.problems.empty() ? "" : r.problems[0]);
    ASSERT_EQ(r.shells.size(), 1u) << name;
    EXPECT_EQ(r.shells[0].genus, 0) << name;
    EXPECT_TRUE(r.selfIntersectionsChecked) << name;
  }
}

TEST(AnalyzeSurfaceReal, HandlesGiveTheGenus) {
  // elephant has χ = −4 (design.md).
  const SurfaceReport elephant = analyzeSurface(readSurface(t2stest::cgalMesh("elephant")));
  ASSERT_EQ(elephant.shells.size(), 1u);
  EXPECT_EQ(elephant.shells[0].eulerCharacteristic, -4);
  EXPECT_EQ(elephant.shells[0].genus, 3);
  for (const char* name : {"femur", "knot", "rotor"}) {
    const SurfaceReport r = analyzeSurface(readSurface(t2stest::cgalMesh(name)));
    ASSERT_FALSE(r.valid()) << name;
    EXPECT_GT(r.shells[0].genus, 0) << name;
    EXPECT_EQ(r.problemKinds[0], ErrorKind::Topology) << name;
  }
}

TEST(AnalyzeSurfaceReal, SelfIntersectionCheckOnBunnyIsFast) {
  const SurfaceMesh s = readSurface(t2stest::cgalMesh("bunny00"));
  const auto t0 = std::chrono::steady_clock::now();
  const SurfaceReport r = analyzeSurface(s);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  RecordProperty("analyze_surface_seconds", std::to_string(seconds));
  std::printf("analyzeSurface(bunny00, %d faces) with self-intersections: %.3f s\n", r.faces, seconds);
  EXPECT_TRUE(r.valid());
}

// normalAngleQuantile: the angle between adjacent triangles' normals.
TEST(NormalAngleQuantile, CubeFacesMeetAtRightAnglesAndShareTheirDiagonalsFlat) {
  const TetMesh cube = t2stest::cube6();
  const Eigen::MatrixX3i F = boundaryFaces(cube);
  ASSERT_EQ(F.rows(), 12);
  // 18 shared edges: 12 cube edges at 90°, 6 face diagonals at 0°.
  EXPECT_NEAR(normalAngleQuantile(cube.V, F, 1.0), 90.0, 1e-9);
  EXPECT_NEAR(normalAngleQuantile(cube.V, F, 0.99), 90.0, 1e-9);
  EXPECT_NEAR(normalAngleQuantile(cube.V, F, 0.0), 0.0, 1e-6);
  EXPECT_NEAR(normalAngleQuantile(cube.V, F, 0.25), 0.0, 1e-6);
  EXPECT_NEAR(normalAngleQuantile(cube.V, F, 0.5), 90.0, 1e-9);
}

TEST(NormalAngleQuantile, RefiningASphereHalvesItsAngles) {
  // On a sphere the angle is about an edge length over the radius: each
  // subdivision halves it, whatever the radius or the position.
  double previous = 180;
  for (int level = 2; level <= 5; ++level) {
    const SurfaceMesh s = t2stest::sphere(level, 3.0, Eigen::RowVector3d(1, -2, 5));
    const double a = normalAngleQuantile(s.V, s.F, 0.99);
    EXPECT_GT(a, 0) << level;
    if (level > 2) {
      EXPECT_NEAR(a / previous, 0.5, 0.1) << level;
    }
    const SurfaceMesh unit = t2stest::sphere(level);
    EXPECT_NEAR(normalAngleQuantile(unit.V, unit.F, 0.99), a, 1e-9) << level;
    previous = a;
  }
  EXPECT_LT(previous, 5.0);
}

TEST(NormalAngleQuantile, EdgesOfOneTriangleOnlyAreSkippedAndBadArgumentsThrow) {
  Eigen::MatrixX3d X(4, 3);
  X << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  Eigen::MatrixX3i one(1, 3);
  one << 0, 1, 2;
  EXPECT_EQ(normalAngleQuantile(X, one, 0.99), 0.0);
  Eigen::MatrixX3i two(2, 3);
  two << 0, 1, 2, 0, 3, 1;  // a right angle along edge 0-1
  EXPECT_NEAR(normalAngleQuantile(X, two, 0.5), 90.0, 1e-9);
  EXPECT_THROW(normalAngleQuantile(X, two, 1.5), Error);
  EXPECT_THROW(normalAngleQuantile(X, two, -0.1), Error);
  two(1, 2) = 4;
  EXPECT_THROW(normalAngleQuantile(X, two, 0.5), Error);
}

TEST(PlanarShare, CubeIsAllPlanarSphereNoneAndSplittingKeepsIt) {
  const TetMesh cube = t2stest::cube6();
  const Eigen::MatrixX3i F = boundaryFaces(cube);
  EXPECT_NEAR(planarShare(cube.V, F, 0.1, 0.01), 1.0, 1e-12);
  EXPECT_NEAR(planarShare(cube.V, F, 0.1, 0.2), 0.0, 1e-12);  // each face is a sixth
  // A sphere: every patch is one triangle, below 1% of the area; at 30° the
  // patches grow, and at 180° one patch holds everything.
  const SurfaceMesh s = t2stest::sphere(4);
  EXPECT_EQ(planarShare(s.V, s.F, 0.1, 0.01), 0.0);
  EXPECT_NEAR(planarShare(s.V, s.F, 180.0, 0.01), 1.0, 1e-12);
  // Splitting each cube face into many coplanar triangles keeps it planar
  // (TetGen's boundary Steiner points), while a sphere split as finely stays curved.
  TetrahedralizeOptions fine;
  fine.maxVolume = 1e-3;
  const TetMesh split = tetrahedralize(SurfaceMesh{cube.V, F}, fine);
  const Eigen::MatrixX3i G = boundaryFaces(split);
  ASSERT_GT(G.rows(), 100);
  EXPECT_NEAR(planarShare(split.V, G, 0.1, 0.01), 1.0, 1e-9);
  const SurfaceMesh finer = t2stest::sphere(6);
  EXPECT_EQ(planarShare(finer.V, finer.F, 0.1, 0.01), 0.0);
  EXPECT_THROW(planarShare(cube.V, F, -1, 0.01), Error);
  EXPECT_THROW(planarShare(cube.V, F, 0.1, 1.5), Error);
}
