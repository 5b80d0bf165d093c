// The param stage (issue 4) on real genus-0 surfaces of the test data, meshed
// as the command line meshes them (TetGen, quality 1.5, coplanar facets
// merged): converged transport, zero inverted tets, boundary exactly on ∂Ω,
// parametric volumes filling Ω. Slow: run with the `slow` label.
//
// Covered: blob-closed, part, fandisk on both domains; blobby, triceratops
// and retinal on the cube. triceratops needs both fixes of issue 4's
// earlier steps: its one cap flipped before TetGen (vertex volumes 3e-21 of
// the total otherwise) and the nearly equiareal sphere (its conformal sites
// failed the line search at Newton iteration 2; now 39 iterations). With the
// boundary held only away from flipped triangles in the final untangling:
// fandisk 13 s, retinal 20 s, triceratops 50 s in all. homer (109 s) passes
// the cube too and is left out to keep the suite short. spool passes when
// meshed with a 15° minimum dihedral angle (below); at the default meshing
// its final untangling leaves 6 tets inverted on the cube, and hand's 2195 on
// the ball and 2974 on the cube: there the barrier morph from the ball map
// (barrier_morph.h) gives the map (ParamMorphFallback below).
#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>
#include <string>
#include <tuple>

#include "param_checks.h"
#include "cli_meshing.h"
#include "test_data.h"
#include "tet2spline/io/cad_io.h"
#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/parameterize.h"
#include "tet2spline/param/tetrahedralize.h"
#include "tet2spline/param/topology.h"

using namespace tet2spline;

namespace {
// "cube" or "ball", for test names and log lines.
std::string domainName(ParamDomain domain) { return domain == ParamDomain::Cube ? "cube" : "ball"; }
}  // namespace

class ParamRealData : public ::testing::TestWithParam<std::tuple<const char*, ParamDomain>> {};

TEST_P(ParamRealData, ValidMeasurePreservingParameterization) {
  const auto [name, domain] = GetParam();
  const TetMesh mesh = t2stest::cliMeshedCgalSurface(name);
  ParamOptions o;
  o.domain = domain;
  const ParamResult r = parameterize(mesh, o);
  t2stest::expectValidParameterization(r, domain);
  // The tets fill Ω up to the boundary triangles: chords inside the sphere,
  // and on the cube triangles cutting across an edge. Measured on the coarsest
  // mesh (blob-closed, 655 vertices): 2.0% short of the ball, 3.7% of the cube.
  EXPECT_NEAR(r.parametricVolume.sum(), r.domainVolume, 0.05 * r.domainVolume) << name;
  EXPECT_GT(r.parametricVolume.minCoeff(), 0) << name;
  std::cout << name << " " << domainName(domain) << ": " << r.mesh.V.rows() << " vertices, "
            << r.mesh.T.rows() << " tets; OT " << r.ot.iterations << " iterations, error " << r.ot.maxRelativeMassError
            << "; inverted before final untangling " << r.param.invertedTetsBeforeUntangling << "; volume ratio p1/p50/p99 "
            << r.param.volumeRatio.p1 << "/" << r.param.volumeRatio.p50 << "/" << r.param.volumeRatio.p99 << "; seconds OT "
            << r.timings.transport << " final untangle " << r.timings.finalUntangle << " total " << r.timings.total
            << std::endl;
}

INSTANTIATE_TEST_SUITE_P(
    Genus0, ParamRealData,
    ::testing::Values(std::make_tuple("blob-closed", ParamDomain::Cube), std::make_tuple("part", ParamDomain::Cube),
                      std::make_tuple("fandisk", ParamDomain::Cube), std::make_tuple("blobby", ParamDomain::Cube),
                      std::make_tuple("triceratops", ParamDomain::Cube), std::make_tuple("retinal", ParamDomain::Cube),
                      std::make_tuple("blob-closed", ParamDomain::Ball), std::make_tuple("part", ParamDomain::Ball),
                      std::make_tuple("fandisk", ParamDomain::Ball)),
    [](const auto& info) {
      return t2stest::testName(std::get<0>(info.param)) + "_" + domainName(std::get<1>(info.param));
    });

