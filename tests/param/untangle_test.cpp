#include "tet2spline/param/untangle.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <tbb/global_control.h>

#include "ball_test_meshes.h"
#include "tet2spline/param/topology.h"

using namespace tet2spline;

namespace {

std::vector<bool> boundaryMask(const TetMesh& m) {
  std::vector<bool> fixed(static_cast<size_t>(m.V.rows()));
  for (Eigen::Index v = 0; v < m.V.rows(); ++v) fixed[v] = m.V.row(v).cwiseAbs().maxCoeff() > 1 - 1e-12;
  return fixed;
}

// A run that cannot succeed: on a 6³ grid with its boundary held, two
// neighbouring vertices of the face x = −1, (i, j, k) = (0, 3, 3) and
// (0, 4, 3), are swapped, so the face folds and its tets stay inverted
// whatever the interior does.
struct FoldedFace {
  TetMesh m;
  std::vector<bool> fixed;
  Eigen::MatrixX3d U;
};
FoldedFace foldedFace() {
  const int n = 6, s = n + 1;
  FoldedFace f{t2stest::cubeGrid(n), {}, {}};
  f.fixed = boundaryMask(f.m);
  f.U = f.m.V;
  const int a = 0 + s * (3 + s * 3), b = 0 + s * (4 + s * 3);
  EXPECT_TRUE(f.fixed[a] && f.fixed[b]);
  f.U.row(a).swap(f.U.row(b));
  return f;
}

// Per vertex: whether it is a corner of one of `faces`.
std::vector<bool> onFaces(const Eigen::MatrixX3i& faces, Eigen::Index numVertices) {
  std::vector<bool> on(static_cast<size_t>(numVertices), false);
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) on[static_cast<size_t>(faces(f, k))] = true;
  return on;
}

}  // namespace

// Every method must untangle; the tests that say so run with both.
class UntangleMethods : public ::testing::TestWithParam<UntangleMethod> {};
INSTANTIATE_TEST_SUITE_P(Methods, UntangleMethods, ::testing::Values(UntangleMethod::Lbfgs, UntangleMethod::Newton),
                         [](const auto& info) { return info.param == UntangleMethod::Lbfgs ? "Lbfgs" : "Newton"; });

TEST_P(UntangleMethods, FixesARandomlyTangledGrid) {
  const TetMesh m = t2stest::cubeGrid(8);
  const auto fixed = boundaryMask(m);
  Eigen::MatrixX3d U = m.V;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-0.3, 0.3);  // cell size 0.25: heavy tangling
  for (Eigen::Index v = 0; v < U.rows(); ++v)
    if (!fixed[v])
      for (int d = 0; d < 3; ++d) U(v, d) += jitter(rng);
  const int before = countNonPositiveTets(U, m.T);
  ASSERT_GT(before, 50);
  UntangleOptions options;
  options.method = GetParam();
  options.rings = -1;
  const UntangleResult r = untangle(m.V, m.T, U, fixed, options);
  EXPECT_EQ(r.invertedBefore, before);
  EXPECT_EQ(r.invertedAfter, 0) << r.status.message;
  EXPECT_EQ(countNonPositiveTets(r.U, m.T), 0);
  EXPECT_TRUE(r.status.ok) << r.status.message;
  for (Eigen::Index v = 0; v < U.rows(); ++v)
    if (fixed[v]) {
      EXPECT_EQ(r.U.row(v), U.row(v));  // bitwise kept
    }
}

TEST_P(UntangleMethods, LocalRegionFixesAFewInvertedTets) {
  const TetMesh m = t2stest::cubeGrid(10);
  const auto fixed = boundaryMask(m);
  Eigen::MatrixX3d U = m.V;
  // Push three interior vertices through their neighbours.
  for (int v : {333, 555, 777}) U.row(v) += Eigen::RowVector3d(0.3, -0.25, 0.2);
  ASSERT_GT(countNonPositiveTets(U, m.T), 0);
  UntangleOptions options;
  options.method = GetParam();
  const UntangleResult r = untangle(m.V, m.T, U, fixed, options);
  EXPECT_EQ(r.invertedAfter, 0) << r.status.message;
  EXPECT_LT(r.freeVertices, m.V.rows() / 2);
}

TEST(Untangle, WorkBudgetEndsAFailingRunEarly) {
  // (foldedFace: the run grows its region up to every free vertex)
  const auto [m, fixed, U] = foldedFace();
  UntangleOptions options;
  options.localRepairSweeps = 0;
  const UntangleResult full = untangle(m.V, m.T, U, fixed, options);
  ASSERT_GT(full.invertedAfter, 0);
  EXPECT_FALSE(full.budgetExhausted);
  EXPECT_GT(full.outerIterations, 2);
  // Each ε round is at least one evaluation of its region.
  EXPECT_GE(full.tetEvaluations, static_cast<double>(full.outerIterations));

  options.maxTetEvaluations = 2.0 * static_cast<double>(m.T.rows());  // two evaluations of the mesh
  const UntangleResult cut = untangle(m.V, m.T, U, fixed, options);
  EXPECT_TRUE(cut.budgetExhausted);
  EXPECT_FALSE(cut.status.ok);
  EXPECT_GT(cut.invertedAfter, 0);
  EXPECT_GE(cut.tetEvaluations, options.maxTetEvaluations);
  EXPECT_LT(cut.tetEvaluations, full.tetEvaluations);
  EXPECT_LT(cut.outerIterations, full.outerIterations);
  EXPECT_NE(cut.status.message.find("budget"), std::string::npos) << cut.status.message;
  EXPECT_LE(cut.invertedAfter, cut.invertedBefore);  // never worse than the start
  for (Eigen::Index v = 0; v < U.rows(); ++v)
    if (fixed[v]) {
      EXPECT_EQ(cut.U.row(v), U.row(v));
    }
}

