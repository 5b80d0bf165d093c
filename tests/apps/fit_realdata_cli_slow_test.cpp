// The fit (issue 5) on real genus-0 meshes of the test data at the default
// settings: `param --domain cube`, then `fit` with nothing but the output
// folder. Every Gauss point must have det J > 0 and the report must say which
// smoothing weight the fit ended with. Slow: run with the `slow` label.
//
// Covered: meshes whose cube parameterization passes today (see
// tests/param/parameterize_realdata_slow_test.cpp); blobby and fandisk are in
// convert_cli_slow_test.cpp, spool is FitCreased below (its volume is not
// within 2%), bunny00 is left to the benchmark. Measured at the defaults (negative Gauss points
// before the validity stage -> after, relative RMS, whole test):
// triceratops 5053 -> 0, 0.0048, 30 s; retinal 2763 -> 0, 0.0032, 16 s;
// homer 6600 -> 0, 0.0060, 79 s (param 75 s; its fit took 22 s before the
// validity stage's sum factorisation, 4 s after); hand 2572 -> 0, 0.0060,
// about 100 s (its transport needs ψ in two doubles at the end,
// optimal_transport.h, and its map comes from the barrier morph: param
// 133 s, 41 s of it on a first morph that ends too far from its target,
// parameterize.cpp). The spline's volume must
// be the mesh's within 2% (design.md, Export): part's coarse boundary leaves
// wedges of the cube uncovered along its edges (a third of the faces' area),
// which the fit fills from the faces' samples (face_coverage.h).
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <string>

#include "cli_runner.h"
#include "test_data.h"

using t2stest::q;
using t2stest::readJson;

class FitRealData : public ::testing::TestWithParam<const char*> {};