// spool.off with TetGen's dihedral bound (tetrahedralize.h minDihedral): its
// ball map keeps no inverted tet, and on the cube the final untangling's
// last resort (face vertices crossing cube edges, untangle.h
// cubeAcrossEdges) repairs the tet that three vertices sliding onto one cube
// edge had left flat. On the ball, L-BFGS leaves 3 tets flat at the concave
// edge where a flange meets the core (one boundary vertex and three interior
// ones each); the projected Newton untangler (--untangler newton) repairs
// them, so the ball runs with it.
class ParamSpoolWithoutSlivers : public ::testing::TestWithParam<ParamDomain> {};

TEST_P(ParamSpoolWithoutSlivers, ValidMeasurePreservingParameterization) {
  const ParamDomain domain = GetParam();
  TetrahedralizeOptions meshing;
  meshing.exactBoundary = false;
  meshing.minDihedral = 15;
  const TetMesh mesh = tetrahedralize(readSurface(t2stest::cgalMesh("spool")), meshing, "spool");
  ParamOptions o;
  o.domain = domain;
  if (domain == ParamDomain::Ball) o.untangle.method = o.ballMap.untangle.method = UntangleMethod::Newton;
  const ParamResult r = parameterize(mesh, o);
  EXPECT_EQ(r.ball.invertedTets, 0);
  t2stest::expectValidParameterization(r, domain);
  EXPECT_NEAR(r.parametricVolume.sum(), r.domainVolume, 0.05 * r.domainVolume);
  std::cout << "spool (15 degrees)" << " " << domainName(domain) << ": " << r.mesh.V.rows()
            << " vertices; inverted before final untangling " << r.param.invertedTetsBeforeUntangling
            << "; volume ratio p1/p50/p99 " << r.param.volumeRatio.p1 << "/" << r.param.volumeRatio.p50 << "/"
            << r.param.volumeRatio.p99 << "; seconds final untangle " << r.timings.finalUntangle << " total "
            << r.timings.total << std::endl;
}

INSTANTIATE_TEST_SUITE_P(Domains, ParamSpoolWithoutSlivers, ::testing::Values(ParamDomain::Cube, ParamDomain::Ball),
                         [](const auto& info) { return domainName(info.param); });

// A solid with a void (models/block_with_void.step, meshed as `mesh --voids`
// meshes it: the void's inside filled and tagged), on both domains, with the
// void as any other region and at a tenth of the density: converged, zero
// inverted tets, boundary on ∂Ω, each region's parametric share within 0.5%
// (absolute) of its target. Measured: cube 2.7 s (as any region) and 8.4 s
// (a tenth), ball 2.4 and 7.3 s.
class ParamSolidWithVoid : public ::testing::TestWithParam<ParamDomain> {};

TEST_P(ParamSolidWithVoid, ValidWithTheVoidFilled) {
  const ParamDomain domain = GetParam();
  TetrahedralizeOptions meshing;
  meshing.exactBoundary = false;
  meshing.voids = true;
  const TetMesh mesh = tetrahedralize(readCadSurface(t2stest::sourceDir() + "/models/block_with_void.step"), meshing,
                                      "block_with_void.step");
  ASSERT_EQ(mesh.voidRegions.size(), 1u);
  for (const double voidDensity : {0.0, 0.1}) {
    ParamOptions o;
    o.domain = domain;
    o.measure.voidDensity = voidDensity;
    const ParamResult r = parameterize(mesh, o);
    t2stest::expectValidParameterization(r, domain);
    int voids = 0;
    for (const RegionFigures& g : r.regions) {
      EXPECT_NEAR(g.achievedVolumeFraction, g.targetVolumeFraction, 0.005) << "region " << g.id;
      voids += g.isVoid;
    }
    EXPECT_EQ(voids, 1);
    std::cout << "block_with_void" << " " << domainName(domain) << ", void density "
              << voidDensity << ": OT " << r.ot.iterations << " iterations; volume ratio p1/p50/p99 "
              << r.param.volumeRatio.p1 << "/" << r.param.volumeRatio.p50 << "/" << r.param.volumeRatio.p99
              << "; total " << r.timings.total << " s" << std::endl;
  }
}

INSTANTIATE_TEST_SUITE_P(Domains, ParamSolidWithVoid, ::testing::Values(ParamDomain::Cube, ParamDomain::Ball),
                         [](const auto& info) { return domainName(info.param); });