// The same run with stallBelow: its first region ends with the folded
// face's tets still inverted, so the regions stop growing there.
TEST(Untangle, AStalledRegionStopsGrowing) {
  const auto [m, fixed, U] = foldedFace();
  UntangleOptions options;
  options.localRepairSweeps = 0;
  const UntangleResult full = untangle(m.V, m.T, U, fixed, options);
  ASSERT_GT(full.invertedAfter, 0);
  EXPECT_FALSE(full.stalled);
  options.stallBelow = 1000;  // (any count: the first region barely lowers it)
  const UntangleResult stalled = untangle(m.V, m.T, U, fixed, options);
  EXPECT_TRUE(stalled.stalled);
  EXPECT_FALSE(stalled.budgetExhausted);
  EXPECT_FALSE(stalled.status.ok);
  EXPECT_GT(stalled.invertedAfter, 0);
  EXPECT_LE(stalled.invertedAfter, stalled.invertedBefore);  // never worse than the start
  EXPECT_LT(stalled.outerIterations, full.outerIterations);
  EXPECT_LT(stalled.freeVertices, full.freeVertices);
  for (Eigen::Index v = 0; v < U.rows(); ++v)
    if (fixed[v]) {
      EXPECT_EQ(stalled.U.row(v), U.row(v));
    }
}

// regionStallRounds: once at most stallBelow are left, a region whose
// rounds stop taking a quarter off its count ends early. The folded face's
// tets cannot be repaired with the boundary held, so no round after the
// first takes a quarter off: the region ends after 1 + 2 rounds instead of
// its regionRounds, and (being stalled) the regions stop growing there.
TEST(Untangle, ARegionWithoutProgressEndsAfterItsStallRounds) {
  const auto [m, fixed, U] = foldedFace();
  UntangleOptions options;
  options.localRepairSweeps = 0;
  options.stallBelow = 1000;
  const UntangleResult rounds = untangle(m.V, m.T, U, fixed, options);
  ASSERT_TRUE(rounds.stalled);
  EXPECT_EQ(rounds.outerIterations, options.regionRounds);
  options.regionStallRounds = 2;
  const UntangleResult early = untangle(m.V, m.T, U, fixed, options);
  EXPECT_TRUE(early.stalled);
  EXPECT_EQ(early.outerIterations, 3);
  EXPECT_GT(early.invertedAfter, 0);
  EXPECT_LE(early.invertedAfter, early.invertedBefore);  // never worse than the start
  for (Eigen::Index v = 0; v < U.rows(); ++v)
    if (fixed[v]) {
      EXPECT_EQ(early.U.row(v), U.row(v));
    }
}

TEST(Untangle, NothingToDoLeavesTheMapAlone) {
  const TetMesh m = t2stest::cubeGrid(3);
  const UntangleResult r = untangle(m.V, m.T, m.V, boundaryMask(m));
  EXPECT_EQ(r.invertedBefore, 0);
  EXPECT_EQ(r.invertedAfter, 0);
  EXPECT_EQ(r.U, m.V);
}

TEST(Untangle, RejectsMismatchedShapes) {
  const TetMesh m = t2stest::cubeGrid(2);
  EXPECT_THROW(untangle(m.V, m.T, m.V.topRows(3), boundaryMask(m)), Error);
}

// ---- Sliding on the boundary of the unit cube (composition with OT) ----

namespace {

struct CubeCase {
  TetMesh mesh;                       // cubeGrid on [0,1]³
  Eigen::MatrixX3i faces;             // outward boundary triangles
  std::vector<std::uint8_t> locks;    // coordinates that are 0 or 1
  Eigen::MatrixX3d U;                 // tangled: boundary flipped within faces, interior inverted
};

CubeCase tangledCube(int n) {
  CubeCase c;
  c.mesh = t2stest::cubeGrid(n);
  c.mesh.V = (c.mesh.V.array() + 1) / 2;  // exact: 0 and 1 on the faces
  c.faces = boundaryFaces(c.mesh);
  c.locks.assign(static_cast<size_t>(c.mesh.V.rows()), 0);
  for (Eigen::Index v = 0; v < c.mesh.V.rows(); ++v)
    for (int d = 0; d < 3; ++d)
      if (c.mesh.V(v, d) == 0 || c.mesh.V(v, d) == 1) c.locks[v] |= static_cast<std::uint8_t>(1u << d);
  c.U = c.mesh.V;
  std::mt19937 rng(11);
  const double h = 1.0 / n;
  std::uniform_real_distribution<double> jitter(-0.9 * h, 0.9 * h);
  for (Eigen::Index v = 0; v < c.U.rows(); ++v) {
    if (c.locks[v] == 7) continue;  // corners stay
    // Boundary vertices move within their face or edge, interior ones anywhere;
    // free coordinates stay inside [0, 1].
    if (c.locks[v] == 0 && v % 5 != 0) continue;  // a fifth of the interior
    if (c.locks[v] != 0 && v % 3 != 0) continue;  // a third of the boundary
    for (int d = 0; d < 3; ++d)
      if (!((c.locks[v] >> d) & 1)) c.U(v, d) = std::clamp(c.U(v, d) + jitter(rng), 0.0, 1.0);
  }
  return c;
}

// Untangling options for a CubeCase: its faces slide on the cube with its locks.
UntangleOptions cubeOptions(const CubeCase& c, UntangleMethod method) {
  UntangleOptions o;
  o.method = method;
  o.cubeFaces = c.faces;
  o.cubeLocks = c.locks;
  return o;
}

int flippedCubeTriangles(const Eigen::MatrixX3d& U, const Eigen::MatrixX3i& F) {
  const Eigen::Vector3d centre(0.5, 0.5, 0.5);
  int flipped = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = U.row(F(f, 0)), b = U.row(F(f, 1)), d = U.row(F(f, 2));
    flipped += orient3d(centre.data(), a.data(), b.data(), d.data()) <= 0;
  }
  return flipped;
}

}  // namespace

class UntangleCubeMethods : public ::testing::TestWithParam<UntangleMethod> {};
INSTANTIATE_TEST_SUITE_P(Methods, UntangleCubeMethods, ::testing::Values(UntangleMethod::Lbfgs, UntangleMethod::Newton),
                         [](const auto& info) { return info.param == UntangleMethod::Lbfgs ? "Lbfgs" : "Newton"; });

