// The ball map on the ten genus-0 test surfaces meshed by TetGen (quality
// 1.5), and on a solid with a filled void, after splitting boundary chords
// as the pipeline does (refine.h). Slow: run with the `slow` label.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <iostream>
#include <vector>

#include "cli_meshing.h"
#include "test_data.h"
#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/ball_map.h"
#include "tet2spline/param/parameterize.h"
#include "tet2spline/param/refine.h"
#include "tet2spline/param/spherical_map.h"
#include "tet2spline/param/tetrahedralize.h"
#include "tet2spline/param/topology.h"

using namespace tet2spline;

namespace {

void expectValidBallMap(const TetMesh& m, const BallMapResult& r, const std::string& name) {
  EXPECT_TRUE(r.status.ok) << name << ": " << r.status.message;
  EXPECT_EQ(r.sphere.flippedTriangles, 0) << name;
  EXPECT_EQ(r.ball.invertedTets, 0) << name;
  EXPECT_EQ(countNonPositiveTets(r.U, m.T), 0) << name;
  EXPECT_EQ(countFlippedSphereTriangles(r.U, r.boundaryFaces), 0) << name;
  EXPECT_LT(r.ball.harmonicResidual, 1e-8) << name;
  EXPECT_LT(r.boundaryMaxDistance, 1e-12) << name;
  EXPECT_LE(r.U.rowwise().norm().maxCoeff(), 1 + 1e-12) << name;
  std::cout << name << ": " << m.V.rows() << " vertices, " << m.T.rows() << " tets, sphere " << r.sphere.method
            << " distortion " << r.sphere.angleDistortionMean << "/" << r.sphere.angleDistortionMax << ", inverted "
            << r.ball.invertedTetsBeforeUntangling << " -> " << r.ball.invertedTets << (r.ball.boundarySlid ? " (slid)" : "")
            << ", seconds sphere " << r.timings.sphere << " harmonic " << r.timings.harmonic << " untangle "
            << r.timings.untangle << std::endl;
}

}  // namespace

class BallMapRealData : public ::testing::TestWithParam<const char*> {};

TEST_P(BallMapRealData, BijectiveOntoTheBall) {
  TetMesh m = tetrahedralize(readSurface(t2stest::cgalMesh(GetParam())), {}, GetParam());
  splitBoundaryChords(m);
  EXPECT_EQ(countBoundaryChords(m), 0);
  expectValidBallMap(m, mapToBall(m), GetParam());
}

INSTANTIATE_TEST_SUITE_P(Genus0, BallMapRealData,
                         ::testing::Values("blob-closed", "part", "spool", "hand", "blobby", "triceratops", "fandisk",
                                           "retinal", "homer", "bunny00"));

TEST(BallMapRealData, SolidWithAFilledVoid) {
  // blobby with a scaled, reversed copy of itself inside: the inner shell is a void.
  const SurfaceMesh outer = readSurface(t2stest::cgalMesh("blobby"));
  SurfaceMesh both = outer;
  const Eigen::RowVector3d c = outer.V.colwise().mean();
  both.V.resize(2 * outer.V.rows(), 3);
  both.V.topRows(outer.V.rows()) = outer.V;
  both.V.bottomRows(outer.V.rows()) = ((outer.V.rowwise() - c) * 0.3).rowwise() + c;
  both.F.resize(2 * outer.F.rows(), 3);
  both.F.topRows(outer.F.rows()) = outer.F;
  for (Eigen::Index f = 0; f < outer.F.rows(); ++f)
    both.F.row(outer.F.rows() + f) << outer.F(f, 0) + static_cast<int>(outer.V.rows()),
        outer.F(f, 2) + static_cast<int>(outer.V.rows()), outer.F(f, 1) + static_cast<int>(outer.V.rows());
  TetrahedralizeOptions o;
  o.voids = true;
  TetMesh m = tetrahedralize(both, o, "blobby with void");
  splitBoundaryChords(m);
  ASSERT_FALSE(m.voidRegions.empty());
  expectValidBallMap(m, mapToBall(m), "blobby with void");
}

// The ball map as the transport path computes it: the command line's
// meshing, the sphere made nearly equiareal (ParamOptions'
// sphereAreaCorrectionIterations), and the untangling's regions no longer
// grown once at most 64 tets stay put (parameterize() sets
// UntangleOptions::stallBelow so, kMaxSplitTets). With transport this map
// only places the transport's sites: its sphere must be bijective, every
// vertex in the closed ball, no two at one point, and at most those few
// tets inverted (parameterize reports them: ball.inverted_tets). It used to
// demand a bijective map on the exact input, which held by its last bits:
// at spool × (1 + 3·10⁻⁹) the energy and the local repair leave one tet,
// where the transport path goes on valid (ParamLastBits, the sweeps in the
// README). So over four inputs in their last bits (the surface scaled by
// 1 + k·10⁻⁹, k = 0..3).
class BallMapForTransport : public ::testing::TestWithParam<const char*> {};

TEST_P(BallMapForTransport, PlacesTheSitesOverTheInputsLastBits) {
  for (int k = 0; k <= 3; ++k) {
    const std::string name = std::string(GetParam()) + " x (1 + " + std::to_string(k) + "e-9)";
    TetMesh m = t2stest::cliMeshedCgalSurface(GetParam(), 1 + k * 1e-9);
    splitBoundaryChords(m);
    BallMapOptions o;
    o.sphere.areaCorrectionIterations = ParamOptions().sphereAreaCorrectionIterations;
    o.untangle.stallBelow = 64;
    const BallMapResult r = mapToBall(m, o);
    EXPECT_TRUE(r.status.ok || r.ball.invertedTets > 0) << name << ": " << r.status.message;
    EXPECT_EQ(r.sphere.flippedTriangles, 0) << name;
    EXPECT_EQ(countFlippedSphereTriangles(r.U, r.boundaryFaces), 0) << name;
    EXPECT_EQ(countNonPositiveTets(r.U, m.T), r.ball.invertedTets) << name;
    EXPECT_LE(r.ball.invertedTets, 64) << name;
    EXPECT_LT(r.ball.harmonicResidual, 1e-8) << name;
    EXPECT_LT(r.boundaryMaxDistance, 1e-12) << name;
    EXPECT_LE(r.U.rowwise().norm().maxCoeff(), 1 + 1e-12) << name;
    std::vector<std::array<double, 3>> points(static_cast<size_t>(r.U.rows()));
    for (Eigen::Index v = 0; v < r.U.rows(); ++v) points[static_cast<size_t>(v)] = {r.U(v, 0), r.U(v, 1), r.U(v, 2)};
    std::sort(points.begin(), points.end());
    EXPECT_EQ(std::adjacent_find(points.begin(), points.end()), points.end()) << name << ": two vertices at one point";
    std::cout << name << ": " << m.V.rows() << " vertices, inverted " << r.ball.invertedTetsBeforeUntangling << " -> "
              << r.ball.invertedTets << ", seconds sphere " << r.timings.sphere << " untangle " << r.timings.untangle
              << std::endl;
  }
}

INSTANTIATE_TEST_SUITE_P(Genus0, BallMapForTransport, ::testing::Values("hand", "spool"),
                         [](const auto& info) { return t2stest::testName(info.param); });
