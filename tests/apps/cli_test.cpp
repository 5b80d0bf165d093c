// The command line as a user meets it: exit statuses of design.md, one clear
// line on stderr naming the file and the cause, and no output file left behind
// by a failure.
#include <gtest/gtest.h>

#include <fstream>

#include "cli_runner.h"

namespace fs = std::filesystem;
using t2stest::filesIn;
using t2stest::q;
using t2stest::runCli;

namespace {

fs::path writeText(const fs::path& dir, const std::string& name, const std::string& text) {
  const fs::path p = dir / name;
  std::ofstream(p, std::ios::binary) << text;
  return p;
}


// A closed octahedron surface: the smallest well-shaped genus-0 solid.
const char* kOctahedron =
    "OFF\n6 8 0\n1 0 0\n-1 0 0\n0 1 0\n0 -1 0\n0 0 1\n0 0 -1\n"
    "3 0 2 4\n3 2 1 4\n3 1 3 4\n3 3 0 4\n3 2 0 5\n3 1 2 5\n3 3 1 5\n3 0 3 5\n";

void expectOneLineError(const t2stest::RunResult& r, int status, const std::string& file, const std::string& cause) {
  EXPECT_EQ(r.status, status) << r.err;
  EXPECT_EQ(r.errLines(), 1) << r.err;
  EXPECT_NE(r.err.find(file), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(cause), std::string::npos) << "expected '" << cause << "' in: " << r.err;
}

}  // namespace

TEST(Cli, BadCommandLinesExitWithStatus2) {
  const auto dir = t2stest::scratchDir("cli_usage");
  for (const std::string args : {"", "frobnicate x.off", "check", "check x.off --no-such-option", "mesh x.off",
                                 "mesh x.off -o out.vtu --quality -1", "mesh x.off -o out.vtu --min-dihedral 25"}) {
    const auto r = runCli(args, dir);
    EXPECT_EQ(r.status, 2) << "args: " << args << "\n" << r.err;
    EXPECT_FALSE(r.err.empty()) << args;
  }
}

TEST(Cli, HelpAndVersionSucceed) {
  const auto dir = t2stest::scratchDir("cli_help");
  EXPECT_EQ(runCli("--help", dir).status, 0);
  const auto v = runCli("--version", dir);
  EXPECT_EQ(v.status, 0);
  EXPECT_NE(v.out.find("tet2spline"), std::string::npos);
}

TEST(Cli, MalformedSurfacesExitWithStatus3NamingFileAndLine) {
  const auto dir = t2stest::scratchDir("cli_malformed");
  struct Case { std::string name, text, cause; };
  const std::vector<Case> cases = {
      {"empty.off", "", "empty"},
      {"header.off", "PLY\n3 1 0\n", "header"},
      {"truncated.off", "OFF\n6 8 0\n1 0 0\n-1 0 0\n", "truncated"},
      {"range.off", "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 9\n3 0 2 3\n3 1 2 3\n", "out of range"},
      {"nan.off", "OFF\n4 4 0\n0 0 0\nnan 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n", "NaN"},
  };
  for (const auto& c : cases) {
    const auto in = writeText(dir, c.name, c.text);
    expectOneLineError(runCli("check " + q(in), dir), 3, c.name, c.cause);
  }
  // The line number is given for text formats.
  const auto r = runCli("check " + q(dir / "range.off"), dir);
  EXPECT_NE(r.err.find("range.off:8"), std::string::npos) << r.err;
}

TEST(Cli, UnknownExtensionAndMissingFileExitWithStatus3) {
  const auto dir = t2stest::scratchDir("cli_unknown");
  const auto in = writeText(dir, "shape.xyz", "1 2 3\n");
  expectOneLineError(runCli("check " + q(in), dir), 3, "shape.xyz", "extension");
  expectOneLineError(runCli("check " + q(dir / "missing.off"), dir), 3, "missing.off", "cannot open");
}

TEST(Cli, SeveralComponentsExitWithStatus4) {
  const auto dir = t2stest::scratchDir("cli_components");
  // Two octahedra far apart in one OFF file.
  std::string two = "OFF\n12 16 0\n1 0 0\n-1 0 0\n0 1 0\n0 -1 0\n0 0 1\n0 0 -1\n"
                    "11 0 0\n9 0 0\n10 1 0\n10 -1 0\n10 0 1\n10 0 -1\n";
  const int f[8][3] = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  for (int o : {0, 6})
    for (const auto& t : f)
      two += "3 " + std::to_string(t[0] + o) + " " + std::to_string(t[1] + o) + " " + std::to_string(t[2] + o) + "\n";
  const auto in = writeText(dir, "two.off", two);
  const auto r = runCli("mesh " + q(in) + " -o " + q(dir / "two.vtu"), dir);
  EXPECT_EQ(r.status, 4) << r.err;
  EXPECT_EQ(r.errLines(), 1) << r.err;
  EXPECT_FALSE(fs::exists(dir / "two.vtu"));
}