TEST_P(FitRealData, PositiveJacobianAtTheDefaults) {
  const std::string name = GetParam();
  const auto dir = t2stest::scratchDir("fit_realdata_" + name);
  const auto vtu = dir / "param.vtu", out = dir / "fit";
  auto r = t2stest::runCli("param " + q(t2stest::cgalMesh(name)) + " -o " + q(vtu) + " --domain cube -q", dir);
  ASSERT_EQ(r.status, 0) << r.err;
  r = t2stest::runCli("fit " + q(vtu) + " -o " + q(out) + " -q", dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = readJson(out / "report.json");
  EXPECT_EQ(j["jacobian"]["negative_gauss_points"].get<long>(), 0) << name;
  EXPECT_GT(j["jacobian"]["min_scaled"].get<double>(), 0) << name;
  const double used = j["fit"]["smoothing"].get<double>(), asked = j["fit"]["smoothing_requested"].get<double>();
  EXPECT_GE(used, asked) << name;
  EXPECT_LT(j["fit"]["rms_error_relative"].get<double>(), 0.02) << name;
  const double splineVolume = j["spline"]["volume"], meshVolume = j["spline"]["mesh_volume"];
  EXPECT_NEAR(splineVolume, meshVolume, 0.02 * meshVolume) << name;
  std::cout << name << ": smoothing " << asked << " -> " << used << ", RMS " << j["fit"]["rms_error_relative"]
            << ", min scaled Jacobian " << j["jacobian"]["min_scaled"] << ", volume " << splineVolume / meshVolume
            << " of the mesh's, boundary Hausdorff " << j["fit"]["boundary_hausdorff_relative"] << std::endl;
}

INSTANTIATE_TEST_SUITE_P(Genus0, FitRealData, ::testing::Values("blob-closed", "part", "triceratops", "retinal", "homer", "hand"),
                         [](const auto& info) { return t2stest::testName(info.param); });

// "The RMS error at least halves from 8 to 16 elements per direction on the
// smooth meshes of the test data" (issue 5). Smooth: surfaces whose adjacent
// triangles' normals differ by less than 30° at the 99th percentile
// (normalAngleQuantile, topology.h; ParamOptions::smoothBoundaryDegrees),
// i.e. bunny00 (16.4°), retinal (22.4°) and blobby (23.7°); the others have
// creases (part, fandisk, spool, hand: 90° or more) or sharp tips
// (blob-closed 57°, triceratops 78°, homer 43°). On these the default cube
// sites are the equal-volume ones (--cube-sites auto). Measured (RMS
// relative to the diagonal, 8 -> 16 elements), stretch -> equal-volume
// sites: blobby 0.00275 -> 0.00118 (2.33) and 0.00211 -> 0.00097 (2.17);
// retinal 0.00537 -> 0.00240 (2.24) and 0.00454 -> 0.00210 (2.16); bunny00
// 0.0102 -> 0.00517 (1.97) and 0.00859 -> 0.00395 (2.17). bunny00's
// parameterization takes about four minutes.
class FitHalving : public ::testing::TestWithParam<const char*> {};

TEST_P(FitHalving, RmsErrorHalvesFrom8To16Elements) {
  const std::string name = GetParam();
  const auto dir = t2stest::scratchDir("fit_halving_" + name);
  const auto vtu = dir / "param.vtu";
  auto r = t2stest::runCli("param " + q(t2stest::cgalMesh(name)) + " -o " + q(vtu) + " --domain cube -q", dir);
  ASSERT_EQ(r.status, 0) << r.err;
  double rms[2] = {0, 0};
  for (int k = 0; k < 2; ++k) {
    const int elements = 8 << k;
    const auto out = dir / ("fit" + std::to_string(elements));
    r = t2stest::runCli("fit " + q(vtu) + " -o " + q(out) + " --elements " + std::to_string(elements) + " -q", dir);
    ASSERT_EQ(r.status, 0) << r.err;
    const auto j = readJson(out / "report.json");
    EXPECT_EQ(j["jacobian"]["negative_gauss_points"].get<long>(), 0) << name;
    rms[k] = j["fit"]["rms_error_relative"].get<double>();
  }
  std::cout << name << ": relative RMS " << rms[0] << " at 8^3 elements, " << rms[1] << " at 16^3 (ratio "
            << rms[0] / rms[1] << ")" << std::endl;
  EXPECT_LE(rms[1], 0.5 * rms[0]) << name;
}

INSTANTIATE_TEST_SUITE_P(Smooth, FitHalving, ::testing::Values("blobby", "retinal", "bunny00"),
                         [](const auto& info) { return t2stest::testName(info.param); });

// spool (a core between two flanges, creases of 90° where they meet) at the
// defaults: no negative det J at any Gauss point, as on the other meshes,
// but a cubic fit rounds the concave creases off, filling them. That is the
// fit's approximation error, so it must shrink as the elements do: the RMS
// error at the mesh's points and the boundary's mean distance from the input
// surface, both ways. Not the volume error nor the Hausdorff distance: the
// first is a signed sum (overfilled creases against underfilled flanges) and
// the second one point's, a crease's rounding; both move with the map's last
// bits. Measured, spool scaled by 1 + k·10⁻⁹ (k = 0..4), 8 -> 16 elements:
// mean spline-to-surface distance (relative to the diagonal) 0.0053 -> 0.0034,
// 0.0047 -> 0.0028, 0.0040 -> 0.0031, 0.0042 -> 0.0027, 0.0043 -> 0.0029;
// surface-to-spline 0.0060 -> 0.0030 .. 0.0062 -> 0.0034; RMS 0.0153 ->
// 0.0079 .. 0.0122 -> 0.0070; but the volume error 5.5% -> 1.7%, 2.2% ->
// 1.8%, 0.2% -> 1.9%, 1.8% -> 2.2%, 0.9% -> 3.0%, and Hausdorff 0.084 ->
// 0.082 at k = 3 (0.0702 -> 0.0707 on another path). The volume error stays
// a few percent: at most 5% at 16 elements.
TEST(FitCreased, SpoolIsValidAndConvergesUnderRefinement) {
  const auto dir = t2stest::scratchDir("fit_creased_spool");
  const auto vtu = dir / "param.vtu";
  auto r = t2stest::runCli("param " + q(t2stest::cgalMesh("spool")) + " -o " + q(vtu) + " --domain cube -q", dir);
  ASSERT_EQ(r.status, 0) << r.err;
  double volumeError[2] = {0, 0}, hausdorff[2] = {0, 0}, rms[2] = {0, 0}, toSurface[2] = {0, 0}, toSpline[2] = {0, 0};
  for (int k = 0; k < 2; ++k) {
    const auto out = dir / ("fit" + std::to_string(k));
    r = t2stest::runCli("fit " + q(vtu) + " -o " + q(out) + (k == 0 ? " --elements 8" : "") + " -q", dir);
    ASSERT_EQ(r.status, 0) << r.err;
    const auto j = readJson(out / "report.json");
    EXPECT_EQ(j["jacobian"]["negative_gauss_points"].get<long>(), 0) << k;
    EXPECT_GT(j["jacobian"]["min_scaled"].get<double>(), 0) << k;
    const double splineVolume = j["spline"]["volume"], meshVolume = j["spline"]["mesh_volume"];
    volumeError[k] = std::abs(splineVolume / meshVolume - 1);
    hausdorff[k] = j["fit"]["boundary_hausdorff_relative"].get<double>();
    rms[k] = j["fit"]["rms_error_relative"].get<double>();
    toSurface[k] = j["fit"]["boundary_mean_spline_to_surface_relative"].get<double>();
    toSpline[k] = j["fit"]["boundary_mean_surface_to_spline_relative"].get<double>();
    EXPECT_GT(toSurface[k], 0) << k;
    EXPECT_LE(toSurface[k], hausdorff[k]) << k;
    EXPECT_LE(toSpline[k], hausdorff[k]) << k;
  }
  std::cout << "spool, 8 -> 16 elements: RMS " << rms[0] << " -> " << rms[1] << ", mean distance spline to surface "
            << toSurface[0] << " -> " << toSurface[1] << ", surface to spline " << toSpline[0] << " -> " << toSpline[1]
            << ", volume error " << volumeError[0] << " -> " << volumeError[1] << ", boundary Hausdorff " << hausdorff[0]
            << " -> " << hausdorff[1] << std::endl;
  EXPECT_LT(rms[1], rms[0]);
  EXPECT_LT(toSurface[1], toSurface[0]);
  EXPECT_LT(toSpline[1], toSpline[0]);
  EXPECT_LT(volumeError[1], 0.05);
}