TEST_P(UntangleCubeMethods, BoundarySlidesOnTheCubeAndNothingFlips) {
  const CubeCase c = tangledCube(6);
  ASSERT_GT(flippedCubeTriangles(c.U, c.faces), 0);
  ASSERT_GT(countNonPositiveTets(c.U, c.mesh.T), 0);
  UntangleOptions o = cubeOptions(c, GetParam());
  const std::vector<bool> none(static_cast<size_t>(c.U.rows()), false);
  const UntangleResult r = untangle(c.mesh.V, c.mesh.T, c.U, none, o);
  EXPECT_TRUE(r.status.ok) << r.status.message;
  EXPECT_EQ(r.invertedAfter, 0);
  EXPECT_EQ(countNonPositiveTets(r.U, c.mesh.T), 0);
  EXPECT_EQ(r.flippedBoundaryTriangles, 0);
  EXPECT_EQ(flippedCubeTriangles(r.U, c.faces), 0);
  EXPECT_EQ(r.flippedSphereTriangles, 0);
  for (Eigen::Index v = 0; v < r.U.rows(); ++v) {
    for (int d = 0; d < 3; ++d) {
      if ((c.locks[v] >> d) & 1) {
        EXPECT_EQ(r.U(v, d), c.U(v, d)) << "vertex " << v << " coordinate " << d;  // bitwise
      }
      EXPECT_GE(r.U(v, d), 0);
      EXPECT_LE(r.U(v, d), 1);
    }
    if (c.locks[v] == 7) {
      EXPECT_EQ(r.U.row(v), c.mesh.V.row(v));  // corners never move
    }
  }
}

// keepInteriorInCube: interior vertices pushed out through a face come back
// in and stay in the cube (a bijection onto it has every interior vertex inside).
TEST_P(UntangleCubeMethods, InteriorVerticesEndInsideTheCube) {
  CubeCase c = tangledCube(6);
  int pushed = 0;
  for (Eigen::Index v = 0; v < c.U.rows(); ++v)
    if (c.locks[v] == 0 && c.U(v, 2) < 0.25 && v % 2 == 0) c.U(v, 2) = -0.05, ++pushed;
  ASSERT_GT(pushed, 2);
  const std::vector<bool> none(static_cast<size_t>(c.U.rows()), false);
  UntangleOptions o = cubeOptions(c, GetParam());
  o.keepInteriorInCube = true;
  const UntangleResult r = untangle(c.mesh.V, c.mesh.T, c.U, none, o);
  EXPECT_TRUE(r.status.ok) << r.status.message;
  EXPECT_EQ(countNonPositiveTets(r.U, c.mesh.T), 0);
  EXPECT_EQ(flippedCubeTriangles(r.U, c.faces), 0);
  for (Eigen::Index v = 0; v < r.U.rows(); ++v)
    for (int d = 0; d < 3; ++d) {
      EXPECT_GE(r.U(v, d), 0) << "vertex " << v;
      EXPECT_LE(r.U(v, d), 1) << "vertex " << v;
    }
}

// A face vertex that starts on the wrong side of a cube edge: on the grid,
// the vertex of face x = 1 next to the edge x = z = 1 is put on face z = 1,
// mirrored across the edge, so its triangles are flipped. Locked to face
// z = 1 it can at best reach the edge (flat cones); crossing it untangles.
TEST_P(UntangleCubeMethods, AVertexOnTheWrongFaceCrossesTheEdge) {
  const int n = 4;
  CubeCase c = tangledCube(n);
  c.U = c.mesh.V;
  const double h = 1.0 / n;
  Eigen::Index moved = -1;
  for (Eigen::Index v = 0; v < c.U.rows() && moved < 0; ++v)
    if (c.locks[v] == 1 && c.U(v, 0) == 1 && std::abs(c.U(v, 2) - (1 - h)) < 1e-12 && c.U(v, 1) > 0 && c.U(v, 1) < 1)
      moved = v;
  ASSERT_GE(moved, 0);
  c.U(moved, 0) = 1 - h;
  c.U(moved, 2) = 1;
  c.locks[moved] = 4;
  ASSERT_GT(flippedCubeTriangles(c.U, c.faces), 0);
  UntangleOptions o = cubeOptions(c, GetParam());
  const std::vector<bool> none(static_cast<size_t>(c.U.rows()), false);
  const UntangleResult locked = untangle(c.mesh.V, c.mesh.T, c.U, none, o);
  EXPECT_GT(locked.invertedAfter + locked.flippedBoundaryTriangles, 0) << "the locked vertex could be repaired";
  o.cubeAcrossEdges = true;
  const UntangleResult r = untangle(c.mesh.V, c.mesh.T, c.U, none, o);
  EXPECT_TRUE(r.status.ok) << r.status.message;
  EXPECT_EQ(countNonPositiveTets(r.U, c.mesh.T), 0);
  EXPECT_EQ(flippedCubeTriangles(r.U, c.faces), 0);
  EXPECT_EQ(r.U(moved, 0), 1) << r.U.row(moved);  // back on face x = 1, exactly
  EXPECT_LT(r.U(moved, 2), 1);
  for (Eigen::Index v = 0; v < r.U.rows(); ++v) {
    if (c.locks[v] == 0) continue;
    int onFace = 0;
    for (int d = 0; d < 3; ++d) {
      EXPECT_GE(r.U(v, d), 0);
      EXPECT_LE(r.U(v, d), 1);
      onFace += r.U(v, d) == 0 || r.U(v, d) == 1;
    }
    EXPECT_GE(onFace, 1) << "boundary vertex " << v << " left the cube's surface: " << r.U.row(v);
    if (__builtin_popcount(c.locks[v]) >= 2) {  // edges and corners keep their locks
      for (int d = 0; d < 3; ++d)
        if ((c.locks[v] >> d) & 1) {
          EXPECT_EQ(r.U(v, d), c.U(v, d));
        }
    }
  }
}

TEST(UntangleCube, LocksDefaultToTheCoordinatesOnAFace) {
  const CubeCase c = tangledCube(5);
  UntangleOptions o;
  o.cubeFaces = c.faces;  // no cubeLocks: derived from the 0/1 coordinates
  const UntangleResult r = untangle(c.mesh.V, c.mesh.T, c.U, std::vector<bool>(static_cast<size_t>(c.U.rows()), false), o);
  EXPECT_EQ(r.invertedAfter, 0) << r.status.message;
  EXPECT_EQ(r.flippedBoundaryTriangles, 0);
  for (Eigen::Index v = 0; v < r.U.rows(); ++v)
    for (int d = 0; d < 3; ++d)
      if ((c.locks[v] >> d) & 1) {
        EXPECT_EQ(r.U(v, d), c.U(v, d));
      }
}

