// The param stage (issue 4) on real genus-0 surfaces of the test data, meshed
// as the command line meshes them (TetGen, quality 1.5, coplanar facets
// merged): converged transport, zero inverted tets, boundary exactly on ∂Ω,
// parametric volumes filling Ω. Slow: run with the `slow` label.
//
// Covered: the meshes the stage passes today (retinal passes the cube too,
// in 82 s, left out to keep the suite short). Not yet: spool (cube: 2 tets
// stay inverted after the final untangling), triceratops (cube: the line
// search fails, the Voronoi start has cells of 1e-29 of their mass), hand
// (cube: inverted tets remain), homer and bunny00 (the harmonic map crushes
// protrusions to 1e-12 of their volume; the transport then takes 59 Newton
// iterations on bunny00). Those are the open part of issue 4.
#include <gtest/gtest.h>

#include <iostream>
#include <string>
#include <tuple>

#include "param_checks.h"
#include "test_data.h"
#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/parameterize.h"
#include "tet2spline/param/tetrahedralize.h"

using namespace tet2spline;

class ParamRealData : public ::testing::TestWithParam<std::tuple<const char*, ParamDomain>> {};

TEST_P(ParamRealData, ValidMeasurePreservingParameterization) {
  const auto [name, domain] = GetParam();
  TetrahedralizeOptions meshing;
  meshing.exactBoundary = false;  // the command line's default
  const TetMesh mesh = tetrahedralize(readSurface(t2stest::cgalMesh(name)), meshing, name);
  ParamOptions o;
  o.domain = domain;
  const ParamResult r = parameterize(mesh, o);
  t2stest::expectValidParameterization(r, domain);
  // The tets fill Ω up to the boundary triangles: chords inside the sphere,
  // and on the cube triangles cutting across an edge. Measured on the coarsest
  // mesh (blob-closed, 655 vertices): 2.0% short of the ball, 3.7% of the cube.
  EXPECT_NEAR(r.parametricVolume.sum(), r.domainVolume, 0.05 * r.domainVolume) << name;
  EXPECT_GT(r.parametricVolume.minCoeff(), 0) << name;
  std::cout << name << (domain == ParamDomain::Cube ? " cube" : " ball") << ": " << r.mesh.V.rows() << " vertices, "
            << r.mesh.T.rows() << " tets; OT " << r.ot.iterations << " iterations, error " << r.ot.maxRelativeMassError
            << "; inverted before final untangling " << r.param.invertedTetsBeforeUntangling << "; volume ratio p1/p50/p99 "
            << r.param.volumeRatioP1 << "/" << r.param.volumeRatioP50 << "/" << r.param.volumeRatioP99 << "; seconds OT "
            << r.timings.transport << " final untangle " << r.timings.finalUntangle << " total " << r.timings.total
            << std::endl;
}

INSTANTIATE_TEST_SUITE_P(
    Genus0, ParamRealData,
    ::testing::Values(std::make_tuple("blob-closed", ParamDomain::Cube), std::make_tuple("part", ParamDomain::Cube),
                      std::make_tuple("fandisk", ParamDomain::Cube),
                      std::make_tuple("blob-closed", ParamDomain::Ball), std::make_tuple("part", ParamDomain::Ball),
                      std::make_tuple("fandisk", ParamDomain::Ball)),
    [](const auto& info) {
      return t2stest::testName(std::get<0>(info.param)) + (std::get<1>(info.param) == ParamDomain::Cube ? "_cube" : "_ball");
    });
