// `tet2spline fit` as a user meets it, on parameterized meshes whose cube
// parameterization is known exactly (X = f(U)): the fit reproduces f, the
// report carries design.md's keys, the exports pass their checks (gmsh meshes
// the STEP), bad input exits 3 with one line and leaves no files, a fit that
// cannot be made valid exits 5 and says what it reached.
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/LU>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "cli_runner.h"
#include "cube_param_meshes.h"
#include "tet2spline/io/mesh_io.h"

namespace fs = std::filesystem;
using nlohmann::json;
using t2stest::filesIn;
using t2stest::q;
using t2stest::readJson;
using t2stest::runCli;

namespace {

bool haveGmsh() { return std::system("command -v gmsh >/dev/null 2>&1") == 0; }

double tetVolume(const tet2spline::TetMesh& m, Eigen::Index t) {
  Eigen::Matrix3d E;
  for (int c = 0; c < 3; ++c) E.col(c) = (m.V.row(m.T(t, c + 1)) - m.V.row(m.T(t, 0))).transpose();
  return E.determinant() / 6;
}

void expectOneLineError(const t2stest::RunResult& r, int status, const std::string& cause) {
  EXPECT_EQ(r.status, status) << r.err;
  EXPECT_EQ(r.errLines(), 1) << r.err;
  EXPECT_NE(r.err.find(cause), std::string::npos) << "expected '" << cause << "' in: " << r.err;
}

/// The files every successful run writes into OUTDIR.
const std::set<std::string> kOutputs = {"spline.step", "spline.igs",      "spline.xml",
                                        "spline.mfem", "spline_regions.gf", "spline.vtu",
                                        "control_net.vtu", "report.json"};


}  // namespace