TEST(UntangleCube, RejectsSphereAndCubeTogetherAndUnlockedFaceVertices) {
  const CubeCase c = tangledCube(2);
  const std::vector<bool> none(static_cast<size_t>(c.U.rows()), false);
  UntangleOptions both;
  both.cubeFaces = c.faces;
  both.sphereFaces = c.faces;
  try {
    untangle(c.mesh.V, c.mesh.T, c.U, none, both);
    FAIL() << "expected Error(Usage)";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::Usage);
  }
  UntangleOptions unlocked;
  unlocked.cubeFaces = c.faces;
  unlocked.cubeLocks.assign(static_cast<size_t>(c.U.rows()), 0);
  Eigen::MatrixX3d tangled = c.U;
  tangled.row(c.faces(0, 0)) = Eigen::RowVector3d(0.5, 0.5, 0.5);  // an inversion, so the options are read
  try {
    untangle(c.mesh.V, c.mesh.T, tangled, none, unlocked);
    FAIL() << "expected Error(Input)";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::Input);
  }
}

TEST(UntangleCube, BoundaryHeldAwayFromFlippedTrianglesIsEnough) {
  // The composition's final untangling: the boundary stays where the
  // placement put it, except around the triangles that came out flipped.
  CubeCase c = tangledCube(8);
  const Eigen::Vector3d centre(0.5, 0.5, 0.5);
  const int flipped = flippedCubeTriangles(c.U, c.faces);
  ASSERT_GT(flipped, 0);
  UntangleOptions o;
  o.cubeFaces = c.faces;
  o.cubeLocks = c.locks;
  // Everything on the boundary held: a flipped triangle keeps its tet inverted.
  std::vector<bool> all(static_cast<size_t>(c.U.rows()), false);
  for (Eigen::Index f = 0; f < c.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) all[static_cast<size_t>(c.faces(f, k))] = true;
  const UntangleResult stuck = untangle(c.mesh.V, c.mesh.T, c.U, all, o);
  EXPECT_FALSE(stuck.status.ok);
  EXPECT_GT(stuck.flippedBoundaryTriangles, 0);

  const std::vector<bool> held = holdBoundaryAwayFromFlips(c.U, c.faces, centre, 1);
  ASSERT_EQ(held.size(), static_cast<size_t>(c.U.rows()));
  int heldCount = 0, boundaryCount = 0;
  for (Eigen::Index v = 0; v < c.U.rows(); ++v) {
    heldCount += held[static_cast<size_t>(v)];
    boundaryCount += all[static_cast<size_t>(v)];
    if (c.locks[v] == 0) {
      EXPECT_FALSE(held[static_cast<size_t>(v)]) << "interior vertex " << v;
    }
  }
  for (Eigen::Index f = 0; f < c.faces.rows(); ++f) {
    const Eigen::Vector3d a = c.U.row(c.faces(f, 0)), b = c.U.row(c.faces(f, 1)), d = c.U.row(c.faces(f, 2));
    if (orient3d(centre.data(), a.data(), b.data(), d.data()) <= 0) {
      for (int k = 0; k < 3; ++k) EXPECT_FALSE(held[static_cast<size_t>(c.faces(f, k))]);
    }
  }
  EXPECT_GT(heldCount, 0);
  EXPECT_LT(heldCount, boundaryCount);
  const UntangleResult r = untangle(c.mesh.V, c.mesh.T, c.U, held, o);
  EXPECT_TRUE(r.status.ok) << r.status.message;
  EXPECT_EQ(countNonPositiveTets(r.U, c.mesh.T), 0);
  EXPECT_EQ(flippedCubeTriangles(r.U, c.faces), 0);
  for (Eigen::Index v = 0; v < r.U.rows(); ++v)
    if (held[static_cast<size_t>(v)]) {
      EXPECT_EQ(r.U.row(v), c.U.row(v)) << "held vertex " << v;  // bitwise
    }
  // No rings: only the flipped triangles' own vertices are released.
  const std::vector<bool> tight = holdBoundaryAwayFromFlips(c.U, c.faces, centre, 0);
  int tightCount = 0;
  for (bool h : tight) tightCount += h;
  EXPECT_GT(tightCount, heldCount);
  EXPECT_THROW(holdBoundaryAwayFromFlips(c.U.topRows(3), c.faces, centre, 1), Error);
}

// ---- Projected Newton: the energy's derivatives and sliding on the sphere ----

#include "../../param/src/untangle_energy.h"

// The energy's own cube root: within an ulp of the library's (the same bits
// on glibc 2.36, where it is glibc's algorithm), cubing back to x, and the
// library's answer where it hands over (zeros, subnormals, inf, NaN).
TEST(UntangleEnergy, CubeRootMatchesTheLibrary) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> exponent(-300, 300), mantissa(1, 10);
  int same = 0;
  const int n = 1000000;
  for (int i = 0; i < n; ++i) {
    const double x = (i % 2 ? -1 : 1) * mantissa(rng) * std::pow(10.0, exponent(rng));
    const double mine = detail::cubeRoot(x), library = std::cbrt(x);
    ASSERT_LE(std::abs(mine - library), std::abs(std::nextafter(library, 0.0) - library)) << x;
    ASSERT_NEAR(mine * mine * mine / x, 1.0, 4e-15) << x;  // (an ulp of the root, three times, and the roundings)
    same += mine == library;
  }
  RecordProperty("same_as_library", same);
  // (volatile: the compiler folds std::cbrt of a constant, correctly
  // rounded, where glibc 2.36's cbrt(27) is 3 + 4·10⁻¹⁶, as is cubeRoot's;
  // a correctly rounded library would differ there by that ulp)
  for (const double c : {0.0, -0.0, 1e-310, -4e-320, std::numeric_limits<double>::infinity(),
                         -std::numeric_limits<double>::infinity()}) {
    const volatile double x = c;
    EXPECT_EQ(detail::cubeRoot(x), std::cbrt(x)) << c;
    EXPECT_EQ(std::signbit(detail::cubeRoot(x)), std::signbit(c)) << c;
  }
  EXPECT_TRUE(std::isnan(detail::cubeRoot(std::numeric_limits<double>::quiet_NaN())));
  EXPECT_NEAR(detail::cubeRoot(27.0), 3.0, 1e-15);
}

