// tet2spline param and transport as a user runs them: usage errors, the
// report's keys and what they must say (design.md, issues 3 and 4).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <vector>
#include <nlohmann/json.hpp>

#include "../param/test_shapes.h"
#include "cli_runner.h"
#include "tet2spline/io/mesh_io.h"
#include "tet2spline/param/topology.h"

namespace fs = std::filesystem;
using t2stest::filesIn;
using t2stest::q;
using t2stest::runCli;
using json = nlohmann::json;

namespace {

/// Runs `param` on blob-closed with `options`, writing TAG.vtu and TAG.json
/// in dir, and checks what every valid run gives: status 0, no inverted tet
/// in the report, the boundary on ∂Ω, and no tet of the written U with
/// orient3d <= 0. Returns the report (empty when the run failed).
json paramWithValidMap(const fs::path& dir, const std::string& tag, const std::string& options) {
  const auto out = dir / (tag + ".vtu"), rep = dir / (tag + ".json");
  const auto r = runCli("param " + q(t2stest::cgalMesh("blob-closed")) + " -o " + q(out) + " " + options +
                            " -q --report " + q(rep),
                        dir);
  EXPECT_EQ(r.status, 0) << tag << ": " << r.err;
  if (r.status != 0) return json();
  const json j = t2stest::readJson(rep);
  EXPECT_EQ(j["param"]["inverted_tets"], 0) << tag;
  EXPECT_LT(j["param"]["boundary_max_distance"].get<double>(), 1e-12) << tag;
  const tet2spline::TetMesh m = tet2spline::readTetMesh(out.string());
  const tet2spline::Field* U = m.pointField("U");
  EXPECT_NE(U, nullptr) << tag;
  if (U) {
    EXPECT_EQ(tet2spline::countNonPositiveTets(Eigen::MatrixX3d(U->values), m.T), 0) << tag;
  }
  return j;
}

}  // namespace

TEST(CliParam, BadOptionsExitWithStatus2BeforeAnyWork) {
  const auto dir = t2stest::scratchDir("cli_param_usage");
  const std::string in = q(t2stest::cgalMesh("blob-closed"));
  for (const std::string& args :
       {"param " + in + " -o x.vtu --domain disk", "param " + in + " -o x.vtu --density 2",
        "param " + in + " -o x.vtu --density a=4", "param " + in + " -o x.vtu --density 2=-1",
        "param " + in + " -o x.vtu --no-transport --domain cube", "param " + in + " -o x.mesh",
        "param " + in + " -o x.vtu --density 7=2" /* no region 7 */, "param " + in + " -o x.vtu --untangler bfgs",
        "param " + in + " -o x.vtu --cube-sites sphere",
        "param " + in + " -o x.vtu --cube-sites equal-volume --site-stretch 0.5"}) {
    const auto r = runCli(args + " -q", dir);
    EXPECT_EQ(r.status, 2) << args << "\n" << r.err;
    EXPECT_EQ(r.errLines(), 1) << r.err;
  }
  EXPECT_TRUE(t2stest::listDir(dir).empty());
}