// A tricubic map on a 6×6×6 Kuhn mesh, fitted by cubics without smoothing:
// reproduced to rounding at every vertex, and the exports hold the spline.
TEST(FitCli, ReproducesATricubicMapAndWritesEveryExport) {
  const auto dir = t2stest::scratchDir("fit_tricubic");
  tet2spline::TetMesh m = t2stest::kuhnCube(6, t2stest::tricubicMap);
  for (Eigen::Index t = 0; t < m.numTets(); ++t) ASSERT_GT(tetVolume(m, t), 0);
  const fs::path in = dir / "param.vtu", out = dir / "out";
  tet2spline::writeTetMesh(m, in.string());
  const auto r = runCli("fit " + q(in) + " -o " + q(out) + " --elements 3,2,4 --smoothing 0 --quiet", dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << r.err;  // --quiet
  EXPECT_EQ(filesIn(out), kOutputs);

  const json j = readJson(out / "report.json");
  EXPECT_EQ(j["spline"]["degree"], 3);
  EXPECT_EQ(j["spline"]["control_points"], json::array({6, 5, 7}));
  EXPECT_LT(j["fit"]["rms_error_relative"].get<double>(), 1e-10);
  EXPECT_LT(j["fit"]["max_error_relative"].get<double>(), 1e-10);
  EXPECT_EQ(j["jacobian"]["negative_gauss_points"], 0);
  EXPECT_GT(j["jacobian"]["min_scaled"].get<double>(), 0);
  // The boundary of the tet mesh is piecewise linear on the curved faces:
  // small, but not zero.
  const double h = j["fit"]["boundary_hausdorff_relative"].get<double>();
  EXPECT_GT(h, 0);
  EXPECT_LT(h, 1e-2);
  ASSERT_EQ(j["regions"].size(), 1u);
  EXPECT_EQ(j["regions"][0]["id"], 1);
  EXPECT_EQ(j["regions"][0]["elements"], 24);
  const double meshVolume = j["spline"]["mesh_volume"], splineVolume = j["spline"]["volume"];
  EXPECT_NEAR(j["regions"][0]["elements_per_volume"].get<double>(), 24 / meshVolume, 1e-9);
  // The tets are inscribed in the curved solid: volumes agree to the chordal error.
  EXPECT_NEAR(splineVolume, meshVolume, 0.01 * meshVolume);
  for (const char* k : {"fit", "export"}) EXPECT_GE(j["timings"][k].get<double>(), 0) << k;
  std::set<std::string> exported;
  for (const auto& p : j["exports"]) {
    EXPECT_TRUE(fs::exists(p.get<std::string>())) << p;
    exported.insert(fs::path(p.get<std::string>()).filename().string());
  }
  EXPECT_EQ(exported, kOutputs);
  EXPECT_TRUE(j["warnings"].empty());

  // MFEM's region file has one value per element; the hex VTU has its fields.
  const std::string gf = t2stest::slurp(out / "spline_regions.gf");
  EXPECT_EQ(gf.rfind("FiniteElementSpace\nFiniteElementCollection: L2_3D_P0\nVDim: 1\nOrdering: 0\n\n", 0), 0u);
  EXPECT_EQ(std::count(gf.begin(), gf.end(), '\n'), 5 + 24);
  const std::string vtu = t2stest::slurp(out / "spline.vtu");
  for (const char* field : {"\"detJ\"", "\"scaledJacobian\"", "\"region\""})
    EXPECT_NE(vtu.find(field), std::string::npos) << field;

  // gmsh, an independent reader, meshes the STEP solid: its volume is the spline's.
  if (!haveGmsh()) GTEST_SKIP() << "gmsh not installed";
  const fs::path msh = dir / "step.msh";
  const std::string cmd = "gmsh -3 -nt 1 " + q(out / "spline.step") + " -clmax 0.2 -format msh2 -o " + q(msh) +
                          " >" + q(dir / "gmsh.log") + " 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << t2stest::slurp(dir / "gmsh.log");
  const tet2spline::TetMesh g = tet2spline::readTetMesh(msh.string());
  double vol = 0;
  for (Eigen::Index t = 0; t < g.numTets(); ++t) vol += std::fabs(tetVolume(g, t));
  EXPECT_GT(g.numTets(), 100);
  EXPECT_NEAR(vol, splineVolume, 0.02 * splineVolume);
}

// An affine map: the spline's boundary is the tet mesh's boundary (planes), so
// the sampled Hausdorff distance vanishes, and the volumes agree exactly.
TEST(FitCli, AffineMapHasZeroBoundaryDistance) {
  const auto dir = t2stest::scratchDir("fit_affine");
  const tet2spline::TetMesh m = t2stest::kuhnCube(5, [](const Eigen::Vector3d& u) {
    return Eigen::Vector3d(3 * u[0] + 0.5 * u[1] - 1, 2 * u[1] + 0.25 * u[2], 0.5 * u[2] + 0.1 * u[0] + 7);
  });
  const fs::path in = dir / "param.vtu", out = dir / "out", rep = dir / "r.json";
  tet2spline::writeTetMesh(m, in.string());
  const auto r = runCli("fit " + q(in) + " -o " + q(out) + " --elements 4 --degree 2 --report " + q(rep), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_FALSE(r.err.empty());  // log lines without --quiet
  EXPECT_FALSE(fs::exists(out / "report.json"));
  const json j = readJson(rep);
  EXPECT_EQ(j["spline"]["control_points"], json::array({6, 6, 6}));
  EXPECT_LT(j["fit"]["boundary_hausdorff_relative"].get<double>(), 1e-10);
  EXPECT_LT(j["fit"]["max_error_relative"].get<double>(), 1e-10);
  EXPECT_NEAR(j["spline"]["volume"].get<double>(), j["spline"]["mesh_volume"].get<double>(), 1e-9);
  EXPECT_EQ(j["exports"].back(), rep.string());
}

// A smooth non-polynomial map: the error falls by at least 2 from 4 to 8
// elements per direction, and --target-error refines by doubling until met.
TEST(FitCli, ErrorFallsUnderRefinementAndTargetErrorRefines) {
  const auto dir = t2stest::scratchDir("fit_ball");
  const tet2spline::TetMesh m = t2stest::kuhnCube(16, t2stest::ballLikeMap);
  const fs::path in = dir / "param.vtu";
  tet2spline::writeTetMesh(m, in.string());
  double rms[2];
  int k = 0;
  for (int n : {4, 8}) {
    const fs::path out = dir / ("out" + std::to_string(n));
    const auto r = runCli("fit " + q(in) + " -o " + q(out) + " -q --elements " + std::to_string(n), dir);
    ASSERT_EQ(r.status, 0) << r.err;
    const json j = readJson(out / "report.json");
    EXPECT_EQ(j["jacobian"]["negative_gauss_points"], 0);
    rms[k++] = j["fit"]["rms_error_relative"];
  }
  EXPECT_LT(rms[1], rms[0] / 2);
  const fs::path out = dir / "target";
  const auto r = runCli("fit " + q(in) + " -o " + q(out) + " -q --elements 2 --target-error " +
                            std::to_string(0.5 * (rms[0] + rms[1])), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const json j = readJson(out / "report.json");
  EXPECT_EQ(j["spline"]["elements"], json::array({8, 8, 8}));
  EXPECT_EQ(j["fit"]["refinements"], 2);
  EXPECT_EQ(j["fit"]["target_error_reached"], true);
}

// Two regions and a void: void elements are tagged in the exports, regions[]
// says which region is a void, and the report warns that STEP/IGES carry no
// inner shells.
TEST(FitCli, VoidRegionsAreTaggedAndWarnedAbout) {
  const auto dir = t2stest::scratchDir("fit_void");
  tet2spline::TetMesh m = t2stest::kuhnCube(8, t2stest::tricubicMap);
  const Eigen::MatrixX3d U = m.pointField("U")->values;
  for (Eigen::Index t = 0; t < m.numTets(); ++t) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k) c += U.row(m.T(t, k)).transpose() / 4;
    const bool inner = (c.array() > 0.25).all() && (c.array() < 0.75).all();
    m.region[t] = inner ? 2 : 1;
  }
  m.voidRegions = {2};
  const fs::path in = dir / "param.vtu", out = dir / "out";
  tet2spline::writeTetMesh(m, in.string());
  const auto r = runCli("fit " + q(in) + " -o " + q(out) + " -q --elements 4", dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const json j = readJson(out / "report.json");
  ASSERT_EQ(j["regions"].size(), 2u);
  EXPECT_EQ(j["regions"][1]["id"], 2);
  EXPECT_EQ(j["regions"][1]["void"], true);
  EXPECT_EQ(j["regions"][0]["void"], false);
  EXPECT_EQ(j["regions"][1]["elements"], 8);  // the 2×2×2 elements whose centres lie in [1/4, 3/4]^3
  EXPECT_EQ(j["regions"][0]["elements"], 56);
  ASSERT_EQ(j["warnings"].size(), 1u);
  EXPECT_NE(j["warnings"][0].get<std::string>().find("STEP/IGES"), std::string::npos);
  const std::string gf = t2stest::slurp(out / "spline_regions.gf");
  // u fastest: element (1,1,1) is number 1 + 4·(1 + 4·1) = 21, a void element.
  std::istringstream in2(gf.substr(gf.find("\n\n") + 2));
  std::vector<int> reg;
  for (int x; in2 >> x;) reg.push_back(x);
  ASSERT_EQ(reg.size(), 64u);
  EXPECT_EQ(reg[21], 2);
  EXPECT_EQ(reg[0], 1);
  EXPECT_EQ(std::count(reg.begin(), reg.end(), 2), 8);
  const std::string xml = t2stest::slurp(out / "spline.xml");
  EXPECT_NE(xml.find("label=\"element_region\""), std::string::npos);
}

// No field U, a ball parameterization (U in [−1,1]^3), a malformed file:
// exit 3, one line naming the file and the cause, nothing written.
TEST(FitCli, BadParameterizationsExitWith3AndLeaveNothing) {
  const auto dir = t2stest::scratchDir("fit_bad");
  tet2spline::TetMesh noU = t2stest::kuhnCube(2, t2stest::tricubicMap);
  noU.pointFields.clear();
  tet2spline::TetMesh ball = noU;
  ball.pointFields.push_back({"U", 2 * t2stest::kuhnCube(2, t2stest::tricubicMap).pointField("U")->values.array() - 1});
  tet2spline::TetMesh twoComponents = noU;
  twoComponents.pointFields.push_back({"U", Eigen::MatrixXd::Zero(noU.numVertices(), 2)});
  tet2spline::writeTetMesh(noU, (dir / "nou.vtu").string());
  tet2spline::writeTetMesh(ball, (dir / "ball.vtu").string());
  tet2spline::writeTetMesh(twoComponents, (dir / "u2.vtu").string());
  std::ofstream(dir / "broken.vtu") << "<VTKFile type=\"UnstructuredGrid\"><Unstr";
  for (const char* name : {"nou.vtu", "ball.vtu", "u2.vtu"}) {
    SCOPED_TRACE(name);
    const fs::path out = dir / (std::string("out_") + name);
    const auto r = runCli("fit " + q(dir / name) + " -o " + q(out), dir);
    expectOneLineError(r, 3, "needs a cube parameterization (tet2spline param --domain cube)");
    EXPECT_NE(r.err.find(name), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
  }
  // An existing OUTDIR keeps what it had and gets nothing new.
  const fs::path keep = dir / "keep";
  fs::create_directories(keep);
  std::ofstream(keep / "mine.txt") << "x";
  expectOneLineError(runCli("fit " + q(dir / "ball.vtu") + " -o " + q(keep), dir), 3, "[-1, 1]");
  EXPECT_EQ(filesIn(keep), std::set<std::string>{"mine.txt"});
  const auto r = runCli("fit " + q(dir / "broken.vtu") + " -o " + q(dir / "out_broken"), dir);
  EXPECT_EQ(r.status, 3) << r.err;
  EXPECT_EQ(r.errLines(), 1) << r.err;
  EXPECT_FALSE(fs::exists(dir / "out_broken"));
}

TEST(FitCli, BadOptionsExitWith2) {
  const auto dir = t2stest::scratchDir("fit_usage");
  tet2spline::writeTetMesh(t2stest::kuhnCube(2, t2stest::tricubicMap), (dir / "p.vtu").string());
  for (const std::string opts : {"", "-o x --elements 0", "-o x --elements 2,3", "-o x --elements a",
                                 "-o x --degree 0", "-o x --smoothing -1"}) {
    const auto r = runCli("fit " + q(dir / "p.vtu") + " " + opts, dir);
    EXPECT_EQ(r.status, 2) << opts << "\n" << r.err;
    EXPECT_EQ(r.errLines(), 1) << r.err;
  }
  EXPECT_FALSE(fs::exists(dir / "x"));
}

// A mirrored map (det J < 0 everywhere) cannot be made valid: exit 5, one line
// saying what the fit reached, and no output folder.
TEST(FitCli, InvalidFitExitsWith5AndWritesNothing) {
  const auto dir = t2stest::scratchDir("fit_invalid");
  const tet2spline::TetMesh m = t2stest::kuhnCube(4, [](const Eigen::Vector3d& u) {
    return Eigen::Vector3d(-t2stest::tricubicMap(u)[0], t2stest::tricubicMap(u)[1], t2stest::tricubicMap(u)[2]);
  });
  tet2spline::writeTetMesh(m, (dir / "mirror.vtu").string());
  const auto r = runCli("fit " + q(dir / "mirror.vtu") + " -o " + q(dir / "out") + " --elements 2", dir);
  EXPECT_EQ(r.status, 5) << r.err;
  const std::string last = r.err.substr(r.err.rfind('\n', r.err.size() - 2) + 1);
  EXPECT_EQ(last.rfind("tet2spline: ", 0), 0u) << r.err;
  EXPECT_NE(last.find("mirror.vtu"), std::string::npos) << last;
  EXPECT_NE(last.find("Gauss points with det J <= 0"), std::string::npos) << last;
  EXPECT_NE(last.find("no output written"), std::string::npos) << last;
  EXPECT_FALSE(fs::exists(dir / "out"));
}

// The same input twice gives byte-identical exports (report.json differs only
// in timings and paths).
TEST(FitCli, SameInputGivesIdenticalExports) {
  const auto dir = t2stest::scratchDir("fit_determinism");
  tet2spline::writeTetMesh(t2stest::kuhnCube(8, t2stest::ballLikeMap), (dir / "p.vtu").string());
  for (const char* o : {"a", "b"}) {
    const auto r = runCli("fit " + q(dir / "p.vtu") + " -o " + q(dir / o) + " -q --elements 4", dir);
    ASSERT_EQ(r.status, 0) << r.err;
  }
  for (const auto& name : kOutputs) {
    if (name == "report.json") continue;
    EXPECT_EQ(t2stest::slurp(dir / "a" / name), t2stest::slurp(dir / "b" / name)) << name;
  }
  json a = readJson(dir / "a" / "report.json"), b = readJson(dir / "b" / "report.json");
  for (json* j : {&a, &b}) {
    j->erase("timings");
    j->erase("exports");
  }
  EXPECT_EQ(a, b);
}