// The Jacobian from the reference barycentric gradients maps every reference
// edge from vertex 0 onto the mapped one (on a real tet mesh, the positions
// a random affine map plus noise), and the energy's gradient, in scalars,
// is the closed form (1 − θ)(2J/χ^(2/3) − (2/3) f χ'/χ K) + θ K (2D − h χ')/χ
// written with matrices, over both signs of det J and barriers from 1e-9.
TEST(UntangleEnergy, JacobianMapsTheEdgesAndTheGradientIsTheClosedForm) {
  const TetMesh m = t2stest::ballGrid(4);
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::Matrix3d A;
  for (int i = 0; i < 9; ++i) A.data()[i] = u(rng);
  int negative = 0, positive = 0;
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> W(2 * m.V.rows(), 3);  // two maps, the second reflected
  for (Eigen::Index v = 0; v < m.V.rows(); ++v) {
    W.row(v) = (A * m.V.row(v).transpose()).transpose() + 0.05 * Eigen::RowVector3d(u(rng), u(rng), u(rng));
    W.row(m.V.rows() + v) = -W.row(v);
  }
  for (Eigen::Index t = 0; t < 2 * m.T.rows(); ++t) {
    const Eigen::Index shift = t < m.T.rows() ? 0 : m.V.rows();
    std::array<int, 4> v;
    for (int k = 0; k < 4; ++k) v[k] = static_cast<int>(m.T(t % m.T.rows(), k) + shift);
    Eigen::Matrix3d E;  // reference edges from vertex 0, as columns
    for (int k = 1; k < 4; ++k) E.col(k - 1) = (m.V.row(v[k] - shift) - m.V.row(v[0] - shift)).transpose();
    const Eigen::Matrix3d Einv = E.inverse();
    Eigen::Matrix<double, 3, 4> G;
    for (int k = 1; k < 4; ++k) G.col(k) = Einv.row(k - 1).transpose();
    G.col(0) = -(G.col(1) + G.col(2) + G.col(3));
    const Eigen::Matrix3d J = detail::tetJacobian(W, v, G);
    for (int k = 1; k < 4; ++k) {
      const Eigen::Vector3d mapped = (W.row(v[k]) - W.row(v[0])).transpose();
      ASSERT_LT((J * E.col(k - 1) - mapped).norm(), 1e-12 * (1 + mapped.norm())) << "tet " << t;
    }
    const double D = J.determinant();
    negative += D < 0, positive += D > 0;
    for (double eps : {1e-9, 1e-3, 0.5})
      for (double theta : {0.0, 0.5}) {
        Eigen::Matrix3d dJ;
        const double e = detail::untangleEnergy(J, eps, theta, &dJ);
        const double chi = detail::untangleChi(eps, D), chi1 = 0.5 + 0.5 * D / std::sqrt(eps * eps + D * D);
        const double f = J.squaredNorm() / std::pow(chi, 2.0 / 3), h = (1 + D * D) / chi;
        EXPECT_NEAR(e, (1 - theta) * f + theta * h, 1e-12 * std::abs(e));
        const Eigen::Matrix3d K = D * J.inverse().transpose();  // the cofactor matrix
        const Eigen::Matrix3d closed = (1 - theta) * (2 * J / std::pow(chi, 2.0 / 3) - 2.0 / 3 * f * chi1 / chi * K) +
                                       theta * K * (2 * D - h * chi1) / chi;
        EXPECT_LT((dJ - closed).cwiseAbs().maxCoeff(), 1e-9 * (1 + closed.cwiseAbs().maxCoeff()))
            << "tet " << t << " eps " << eps << " theta " << theta;
      }
  }
  EXPECT_GT(negative, 0);
  EXPECT_GT(positive, 0);
}

TEST(UntangleEnergy, GradientAndHessianMatchFiniteDifferences) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  int checked = 0;
  for (int trial = 0; trial < 40; ++trial) {
    Eigen::Matrix3d J;
    for (int i = 0; i < 9; ++i) J(i / 3, i % 3) = u(rng);
    if (trial % 2 == 0) J += 1.5 * Eigen::Matrix3d::Identity();  // both signs of det J
    const double eps = trial % 3 == 0 ? 1e-1 : 0.5, theta = trial % 4 == 0 ? 0.999 : 0.5;
    Eigen::Matrix3d dJ;
    detail::Matrix9d H;
    const double e = detail::untangleEnergy(J, eps, theta, &dJ, &H);
    ASSERT_TRUE(std::isfinite(e));
    EXPECT_LT((H - H.transpose()).norm(), 1e-12 * (1 + H.norm()));
    const double h = 1e-6;
    for (int i = 0; i < 9; ++i) {
      Eigen::Matrix3d Jp = J, Jm = J;
      Jp(i / 3, i % 3) += h, Jm(i / 3, i % 3) -= h;
      Eigen::Matrix3d gp, gm;
      const double ep = detail::untangleEnergy(Jp, eps, theta, &gp), em = detail::untangleEnergy(Jm, eps, theta, &gm);
      const double scale = 1 + dJ.cwiseAbs().maxCoeff();
      EXPECT_NEAR((ep - em) / (2 * h), dJ(i / 3, i % 3), 1e-5 * scale) << "trial " << trial << " entry " << i;
      const Eigen::Matrix3d column = (gp - gm) / (2 * h);
      const double hscale = 1 + H.cwiseAbs().maxCoeff();
      for (int j = 0; j < 9; ++j) EXPECT_NEAR(column(j / 3, j % 3), H(j, i), 1e-5 * hscale) << "trial " << trial;
    }
    ++checked;
  }
  EXPECT_EQ(checked, 40);
}