TEST(Cli, MeshThenCheckAWellFormedSolid) {
  const auto dir = t2stest::scratchDir("cli_mesh_ok");
  const auto in = writeText(dir, "octa.off", kOctahedron);
  for (const std::string ext : {"vtu", "mesh", "msh"}) {
    const auto out = dir / ("octa." + ext);
    const auto m = runCli("mesh " + q(in) + " -o " + q(out) + " --quality 1.2", dir);
    ASSERT_EQ(m.status, 0) << m.err;
    ASSERT_TRUE(fs::exists(out));
    const auto c = runCli("check --json " + q(out), dir);
    ASSERT_EQ(c.status, 0) << c.err;
    for (const char* key : {"\"vertices\"", "\"tets\"", "\"genus\": 0", "\"voids\": 0", "\"regions\"",
                            "\"inverted_tets\": 0"})
      EXPECT_NE(c.out.find(key), std::string::npos) << key << " missing in " << c.out;
  }
}

TEST(Cli, MinimumDihedralAngleWithoutQualityRefinementIsRefused) {
  const auto dir = t2stest::scratchDir("cli_min_dihedral");
  const auto in = writeText(dir, "octa.off", kOctahedron);
  const auto out = dir / "octa.vtu";
  const auto bad = runCli("mesh " + q(in) + " -o " + q(out) + " --quality 0 --min-dihedral 10", dir);
  EXPECT_EQ(bad.status, 2) << bad.err;
  EXPECT_EQ(bad.errLines(), 1) << bad.err;
  EXPECT_NE(bad.err.find("dihedral"), std::string::npos) << bad.err;
  EXPECT_FALSE(fs::exists(out));
  const auto ok = runCli("mesh " + q(in) + " -o " + q(out) + " --min-dihedral 12", dir);
  EXPECT_EQ(ok.status, 0) << ok.err;
  EXPECT_TRUE(fs::exists(out));
}

TEST(Cli, UnwritableOutputExitsWithStatus3AndWritesNothing) {
  const auto dir = t2stest::scratchDir("cli_unwritable");
  const auto in = writeText(dir, "octa.off", kOctahedron);
  const auto r = runCli("mesh " + q(in) + " -o " + q(dir / "no-such-dir" / "out.vtu"), dir);
  expectOneLineError(r, 3, "out.vtu", "does not exist");
  const auto bad = runCli("mesh " + q(in) + " -o " + q(dir / "out.stl"), dir);
  EXPECT_EQ(bad.status, 2) << bad.err;
}

TEST(Cli, FailedMeshLeavesNoFileBehind) {
  const auto dir = t2stest::scratchDir("cli_no_partial");
  // Open surface: the octahedron without its last face.
  std::string open(kOctahedron);
  open.replace(open.find("6 8 0"), 5, "6 7 0");
  open.erase(open.rfind("3 0 3 5\n"));
  const auto in = writeText(dir, "open.off", open);
  const auto r = runCli("mesh " + q(in) + " -o " + q(dir / "open.vtu"), dir);
  EXPECT_EQ(r.status, 4) << r.err;
  EXPECT_EQ(r.errLines(), 1) << r.err;
  EXPECT_EQ(t2stest::listDir(dir), std::vector<std::string>{"open.off"});
}

namespace {
// Two tets sharing the face (1,2,3); `flipA`/`flipB` swap two vertices of a tet.
std::string twoTetMedit(bool flipA, bool flipB) {
  return std::string("MeshVersionFormatted 1\nDimension 3\nVertices\n5\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n1 1 1 0\n") +
         "Tetrahedra\n2\n" + (flipA ? "1 3 2 4 1\n" : "1 2 3 4 1\n") + (flipB ? "3 2 4 5 1\n" : "2 3 4 5 1\n") + "End\n";
}
}  // namespace