// Where the final untangling fails, the parameterization is the ball map
// morphed towards its result (ParamOptions::morphWhenTangled): spool at the
// default meshing on the cube (the ball map itself keeps one tet inverted,
// repaired for the start), hand on the ball. spool's last tets are now
// often finished by the finishing rounds and edge splits (parameterize.cpp;
// on one run 3 were left and the morph took them), so there the map may
// come from either; hand needs the morph today.
class ParamMorphFallback : public ::testing::TestWithParam<std::tuple<const char*, ParamDomain>> {};

TEST_P(ParamMorphFallback, ValidWhereTheUntanglingFails) {
  const auto [name, domain] = GetParam();
  const TetMesh mesh = t2stest::cliMeshedCgalSurface(name);
  ParamOptions o;
  o.domain = domain;
  const ParamResult r = parameterize(mesh, o);
  ASSERT_TRUE(r.status.ok) << name << ": " << r.status.message;
  if (domain == ParamDomain::Ball || r.param.morphed) {
    EXPECT_TRUE(r.param.morphed) << name;
    EXPECT_NE(std::find_if(r.warnings.begin(), r.warnings.end(),
                           [](const std::string& w) { return w.find("param.morph") != std::string::npos; }),
              r.warnings.end());
  } else {  // finished by the last resort: rounds after a spent budget or a stall, edge splits
    EXPECT_GT(r.param.finishingRounds + r.param.splitEdges, 0) << name;
  }
  t2stest::expectValidParameterization(r, domain);
  EXPECT_EQ(r.mesh.numVertices(), r.U.rows());
  EXPECT_EQ(r.mesh.numTets(), r.targetVolume.size());
  EXPECT_NEAR(r.parametricVolume.sum(), r.domainVolume, 0.05 * r.domainVolume) << name;
  EXPECT_GT(r.parametricVolume.minCoeff(), 0) << name;
  std::cout << name << (r.param.morphed ? " (morph)" : " (no morph)") << ", split edges " << r.param.splitEdges << ", " << name << " " << domainName(domain) << ": morph distance " << r.param.morphDistance
            << " target edges (max " << r.param.morphMaxDistance << "); volume ratio p1/p50/p99 " << r.param.volumeRatio.p1
            << "/" << r.param.volumeRatio.p50 << "/" << r.param.volumeRatio.p99 << "; seconds final untangle "
            << r.timings.finalUntangle << " morph " << r.timings.morph << " total " << r.timings.total << std::endl;
}

INSTANTIATE_TEST_SUITE_P(Genus0, ParamMorphFallback,
                         ::testing::Values(std::make_tuple("spool", ParamDomain::Cube),
                                           std::make_tuple("hand", ParamDomain::Ball)),
                         [](const auto& info) {
                           return t2stest::testName(std::get<0>(info.param)) +
                                  "_" + domainName(std::get<1>(info.param));
                         });

// The last bits of the input must not decide whether the map is valid: a
// surface scaled by 1 + k·10⁻⁹ before meshing, as a unit conversion would
// scale it. spool (creases of 90°) on the cube, whose final untangling ends
// with the fewest, most pinched tets, and hand's harmonic ball map alone
// (no transport). Measured before the every-edge splits and the ball map's
// splits (parameterize.cpp): spool at k = 3 ended with 2 tets inverted after
// the longest-edge splits and the morph (90 s), hand at k = 1 with 2 (the
// ball map had no splits); the others were valid.
struct LastBitsCase {
  const char* name;
  ParamDomain domain;
  bool transport;
  int k;
};

void PrintTo(const LastBitsCase& c, std::ostream* os) { *os << c.name << " k " << c.k; }

class ParamLastBits : public ::testing::TestWithParam<LastBitsCase> {};