TEST(UntangleEnergy, ProjectionGivesTheNearestPsdMatrix) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  detail::Matrix9d A;
  for (int i = 0; i < 81; ++i) A(i / 9, i % 9) = u(rng);
  A = (A + A.transpose()).eval();
  Eigen::SelfAdjointEigenSolver<detail::Matrix9d> before(A);
  ASSERT_LT(before.eigenvalues().minCoeff(), 0);
  detail::Matrix9d P = A;
  detail::projectToPsd(P);
  Eigen::SelfAdjointEigenSolver<detail::Matrix9d> after(P);
  EXPECT_GT(after.eigenvalues().minCoeff(), -1e-12);
  // The positive part is kept: A − P is negative semi-definite and P (A − P) = 0.
  Eigen::SelfAdjointEigenSolver<detail::Matrix9d> diff(A - P);
  EXPECT_LT(diff.eigenvalues().maxCoeff(), 1e-12);
  EXPECT_LT((P * (A - P)).norm(), 1e-10);
  // A positive definite matrix is left bitwise as it is.
  detail::Matrix9d S = A * A.transpose() + detail::Matrix9d::Identity(), S0 = S;
  detail::projectToPsd(S);
  EXPECT_EQ(S, S0);
}

TEST(UntangleEnergy, AnalyticEigensystemGivesTheProjectedHessian) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1, 1);
  int indefinite = 0, inverted = 0;
  for (int trial = 0; trial < 200; ++trial) {
    Eigen::Matrix3d J;
    for (int i = 0; i < 9; ++i) J(i / 3, i % 3) = u(rng);
    if (trial % 2 == 0) J += 1.2 * Eigen::Matrix3d::Identity();
    if (trial % 7 == 0) J.row(2) = J.row(0) + 1e-9 * J.row(1);  // nearly flat
    const double eps = trial % 3 == 0 ? 1e-3 : 0.3, theta = trial % 4 == 0 ? 0.999 : 0.5;
    detail::Matrix9d H;
    detail::untangleEnergy(J, eps, theta, nullptr, &H);
    Eigen::SelfAdjointEigenSolver<detail::Matrix9d> eig(H);
    indefinite += eig.eigenvalues().minCoeff() < 0;
    inverted += J.determinant() < 0;
    detail::Matrix9d P = H;
    detail::projectToPsd(P);
    const detail::Matrix9d A = detail::untangleHessianProjected(J, eps, theta);
    EXPECT_LT((A - P).norm(), 1e-9 * (1 + H.norm())) << "trial " << trial << " det " << J.determinant();
  }
  EXPECT_GT(indefinite, 50);  // the projection had work to do
  EXPECT_GT(inverted, 20);
}

TEST_P(UntangleMethods, BoundarySlidesOnTheSphereAndNothingFlips) {
  const TetMesh m = t2stest::ballGrid(6);
  const Eigen::MatrixX3i faces = boundaryFaces(m);
  const std::vector<bool> onSphere = onFaces(faces, m.V.rows());
  Eigen::MatrixX3d U = m.V;
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> jitter(-0.3, 0.3);  // edges about 1/3 on the sphere
  for (Eigen::Index v = 0; v < U.rows(); ++v) {
    if (v % 3 != 0) continue;
    for (int d = 0; d < 3; ++d) U(v, d) += jitter(rng);
    if (onSphere[static_cast<size_t>(v)]) U.row(v).normalize();
  }
  const int flippedBefore = countFlippedTriangles(U, faces, Eigen::Vector3d::Zero());
  ASSERT_GT(flippedBefore, 0);
  ASSERT_GT(countNonPositiveTets(U, m.T), 0);
  UntangleOptions o;
  o.method = GetParam();
  o.sphereFaces = faces;
  const UntangleResult r = untangle(m.V, m.T, U, std::vector<bool>(static_cast<size_t>(U.rows()), false), o);
  EXPECT_TRUE(r.status.ok) << r.status.message;
  EXPECT_EQ(countNonPositiveTets(r.U, m.T), 0);
  EXPECT_EQ(r.flippedSphereTriangles, 0);
  for (Eigen::Index v = 0; v < U.rows(); ++v)
    if (onSphere[static_cast<size_t>(v)]) {
      EXPECT_NEAR(r.U.row(v).norm(), 1, 1e-14);
    }
  if (GetParam() == UntangleMethod::Newton) {
    EXPECT_GT(r.newtonIterations, 0);
    EXPECT_EQ(r.lbfgsIterations, 0);
  }
}

// ---- Local max-min repair (the last resort after the energy) ----

// A cube grid's positions with every `every`-th interior vertex pushed by up
// to `amplitude` in each coordinate (seeded); returns how many moved.
int pushInteriorVertices(Eigen::MatrixX3d& U, const std::vector<bool>& fixed, unsigned seed, double amplitude,
                         int every) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> jitter(-amplitude, amplitude);
  int pushed = 0;
  for (Eigen::Index v = 0; v < U.rows(); ++v)
    if (!fixed[v] && v % every == 0) {
      for (int d = 0; d < 3; ++d) U(v, d) += jitter(rng);
      ++pushed;
    }
  return pushed;
}

// With the energy switched off (no ε rounds), the local max-min moves alone
// repair interior vertices pushed through their neighbours; without them the
// same input stays tangled. Fixed vertices keep their bits.
TEST(UntangleLocalRepair, MaxMinMovesRepairInteriorVertices) {
  const TetMesh m = t2stest::cubeGrid(6);
  const auto fixed = boundaryMask(m);
  Eigen::MatrixX3d U = m.V;
  const int pushed = pushInteriorVertices(U, fixed, 5, 0.25, 5);  // (cell size 1/3)
  const int before = countNonPositiveTets(U, m.T);
  ASSERT_GT(pushed, 5);
  ASSERT_GT(before, 10);
  UntangleOptions off;
  off.maxOuterIterations = 0;
  off.localRepairSweeps = 0;
  EXPECT_EQ(untangle(m.V, m.T, U, fixed, off).invertedAfter, before);
  UntangleOptions repair = off;
  repair.localRepairSweeps = 100;
  const UntangleResult r = untangle(m.V, m.T, U, fixed, repair);
  EXPECT_EQ(r.invertedAfter, 0) << r.status.message;
  EXPECT_EQ(countNonPositiveTets(r.U, m.T), 0);
  EXPECT_TRUE(r.status.ok);
  for (Eigen::Index v = 0; v < U.rows(); ++v)
    if (fixed[v]) {
      EXPECT_EQ(r.U.row(v), U.row(v));
    }
}