TEST(Cli, AllTetsInvertedIsReorientedButSomeInvertedIsRefused) {
  const auto dir = t2stest::scratchDir("cli_orientation");
  const auto ok = writeText(dir, "ok.mesh", twoTetMedit(false, false));
  const auto all = writeText(dir, "all.mesh", twoTetMedit(true, true));
  const auto some = writeText(dir, "some.mesh", twoTetMedit(false, true));
  EXPECT_EQ(runCli("check " + q(ok), dir).status, 0);
  const auto r = runCli("check --json " + q(all), dir);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("\"reoriented\": true"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\"inverted_tets\": 0"), std::string::npos) << r.out;
  expectOneLineError(runCli("check " + q(some), dir), 3, "some.mesh", "1 of 2 tets are inverted");
  // Converting the refused mesh writes nothing.
  EXPECT_EQ(runCli("mesh " + q(some) + " -o " + q(dir / "some.vtu"), dir).status, 3);
  EXPECT_FALSE(fs::exists(dir / "some.vtu"));
}

TEST(Cli, NonTetCellsInAVolumeFileAreRefused) {
  const auto dir = t2stest::scratchDir("cli_hex");
  const auto hex = writeText(dir, "hex.msh",
                             "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n8\n1 0 0 0\n2 1 0 0\n3 1 1 0\n4 0 1 0\n"
                             "5 0 0 1\n6 1 0 1\n7 1 1 1\n8 0 1 1\n$EndNodes\n$Elements\n1\n1 5 2 1 1 1 2 3 4 5 6 7 8\n"
                             "$EndElements\n");
  expectOneLineError(runCli("check " + q(hex), dir), 3, "hex.msh", "hexahedron");
}

TEST(Cli, UnusedVerticesOfAVolumeFileAreDropped) {
  const auto dir = t2stest::scratchDir("cli_unused");
  std::string text = twoTetMedit(false, false);
  text.replace(text.find("Vertices\n5\n"), 11, "Vertices\n6\n7 7 7 0\n");
  // The extra vertex comes first, so every tet index shifts by one.
  text.replace(text.find("Tetrahedra\n2\n1 2 3 4 1\n2 3 4 5 1\n"), 33, "Tetrahedra\n2\n2 3 4 5 1\n3 4 5 6 1\n");
  const auto in = writeText(dir, "unused.mesh", text);
  const auto r = runCli("check --json " + q(in), dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("\"vertices\": 5"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\"removed_unused_vertices\": 1"), std::string::npos) << r.out;
}

// The program runs itself once more with glibc's heap on transparent huge
// pages (apps/allocator_tuning.h). Whatever the environment says about that
// (the default, TET2SPLINE_HUGEPAGES=0, another glibc tunable set already),
// the arguments reach it unchanged, a file name with a space in it among them,
// and it writes the same mesh, prints the same report (but for its seconds),
// and exits with the same status and one line for bad input.
TEST(Cli, HugePageRerunKeepsArgumentsOutputAndExitStatus) {
  const auto dir = t2stest::scratchDir("cli_hugepages");
  const auto in = writeText(dir, "octa hedron.off", kOctahedron);
  const auto bad = writeText(dir, "bad shape.off",
                             "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 9\n3 0 2 3\n3 1 2 3\n");
  const std::string cli = t2stest::q(t2stest::cliPath());
  std::vector<std::string> meshes;
  std::vector<nlohmann::json> reports;
  for (const std::string env : {"", "TET2SPLINE_HUGEPAGES=0", "GLIBC_TUNABLES=glibc.malloc.tcache_count=0"}) {
    SCOPED_TRACE(env.empty() ? "default environment" : env);
    const std::string run = env + " " + cli + " ";
    const auto out = dir / "octa.vtu";
    fs::remove(out);
    const auto m = t2stest::runProgram("/usr/bin/env", run + "mesh " + q(in) + " -o " + q(out) + " --quality 1.2", dir);
    ASSERT_EQ(m.status, 0) << m.err;
    meshes.push_back(t2stest::slurp(out));
    const auto c = t2stest::runProgram("/usr/bin/env", run + "check --json " + q(out), dir);
    ASSERT_EQ(c.status, 0) << c.err;
    reports.push_back(nlohmann::json::parse(c.out));
    reports.back().erase("seconds");  // (the only figure that may differ)
    expectOneLineError(t2stest::runProgram("/usr/bin/env", run + "check " + q(bad), dir), 3, "bad shape.off:8",
                       "out of range");
  }
  for (size_t k = 1; k < meshes.size(); ++k) {
    EXPECT_EQ(meshes[k], meshes[0]) << k;
    EXPECT_EQ(reports[k], reports[0]) << k;
  }
}