TEST_P(ParamLastBits, ScaledByOnePlusKNanoIsValid) {
  const LastBitsCase c = GetParam();
  const TetMesh mesh = t2stest::cliMeshedCgalSurface(c.name, 1 + c.k * 1e-9);
  ParamOptions o;
  o.domain = c.domain;
  o.transport = c.transport;
  const ParamResult r = parameterize(mesh, o);
  ASSERT_TRUE(r.status.ok) << c.name << " k " << c.k << ": " << r.status.message;
  t2stest::expectValidParameterization(r, c.domain);
  EXPECT_GT(r.parametricVolume.minCoeff(), 0) << c.name;
  EXPECT_EQ(r.mesh.numVertices(), r.U.rows());
  EXPECT_EQ(countNonPositiveTets(r.mesh.V, r.mesh.T), 0) << c.name;  // (the splits keep the input's tets valid)
  std::cout << c.name << " x (1 + " << c.k << "e-9) " << domainName(c.domain) << (c.transport ? "" : " (no transport)")
            << ": split edges " << r.param.splitEdges << (r.param.morphed ? ", morph" : "") << ", volume ratio p1/p50/p99 "
            << r.param.volumeRatio.p1 << "/" << r.param.volumeRatio.p50 << "/" << r.param.volumeRatio.p99 << "; seconds "
            << r.timings.total << std::endl;
}

INSTANTIATE_TEST_SUITE_P(Genus0, ParamLastBits,
                         ::testing::Values(LastBitsCase{"spool", ParamDomain::Cube, true, 1},
                                           LastBitsCase{"spool", ParamDomain::Cube, true, 2},
                                           LastBitsCase{"spool", ParamDomain::Cube, true, 3},
                                           LastBitsCase{"hand", ParamDomain::Ball, false, 1},
                                           LastBitsCase{"hand", ParamDomain::Ball, false, 2}),
                         [](const auto& info) {
                           return t2stest::testName(info.param.name) + "_" + domainName(info.param.domain) +
                                  (info.param.transport ? "" : "_harmonic") + "_k" + std::to_string(info.param.k);
                         });

// The rule of ParamOptions::CubeSites::Auto on the boundaries the command
// line meshes: the smooth, curved meshes of the test data (bunny00,
// retinal, blobby) stay well inside it; the others have creases or sharp
// tips (normal angle p99 above smoothBoundaryDegrees, edges inside planar
// faces left out) or, the CAD solids, mostly planar faces (planarShare at
// 0.1°, patches of 1% or more, above planarBoundaryShare), fillets or not.
// Measured: blobby 23.5°, retinal 24.7°, bunny00 16.4°, all three with no
// planar patch; blob-closed 57.5°, homer 42.7°, triceratops 91.1°, fandisk
// 90.2°, part 101.2°, spool 106.9°, hand 107.4°; bracket.step 12.7° and
// 0.69 planar, block_with_void.step 13.8° and 0.64. 23 s (TetGen).
TEST(CubeSitesRule, SmoothCurvedMeshesAreTheOnlyOnesTakingTheEqualVolumeSites) {
  const ParamOptions defaults;
  auto measure = [](const TetMesh& mesh, const std::string& name) {
    const Eigen::MatrixX3i F = boundaryFaces(mesh);
    const double angle = normalAngleQuantile(mesh.V, F, 0.99, 0.1), planar = planarShare(mesh.V, F, 0.1, 0.01);
    std::cout << name << ": boundary normal angle p99 " << angle << "°, planar share " << planar << std::endl;
    return std::make_pair(angle, planar);
  };
  for (const char* name : {"blobby", "retinal", "bunny00"}) {
    const auto [angle, planar] = measure(t2stest::cliMeshedCgalSurface(name), name);
    EXPECT_LT(angle, defaults.smoothBoundaryDegrees - 3) << name;
    EXPECT_LT(planar, defaults.planarBoundaryShare - 0.3) << name;
  }
  for (const char* name : {"blob-closed", "part", "spool", "hand", "triceratops", "fandisk", "homer"}) {
    const auto [angle, planar] = measure(t2stest::cliMeshedCgalSurface(name), name);
    EXPECT_GT(angle, defaults.smoothBoundaryDegrees + 10) << name;
  }
  TetrahedralizeOptions meshing;
  meshing.exactBoundary = false;
  for (const char* name : {"bracket.step", "block_with_void.step"}) {
    const TetMesh mesh = tetrahedralize(readCadSurface(t2stest::sourceDir() + "/models/" + name), meshing, name);
    const auto [angle, planar] = measure(mesh, name);
    EXPECT_LT(angle, defaults.smoothBoundaryDegrees) << name << " (filleted: smooth)";
    EXPECT_GT(planar, defaults.planarBoundaryShare + 0.1) << name;
  }
}