// A sweep moves the vertices of one colour (no two of a tet) at once on the
// cores: on one thread the repair must give the same bits. Many vertices
// pushed through their neighbours, so that the colours hold many each.
TEST(UntangleLocalRepair, MaxMinMovesGiveTheSameBitsOnOneThread) {
  const TetMesh m = t2stest::cubeGrid(14);
  const auto fixed = boundaryMask(m);
  Eigen::MatrixX3d U = m.V;
  pushInteriorVertices(U, fixed, 7, 0.08, 3);  // (cell size 1/7)
  const int before = countNonPositiveTets(U, m.T);
  ASSERT_GT(before, 200);
  UntangleOptions o;
  o.maxOuterIterations = 0;
  o.localRepairSweeps = 20;
  o.localRepairFraction = 1;
  const UntangleResult r = untangle(m.V, m.T, U, fixed, o);
  UntangleResult single;
  {
    tbb::global_control oneThread(tbb::global_control::max_allowed_parallelism, 1);
    single = untangle(m.V, m.T, U, fixed, o);
  }
  EXPECT_LT(r.invertedAfter, before / 4);
  EXPECT_EQ(single.invertedAfter, r.invertedAfter);
  ASSERT_EQ(single.U.rows(), r.U.rows());
  for (Eigen::Index i = 0; i < r.U.size(); ++i)
    ASSERT_EQ(std::memcmp(&single.U.data()[i], &r.U.data()[i], sizeof(double)), 0) << "coordinate " << i;
}

// Vertex rings (over the tets' edges) from the vertices of the tets not
// positive in U (exactly, as countNonPositiveTets and the untangler test
// them): 0 on those, -1 where none reaches.
std::vector<int> ringsFromInverted(const TetMesh& m, const Eigen::MatrixX3d& U) {
  std::vector<int> ring(static_cast<size_t>(m.V.rows()), -1);
  std::vector<int> front;
  for (Eigen::Index t = 0; t < m.T.rows(); ++t) {
    const Eigen::Vector3d a = U.row(m.T(t, 0)), b = U.row(m.T(t, 1)), c = U.row(m.T(t, 2)), d = U.row(m.T(t, 3));
    if (orient3d(a.data(), b.data(), c.data(), d.data()) > 0) continue;
    for (int k = 0; k < 4; ++k)
      if (ring[static_cast<size_t>(m.T(t, k))] < 0) ring[static_cast<size_t>(m.T(t, k))] = 0, front.push_back(m.T(t, k));
  }
  for (int r = 1; !front.empty(); ++r) {
    std::vector<int> next;
    for (Eigen::Index t = 0; t < m.T.rows(); ++t) {
      bool touches = false;
      for (int k = 0; k < 4; ++k) touches = touches || ring[static_cast<size_t>(m.T(t, k))] == r - 1;
      if (!touches) continue;
      for (int k = 0; k < 4; ++k)
        if (ring[static_cast<size_t>(m.T(t, k))] < 0) ring[static_cast<size_t>(m.T(t, k))] = r, next.push_back(m.T(t, k));
    }
    front.swap(next);
  }
  return ring;
}

// localRepairFewTets: with that many or fewer tets inverted, the sweeps widen
// to one ring around them at most. Around a folded boundary face (held, so
// no move repairs it) in a jittered grid, the default repair widens to four
// rings and moves vertices up to there; the narrow one keeps every vertex
// more than two rings from the tets inverted at the start, and both still
// repair what moves can repair (an interior vertex pushed through its
// neighbours), so both results are kept.
TEST(UntangleLocalRepair, FewTetsWidenTheRepairToOneRingOnly) {
  const int n = 10, s = n + 1;
  const TetMesh m = t2stest::cubeGrid(n);
  const auto fixed = boundaryMask(m);
  Eigen::MatrixX3d U = m.V;
  pushInteriorVertices(U, fixed, 11, 0.35 / n, 1);  // (every interior vertex, within 0.175 of a cell)
  ASSERT_EQ(countNonPositiveTets(U, m.T), 0);
  U.row(0 + s * (5 + s * 5)).swap(U.row(0 + s * (6 + s * 5)));  // fold the face x = -1
  U(8 + s * (5 + s * 5), 0) += 1.5 * 2.0 / n;                   // and push a vertex near x = 1 through its neighbour
  const int before = countNonPositiveTets(U, m.T);
  const std::vector<int> ring = ringsFromInverted(m, U);
  UntangleOptions wide;
  wide.maxOuterIterations = 0;
  wide.localRepairSweeps = 100;
  UntangleOptions narrow = wide;
  narrow.localRepairFewTets = 100;
  int farthest[2] = {-1, -1}, after[2] = {0, 0};
  for (int run = 0; run < 2; ++run) {
    const UntangleResult r = untangle(m.V, m.T, U, fixed, run == 0 ? wide : narrow);
    after[run] = r.invertedAfter;
    for (Eigen::Index v = 0; v < U.rows(); ++v)
      if (r.U.row(v) != U.row(v)) farthest[run] = std::max(farthest[run], ring[static_cast<size_t>(v)]);
  }
  EXPECT_LT(after[0], before);
  EXPECT_LT(after[1], before);
  EXPECT_GT(farthest[0], 2);  // (4 here)
  EXPECT_GE(farthest[1], 0);
  EXPECT_LE(farthest[1], 2);
}