TEST(CliParam, HarmonicBallMapWithoutTransport) {
  const auto dir = t2stest::scratchDir("cli_param_ball");
  const auto out = dir / "ball.vtu", rep = dir / "r.json", mapped = dir / "mapped.vtu";
  const auto r = runCli("param " + q(t2stest::cgalMesh("blob-closed")) + " -o " + q(out) +
                            " --domain ball --no-transport -q --report " + q(rep),
                        dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const json j = t2stest::readJson(rep);
  for (const char* key : {"sphere", "ball", "param", "timings"}) EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j["sphere"]["flipped_triangles"], 0);
  EXPECT_EQ(j["ball"]["inverted_tets"], 0);
  EXPECT_LT(j["ball"]["harmonic_residual"].get<double>(), 1e-8);
  EXPECT_LT(j["param"]["boundary_max_distance"].get<double>(), 1e-12);
  for (const char* key : {"spherical_map", "harmonic", "untangle"}) EXPECT_TRUE(j["timings"].contains(key)) << key;
  EXPECT_FALSE(j.contains("ot"));
  // The file holds U; the ball coordinates are positive tets inside the ball.
  const tet2spline::TetMesh m = tet2spline::readTetMesh(out.string());
  const tet2spline::Field* U = m.pointField("U");
  ASSERT_NE(U, nullptr);
  ASSERT_EQ(U->values.cols(), 3);
  EXPECT_EQ(tet2spline::countNonPositiveTets(Eigen::MatrixX3d(U->values), m.T), 0);
  EXPECT_LE(U->values.rowwise().norm().maxCoeff(), 1 + 1e-12);
  // ball.volume_ratio: per tet, its share of the ball map's volume over its
  // share of the solid's (the target without densities), recomputed here
  // from the map the file holds.
  {
    const Eigen::Index nt = m.T.rows();
    std::vector<double> ball(static_cast<size_t>(nt)), solid(static_cast<size_t>(nt)), ratio;
    double ballSum = 0, solidSum = 0;
    const Eigen::MatrixX3d ballMap = U->values;
    for (Eigen::Index t = 0; t < nt; ++t) {
      ballSum += ball[static_cast<size_t>(t)] = t2stest::tetVolume(ballMap, m.T, t);
      solidSum += solid[static_cast<size_t>(t)] = t2stest::tetVolume(m.V, m.T, t);
    }
    for (Eigen::Index t = 0; t < nt; ++t)
      ratio.push_back((ball[static_cast<size_t>(t)] / ballSum) / (solid[static_cast<size_t>(t)] / solidSum));
    std::sort(ratio.begin(), ratio.end());
    auto at = [&](double p) { return ratio[static_cast<size_t>(std::floor(p * static_cast<double>(nt - 1) + 0.5))]; };
    const json& v = j["ball"]["volume_ratio"];
    EXPECT_NEAR(v["p1"].get<double>(), at(0.01), 1e-9 * at(0.01));
    EXPECT_NEAR(v["p50"].get<double>(), at(0.5), 1e-9 * at(0.5));
    EXPECT_NEAR(v["p99"].get<double>(), at(0.99), 1e-9 * at(0.99));
    EXPECT_NEAR(v["min"].get<double>(), ratio.front(), 1e-9 * std::abs(ratio.front()));
    EXPECT_NEAR(v["max"].get<double>(), ratio.back(), 1e-9 * ratio.back());
    EXPECT_GT(ratio.front(), 0);
    EXPECT_LT(at(0.01), 1);  // a harmonic map does not preserve volume
    EXPECT_GT(at(0.99), 1);
  }
  // --mapped writes the mesh at U with the physical positions as X.
  ASSERT_EQ(runCli("param " + q(t2stest::cgalMesh("blob-closed")) + " -o " + q(mapped) +
                       " --domain ball --no-transport -q --mapped",
                   dir).status,
            0);
  const tet2spline::TetMesh mm = tet2spline::readTetMesh(mapped.string());
  ASSERT_NE(mm.pointField("X"), nullptr);
  EXPECT_LT((mm.V - Eigen::MatrixX3d(U->values)).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(CliParam, NewtonUntanglerGivesAPositiveParameterizationOnBothDomains) {
  const auto dir = t2stest::scratchDir("cli_param_newton");
  for (const std::string domain : {"cube", "ball"}) {
    const json j = paramWithValidMap(dir, domain, "--domain " + domain + " --untangler newton");
    ASSERT_FALSE(j.is_null()) << domain;
    EXPECT_EQ(j["param"]["untangler"], "newton");
    EXPECT_GT(j["param"]["inverted_tets_before_untangling"].get<int>(), 0) << "nothing was untangled";
  }
}

// --cube-sites: the report says which sites the transport started from, and
// the equal-volume sites give a valid map with the boundary on the cube.
// auto (the default) takes the stretch on blob-closed, whose sharp tips put
// its boundary normal angle's 99th percentile far above the threshold.
TEST(CliParam, CubeSitesAreReportedAndEqualVolumeSitesGiveAValidMap) {
  const auto dir = t2stest::scratchDir("cli_param_cube_sites");
  for (const std::string sites : {"stretch", "equal-volume", "auto"}) {
    const json j = paramWithValidMap(dir, sites, "--cube-sites " + sites);
    ASSERT_FALSE(j.is_null()) << sites;
    EXPECT_EQ(j["param"]["cube_sites"], sites == "equal-volume" ? "equal-volume" : "stretch 0");
    EXPECT_EQ(j["param"]["cube_sites_requested"], sites);
    EXPECT_GT(j["param"]["boundary_normal_angle_p99"].get<double>(), 45.0) << sites;
    EXPECT_GE(j["param"]["boundary_planar_share"].get<double>(), 0.0) << sites;
    EXPECT_LE(j["ot"]["max_relative_mass_error"].get<double>(), 1e-6);
  }
}

TEST(CliParam, BallTransportConservesMassAndKeepsTheBoundaryOnTheSphere) {
  const auto dir = t2stest::scratchDir("cli_param_ot_ball");
  const auto out = dir / "p.vtu", rep = dir / "r.json";
  const auto r = runCli("param " + q(t2stest::cgalMesh("blob-closed")) + " -o " + q(out) + " --domain ball -q --report " + q(rep), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const json j = t2stest::readJson(rep);
  EXPECT_LE(j["ot"]["max_relative_mass_error"].get<double>(), 1e-6);
  EXPECT_EQ(j["ot"]["step_sizes"].size(), j["ot"]["iterations"].get<size_t>());
  EXPECT_EQ(j["param"]["inverted_tets"], 0);
  EXPECT_LT(j["param"]["boundary_max_distance"].get<double>(), 1e-12);
  ASSERT_EQ(j["regions"].size(), 1u);
  EXPECT_NEAR(j["regions"][0]["achieved_volume_fraction"].get<double>(), 1.0, 1e-12);
  const auto vr = j["param"]["volume_ratio"];
  EXPECT_LE(vr["p1"].get<double>(), vr["p50"].get<double>());
  EXPECT_LE(vr["p50"].get<double>(), vr["p99"].get<double>());
  for (const char* key : {"transport", "transport_triangulation", "transport_clipping", "transport_linear_solve"})
    EXPECT_TRUE(j["timings"].contains(key)) << key;
  const tet2spline::TetMesh m = tet2spline::readTetMesh(out.string());
  for (const char* field : {"volume_ratio", "inverted"}) EXPECT_NE(m.cellField(field), nullptr) << field;
  // The covered fraction is the written map's Σ tet volumes over |Ω|; the
  // tets fill the ball up to the chords (2% short on this coarse mesh).
  const auto* U = m.pointField("U");
  ASSERT_NE(U, nullptr);
  double covered = 0;
  for (Eigen::Index t = 0; t < m.T.rows(); ++t) {
    const Eigen::Vector3d a = U->values.row(m.T(t, 0)), b = U->values.row(m.T(t, 1)), c = U->values.row(m.T(t, 2)),
                          d = U->values.row(m.T(t, 3));
    covered += (b - a).cross(c - a).dot(d - a) / 6;
  }
  const double fraction = j["param"]["covered_volume_fraction"].get<double>();
  EXPECT_NEAR(fraction, covered / j["param"]["domain_volume"].get<double>(), 1e-9);
  EXPECT_GT(fraction, 0.95);
  EXPECT_LE(fraction, 1.0 + 1e-9);
}

TEST(CliTransport, EqualMassesOnAGridGiveEqualCellsAndConstantWeights) {
  const auto dir = t2stest::scratchDir("cli_transport_grid");
  const auto in = dir / "grid.txt", out = dir / "w.txt";
  {
    std::ofstream f(in);
    f << "64\n# 4x4x4 cell centres\n";
    for (int k = 0; k < 4; ++k)
      for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 4; ++i) f << (i + 0.5) / 4 << ' ' << (j + 0.5) / 4 << ' ' << (k + 0.5) / 4 << " 3.5\n";
  }
  const auto r = runCli("transport " + q(in) + " -o " + q(out) + " --domain cube -q", dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const json j = json::parse(r.out);
  EXPECT_LE(j["ot"]["max_relative_mass_error"].get<double>(), 1e-6);
  std::ifstream f(out);
  int n = 0;
  f >> n;
  ASSERT_EQ(n, 64);
  double psi0 = 0;
  for (int i = 0; i < n; ++i) {
    double psi, x, y, z;
    f >> psi >> x >> y >> z;
    if (i == 0) psi0 = psi;
    EXPECT_NEAR(psi, psi0, 1e-7);  // mass error 1e-6 moves facets by ~1e-7
    EXPECT_NEAR(x, ((i % 4) + 0.5) / 4, 1e-7);  // the centroid of its own cube cell
  }
}

TEST(CliTransport, MalformedPointFilesNameFileAndLine) {
  const auto dir = t2stest::scratchDir("cli_transport_bad");
  struct Case { std::string name, text, cause; };
  for (const Case& c : std::vector<Case>{{"empty.txt", "", "empty"},
                                         {"count.txt", "two\n", ":1:"},
                                         {"short.txt", "3\n0 0 0 1\n0.5 0.5 0.5 1\n", "ends after 2 of 3"},
                                         {"mass.txt", "2\n0.1 0.1 0.1 1\n0.2 0.2 0.2 -1\n", ":3: the mass"},
                                         {"nan.txt", "1\nnan 0 0 1\n", ":2: coordinates"}}) {
    std::ofstream(dir / c.name) << c.text;
    const auto r = runCli("transport " + q(dir / c.name) + " -o " + q(dir / "out.txt"), dir);
    EXPECT_EQ(r.status, 3) << c.name << ": " << r.err;
    EXPECT_EQ(r.errLines(), 1) << r.err;
    EXPECT_NE(r.err.find(c.cause), std::string::npos) << c.name << ": " << r.err;
    EXPECT_FALSE(fs::exists(dir / "out.txt"));
  }
}

TEST(CliParam, VerbosePrintsEveryProgressMessageAsALine) {
  // Not a terminal here: without -v, one line per stage; with -v, every
  // sub-stage, Newton step and untangling round gets its own line.
  const auto dir = t2stest::scratchDir("cli_param_verbose");
  const std::string in = q(t2stest::cgalMesh("blob-closed"));
  const auto plain = runCli("param " + in + " -o " + q(dir / "a.vtu"), dir);
  ASSERT_EQ(plain.status, 0) << plain.err;
  EXPECT_EQ(plain.err.find("newton 1:"), std::string::npos) << plain.err;
  const auto verbose = runCli("param " + in + " -o " + q(dir / "b.vtu") + " -v", dir);
  ASSERT_EQ(verbose.status, 0) << verbose.err;
  for (const char* line : {"param: 1% split", "harmonic map", "newton 1:", "composition", "param: untangle: eps",
                           "param: final untangle: eps"})
    EXPECT_NE(verbose.err.find(line), std::string::npos) << line << "\n" << verbose.err;
  EXPECT_EQ(verbose.err.find("untangle: untangle"), std::string::npos) << "a doubled prefix\n" << verbose.err;
  EXPECT_GT(verbose.errLines(), plain.errLines() + 5);
  // -q wins over -v.
  const auto quiet = runCli("param " + in + " -o " + q(dir / "c.vtu") + " -v -q", dir);
  ASSERT_EQ(quiet.status, 0);
  EXPECT_TRUE(quiet.err.empty()) << quiet.err;
}