// On the cube, face vertices move only within their face: the locked
// coordinate keeps its bits, the others stay in [0, 1], and no boundary
// triangle is left flipped.
TEST(UntangleLocalRepair, MaxMinMovesKeepFaceVerticesOnTheirFaces) {
  CubeCase c = tangledCube(5);
  const int before = countNonPositiveTets(c.U, c.mesh.T) + flippedCubeTriangles(c.U, c.faces);
  ASSERT_GT(before, 10);
  UntangleOptions o = cubeOptions(c, UntangleMethod::Lbfgs);
  o.maxOuterIterations = 0;
  o.localRepairSweeps = 0;
  const UntangleResult none = untangle(c.mesh.V, c.mesh.T, c.U, std::vector<bool>(c.U.rows(), false), o);
  EXPECT_GT(none.invertedAfter + none.flippedBoundaryTriangles, 0);
  o.localRepairSweeps = 100;
  const UntangleResult r = untangle(c.mesh.V, c.mesh.T, c.U, std::vector<bool>(c.U.rows(), false), o);
  EXPECT_EQ(r.invertedAfter, 0) << r.status.message;
  EXPECT_EQ(flippedCubeTriangles(r.U, c.faces), 0);
  for (Eigen::Index v = 0; v < c.U.rows(); ++v)
    for (int d = 0; d < 3; ++d) {
      if ((c.locks[v] >> d) & 1) {
        EXPECT_EQ(r.U(v, d), c.U(v, d));
      } else {
        EXPECT_GE(r.U(v, d), 0.0);
        EXPECT_LE(r.U(v, d), 1.0);
      }
    }
}

// On the sphere, flipped boundary triangles involve only sphere vertices
// (their cones have the centre as apex), so no interior move repairs them:
// the local repair's second pass slides the sphere vertices (tangent moves,
// projected back onto the sphere) and repairs them with the energy off.
// The case: the sphere vertex at the middle of a grid face pulled along the
// sphere across the edge opposite it in one of its triangles, folding the
// triangles around it. (Pulled past a neighbouring vertex instead, its way
// back goes through that vertex: max-min moves, which never let the worst
// volume fall, then shrink the folded tets towards zero volume instead.)
TEST(UntangleLocalRepair, MaxMinMovesSlideSphereVertices) {
  const TetMesh m = t2stest::ballGrid(6);
  const Eigen::MatrixX3i faces = boundaryFaces(m);
  const std::vector<bool> onSphere = onFaces(faces, m.V.rows());
  Eigen::Index top = 0;  // the vertex at (0, 0, 1)
  for (Eigen::Index v = 0; v < m.V.rows(); ++v)
    if ((m.V.row(v) - Eigen::RowVector3d(0, 0, 1)).norm() < (m.V.row(top) - Eigen::RowVector3d(0, 0, 1)).norm()) top = v;
  ASSERT_LT((m.V.row(top) - Eigen::RowVector3d(0, 0, 1)).norm(), 1e-12);
  Eigen::RowVector3d across = Eigen::RowVector3d::Zero();  // the middle of the edge opposite it in a triangle
  for (Eigen::Index f = 0; f < faces.rows() && across.isZero(); ++f)
    for (int k = 0; k < 3; ++k)
      if (faces(f, k) == top) across = 0.5 * (m.V.row(faces(f, (k + 1) % 3)) + m.V.row(faces(f, (k + 2) % 3)));
  ASSERT_FALSE(across.isZero());
  Eigen::MatrixX3d U = m.V;
  U.row(top) = (m.V.row(top) + 1.3 * (across - m.V.row(top))).normalized();
  const int flippedBefore = countFlippedTriangles(U, faces, Eigen::Vector3d::Zero());
  ASSERT_GT(flippedBefore, 0);
  UntangleOptions o;
  o.sphereFaces = faces;
  o.maxOuterIterations = 0;
  o.localRepairSweeps = 0;
  const std::vector<bool> none(static_cast<size_t>(U.rows()), false);
  EXPECT_EQ(untangle(m.V, m.T, U, none, o).flippedBoundaryTriangles, flippedBefore);
  o.localRepairSweeps = 100;
  const UntangleResult r = untangle(m.V, m.T, U, none, o);
  EXPECT_TRUE(r.status.ok) << r.status.message;
  EXPECT_EQ(countFlippedTriangles(r.U, faces, Eigen::Vector3d::Zero()), 0);
  EXPECT_EQ(countNonPositiveTets(r.U, m.T), 0);
  for (Eigen::Index v = 0; v < U.rows(); ++v)
    if (onSphere[static_cast<size_t>(v)]) {
      EXPECT_NEAR(r.U.row(v).norm(), 1, 1e-14);
    }
  EXPECT_NE(r.U.row(top), U.row(top));
}

// Joint moves of patches repair some of what single-vertex moves leave
// where each vertex's star blocks it: a 3×3×3 grid whose interior vertices
// are jittered by up to 1.2 cells, so tangled that the sweeps stall with
// 4–26 tets inverted. Over six such tangles the patches never leave more
// and leave fewer in all; fixed vertices keep their bits; counts are exact.
TEST(UntangleLocalRepair, PatchMovesRepairWhatSingleMovesLeave) {
  const TetMesh m = t2stest::cubeGrid(3);
  const auto fixed = boundaryMask(m);
  int leftBySingle = 0, leftByJoint = 0;
  for (int seed = 1; seed <= 6; ++seed) {
    Eigen::MatrixX3d U = m.V;
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> jitter(-0.8, 0.8);  // cell size 2/3
    for (Eigen::Index v = 0; v < U.rows(); ++v)
      if (!fixed[v])
        for (int d = 0; d < 3; ++d) U(v, d) += jitter(rng);
    UntangleOptions o;
    o.maxOuterIterations = 0;  // the local repair alone
    o.localRepairPatches = false;
    const UntangleResult single = untangle(m.V, m.T, U, fixed, o);
    o.localRepairPatches = true;
    const UntangleResult joint = untangle(m.V, m.T, U, fixed, o);
    EXPECT_LE(joint.invertedAfter, single.invertedAfter) << "seed " << seed;
    EXPECT_EQ(joint.invertedAfter, countNonPositiveTets(joint.U, m.T));
    leftBySingle += single.invertedAfter, leftByJoint += joint.invertedAfter;
    for (Eigen::Index v = 0; v < U.rows(); ++v)
      if (fixed[v]) {
        EXPECT_EQ(joint.U.row(v), U.row(v));
      }
  }
  ASSERT_GT(leftBySingle, 0) << "nothing left for the patches: the test means nothing";
  EXPECT_LT(leftByJoint, leftBySingle);
}
